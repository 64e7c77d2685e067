//! `[rotation]` of the case file (issue 23; docs/ROTATION.md, "The rotating study"): the
//! operating speed, the kinematics of the centrifugal static solve, the speeds, modes and
//! engine orders of the Campbell diagram. Speeds in rpm (revolutions per minute) about the
//! case's rotor axis (`[model] rotor_axis_point`, `rotor_axis_direction`). Without the table the
//! blade is at rest and every result is today's.

use serde::{Deserialize, Serialize};

use crate::problems::Problems;

/// rpm -> rad/s.
pub const RPM_TO_RAD_S: f64 = std::f64::consts::PI / 30.0;

/// The `[rotation]` table; every key has a default.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct RotationSection {
    /// The operating speed, rpm: the prestress, the running gaps, the reduced model and the
    /// backbone at speed are computed there.
    pub operating_speed: f64,
    /// The centrifugal static solve at the operating speed: "nonlinear" (total Lagrangian, the
    /// load following the deformation) or "linear" (small strain, K_e u = f_c(X)).
    pub kinematics: String,
    /// The speed range of the Campbell diagram, rpm: [from, to]; must contain the operating
    /// speed.
    pub campbell_range: [f64; 2],
    /// Number of speeds of the Campbell diagram, evenly spaced over the range (>= 2).
    pub campbell_speeds: usize,
    /// Number of linear modes drawn on the Campbell diagram (>= 1).
    pub campbell_modes: usize,
    /// Engine orders drawn (integers >= 1): the lines f = EO x speed / 60 Hz.
    pub engine_orders: Vec<i64>,
    /// Amplitudes q/g0 (running gap) of the first nonlinear mode marked on the interaction map
    /// besides the band from grazing to the largest traced amplitude.
    pub map_amplitudes: Vec<f64>,
    /// Speeds (rpm) besides rest and the operating speed at which the prestress, the reduced
    /// model and the backbone are computed too (`results/<case>/speeds/<rpm>rpm/`), each adding
    /// a band to the interaction map. Within `campbell_range`.
    pub map_speeds: Vec<f64>,
    /// Speeds midway between those of the parametric reduced model (the Campbell speeds) at
    /// which it is checked against a direct solve (`results/<case>/parametric/`; each costs a
    /// static solve): the first, the last and evenly spread intervals.
    pub parametric_checks: usize,
}

impl Default for RotationSection {
    /// 8000 rpm: tip speed 310 m/s at the default blade's 0.37 m tip radius, a compressor
    /// stage's; there the default blade's 0.2 mm cold gap runs at 0.07-0.13 mm
    /// (docs/ROTATION.md, "The rotating study").
    fn default() -> Self {
        Self {
            operating_speed: 8_000.0,
            kinematics: "nonlinear".into(),
            campbell_range: [0.0, 10_000.0],
            campbell_speeds: 11,
            campbell_modes: 6,
            engine_orders: (1..=8).collect(),
            map_amplitudes: vec![5.0, 10.0],
            map_speeds: vec![4_000.0],
            parametric_checks: 3,
        }
    }
}

impl RotationSection {
    /// The speeds of the Campbell diagram, rpm, evenly spaced over the range.
    pub fn campbell_rpm(&self) -> Vec<f64> {
        let [a, b] = self.campbell_range;
        let n = self.campbell_speeds.max(2);
        (0..n)
            .map(|i| a + (b - a) * i as f64 / (n - 1) as f64)
            .collect()
    }

    /// The speeds of the interaction map besides rest and the operating speed, rpm: increasing,
    /// without duplicates, rest or the operating speed (those are always computed).
    pub fn extra_map_speeds(&self) -> Vec<f64> {
        let mut v: Vec<f64> = self
            .map_speeds
            .iter()
            .copied()
            .filter(|&s| s > 0.0 && s != self.operating_speed)
            .collect();
        v.sort_by(f64::total_cmp);
        v.dedup();
        v
    }

    /// Whether the static solve is geometrically nonlinear.
    pub fn nonlinear(&self) -> bool {
        self.kinematics == "nonlinear"
    }

    /// Every key: recorded in `p` as `rotation.KEY = value: expected ...`.
    pub fn check(&self, p: &mut Problems) {
        let speed_ok = |v: f64| v.is_finite() && v >= 0.0;
        p.check(
            speed_ok(self.operating_speed),
            "rotation.operating_speed",
            self.operating_speed,
            "a finite speed >= 0 (rpm)",
        );
        p.check(
            matches!(self.kinematics.as_str(), "nonlinear" | "linear"),
            "rotation.kinematics",
            &self.kinematics,
            "\"nonlinear\" or \"linear\"",
        );
        let [a, b] = self.campbell_range;
        let range_ok = speed_ok(a) && speed_ok(b) && a < b;
        p.check(
            range_ok,
            "rotation.campbell_range",
            self.campbell_range,
            "[from, to] rpm with 0 <= from < to, finite",
        );
        if range_ok && speed_ok(self.operating_speed) {
            p.check(
                (a..=b).contains(&self.operating_speed),
                "rotation.operating_speed",
                self.operating_speed,
                &format!("a speed within rotation.campbell_range = [{a}, {b}] rpm"),
            );
        }
        p.check(
            (2..=1000).contains(&self.campbell_speeds),
            "rotation.campbell_speeds",
            self.campbell_speeds,
            "between 2 and 1000 speeds",
        );
        p.check(
            (1..=30).contains(&self.campbell_modes),
            "rotation.campbell_modes",
            self.campbell_modes,
            "between 1 and 30 modes",
        );
        p.check(
            !self.engine_orders.is_empty(),
            "rotation.engine_orders",
            &self.engine_orders,
            "at least one engine order",
        );
        for (i, eo) in self.engine_orders.iter().enumerate() {
            p.check(
                (1..=200).contains(eo),
                "rotation.engine_orders",
                eo,
                "integers 1 <= EO <= 200",
            );
            p.check(
                !self.engine_orders[..i].contains(eo),
                "rotation.engine_orders",
                eo,
                "each engine order listed once",
            );
        }
        for q in &self.map_amplitudes {
            p.check(
                q.is_finite() && *q > 0.0,
                "rotation.map_amplitudes",
                q,
                "finite amplitudes q/g0 > 0",
            );
        }
        p.check(
            self.parametric_checks <= 100,
            "rotation.parametric_checks",
            self.parametric_checks,
            "between 0 and 100 speeds",
        );
        for v in &self.map_speeds {
            let ok = speed_ok(*v) && (!range_ok || (a..=b).contains(v));
            p.check(
                ok,
                "rotation.map_speeds",
                v,
                &format!("finite speeds within rotation.campbell_range = [{a}, {b}] rpm"),
            );
        }
    }
}

impl RotationSection {
    /// `map_amplitudes` within the traced range [`q_start`, `q_max`] of `[continuation]` (each
    /// backbone, at rest and at every speed, runs over it in its own gap): a mark outside it
    /// falls on no traced point and would be left out of the map without a word.
    pub fn check_map_amplitudes(&self, cont: &nlmodes_nnm::ContinuationSettings, p: &mut Problems) {
        let (lo, hi) = (cont.q_start, cont.q_max);
        for q in &self.map_amplitudes {
            if q.is_finite() && *q > 0.0 {
                p.check(
                    (lo..=hi).contains(q),
                    "rotation.map_amplitudes",
                    q,
                    &format!(
                        "an amplitude q/g0 within [continuation.q_start, continuation.q_max] = \
                         [{lo}, {hi}], the range every backbone traces"
                    ),
                );
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn problems_of(s: &RotationSection) -> String {
        let mut p = Problems::new(|k| format!("case.toml: {k}"));
        s.check(&mut p);
        p.finish().map_or_else(|e| e.to_string(), |_| String::new())
    }

    #[test]
    fn the_defaults_are_valid_and_the_speeds_span_the_range() {
        let s = RotationSection::default();
        assert_eq!(problems_of(&s), "");
        let rpm = s.campbell_rpm();
        assert_eq!(rpm.len(), 11);
        assert_eq!((rpm[0], rpm[10]), (0.0, 10_000.0));
        assert!((rpm[1] - 1000.0).abs() < 1e-9);
        assert!((s.operating_speed * RPM_TO_RAD_S - 837.7580409572781).abs() < 1e-9);
        let many = RotationSection {
            map_speeds: vec![6000.0, 0.0, 8000.0, 2000.0, 6000.0],
            ..s
        };
        assert_eq!(many.extra_map_speeds(), vec![2000.0, 6000.0]);
    }

    #[test]
    fn bad_values_are_named_with_the_key_and_the_value() {
        let s = RotationSection {
            operating_speed: -5.0,
            kinematics: "big".into(),
            campbell_range: [3000.0, 1000.0],
            campbell_speeds: 1,
            campbell_modes: 0,
            engine_orders: vec![0, 2],
            map_amplitudes: vec![f64::NAN],
            map_speeds: vec![-1.0],
            parametric_checks: 1000,
        };
        let msg = problems_of(&s);
        for want in [
            "rotation.operating_speed = -5.0",
            "rotation.kinematics = \"big\"",
            "rotation.campbell_range = [3000.0, 1000.0]",
            "rotation.campbell_speeds = 1",
            "rotation.campbell_modes = 0",
            "rotation.engine_orders = 0",
            "rotation.map_amplitudes = NaN",
            "rotation.map_speeds = -1.0",
            "rotation.parametric_checks = 1000",
        ] {
            assert!(msg.contains(want), "missing `{want}` in:\n{msg}");
        }
        let repeated = RotationSection {
            engine_orders: vec![2, 3, 2],
            ..RotationSection::default()
        };
        let msg = problems_of(&repeated);
        assert!(
            msg.contains("rotation.engine_orders = 2: expected each engine order listed once"),
            "{msg}"
        );
        let outside = RotationSection {
            operating_speed: 20_000.0,
            ..RotationSection::default()
        };
        let msg = problems_of(&outside);
        assert!(
            msg.contains("rotation.operating_speed = 20000.0: expected a speed within"),
            "{msg}"
        );
    }

    /// A map amplitude outside the traced range falls on no backbone point: refused.
    #[test]
    fn map_amplitudes_lie_within_the_traced_range() {
        let cont = nlmodes_nnm::ContinuationSettings {
            q_start: 0.5,
            q_max: 14.0,
            ..Default::default()
        };
        let s = RotationSection {
            map_amplitudes: vec![0.5, 14.0, 20.0, 0.1],
            ..RotationSection::default()
        };
        let mut p = Problems::new(|k| format!("case.toml: {k}"));
        s.check_map_amplitudes(&cont, &mut p);
        let msg = p.finish().map_or_else(|e| e.to_string(), |_| String::new());
        assert!(
            msg.contains(
                "rotation.map_amplitudes = 20.0: expected an amplitude q/g0 within \
                 [continuation.q_start, continuation.q_max] = [0.5, 14]"
            ),
            "{msg}"
        );
        assert!(msg.contains("rotation.map_amplitudes = 0.1"), "{msg}");
        assert_eq!(msg.lines().count(), 2, "{msg}");
    }
}
