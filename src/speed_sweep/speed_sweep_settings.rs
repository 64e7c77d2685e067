//! `[speed_sweep]` of the case file (issue 39, item 2; README "Speed sweeps"): forced responses
//! along the rotation speed at engine orders, W = e Omega, on the parametric reduced model of
//! the Campbell stage, with the damping, the load, the levels, N and the contact law of
//! `[forced]`. Speeds in rpm. Without the table no speed sweep runs.

use serde::{Deserialize, Serialize};

use crate::problems::Problems;

/// How the speed sweeps converge N (`[speed_sweep] adapt_harmonics`; docs/DESIGN.md §10.10).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum SweepHarmonics {
    /// Traced at `[forced] harmonics`; its peak, folds, deepest contact and four points spread
    /// over its contact solved again at 2N, and the whole sweep traced again at 2N while one
    /// moves by more than `[forced] harmonic_tolerance` (up to `[forced] max_harmonics`);
    /// where the last trace's check still moves, N raised around those points alone (in
    /// segments along the sweep, checked at twice the raised N).
    Retrace,
    /// Traced at `[forced] harmonics`, the same points checked at 2N and flagged, no retrace.
    Check,
    /// Traced at `[forced] harmonics`, unchecked.
    Fixed,
}

impl SweepHarmonics {
    /// The library's policy.
    pub fn policy(self) -> nlmodes_forced::SpeedHarmonics {
        match self {
            Self::Retrace => nlmodes_forced::SpeedHarmonics::Retrace,
            Self::Check => nlmodes_forced::SpeedHarmonics::Check,
            Self::Fixed => nlmodes_forced::SpeedHarmonics::Fixed,
        }
    }
}

/// How the casing study converges N (`[speed_sweep.casing] adapt_harmonics`; docs/ROTATION.md
/// "The casing study's N").
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum CasingHarmonics {
    /// Traced at `[forced] harmonics`; every point in contact solved again at 2N from its own
    /// orbit, and again at 4N, ... while its doubling moves its first harmonic or largest
    /// contact force by more than `[forced] harmonic_tolerance` (up to `[forced]
    /// max_harmonics`); each point keeps its finer orbit and says its N.
    Refine,
    /// Traced at `[forced] harmonics`; its largest response and force, jumps and four points
    /// spread over the contact checked at 2N and flagged, the orbits kept.
    Check,
    /// Traced at `[forced] harmonics`, unchecked.
    Fixed,
}

impl CasingHarmonics {
    /// The library's policy (`SpeedHarmonics::Retrace` is the casing sweep's refinement).
    pub fn policy(self) -> nlmodes_forced::SpeedHarmonics {
        match self {
            Self::Refine => nlmodes_forced::SpeedHarmonics::Retrace,
            Self::Check => nlmodes_forced::SpeedHarmonics::Check,
            Self::Fixed => nlmodes_forced::SpeedHarmonics::Fixed,
        }
    }
}

/// The `[speed_sweep]` table; every key has a default.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct SpeedSweepSection {
    /// Run the sweeps (a table with `enabled = false` keeps its settings without running).
    pub enabled: bool,
    /// Engine orders e (integers >= 1) swept through their crossing with the traced mode
    /// (`[forced] mode`); empty: every engine order of `[rotation] engine_orders` whose
    /// crossing lies inside `speed_range`.
    pub engine_orders: Vec<i64>,
    /// The speeds the sweeps may cover, rpm: [from, to] within the Campbell range (the
    /// parametric model's); default: that range.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub speed_range: Option<[f64; 2]>,
    /// The detuning e Omega / w_mode(Omega) each sweep runs over, around its crossing (where it
    /// is 1): [from, to] with from < 1 < to, the counterpart of `[forced] range`; cut to
    /// `speed_range` and to the speed where a running gap closes statically.
    pub window: [f64; 2],
    /// The levels of the sweeps (one sweep per engine order and level) in `[forced]
    /// level_unit` (`"grazing"`: of the grazing force at the crossing's speed); empty: the
    /// levels of `[forced]`.
    pub levels: Vec<f64>,
    /// Most points per sweep.
    pub max_points: usize,
    /// How N is converged: "retrace" (default), "check" or "fixed" ([`SweepHarmonics`]).
    pub adapt_harmonics: SweepHarmonics,
    /// `[speed_sweep.casing]`: the response to a growing casing distortion at one speed
    /// (absent: none).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub casing: Option<CasingSection>,
}

/// `[speed_sweep.casing]` (issue 39, item 6; docs/ROTATION.md "Casing distortion at the
/// operating speed"): an n-lobed casing's intrusion delta swept at one speed, no load; W the
/// lobe-passing frequency n Omega, every contact row's gap g0_j(Omega) - delta cos(n Omega t +
/// phase). Every key has a default.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct CasingSection {
    /// Run it (default true).
    pub enabled: bool,
    /// n, the casing's lobes (2: an ovalized casing).
    pub lobes: i64,
    /// [from, to] of delta in mean running gaps at the speed (default [0, 2]).
    pub amplitudes: [f64; 2],
    /// Amplitudes evenly spaced over `amplitudes` (default 41); the onset (delta = the smallest
    /// running gap) is added.
    pub points: usize,
    /// The phase (rad) of the intrusion: the gap is smallest at n Omega t + phase = 0.
    pub phase: f64,
    /// The speed (rpm; default: `[rotation] operating_speed`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub speed: Option<f64>,
    /// How N is converged: "refine" (default), "check" or "fixed" ([`CasingHarmonics`]).
    pub adapt_harmonics: CasingHarmonics,
}

impl Default for CasingSection {
    fn default() -> Self {
        Self {
            enabled: true,
            lobes: 2,
            amplitudes: [0.0, 2.0],
            points: 41,
            phase: 0.0,
            speed: None,
            adapt_harmonics: CasingHarmonics::Refine,
        }
    }
}

impl CasingSection {
    /// Every key: `speed_sweep.casing.KEY = value: expected ...`; `campbell` the speed range
    /// (rpm) of the parametric model, named by `range_key`.
    pub fn check(&self, p: &mut Problems, campbell: Option<[f64; 2]>, range_key: &str) {
        let max = crate::forced::forced_distortion::MAX_LOBES;
        p.check(
            (1..=max).contains(&self.lobes),
            "speed_sweep.casing.lobes",
            self.lobes,
            &format!("an integer 1 <= n <= {max} (the casing's lobes)"),
        );
        let [a, b] = self.amplitudes;
        p.check(
            a.is_finite() && b.is_finite() && a >= 0.0 && a < b,
            "speed_sweep.casing.amplitudes",
            self.amplitudes,
            "[from, to] in mean running gaps with 0 <= from < to, finite",
        );
        p.check(
            (2..=1000).contains(&self.points),
            "speed_sweep.casing.points",
            self.points,
            "2 <= points <= 1000",
        );
        p.check(
            self.phase.is_finite(),
            "speed_sweep.casing.phase",
            self.phase,
            "a finite phase (rad)",
        );
        if let (Some(v), Some([lo, hi])) = (self.speed, campbell) {
            p.check(
                v.is_finite() && v > 0.0 && v >= lo && v <= hi,
                "speed_sweep.casing.speed",
                v,
                &format!("a speed > 0 within {range_key} = [{lo}, {hi}] rpm"),
            );
        }
    }

    /// The amplitudes (in mean running gaps `g0`, m): `points` evenly spaced, and the onset
    /// `onset` (m, the smallest running gap) when inside; ascending, each once.
    pub fn grid(&self, g0: f64, onset: f64) -> Vec<f64> {
        let [a, b] = self.amplitudes;
        let n = self.points.max(2);
        let mut v: Vec<f64> = (0..n)
            .map(|i| g0 * (a + (b - a) * i as f64 / (n - 1) as f64))
            .collect();
        if onset > v[0] && onset < v[n - 1] {
            v.push(onset);
        }
        v.sort_by(f64::total_cmp);
        v.dedup_by(|x, y| (*x - *y).abs() <= 1e-12 * g0);
        v
    }
}

impl Default for SpeedSweepSection {
    fn default() -> Self {
        Self {
            enabled: true,
            engine_orders: Vec::new(),
            speed_range: None,
            window: [0.9, 1.2],
            levels: Vec::new(),
            max_points: 2000,
            adapt_harmonics: SweepHarmonics::Retrace,
            casing: None,
        }
    }
}

impl SpeedSweepSection {
    /// Every key: recorded in `p` as `speed_sweep.KEY = value: expected ...`; `campbell` is the
    /// range (rpm) the parametric model covers, and `range_key` names where it comes from.
    pub fn check(&self, p: &mut Problems, campbell: Option<[f64; 2]>, range_key: &str) {
        for (i, eo) in self.engine_orders.iter().enumerate() {
            p.check(
                (1..=200).contains(eo),
                "speed_sweep.engine_orders",
                eo,
                "integers 1 <= EO <= 200 (W = EO x Omega)",
            );
            p.check(
                !self.engine_orders[..i].contains(eo),
                "speed_sweep.engine_orders",
                eo,
                "each engine order listed once",
            );
        }
        if let Some([a, b]) = self.speed_range {
            let finite = a.is_finite() && b.is_finite() && a >= 0.0 && a < b;
            p.check(
                finite,
                "speed_sweep.speed_range",
                [a, b],
                "[from, to] rpm with 0 <= from < to, finite",
            );
            if let (true, Some([lo, hi])) = (finite, campbell) {
                p.check(
                    a >= lo && b <= hi,
                    "speed_sweep.speed_range",
                    [a, b],
                    &format!(
                        "a range within {range_key} = [{lo}, {hi}] rpm (the parametric model's)"
                    ),
                );
            }
        }
        let [w0, w1] = self.window;
        p.check(
            w0.is_finite() && w1.is_finite() && w0 > 0.0 && w0 < 1.0 && w1 > 1.0,
            "speed_sweep.window",
            self.window,
            "[from, to] of e Omega / w_mode with 0 < from < 1 < to (around the crossing)",
        );
        for l in &self.levels {
            p.check(
                l.is_finite() && *l >= 0.0,
                "speed_sweep.levels",
                l,
                "finite levels >= 0 (0 only with a [forced.distortion]: the casing alone)",
            );
        }
        p.check(
            self.max_points >= 3,
            "speed_sweep.max_points",
            self.max_points,
            "at least 3 points",
        );
        if let Some(c) = self.casing.as_ref().filter(|c| c.enabled) {
            c.check(p, campbell, range_key);
        }
    }

    /// The engine orders to sweep: `engine_orders`, or `default` (the Campbell diagram's) when
    /// empty.
    pub fn orders(&self, default: &[i64]) -> Vec<usize> {
        let v = if self.engine_orders.is_empty() {
            default
        } else {
            &self.engine_orders
        };
        v.iter().map(|&e| e.max(1) as usize).collect()
    }
}

/// What the speed sweeps need of `[forced]`: the penalty law (the continuation in the speed
/// has no corner hops for the sampled law of exact contact). Its casing distortion:
/// `crate::speed_sweep::forced_speed_distortion::check`.
pub fn check_forced_for_sweeps(
    forced: &crate::forced::forced_settings::ForcedSection,
    p: &mut Problems,
) {
    p.check(
        forced.contact == crate::forced::forced_settings::ForcedContact::Penalty,
        "forced.contact",
        match forced.contact {
            crate::forced::forced_settings::ForcedContact::Exact => "exact",
            crate::forced::forced_settings::ForcedContact::Penalty => "penalty",
        },
        "\"penalty\" for the speed sweeps of [speed_sweep] (exact contact is not continued in \
         the speed)",
    );
}

/// The `[speed_sweep]` and `[rotation]` tables of a TOML file (`nlmodes forced --speed-sweep
/// --settings FILE`; other tables ignored); a table absent gives `None`, unknown keys are bad
/// input naming the file.
pub fn load(
    path: &std::path::Path,
) -> anyhow::Result<(
    Option<SpeedSweepSection>,
    Option<crate::rotation::rotation_settings::RotationSection>,
)> {
    let bad = |m: String| crate::exit::bad_input(format!("{}: {m}", path.display()));
    let text =
        std::fs::read_to_string(path).map_err(|e| bad(format!("cannot read the file: {e}")))?;
    let value: toml::Value =
        toml::from_str(&text).map_err(|e| bad(format!("invalid TOML: {e}")))?;
    let table = |name: &str| value.get(name).cloned();
    let sweep = table("speed_sweep")
        .map(|t| t.try_into())
        .transpose()
        .map_err(|e| bad(format!("[speed_sweep]: {e}")))?;
    let rotation = table("rotation")
        .map(|t| t.try_into())
        .transpose()
        .map_err(|e| bad(format!("[rotation]: {e}")))?;
    Ok((sweep, rotation))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn problems(s: &SpeedSweepSection) -> String {
        let mut p = Problems::new(|k| format!("case.toml: {k}"));
        s.check(&mut p, Some([0.0, 10_000.0]), "rotation.campbell_range");
        p.finish().err().map(|e| e.to_string()).unwrap_or_default()
    }

    /// The defaults are valid; an engine order below 1, a speed range outside the Campbell
    /// range, a window that does not bracket the crossing: each named with the file, the key
    /// and the value.
    #[test]
    fn bad_values_are_named_with_the_key_and_the_value() {
        assert_eq!(problems(&SpeedSweepSection::default()), "");
        let s = SpeedSweepSection {
            engine_orders: vec![0, 3],
            speed_range: Some([5000.0, 12_000.0]),
            window: [1.1, 1.2],
            ..SpeedSweepSection::default()
        };
        let text = problems(&s);
        assert!(
            text.contains("case.toml: speed_sweep.engine_orders = 0: expected integers 1 <= EO"),
            "{text}"
        );
        assert!(
            text.contains(
                "case.toml: speed_sweep.speed_range = [5000.0, 12000.0]: expected a range within \
                 rotation.campbell_range = [0, 10000] rpm"
            ),
            "{text}"
        );
        assert!(text.contains("speed_sweep.window = [1.1, 1.2]"), "{text}");
        let three = SpeedSweepSection {
            engine_orders: vec![3],
            ..SpeedSweepSection::default()
        };
        assert_eq!(three.orders(&[1, 2]), vec![3]);
        assert_eq!(SpeedSweepSection::default().orders(&[1, 2]), vec![1, 2]);
    }
}
