//! The settings of a speed sweep and the points it traces (docs/DESIGN.md §10.10), shared by
//! the continuation (`speed_sweep`) and its steps (`speed_step`).

use crate::distortion::CasingDistortion;
use crate::error::ForcedError;
use crate::point_stability::PointStability;
use crate::solver::{ForcedPoint, ForcedSettings};

/// An n-lobed casing seen by the rotating blade (DESIGN §10.11): every row's gap is
/// g0_j(Omega) - delta cos(n Omega t + phi).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LobedCasing {
    /// n >= 1 lobes.
    pub lobes: usize,
    /// delta (m, finite, >= 0).
    pub amplitude: f64,
    /// phi (rad).
    pub phase: f64,
}

impl LobedCasing {
    /// k with the orbit's fundamental k Omega under this casing and a load at engine order
    /// `engine_order`: gcd(e, n) (DESIGN §10.11).
    pub fn fundamental_order(&self, engine_order: usize) -> usize {
        gcd(engine_order, self.lobes)
    }
}

/// The greatest common divisor (gcd(a, 0) = a).
fn gcd(a: usize, b: usize) -> usize {
    if b == 0 {
        a
    } else {
        gcd(b, a % b)
    }
}

/// How a speed sweep converges its number of harmonics N (DESIGN §10.10; the frequency sweep's
/// `HarmonicPolicy::Retrace` and `Check`, §10.8).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SpeedHarmonics {
    /// The sweep at the solver's N, unchecked.
    Fixed,
    /// The sweep at the solver's N; its peak, folds, deepest contact and a few points spread
    /// over its contact are solved again at 2N and flagged (`speed_harmonics`).
    Check,
    /// As `Check`, and while a checked point moves by more than the tolerance (and 2N is within
    /// `max_harmonics`) the whole sweep is traced again at 2N, or at 4N when the moving points
    /// move again there (`speed_harmonics`): every point shares one N.
    Retrace,
}

/// Settings of one speed sweep.
#[derive(Clone, Debug)]
pub struct SpeedSweepSettings {
    /// Engine order e >= 1 of the load: the family's load acts at harmonics of e Omega.
    pub engine_order: usize,
    /// The casing's lobes, when distorted: then the orbit's fundamental is gcd(e, n) Omega
    /// ([`SpeedSweepSettings::fundamental_order`]); `None` (default): W = e Omega.
    pub casing: Option<LobedCasing>,
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
    /// How N is converged (default `SpeedHarmonics::Fixed`).
    pub harmonic_policy: SpeedHarmonics,
    /// The largest N a retrace may reach (0, default: four times the solver's N); the last
    /// trace's check and the points raised around its moving ones reach twice it.
    pub max_harmonics: usize,
    /// A checked point's N is enough when doubling it moves the master's first harmonic and
    /// the speed by at most this (relative; default 1e-3, as `FrfSettings::harmonic_tolerance`).
    pub harmonic_tolerance: f64,
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
            casing: None,
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
            harmonic_policy: SpeedHarmonics::Fixed,
            max_harmonics: 0,
            harmonic_tolerance: 1e-3,
        }
    }

    /// The largest N of the sweep's retraces: `max_harmonics`, or four times the solver's N.
    pub fn top_harmonics(&self) -> usize {
        let base = self.solver.harmonics.harmonics;
        if self.max_harmonics == 0 {
            4 * base
        } else {
            self.max_harmonics.max(base)
        }
    }

    /// k with the orbit's fundamental W = k Omega: gcd(e, n) under an n-lobed casing (the load
    /// at harmonic e / k of W, the gap at harmonic n / k), e otherwise (DESIGN §10.11).
    pub fn fundamental_order(&self) -> usize {
        match self.casing {
            Some(c) => c.fundamental_order(self.engine_order),
            None => self.engine_order,
        }
    }

    /// The solver's settings on the orbit's fundamental: the casing's gap at harmonic n / k.
    pub fn solver_settings(&self) -> ForcedSettings {
        let k = self.fundamental_order().max(1);
        ForcedSettings {
            distortion: self.casing.map(|c| CasingDistortion {
                harmonic: c.lobes / k,
                amplitude: c.amplitude,
                phase: c.phase,
            }),
            ..self.solver.clone()
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
        if let Some(c) = self.casing {
            if c.lobes < 1 {
                return bad("lobes", c.lobes as f64, "an integer >= 1");
            }
            let highest = self.solver.harmonics.harmonics;
            self.solver_settings()
                .distortion
                .map_or(Ok(()), |d| d.validate(highest))?;
            if self.engine_order / self.fundamental_order() > highest {
                return bad(
                    "engine_order",
                    self.engine_order as f64,
                    "e / gcd(e, lobes) <= N: the load's harmonic of the orbit's fundamental \
                     must be on the basis",
                );
            }
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
            ("harmonic_tolerance", self.harmonic_tolerance),
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
    /// The rotation speed Omega (rad/s); the orbit's W is k Omega
    /// ([`SpeedSweepSettings::fundamental_order`]: e without a casing distortion).
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
    /// Solves the point took: the corrections of the frozen speed, or the runs of the solve
    /// with the structure following W, each with the last solve onto the speed line.
    pub corrections: usize,
}
