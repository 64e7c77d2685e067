//! A forced response curve and its settings (DESIGN §10.5): what is swept, the settings of the
//! trace, the folds, how the curve ended and whether it covers its range. Traced by
//! `frf::response_curve`.

use crate::error::ForcedError;
use crate::newton::Parameter;
use crate::point_stability::PointStability;
use crate::solver::ForcedPoint;

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

/// How a response curve converges its number of harmonics N (DESIGN §10.8).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum HarmonicPolicy {
    /// Every point in contact is checked at 2N and the trace takes the N the point needed for
    /// its next steps (N changes between neighbouring points).
    Follow,
    /// The trace keeps the base N; every point in contact is checked once at 2N and flagged.
    Check,
    /// The whole curve is traced at one N; its peak, folds, deepest contact and a few points
    /// spread over the contact are checked at 2N, and while any has not converged the curve is
    /// traced again at 2N (`FrequencyResponse::retraces`): the curve's points share one N, so
    /// its folds are those of one truncation, never an artefact of N switching.
    Retrace,
}

/// One trace of a curve under `HarmonicPolicy::Retrace`: its N and what its checked points
/// found.
#[derive(Clone, Debug, PartialEq)]
pub struct CurveHarmonics {
    /// N of every point of that trace.
    pub harmonics: usize,
    /// Points of that trace checked at 2N (indices into its points).
    pub checked: Vec<usize>,
    /// Checked points whose solve at 2N moved the master's first harmonic or W by more than
    /// the tolerance, or failed.
    pub not_converged: usize,
    /// The largest [|dq1| / q1, |dW| / W] over the checked points whose solve at 2N converged.
    pub largest_change: [f64; 2],
    /// Whether 2N was available (below `max_harmonics`) to check this trace at all.
    pub checkable: bool,
    /// The largest contact force of the trace at its N and at 2N (`None` when the trace never
    /// touches or was not checked there).
    pub force: Option<ForceCheck>,
}

impl CurveHarmonics {
    /// Whether this trace's N is enough at every checked point.
    pub fn converged(&self) -> bool {
        self.checkable && self.not_converged == 0
    }
}

/// The largest contact force of one trace, checked at 2N (DESIGN §10.8): the point of the
/// largest force is among the checked points, and its solve at 2N on its row says how far the
/// force an engineer reads off the curve is from converged. It converges in N more slowly than
/// the first harmonic under a stiff penalty law (the default blade's EO 3 sweep: 160 N at
/// N = 20, 102 N at 40, 98 N at 80, with q1 within 3e-3 at all three), so it is reported
/// beside the check of N, not folded into its tolerance.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ForceCheck {
    /// The point of the trace with the largest contact force (index into its points).
    pub point: usize,
    /// Its largest contact force at the trace's N (force units).
    pub force: f64,
    /// The same orbit's largest contact force at 2N (`None`: that solve failed or landed on
    /// another orbit).
    pub finer: Option<f64>,
    /// The largest contact force on the exact orbits of the curve, from its strongest point
    /// and its peak along the curve (`exact_force::climbed_exact`): the number the truncated
    /// series converges to. Shot
    /// on the last trace only, once its points are final (raised segments included); `None`
    /// on earlier traces, where neither touches on its exact orbit or the boundary does not
    /// shoot.
    pub exact: Option<ExactForce>,
}

/// The largest contact force of one point's exact orbit.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ExactForce {
    /// The force (force units of the model, N).
    pub force: f64,
    /// The exact orbit's W (rad/s): shot with W free from the harmonic-balance orbit, within
    /// the boundary's shift of the point's.
    pub omega: f64,
}

impl ForceCheck {
    /// |F(2N) - F(N)| / F(2N), when the solve at 2N converged (`None` otherwise, or when it
    /// does not touch).
    pub fn change(&self) -> Option<f64> {
        self.finer
            .filter(|&f| f > 0.0)
            .map(|f| (self.force - f).abs() / f)
    }
}

/// The points of a retraced curve raised above its N where the check of its N found them
/// moving (DESIGN §10.8, `raised_segments`), over all rounds: each not converged checked point
/// and its neighbours along the curve until two in a row are converged at N, raised to 2N
/// (round 1); each segment of round k whose check still moves raised again one level up
/// (round k + 1).
#[derive(Clone, Debug, PartialEq)]
pub struct RaisedSegments {
    /// Each segment's first and last point (indices into the curve, inclusive), every round's
    /// (a later round's segments lie inside round 1's).
    pub segments: Vec<[usize; 2]>,
    /// The points raised: solved above the trace's N (each point's N is its `harmonics`).
    pub raised: Vec<usize>,
    /// Points of the segments whose raised solve failed (kept one level down, `check_failed`),
    /// and not converged checked points that could not be raised.
    pub failed: Vec<usize>,
    /// The checks that decide: in each segment of each round its seed and point of largest change,
    /// checked one level above it, unless a later round raised that segment again.
    /// `harmonics` is the largest N raised to (the last round's); `checkable` whether round 1
    /// could be checked at all.
    pub check: CurveHarmonics,
    /// Each round: its N, segments, raised and failed points, and its own check.
    pub rounds: Vec<RaisedRound>,
}

/// One round of `RaisedSegments`: points raised to `harmonics` and checked at twice it.
#[derive(Clone, Debug, PartialEq)]
pub struct RaisedRound {
    /// N of the points this round raised.
    pub harmonics: usize,
    /// Its segments (first and last point, inclusive).
    pub segments: Vec<[usize; 2]>,
    /// The points it raised to `harmonics`.
    pub raised: Vec<usize>,
    /// The points whose solve at `harmonics` failed.
    pub failed: Vec<usize>,
    /// Its check at 2 `harmonics`: each segment's seed and point of largest change.
    pub check: CurveHarmonics,
}

impl RaisedSegments {
    /// Whether the raised points are enough: every deciding check converged and nothing
    /// failed.
    pub fn converged(&self) -> bool {
        self.check.converged() && self.failed.is_empty()
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
    /// How N is converged along the curve (DESIGN §10.8; default `HarmonicPolicy::Follow`).
    pub harmonic_policy: HarmonicPolicy,
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
            harmonic_policy: HarmonicPolicy::Follow,
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
    /// Under `HarmonicPolicy::Retrace`, every trace at its N, the last one being this curve's
    /// (empty under the other policies).
    pub retraces: Vec<CurveHarmonics>,
    /// Under `HarmonicPolicy::Retrace`, the points raised to twice the last trace's N where
    /// its check found that N too small (`None` when nothing was raised).
    pub raised: Option<RaisedSegments>,
}

impl FrequencyResponse {
    /// The first point of the piece holding point `i` and the end of that piece (exclusive).
    pub(crate) fn piece_of(&self, i: usize) -> (usize, usize) {
        piece_bounds(&self.pieces, self.points.len(), i)
    }

    /// Under `HarmonicPolicy::Retrace`: whether the curve's N is converged at every point
    /// checked (the last trace's checked points, and those of its raised segments); `None`
    /// under the other policies.
    pub fn harmonics_converged(&self) -> Option<bool> {
        harmonics_converged(&self.retraces, self.raised.as_ref())
    }

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
            retraces: Vec::new(),
            raised: None,
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
            FrfTermination::PointLimit => match self.points.last() {
                Some(p) => format!(
                    "stopped at the point limit (max_points) at {}: the branch beyond it is not \
                     computed",
                    at(self.parameter(p))
                ),
                None => "stopped at the point limit (max_points)".into(),
            },
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
    /// (when a second piece was traced) ends; a curve that stopped with one piece misses
    /// everything beyond its last point.
    pub fn gap(&self) -> Option<(usize, Option<usize>)> {
        match &self.termination {
            FrfTermination::Gap { from, to, .. } => Some((*from, *to)),
            t if !t.covers_range() && !self.points.is_empty() => {
                Some((self.points.len() - 1, None))
            }
            _ => None,
        }
    }
}

/// The first point and one past the last of the piece holding point `i` of a curve of `len`
/// points whose pieces start at `pieces` (none listed: one piece).
pub(crate) fn piece_bounds(pieces: &[usize], len: usize, i: usize) -> (usize, usize) {
    let start = pieces.iter().copied().filter(|&k| k <= i).max();
    let end = pieces.iter().copied().filter(|&k| k > i).min();
    (start.unwrap_or(0), end.unwrap_or(len))
}

/// Whether a curve's N is converged at every point checked: its last trace's checked points
/// (`retraces`), and those of its `raised` segments; `None` without a check.
pub(crate) fn harmonics_converged(
    retraces: &[CurveHarmonics],
    raised: Option<&RaisedSegments>,
) -> Option<bool> {
    let last = retraces.last()?;
    Some(match raised {
        Some(raised) => last.checkable && raised.converged(),
        None => last.converged(),
    })
}
