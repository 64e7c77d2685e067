//! What a speed sweep (`speed_sweep`) is asked for and what it gives: its settings, its points
//! (each an orbit of the structure at its own speed, at W = e Omega), its folds and how it
//! ended.

use crate::error::ForcedError;
use crate::frf::{FoldKind, FrfTermination};
use crate::point_stability::PointStability;
use crate::solver::{ForcedPoint, ForcedSettings};

/// Settings of one speed sweep.
#[derive(Clone, Debug)]
pub struct SpeedSweepSettings {
    /// Engine order e >= 1: W = e Omega.
    pub engine_order: usize,
    /// The mode whose frequency each point records (0-based, `SpeedPoint::mode_frequency`).
    pub mode: usize,
    /// First speed (rad/s, > 0), where the response is taken from its linear solution.
    pub start: f64,
    /// Last speed (rad/s, > start).
    pub end: f64,
    /// Omega_ref (rad/s) of the scaled space (module docs).
    pub speed_scale: f64,
    /// The harmonic balance and contact law of every point (the same at every speed).
    pub solver: ForcedSettings,
    /// First step in the scaled space (default 0.005).
    pub step: f64,
    /// Smallest step before giving up (default 1e-6).
    pub min_step: f64,
    /// Largest step (default 0.02).
    pub max_step: f64,
    /// Most points (default 2000).
    pub max_points: usize,
    /// Floquet stability of every point (default true).
    pub stability: bool,
    /// `FrfSettings::stability_margin` (default 1e-3).
    pub stability_margin: f64,
    /// `FrfSettings::period_tolerance` (default 1e-3).
    pub period_tolerance: f64,
    /// How close W / e and the structure's speed must agree on a row, relative to Omega_ref
    /// (default 1e-7: in contact the row's W is reproducible to about 1e-8 relative, measured
    /// on the default blade, where the mismatch wanders between 1e-6 and 1e-5 rad/s at 802
    /// rad/s as the frozen speed moves by 1e-9; the point is then solved at W = e Omega).
    pub speed_tolerance: f64,
}

impl SpeedSweepSettings {
    /// A sweep at engine order `engine_order` over [start, end] (rad/s), defaults otherwise.
    pub fn new(
        engine_order: usize,
        mode: usize,
        (start, end): (f64, f64),
        speed_scale: f64,
        solver: ForcedSettings,
    ) -> Self {
        Self {
            engine_order,
            mode,
            start,
            end,
            speed_scale,
            solver,
            step: 0.005,
            min_step: 1e-6,
            max_step: 0.02,
            max_points: 2000,
            stability: true,
            stability_margin: 1e-3,
            period_tolerance: 1e-3,
            speed_tolerance: 1e-7,
        }
    }

    /// Checks the engine order, the range and the steps; errors name the setting.
    pub fn validate(&self) -> Result<(), ForcedError> {
        let bad = |name, value, expected| {
            Err(ForcedError::Parameter {
                name,
                value,
                expected,
            })
        };
        let positive = |v: f64| v.is_finite() && v > 0.0;
        if self.engine_order < 1 {
            return bad("engine_order", self.engine_order as f64, "an integer >= 1");
        }
        if !positive(self.start) {
            return bad("start", self.start, "a finite speed > 0 (rad/s)");
        }
        if !(self.end.is_finite() && self.end > self.start) {
            return bad("end", self.end, "a finite speed > start (rad/s)");
        }
        for (name, v) in [
            ("speed_scale", self.speed_scale),
            ("step", self.step),
            ("min_step", self.min_step),
            ("max_step", self.max_step),
            ("speed_tolerance", self.speed_tolerance),
        ] {
            if !positive(v) {
                return bad(name, v, "a finite value > 0");
            }
        }
        if self.min_step > self.step || self.step > self.max_step {
            return bad("step", self.step, "min_step <= step <= max_step");
        }
        if self.max_points < 3 {
            return bad("max_points", self.max_points as f64, ">= 3");
        }
        Ok(())
    }
}

/// A point of a speed sweep.
#[derive(Clone, Debug)]
pub struct SpeedPoint {
    /// The rotation speed Omega (rad/s); the orbit's W is e Omega.
    pub speed: f64,
    /// The orbit (its coefficients in the reduced coordinates, the same at every speed).
    pub point: ForcedPoint,
    /// The structure's gap reference at this speed (m; the mean running gap).
    pub gap_reference: f64,
    /// Each contact row's running gap at this speed (m).
    pub running_gaps: Vec<f64>,
    /// w of `SpeedSweepSettings::mode` at this speed (rad/s).
    pub mode_frequency: f64,
    /// Floquet stability (when asked for).
    pub stability: Option<PointStability>,
    /// Solves the point took (corrections of the frozen speed).
    pub corrections: usize,
}

/// A fold of a speed sweep: where the speed turns.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SpeedFold {
    /// Index of the point nearest the fold.
    pub point: usize,
    /// The speed at the fold (rad/s).
    pub speed: f64,
    /// `TurnsBack`: the speed rose and now falls (a run-up jumps there); `TurnsForward`: a
    /// run-down jumps there.
    pub kind: FoldKind,
}

/// A traced speed sweep.
#[derive(Clone, Debug)]
pub struct SpeedSweep {
    /// The points in continuation order.
    pub points: Vec<SpeedPoint>,
    /// The folds met.
    pub folds: Vec<SpeedFold>,
    /// Indices of the points reached by a hop at a fixed speed (`speed_grazing`).
    pub hops: Vec<usize>,
    /// Why it stopped (`at`: the speed of the last point, rad/s).
    pub termination: FrfTermination,
}

impl SpeedSweep {
    /// Why the sweep ended, as a sentence (speeds in rpm).
    pub fn end_text(&self) -> String {
        let rpm = |w: f64| format!("{:.2} rpm", w * 30.0 / std::f64::consts::PI);
        match &self.termination {
            FrfTermination::Complete => "complete".into(),
            FrfTermination::StepTooSmall { at, reason } => format!(
                "stopped at {}: no step down to min_step converged ({reason})",
                rpm(*at)
            ),
            FrfTermination::PointLimit => "stopped at the point limit (max_points)".into(),
            FrfTermination::LeftRange { at } => format!(
                "the sweep turned back below the start of the range after {}",
                rpm(*at)
            ),
            other => format!("{other:?}"),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::SpeedSweepSettings;
    use crate::error::ForcedError;
    use crate::solver::ForcedSettings;

    /// An engine order below 1, a speed range not above 0 or inverted: refused, naming the
    /// setting.
    #[test]
    fn bad_settings_are_named() {
        let ok = SpeedSweepSettings::new(3, 0, (10.0, 20.0), 5.0, ForcedSettings::new(4).unwrap());
        assert!(ok.validate().is_ok());
        let named = |s: SpeedSweepSettings, name: &str| match s.validate() {
            Err(ForcedError::Parameter { name: n, .. }) => assert_eq!(n, name),
            other => panic!("{other:?}"),
        };
        named(
            SpeedSweepSettings {
                engine_order: 0,
                ..ok.clone()
            },
            "engine_order",
        );
        named(
            SpeedSweepSettings {
                start: 0.0,
                ..ok.clone()
            },
            "start",
        );
        named(
            SpeedSweepSettings {
                end: 10.0,
                ..ok.clone()
            },
            "end",
        );
        named(
            SpeedSweepSettings {
                speed_scale: f64::NAN,
                ..ok
            },
            "speed_scale",
        );
    }
}
