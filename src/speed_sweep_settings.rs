//! `[speed_sweep]` of the case file (issue 39, item 2; README "Speed sweeps"): forced responses
//! along the rotation speed at engine orders, W = e Omega, on the parametric reduced model of
//! the Campbell stage, with the damping, the load, the levels, N and the contact law of
//! `[forced]`. Speeds in rpm. Without the table no speed sweep runs.

use serde::{Deserialize, Serialize};

use crate::problems::Problems;

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
/// `crate::forced_speed_distortion::check`.
pub fn check_forced_for_sweeps(forced: &crate::forced_settings::ForcedSection, p: &mut Problems) {
    p.check(
        forced.contact == crate::forced_settings::ForcedContact::Penalty,
        "forced.contact",
        match forced.contact {
            crate::forced_settings::ForcedContact::Exact => "exact",
            crate::forced_settings::ForcedContact::Penalty => "penalty",
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
    Option<crate::rotation_settings::RotationSection>,
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
