//! `[forced.distortion]`: an ovalized or n-lobed casing as the excitation (issue 39, item 3;
//! docs/DESIGN.md §10.11). The gap every contact row sees becomes
//! g0_j - delta cos(h W t + phase) in a frequency sweep (W the orbit's fundamental, h =
//! `harmonic`, default 1: W is the lobe-passing frequency n Omega) and
//! g0_j(Omega) - delta cos(n Omega t + phase) in a speed sweep (the orbit's fundamental then
//! gcd(e, n) Omega). The table's absence is a casing without distortion.

use serde::{Deserialize, Serialize};

use crate::problems::Problems;

/// How `amplitude` is read.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub enum AmplitudeUnit {
    /// Metres.
    #[serde(rename = "m")]
    Metre,
    /// A fraction of the mean gap g0 of the model the study runs on (in a speed sweep, the
    /// mean running gap at the crossing's speed; the amplitude is then held in metres along
    /// the sweep, as a casing's shape does not follow the blade's speed).
    #[serde(rename = "gap")]
    Gap,
}

/// Largest `lobes`: the engine orders' bound (`speed_sweep.engine_orders`, 1..200).
pub const MAX_LOBES: i64 = 200;

/// `[forced.distortion]`; every key has a default.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct DistortionSection {
    /// n, the casing's lobes (2: an ovalized casing).
    pub lobes: i64,
    /// delta, the largest reduction of the gap, in `amplitude_unit`. Above the smallest gap
    /// the casing reaches the blade at rest at every lobe (the excitation of a distortion
    /// alone; without a load, below it nothing moves and the study is refused).
    pub amplitude: f64,
    /// Unit of `amplitude`: "m" (default) or "gap" (fraction of the mean gap g0).
    pub amplitude_unit: AmplitudeUnit,
    /// phase (rad): the gap is smallest at n Omega t + phase = 0 mod 2 pi.
    pub phase: f64,
    /// h, the harmonic of W at which the gap varies in a frequency sweep (`nlmodes forced`,
    /// the forced stages of `nlmodes run`): 1, W is the lobe-passing frequency. The load acts at
    /// `[forced] harmonic` of the same W. Speed sweeps place the harmonics themselves (n / gcd)
    /// and need 1 here.
    pub harmonic: i64,
}

impl Default for DistortionSection {
    fn default() -> Self {
        Self {
            lobes: 2,
            amplitude: 0.0,
            amplitude_unit: AmplitudeUnit::Metre,
            phase: 0.0,
            harmonic: 1,
        }
    }
}

impl DistortionSection {
    /// Every key: `forced.distortion.KEY = value: expected ...`; `harmonics` is `[forced]
    /// harmonics` (the distortion's harmonic must be on the basis).
    pub fn check(&self, p: &mut Problems, harmonics: usize) {
        p.check(
            (1..=MAX_LOBES).contains(&self.lobes),
            "forced.distortion.lobes",
            self.lobes,
            &format!("an integer 1 <= n <= {MAX_LOBES} (the casing's lobes)"),
        );
        p.check(
            self.amplitude.is_finite() && self.amplitude >= 0.0,
            "forced.distortion.amplitude",
            self.amplitude,
            "a finite amplitude >= 0 (m, or a fraction of the gap with amplitude_unit = \"gap\")",
        );
        p.check(
            self.phase.is_finite(),
            "forced.distortion.phase",
            self.phase,
            "a finite phase (rad)",
        );
        p.check(
            self.harmonic >= 1 && self.harmonic as usize <= harmonics,
            "forced.distortion.harmonic",
            self.harmonic,
            &format!(
                "1 <= h <= forced.harmonics = {harmonics} (the harmonic of W at which the gap \
                 varies)"
            ),
        );
    }

    /// Whether the casing moves the gap at all (amplitude > 0).
    pub fn excites(&self) -> bool {
        self.amplitude > 0.0
    }

    /// delta in metres for a model of mean gap `gap_reference` (m).
    pub fn amplitude_m(&self, gap_reference: f64) -> f64 {
        match self.amplitude_unit {
            AmplitudeUnit::Metre => self.amplitude,
            AmplitudeUnit::Gap => self.amplitude * gap_reference,
        }
    }

    /// The solver's distortion of a frequency sweep on a model of mean gap `gap_reference` (m).
    pub fn frequency_sweep(&self, gap_reference: f64) -> nlmodes_forced::CasingDistortion {
        nlmodes_forced::CasingDistortion {
            harmonic: self.harmonic.max(1) as usize,
            amplitude: self.amplitude_m(gap_reference),
            phase: self.phase,
        }
    }
}

/// The study's distortion as its outputs state it (`frf.json`, `speed_sweep.json`).
#[derive(Debug, Clone, Serialize)]
pub struct DistortionRecord {
    pub lobes: usize,
    /// delta (m) and delta / g0 (the mean gap of the model, or the running gap at the
    /// crossing's speed).
    pub amplitude_m: f64,
    pub amplitude_over_g0: f64,
    pub phase_rad: f64,
    /// The harmonic of the orbit's fundamental W at which the gap varies.
    pub harmonic: usize,
    /// What W is, in words.
    pub fundamental: String,
}

impl DistortionRecord {
    /// The record of a frequency sweep on a model of mean gap `g0` (m).
    pub fn of_frequency_sweep(d: &DistortionSection, g0: f64) -> Self {
        let h = d.harmonic.max(1) as usize;
        let fundamental = if h == 1 {
            format!(
                "W is the lobe-passing frequency {} Omega (the structure frozen at the model's \
                 speed)",
                d.lobes
            )
        } else {
            format!(
                "the lobes pass at harmonic {h} of W: {} Omega = {h} W (the structure frozen at \
                 the model's speed)",
                d.lobes
            )
        };
        Self {
            lobes: d.lobes.max(1) as usize,
            amplitude_m: d.amplitude_m(g0),
            amplitude_over_g0: d.amplitude_m(g0) / g0,
            phase_rad: d.phase,
            harmonic: h,
            fundamental,
        }
    }
}

/// The report's sentence on a study's casing distortion.
pub fn report_sentence(d: &DistortionRecord) -> String {
    format!(
        "Casing distortion (docs/DESIGN.md §10.11): {} lobes, the gap of every contact row \
         reduced by delta cos(h W t + phase), delta = {:.4e} m ({:.4} g0), phase {} rad, h = {}: \
         {}. Under a distortion the massless contact boundary (constant gaps) gives neither \
         the stability of points in contact nor an exact curve: a verdict comes from the \
         harmonic-balance orbit's monodromy where one period of time integration of the \
         penalty equation with the moving gap returns it to its start, otherwise the point is \
         undetermined; no backbone synthesis is drawn (it is the response to a load).",
        d.lobes, d.amplitude_m, d.amplitude_over_g0, d.phase_rad, d.harmonic, d.fundamental
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    fn problems(d: &DistortionSection) -> String {
        let mut p = Problems::new(|k| format!("s.toml: {k}"));
        d.check(&mut p, 10);
        p.finish().err().map(|e| e.to_string()).unwrap_or_default()
    }

    /// Lobes below 1, an amplitude negative or not finite, a phase not finite, a harmonic off
    /// the basis: each named with the file, the key and the value.
    #[test]
    fn bad_values_are_named() {
        assert_eq!(problems(&DistortionSection::default()), "");
        let d = DistortionSection {
            lobes: 0,
            amplitude: -1e-5,
            phase: f64::NAN,
            harmonic: 11,
            ..DistortionSection::default()
        };
        let text = problems(&d);
        for want in [
            "s.toml: forced.distortion.lobes = 0: expected an integer 1 <= n <= 200",
            "s.toml: forced.distortion.amplitude = -1e-5: expected a finite amplitude >= 0",
            "s.toml: forced.distortion.phase = NaN: expected a finite phase (rad)",
            "s.toml: forced.distortion.harmonic = 11: expected 1 <= h <= forced.harmonics = 10",
        ] {
            assert!(text.contains(want), "missing `{want}` in:\n{text}");
        }
        let infinite = DistortionSection {
            amplitude: f64::INFINITY,
            ..DistortionSection::default()
        };
        assert!(problems(&infinite).contains("forced.distortion.amplitude = inf"));
    }

    #[test]
    fn the_amplitude_in_gaps_is_a_fraction_of_the_mean_gap() {
        let d = DistortionSection {
            amplitude: 0.3,
            amplitude_unit: AmplitudeUnit::Gap,
            ..DistortionSection::default()
        };
        assert!((d.amplitude_m(2e-4) - 6e-5).abs() < 1e-20);
        let m = DistortionSection {
            amplitude: 0.3,
            ..DistortionSection::default()
        };
        assert_eq!(m.amplitude_m(2e-4), 0.3);
    }
}
