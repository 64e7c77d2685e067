//! The forced response over a range (DESIGN §10.5): its settings, the curve and its folds, how
//! it ended, and [`response_curve`], which traces it from the linear response at the start of
//! the range, through folds, to its end, where p is W (the frequency response at a fixed load,
//! [`Sweep::Frequency`]) or the load scale s at a fixed W (the response to a growing force,
//! [`Sweep::Level`]). The continuation itself is `trace` (pseudo-arc-length along the exact
//! tangent), N is converged point by point by `ladder`, the folds are located by `fold`, the
//! stability of every point is `point_stability`.
//!
//! A fold is where p turns: `FoldKind::TurnsBack` (p rising, then falling: on a sweep up the
//! response jumps down there) and `FoldKind::TurnsForward` (on a sweep down it jumps up there).
//! A frequency sweep whose trace from the start of the range stops is traced again from its end;
//! the curve covers its range only when one trace crosses it or the two meet
//! ([`FrfTermination::covers_range`]); two that do not meet leave the branch between their last
//! points uncomputed ([`FrfTermination::Gap`]).

use crate::error::ForcedError;
use crate::ladder::HarmonicLadder;
use crate::newton::Parameter;
use crate::point_stability::{assess_stability, PointStability};
use crate::solver::{ForcedPoint, ForcedSolver};
use crate::trace::FrfTrace;

/// What a continuation sweeps.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Sweep {
    /// W over [start, end] (rad/s) at the solver's load.
    Frequency,
    /// The load scale s over [start, end] (times the solver's load) at W = `omega` (rad/s).
    Level {
        /// The fixed excitation frequency (rad/s).
        omega: f64,
    },
}

impl Sweep {
    /// The free parameter of the arc rows.
    pub fn parameter(&self) -> Parameter {
        match self {
            Self::Frequency => Parameter::Frequency,
            Self::Level { .. } => Parameter::Level,
        }
    }
}

/// Settings of one continuation.
#[derive(Clone, Debug, PartialEq)]
pub struct FrfSettings {
    /// What is swept (default: the frequency).
    pub sweep: Sweep,
    /// Start of the range (rad/s, or the load scale), where the response is taken from its
    /// linear solution.
    pub start: f64,
    /// End of the range, > start.
    pub end: f64,
    /// First step in the scaled space (default 0.005: half a percent of w_ref, or of the end
    /// level).
    pub step: f64,
    /// Smallest step before giving up (default 1e-6).
    pub min_step: f64,
    /// Largest step (default 0.02).
    pub max_step: f64,
    /// Most points (default 2000).
    pub max_points: usize,
    /// Floquet stability of every point (default true).
    pub stability: bool,
    /// Largest N a point in contact may be raised to (`ladder`; default `None`: four times the
    /// solver's N, two doublings).
    pub max_harmonics: Option<usize>,
    /// A point's N is enough when doubling it moves the master's first harmonic and W by at
    /// most this (relative; default 1e-3).
    pub harmonic_tolerance: f64,
    /// Margin around |mu| = 1 inside which the verdict is undetermined (default 1e-3; the
    /// Liouville error of the point is added to it).
    pub stability_margin: f64,
    /// Largest period residual (`PointStability::period_residual`) for which a verdict is
    /// given (default 1e-3). The monodromy linearizes the equation of motion along the
    /// harmonic-balance orbit; an orbit that one period of independent time integration does not
    /// bring back to its start is not a periodic solution of that equation (on the coarse blade,
    /// penalty contact on nodes with mass: 1-7 % in contact, against 5e-6 out of contact), and
    /// its verdict cannot be backed.
    pub period_tolerance: f64,
}

impl FrfSettings {
    /// A frequency sweep over [start, end] (rad/s), defaults otherwise.
    pub fn new(start: f64, end: f64) -> Self {
        Self {
            sweep: Sweep::Frequency,
            start,
            end,
            step: 0.005,
            min_step: 1e-6,
            max_step: 0.02,
            max_points: 2000,
            stability: true,
            max_harmonics: None,
            harmonic_tolerance: 1e-3,
            stability_margin: 1e-3,
            period_tolerance: 1e-3,
        }
    }

    /// Checks the range and the steps; errors name the setting.
    pub fn validate(&self) -> Result<(), ForcedError> {
        let bad = |name, value, expected| {
            Err(ForcedError::Parameter {
                name,
                value,
                expected,
            })
        };
        if let Sweep::Level { omega } = self.sweep {
            if !(omega.is_finite() && omega > 0.0) {
                return bad("omega", omega, "a finite frequency > 0");
            }
        }
        if !(self.start.is_finite() && self.start > 0.0) {
            return bad("start", self.start, "a finite value > 0");
        }
        if !(self.end.is_finite() && self.end > self.start) {
            return bad("end", self.end, "a finite value > start");
        }
        for (name, v) in [
            ("step", self.step),
            ("min_step", self.min_step),
            ("max_step", self.max_step),
        ] {
            if !(v.is_finite() && v > 0.0) {
                return bad(name, v, "a finite value > 0");
            }
        }
        if self.min_step > self.step || self.step > self.max_step {
            return bad("step", self.step, "min_step <= step <= max_step");
        }
        if !(self.harmonic_tolerance.is_finite() && self.harmonic_tolerance > 0.0) {
            return bad(
                "harmonic_tolerance",
                self.harmonic_tolerance,
                "a finite value > 0",
            );
        }
        if !(self.stability_margin.is_finite() && self.stability_margin >= 0.0) {
            return bad(
                "stability_margin",
                self.stability_margin,
                "a finite value >= 0",
            );
        }
        if self.max_points < 3 {
            return bad("max_points", self.max_points as f64, ">= 3");
        }
        Ok(())
    }
}

/// Which way W turns at a fold.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FoldKind {
    /// The parameter rose and now falls: a sweep up jumps down here.
    TurnsBack,
    /// The parameter fell and now rises: a sweep down jumps up here.
    TurnsForward,
}

/// A fold of the curve.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Fold {
    /// Index of the point nearest the fold.
    pub point: usize,
    /// The swept parameter at the fold, refined (W in rad/s, or the load scale).
    pub at: f64,
    /// Which way the parameter turns.
    pub kind: FoldKind,
}

/// Why the continuation stopped.
#[derive(Clone, Debug, PartialEq)]
pub enum FrfTermination {
    /// The parameter passed the end of the range.
    Complete,
    /// The step fell below `min_step` (the reason of the last failure).
    StepTooSmall {
        /// The parameter at the last point (W in rad/s, or the load scale).
        at: f64,
        /// The last solver error.
        reason: String,
    },
    /// `max_points` reached.
    PointLimit,
    /// The curve turned back below the start of the range (an isola-like branch, or a wrong
    /// turn at a corner): the points below it are not kept.
    LeftRange {
        /// The parameter at the last point kept (W in rad/s, or the load scale).
        at: f64,
    },
    /// The trace from the start of the range stopped (`stopped`: why), and a second trace from
    /// the end of the range down met it at W = `met` (rad/s): the two pieces cover the range
    /// (`FrequencyResponse::pieces`).
    Joined {
        /// Why the first piece stopped (as `end_text` words).
        stopped: String,
        /// Where the second piece met the first (rad/s).
        met: f64,
    },
    /// The trace from the start of the range stopped and the trace from its end did not meet
    /// it: the branch between the two pieces' last points is not computed.
    Gap {
        /// Why the first piece stopped (as `end_text` words).
        stopped: String,
        /// Why the second piece stopped.
        second: String,
        /// Index of the first piece's last point (where the missing branch starts).
        from: usize,
        /// Index of the second piece's last point (where it ends), when there is a second
        /// piece.
        to: Option<usize>,
    },
}

impl FrfTermination {
    /// Whether the curve covers its whole range: one branch from its start to its end, or two
    /// pieces that meet.
    pub fn covers_range(&self) -> bool {
        matches!(self, Self::Complete | Self::Joined { .. })
    }
}

/// A response curve over the swept parameter.
#[derive(Clone, Debug)]
pub struct FrequencyResponse {
    /// What was swept.
    pub sweep: Sweep,
    /// The points in continuation order.
    pub points: Vec<ForcedPoint>,
    /// The folds met.
    pub folds: Vec<Fold>,
    /// Indices of the points reached by a hop at fixed W past a corner.
    pub hops: Vec<usize>,
    /// Stability of each point (empty when not asked for).
    pub stability: Vec<PointStability>,
    /// Why it stopped.
    pub termination: FrfTermination,
    /// Index of the first point of each piece: [0], or [0, k] when the trace from the start of
    /// the range stopped and a second one from its end (points k.., in the order traced, W
    /// falling first) met it or also stopped.
    pub pieces: Vec<usize>,
}

impl FrequencyResponse {
    /// The swept parameter of a point (W in rad/s, or the load scale).
    pub fn parameter(&self, p: &ForcedPoint) -> f64 {
        match self.sweep {
            Sweep::Frequency => p.omega,
            Sweep::Level { .. } => p.level,
        }
    }

    /// A curve of its first points, running.
    pub(crate) fn starting(sweep: Sweep, points: Vec<ForcedPoint>) -> Self {
        Self {
            sweep,
            points,
            folds: Vec::new(),
            hops: Vec::new(),
            stability: Vec::new(),
            termination: FrfTermination::Complete,
            pieces: vec![0],
        }
    }

    /// Why the curve ended, as a sentence naming the parameter with its unit.
    pub fn end_text(&self) -> String {
        let at = |v: f64| match self.sweep {
            Sweep::Frequency => format!("W = {v:.6e} rad/s"),
            Sweep::Level { .. } => format!("load scale {v:.6e}"),
        };
        match &self.termination {
            FrfTermination::Complete => "complete".into(),
            FrfTermination::StepTooSmall { at: v, reason } => format!(
                "stopped at {}: no step down to min_step converged ({reason})",
                at(*v)
            ),
            FrfTermination::PointLimit => "stopped at the point limit (max_points)".into(),
            FrfTermination::LeftRange { at: v } => format!(
                "the curve turned back below the start of the range after {}",
                at(*v)
            ),
            FrfTermination::Joined { stopped, met } => format!(
                "complete in two pieces: the trace from the start of the range {stopped}; the \
                 trace from its end met it at {}",
                at(*met)
            ),
            FrfTermination::Gap {
                stopped,
                second,
                from,
                to,
            } => {
                let end = |i: usize| at(self.parameter(&self.points[i]));
                let missing = match to {
                    Some(to) => format!(
                        "the branch between {} (where the trace from the start stopped) and {} \
                         (where the trace from the end stopped) is not computed",
                        end(*from),
                        end(*to)
                    ),
                    None => format!("the branch beyond {} is not computed", end(*from)),
                };
                format!(
                    "incomplete: {missing}; the trace from the start of the range {stopped}; \
                     the trace from its end {second}"
                )
            }
        }
    }

    /// The missing branch of an incomplete curve: the indices of the points where it starts and
    /// (when a second piece was traced) ends.
    pub fn gap(&self) -> Option<(usize, Option<usize>)> {
        match &self.termination {
            FrfTermination::Gap { from, to, .. } => Some((*from, *to)),
            _ => None,
        }
    }
}

/// Traces the response curve of `solver` over the settings' range, in W or in the load scale
/// (see module docs), N raised point by point up to `max_harmonics` (`ladder`); `progress` sees
/// every accepted point. A frequency sweep whose trace from the start of the range stops or
/// turns back is traced again from the end of the range, W falling, until it meets the first
/// piece (`FrfTermination::Joined`, two `pieces`) or stops too (`FrfTermination::Gap`).
pub fn response_curve(
    solver: &ForcedSolver<'_>,
    settings: &FrfSettings,
    mut progress: impl FnMut(&ForcedPoint),
) -> Result<FrequencyResponse, ForcedError> {
    settings.validate()?;
    let base = solver.basis().harmonics();
    let top = settings.max_harmonics.unwrap_or(4 * base).max(base);
    let ladder = HarmonicLadder::new(solver, top, settings.harmonic_tolerance)?;
    let mut trace = FrfTrace::begin(&ladder, settings, 1.0, Vec::new(), &mut progress)?;
    trace.run(&mut progress);
    let stopped = matches!(
        trace.curve.termination,
        FrfTermination::StepTooSmall { .. } | FrfTermination::LeftRange { .. }
    );
    if stopped && settings.sweep == Sweep::Frequency {
        let meet = trace
            .curve
            .points
            .iter()
            .map(|p| trace.scaled_base(p))
            .collect();
        let back = FrfTrace::begin(&ladder, settings, -1.0, meet, &mut progress).map(|mut back| {
            back.run(&mut progress);
            back.curve
        });
        append(&mut trace.curve, back);
    } else if stopped {
        let stopped = trace.curve.end_text();
        trace.curve.termination = FrfTermination::Gap {
            stopped,
            second: "was not traced (a level sweep is traced from its start only)".into(),
            from: trace.curve.points.len() - 1,
            to: None,
        };
    }
    assess_stability(&ladder, settings, &mut trace.curve)?;
    Ok(trace.curve)
}

/// Appends the trace from the end of the range (`back`, or why it could not start) as the
/// second piece: joined when it met the first piece, a gap otherwise.
fn append(curve: &mut FrequencyResponse, back: Result<FrequencyResponse, ForcedError>) {
    let stopped = curve.end_text();
    let from = curve.points.len() - 1;
    let back = match back {
        Ok(back) => back,
        Err(e) => {
            curve.termination = FrfTermination::Gap {
                stopped,
                second: format!("could not start ({e})"),
                from,
                to: None,
            };
            return;
        }
    };
    let offset = curve.points.len();
    curve.termination = match back.termination {
        FrfTermination::Joined { met, .. } => FrfTermination::Joined { stopped, met },
        FrfTermination::LeftRange { at } => FrfTermination::Gap {
            stopped,
            second: format!("turned back past the end of the range after W = {at:.6e} rad/s"),
            from,
            to: Some(offset + back.points.len() - 1),
        },
        _ => FrfTermination::Gap {
            stopped,
            second: match back.termination {
                FrfTermination::Complete => {
                    "crossed the range on another branch without meeting it".into()
                }
                _ => back.end_text(),
            },
            from,
            to: Some(offset + back.points.len() - 1),
        },
    };
    curve.pieces.push(offset);
    curve.folds.extend(back.folds.into_iter().map(|f| Fold {
        point: f.point + offset,
        ..f
    }));
    curve.hops.extend(back.hops.into_iter().map(|h| h + offset));
    curve.points.extend(back.points);
}
