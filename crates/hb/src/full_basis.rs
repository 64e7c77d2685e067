//! The full Fourier basis of damped and forced orbits (DESIGN §10.1):
//! u(t) = u_0 + sum_{n=1..N} (a_n cos(n w t) + b_n sin(n w t)), sampled at t_k = k T / m (Eq. 18).
//!
//! A signal's 2N + 1 coefficients are ordered [u_0, a_1, b_1, ..., a_N, b_N]
//! ([`FullBasis::cos_index`], [`FullBasis::sin_index`]). The cosine series of the free modes
//! (Eq. 6) is the special case b_n = 0 of time-symmetric orbits. Synthesis and analysis are dense
//! products with the m x (2N + 1) matrix E of the basis functions at the samples and its discrete
//! projection P (P E = I for m >= 2N + 1): exact on trigonometric polynomials of degree N, the
//! alternating frequency-time scheme (Eq. 19) on the contact forces. The sizes of this engine
//! (2N + 1 <= 161, m <= 1024) make the products cheaper than an FFT's bookkeeping.

use faer::{Mat, MatMut};

use crate::error::HbError;
use crate::fourier::HarmonicSettings;

/// Basis functions at the time samples, and their projection (see module docs).
#[derive(Clone, Debug)]
pub struct FullBasis {
    harmonics: usize,
    samples: usize,
    /// E[(k, p)]: basis function p at sample k.
    synthesis: Mat<f64>,
    /// P[(p, k)]: coefficient p from sample k (1/m for the mean, 2/m cos or sin otherwise).
    analysis: Mat<f64>,
    /// D[(k, p)]: the phase derivative d phi_p / d(w t) at sample k.
    slope: Mat<f64>,
}

impl FullBasis {
    /// The basis for `settings` (N >= 1, m >= 2N + 1, checked).
    pub fn new(settings: HarmonicSettings) -> Result<Self, HbError> {
        settings.validate()?;
        let (nh, m) = (settings.harmonics, settings.samples);
        let terms = 2 * nh + 1;
        // Reduce n k modulo m before scaling: the same angle for every (n, k) with equal n k
        // mod m, so one table of the m angles' cosines and sines serves every entry.
        let angle = |j: usize| 2.0 * std::f64::consts::PI * j as f64 / m as f64;
        let cosines: Vec<f64> = (0..m).map(|j| angle(j).cos()).collect();
        let sines: Vec<f64> = (0..m).map(|j| angle(j).sin()).collect();
        let value = |k: usize, p: usize| match p {
            0 => 1.0,
            _ if p % 2 == 1 => cosines[(p.div_ceil(2) * k) % m],
            _ => sines[(p / 2 * k) % m],
        };
        let derivative = |k: usize, p: usize| {
            let n = Self::harmonic_of(p) as f64;
            match p {
                0 => 0.0,
                _ if p % 2 == 1 => -n * value(k, p + 1),
                _ => n * value(k, p - 1),
            }
        };
        let synthesis = Mat::from_fn(m, terms, value);
        let weight = |p: usize| if p == 0 { 1.0 } else { 2.0 } / m as f64;
        let analysis = Mat::from_fn(terms, m, |p, k| weight(p) * value(k, p));
        let slope = Mat::from_fn(m, terms, derivative);
        Ok(Self {
            harmonics: nh,
            samples: m,
            synthesis,
            analysis,
            slope,
        })
    }

    /// Highest harmonic N.
    pub fn harmonics(&self) -> usize {
        self.harmonics
    }

    /// Time samples per period m.
    pub fn samples(&self) -> usize {
        self.samples
    }

    /// Coefficients per signal, 2N + 1.
    pub fn terms(&self) -> usize {
        2 * self.harmonics + 1
    }

    /// Index of a_n (n >= 1).
    #[inline]
    pub fn cos_index(n: usize) -> usize {
        2 * n - 1
    }

    /// Index of b_n (n >= 1).
    #[inline]
    pub fn sin_index(n: usize) -> usize {
        2 * n
    }

    /// The harmonic a coefficient index belongs to (0 for the mean).
    #[inline]
    pub fn harmonic_of(p: usize) -> usize {
        p.div_ceil(2)
    }

    /// Samples of one signal from its 2N + 1 coefficients (E c, column by column: contiguous).
    pub fn synthesize(&self, coeffs: &[f64], out: &mut [f64]) {
        combine_columns(self.synthesis.as_ref(), coeffs, &mut out[..self.samples]);
    }

    /// Samples of one signal and of its phase derivative d/d(w t) (E c and D c).
    pub fn synthesize_with_slope(&self, coeffs: &[f64], values: &mut [f64], slopes: &mut [f64]) {
        combine_columns(self.synthesis.as_ref(), coeffs, &mut values[..self.samples]);
        combine_columns(self.slope.as_ref(), coeffs, &mut slopes[..self.samples]);
    }

    /// Samples of several signals at once, E Y (and D Y into `slopes` when given): `coeffs`
    /// holds 2N + 1 coefficients per signal, `values` and `slopes` m samples per signal, both
    /// signal after signal (one matrix product instead of a loop over signals).
    pub fn synthesize_signals(
        &self,
        coeffs: &[f64],
        values: &mut [f64],
        slopes: Option<&mut [f64]>,
    ) {
        let (t, m) = (self.terms(), self.samples);
        let signals = coeffs.len() / t;
        let y = faer::MatRef::from_column_major_slice(coeffs, t, signals);
        let product = |table: &Mat<f64>, out: &mut [f64]| {
            let out =
                faer::MatMut::from_column_major_slice_mut(&mut out[..m * signals], m, signals);
            faer::linalg::matmul::matmul(
                out,
                faer::Accum::Replace,
                table.as_ref(),
                y,
                1.0,
                faer::Par::Seq,
            );
        };
        product(&self.synthesis, values);
        if let Some(slopes) = slopes {
            product(&self.slope, slopes);
        }
    }

    /// The 2N + 1 coefficients of one signal from its m samples (the AFT's forward half).
    pub fn analyze(&self, samples: &[f64], out: &mut [f64]) {
        combine_columns(
            self.analysis.as_ref(),
            &samples[..self.samples],
            &mut out[..self.terms()],
        );
    }

    /// The harmonic-balance Jacobian of a sampled law with slopes s_k = d lambda / d g at the
    /// samples: d Lambda_p / d y_q = sum_k P[p, k] s_k E[k, q], written into `out` ((2N+1)^2).
    pub fn project_slopes(&self, slopes: &[f64], mut out: MatMut<'_, f64>) {
        let terms = self.terms();
        out.fill(0.0);
        for (k, &s) in slopes.iter().enumerate().take(self.samples) {
            if s == 0.0 {
                continue;
            }
            for q in 0..terms {
                let sq = s * self.synthesis[(k, q)];
                for p in 0..terms {
                    out[(p, q)] += self.analysis[(p, k)] * sq;
                }
            }
        }
    }

    /// Value of a series at the phase w t (radians).
    pub fn value_at(coeffs: &[f64], phase: f64) -> f64 {
        let nh = coeffs.len() / 2;
        let mut v = coeffs[0];
        // cos(n x), sin(n x) by angle addition from one sin_cos: a rounding error of order
        // n eps (1e-14 at N = 50), against N calls of sin_cos (the switch search of the
        // monodromy evaluates series millions of times).
        let (s1, c1) = phase.sin_cos();
        let (mut s, mut c) = (s1, c1);
        for n in 1..=nh {
            v += coeffs[Self::cos_index(n)] * c + coeffs[Self::sin_index(n)] * s;
            (s, c) = (s * c1 + c * s1, c * c1 - s * s1);
        }
        v
    }

    /// Value and phase derivative (d/d(w t)) of a series at the phase w t, by the angle-addition
    /// recurrence of [`FullBasis::value_at`] (one `sin_cos` per call).
    pub fn value_and_slope_at(coeffs: &[f64], phase: f64) -> (f64, f64) {
        let nh = coeffs.len() / 2;
        let (mut v, mut d) = (coeffs[0], 0.0);
        let (s1, c1) = phase.sin_cos();
        let (mut s, mut c) = (s1, c1);
        for n in 1..=nh {
            let (a, b) = (coeffs[Self::cos_index(n)], coeffs[Self::sin_index(n)]);
            v += a * c + b * s;
            d += n as f64 * (b * c - a * s);
            (s, c) = (s * c1 + c * s1, c * c1 - s * s1);
        }
        (v, d)
    }

    /// First and second phase derivatives (d/d(w t), d^2/d(w t)^2) of a series at the phase
    /// w t, by the angle-addition recurrence of [`FullBasis::value_at`].
    pub fn slope_and_curvature_at(coeffs: &[f64], phase: f64) -> (f64, f64) {
        let nh = coeffs.len() / 2;
        let (mut d, mut dd) = (0.0, 0.0);
        let (s1, c1) = phase.sin_cos();
        let (mut s, mut c) = (s1, c1);
        for n in 1..=nh {
            let (a, b) = (coeffs[Self::cos_index(n)], coeffs[Self::sin_index(n)]);
            let nf = n as f64;
            d += nf * (b * c - a * s);
            dd -= nf * nf * (a * c + b * s);
            (s, c) = (s * c1 + c * s1, c * c1 - s * s1);
        }
        (d, dd)
    }

    /// Time derivative of a series at the phase w t, for the fundamental w (rad/s).
    pub fn rate_at(coeffs: &[f64], omega: f64, phase: f64) -> f64 {
        let nh = coeffs.len() / 2;
        let mut v = 0.0;
        for n in 1..=nh {
            let (s, c) = (n as f64 * phase).sin_cos();
            let nw = n as f64 * omega;
            v += nw * (-coeffs[Self::cos_index(n)] * s + coeffs[Self::sin_index(n)] * c);
        }
        v
    }

    /// Amplitude sqrt(a_n^2 + b_n^2) and phase atan2(b_n, a_n) of harmonic n >= 1 (the series
    /// reads amplitude cos(n w t - phase)).
    pub fn amplitude_phase(coeffs: &[f64], n: usize) -> (f64, f64) {
        let (a, b) = (coeffs[Self::cos_index(n)], coeffs[Self::sin_index(n)]);
        (a.hypot(b), b.atan2(a))
    }
}

/// out = A x, as a sum of A's columns (contiguous in faer's column-major storage).
fn combine_columns(a: faer::MatRef<'_, f64>, x: &[f64], out: &mut [f64]) {
    out.fill(0.0);
    for (j, &xj) in x.iter().enumerate() {
        if xj == 0.0 {
            continue;
        }
        let column = a
            .col(j)
            .try_as_col_major()
            .expect("faer matrices are column-major");
        for (o, v) in out.iter_mut().zip(column.as_slice()) {
            *o += v * xj;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn basis(n: usize, m: usize) -> FullBasis {
        FullBasis::new(HarmonicSettings::new(n, m).unwrap()).unwrap()
    }

    #[test]
    fn analysis_inverts_synthesis_and_matches_the_series() {
        let b = basis(4, 9); // the smallest admissible m = 2N + 1
        let c: Vec<f64> = (0..9).map(|p| 0.3 * p as f64 - 0.7).collect();
        let mut s = vec![0.0; 9];
        b.synthesize(&c, &mut s);
        for (k, &v) in s.iter().enumerate() {
            let phase = 2.0 * std::f64::consts::PI * k as f64 / 9.0;
            assert!((v - FullBasis::value_at(&c, phase)).abs() < 1e-13);
        }
        let mut back = vec![0.0; 9];
        b.analyze(&s, &mut back);
        for p in 0..9 {
            assert!(
                (back[p] - c[p]).abs() < 1e-13,
                "{p}: {} vs {}",
                back[p],
                c[p]
            );
        }
    }

    #[test]
    fn projected_slopes_are_the_derivative_of_the_aft() {
        // Lambda(y) = analyze(s .* synthesize(y)) is linear in y with matrix P diag(s) E.
        let b = basis(3, 16);
        let slopes: Vec<f64> = (0..16)
            .map(|k| if k % 3 == 0 { 2.0 } else { 0.0 })
            .collect();
        let mut j = Mat::zeros(7, 7);
        b.project_slopes(&slopes, j.as_mut());
        for q in 0..7 {
            let mut e = vec![0.0; 7];
            e[q] = 1.0;
            let mut s = vec![0.0; 16];
            b.synthesize(&e, &mut s);
            s.iter_mut().zip(&slopes).for_each(|(v, k)| *v *= k);
            let mut col = vec![0.0; 7];
            b.analyze(&s, &mut col);
            for p in 0..7 {
                assert!((col[p] - j[(p, q)]).abs() < 1e-14);
            }
        }
    }

    #[test]
    fn sampled_slopes_are_the_series_derivative() {
        let b = basis(3, 20);
        let c = [0.1, 1.0, -0.5, 0.25, 0.75, -0.3, 0.2];
        let (mut v, mut d) = (vec![0.0; 20], vec![0.0; 20]);
        b.synthesize_with_slope(&c, &mut v, &mut d);
        for k in 0..20 {
            let (value, slope) =
                FullBasis::value_and_slope_at(&c, std::f64::consts::TAU * k as f64 / 20.0);
            assert!(
                (v[k] - value).abs() < 1e-13 && (d[k] - slope).abs() < 1e-13,
                "{k}"
            );
        }
    }

    #[test]
    fn signals_at_once_equal_signals_one_by_one() {
        let b = basis(3, 20);
        let c: Vec<f64> = (0..21).map(|p| (0.3 * p as f64).cos()).collect();
        let (mut v, mut d) = (vec![0.0; 60], vec![0.0; 60]);
        b.synthesize_signals(&c, &mut v, Some(&mut d));
        for j in 0..3 {
            let (mut vj, mut dj) = (vec![0.0; 20], vec![0.0; 20]);
            b.synthesize_with_slope(&c[7 * j..7 * (j + 1)], &mut vj, &mut dj);
            for k in 0..20 {
                assert!(
                    (v[20 * j + k] - vj[k]).abs() < 1e-14 && (d[20 * j + k] - dj[k]).abs() < 1e-13
                );
            }
        }
    }

    #[test]
    fn value_and_slope_agree_with_value_and_rate() {
        let c = [0.1, 1.0, -0.5, 0.25, 0.75, -0.3, 0.2];
        for ph in [0.0, 0.4, 2.9, 5.5] {
            let (v, d) = FullBasis::value_and_slope_at(&c, ph);
            assert!((v - FullBasis::value_at(&c, ph)).abs() < 1e-14);
            assert!((d - FullBasis::rate_at(&c, 1.0, ph)).abs() < 1e-13);
        }
    }

    #[test]
    fn rate_is_the_derivative_of_the_value() {
        let c = [0.1, 1.0, -0.5, 0.25, 0.75];
        let (w, ph, h) = (3.0, 0.4, 1e-6);
        let fd = (FullBasis::value_at(&c, ph + h) - FullBasis::value_at(&c, ph - h)) / (2.0 * h);
        assert!((FullBasis::rate_at(&c, w, ph) - w * fd).abs() < 1e-8);
        let (amp, phase) = FullBasis::amplitude_phase(&c, 2);
        assert!(
            (amp * (2.0 * ph - phase).cos() + c[1] * ph.cos() + c[2] * ph.sin() + c[0]
                - FullBasis::value_at(&c, ph))
            .abs()
                < 1e-14
        );
    }
}
