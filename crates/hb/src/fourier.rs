//! Harmonic settings and the alternating frequency-time (AFT) transforms of Eqs. (18)-(19).
//!
//! A periodic signal is the cosine series f(t) = sum_{n=0..N} f_n cos(n w t) (docs/DESIGN.md §3: a
//! conservative, time-reversible orbit with a turning point at t = 0 is even in t, so the paper's
//! complex series with n in Z reduces to cosines; the mean term f_0 is kept). It is sampled at
//! t_k = k T / m, k = 0..m-1 (Eq. 18, shifted to start at 0), i.e. at phases 2 pi k / m that do not
//! depend on w. Back to coefficients (Eq. 19): f_0 = mean_k f_k and
//! f_n = (2/m) sum_k f_k cos(2 pi n k / m). Both directions use rustfft (unnormalized, so the code
//! divides by m); plans are built once per solver. With m >= 2N + 1 the round trip is exact.

use std::sync::Arc;

use rustfft::num_complex::Complex;
use rustfft::{Fft, FftPlanner};
use serde::{Deserialize, Serialize};

use crate::error::HbError;

/// Truncation order and time sampling of the harmonic balance.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct HarmonicSettings {
    /// Highest harmonic N (>= 1); the series has N + 1 cosine terms including the mean.
    pub harmonics: usize,
    /// Time samples per period m (>= 2N + 1).
    pub samples: usize,
}

impl HarmonicSettings {
    /// Checked constructor.
    pub fn new(harmonics: usize, samples: usize) -> Result<Self, HbError> {
        let s = Self { harmonics, samples };
        s.validate()?;
        Ok(s)
    }

    /// Number of cosine terms N + 1 (the mean included).
    pub fn terms(&self) -> usize {
        self.harmonics + 1
    }

    /// N harmonics with the default sampling [`HarmonicSettings::default_samples`].
    pub fn with_default_samples(harmonics: usize) -> Result<Self, HbError> {
        Self::new(harmonics, Self::default_samples(harmonics))
    }

    /// Default number of samples: max(8N, 64) rounded up to a power of two (fast FFT lengths; 8
    /// samples per period of the highest harmonic resolve contact onsets well).
    pub fn default_samples(harmonics: usize) -> usize {
        harmonics.saturating_mul(8).max(64).next_power_of_two()
    }

    /// Checks N >= 1 and m >= 2N + 1 (below that, cosines of different orders alias).
    pub fn validate(&self) -> Result<(), HbError> {
        if self.harmonics == 0 {
            return Err(HbError::HarmonicSettings {
                detail: "harmonics N = 0; at least the fundamental (N >= 1) is needed".to_string(),
            });
        }
        let min = 2 * self.harmonics + 1;
        if self.samples < min {
            return Err(HbError::HarmonicSettings {
                detail: format!(
                    "{} time samples for N = {} harmonics; need m >= 2N + 1 = {min}",
                    self.samples, self.harmonics
                ),
            });
        }
        Ok(())
    }
}

/// FFT plans and buffers for batches of cosine series.
pub struct Aft {
    settings: HarmonicSettings,
    samples: usize,
    forward: Arc<dyn Fft<f64>>,
    inverse: Arc<dyn Fft<f64>>,
    buffer: Vec<Complex<f64>>,
    scratch: Vec<Complex<f64>>,
}

impl Aft {
    /// Builds the plans (settings must be valid).
    pub fn new(settings: HarmonicSettings) -> Self {
        let mut planner = FftPlanner::new();
        let forward = planner.plan_fft_forward(settings.samples);
        let inverse = planner.plan_fft_inverse(settings.samples);
        let scratch_len = forward
            .get_inplace_scratch_len()
            .max(inverse.get_inplace_scratch_len());
        Self {
            settings,
            samples: settings.samples,
            forward,
            inverse,
            buffer: Vec::new(),
            scratch: vec![Complex::new(0.0, 0.0); scratch_len],
        }
    }

    /// Time samples of `count` series: `coeffs[s * (N+1) + n]` -> `out[s * m + k]`.
    pub fn synthesize(&mut self, coeffs: &[f64], count: usize, out: &mut [f64]) {
        let (nh, m) = (self.settings.terms(), self.samples);
        if count == 0 {
            return;
        }
        self.buffer.clear();
        self.buffer.resize(count * m, Complex::new(0.0, 0.0));
        for s in 0..count {
            let c = &coeffs[s * nh..(s + 1) * nh];
            let b = &mut self.buffer[s * m..(s + 1) * m];
            b[0] = Complex::new(c[0], 0.0);
            for n in 1..nh {
                let h = 0.5 * c[n];
                b[n].re += h;
                b[m - n].re += h;
            }
        }
        self.inverse
            .process_with_scratch(&mut self.buffer, &mut self.scratch);
        for (o, b) in out[..count * m].iter_mut().zip(&self.buffer) {
            *o = b.re;
        }
    }

    /// Cosine coefficients of `count` sampled signals: `samples[s * m + k]` -> `out[s * (N+1) + n]`.
    pub fn analyze(&mut self, samples: &[f64], count: usize, out: &mut [f64]) {
        let (nh, m) = (self.settings.terms(), self.samples);
        if count == 0 {
            return;
        }
        self.transform_forward(samples, count);
        let inv_m = 1.0 / m as f64;
        for s in 0..count {
            let b = &self.buffer[s * m..(s + 1) * m];
            let o = &mut out[s * nh..(s + 1) * nh];
            o[0] = b[0].re * inv_m;
            for n in 1..nh {
                o[n] = 2.0 * b[n].re * inv_m;
            }
        }
    }

    /// Cosine moments D_p = (1/m) sum_k d_k cos(2 pi p k / m), p = 0..=2N, of `count` signals:
    /// `out[s * (2N+1) + p]`. The projected Jacobian of a sampled pointwise law with slope d_k is
    /// then J_{0,n'} = D_{n'} and J_{n,n'} = D_{n+n'} + D_{|n-n'|} for n >= 1.
    pub fn cosine_moments(&mut self, d: &[f64], count: usize, out: &mut [f64]) {
        let (np, m) = (2 * self.settings.harmonics + 1, self.samples);
        if count == 0 {
            return;
        }
        self.transform_forward(d, count);
        let inv_m = 1.0 / m as f64;
        for s in 0..count {
            let b = &self.buffer[s * m..(s + 1) * m];
            for p in 0..np {
                out[s * np + p] = b[p % m].re * inv_m;
            }
        }
    }

    fn transform_forward(&mut self, samples: &[f64], count: usize) {
        let m = self.samples;
        self.buffer.clear();
        self.buffer
            .extend(samples[..count * m].iter().map(|&v| Complex::new(v, 0.0)));
        self.forward
            .process_with_scratch(&mut self.buffer, &mut self.scratch);
    }
}

/// Value at phase `phase` (= w t, rad) of the cosine series with coefficients `coeffs`.
pub fn cosine_series(coeffs: &[f64], phase: f64) -> f64 {
    coeffs
        .iter()
        .enumerate()
        .map(|(n, c)| c * (n as f64 * phase).cos())
        .sum()
}

/// Derivative with respect to time of the cosine series at phase `phase`, for circular frequency
/// `omega` (rad/s): -sum n w c_n sin(n w t).
pub fn cosine_series_rate(coeffs: &[f64], omega: f64, phase: f64) -> f64 {
    -coeffs
        .iter()
        .enumerate()
        .map(|(n, c)| n as f64 * omega * c * (n as f64 * phase).sin())
        .sum::<f64>()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn settings_validation() {
        assert!(HarmonicSettings::new(0, 64).is_err());
        assert!(HarmonicSettings::new(10, 20).is_err());
        assert!(HarmonicSettings::new(10, 21).is_ok());
        assert_eq!(HarmonicSettings::default_samples(5), 64);
        assert_eq!(HarmonicSettings::default_samples(20), 256);
    }

    #[test]
    fn round_trip_and_direct_sums_agree() {
        // Independent check: direct evaluation of the cosine sums, to round-off (1e-13 on O(1) data).
        let s = HarmonicSettings::new(5, 16).expect("valid");
        let mut aft = Aft::new(s);
        let coeffs = [
            0.3, 1.0, -0.5, 0.25, 0.1, -0.05, 2.0, 0.0, 0.0, 0.0, 0.0, 1.0,
        ];
        let mut samples = vec![0.0; 32];
        aft.synthesize(&coeffs, 2, &mut samples);
        for sig in 0..2 {
            for k in 0..16 {
                let phase = 2.0 * std::f64::consts::PI * k as f64 / 16.0;
                let direct = cosine_series(&coeffs[sig * 6..(sig + 1) * 6], phase);
                assert!((samples[sig * 16 + k] - direct).abs() < 1e-13);
            }
        }
        let mut back = vec![0.0; 12];
        aft.analyze(&samples, 2, &mut back);
        for (a, b) in back.iter().zip(coeffs.iter()) {
            assert!((a - b).abs() < 1e-13, "{back:?}");
        }
        let d: Vec<f64> = (0..16).map(|k| (k as f64 * 0.37).sin().abs()).collect();
        let mut moments = vec![0.0; 11];
        aft.cosine_moments(&d, 1, &mut moments);
        for (p, mp) in moments.iter().enumerate() {
            let direct: f64 = (0..16)
                .map(|k| d[k] * (2.0 * std::f64::consts::PI * (p * k) as f64 / 16.0).cos())
                .sum::<f64>()
                / 16.0;
            assert!((mp - direct).abs() < 1e-13);
        }
    }
}
