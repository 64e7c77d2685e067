//! Continuation of the forced response (DESIGN §10.5): pseudo-arc-length in (orbit, p) from the
//! linear response at the start of the range, through folds, to its end, where p is W (the
//! frequency response at a fixed load, [`Sweep::Frequency`]) or the load scale s at a fixed W
//! (the response to a growing force, [`Sweep::Level`]).
//!
//! Scaled space: y / (g_ref sqrt(c)) and p / p_ref (w_ref the first linear frequency for W, the
//! end of the range for s). The first
//! two points are solved at fixed W; then each step predicts along the secant of the last two
//! points, x_p = x_k + h t, and solves the forced problem with the row t . (x - x_p) = 0
//! (`ArcRow`). A step that fails is halved; one that converges in few Newton iterations lets the
//! next grow. A fold is where W turns: `FoldKind::TurnsBack` (W rising, then falling: on a
//! sweep up the response jumps down there) and `FoldKind::TurnsForward` (on a sweep down it
//! jumps up there), reported once W has retreated from its extremum by `fold_tolerance`; its W
//! is refined by the parabola through the three points around the extremum.

use crate::error::ForcedError;
use crate::newton::{ArcRow, OrbitState, Parameter};
use crate::solver::{ForcedPoint, ForcedSolver, ForcedStart};
use nlmodes_hb::floquet::{SampledMonodromy, Verdict};
use nlmodes_hb::FullBasis;

/// How far (scaled distance) a hop at fixed phase may land from the last orbit: past a corner
/// of the resonance tip the returning branch is that close; farther, the hop has skipped along
/// a branch on which the phase hardly turns (the middle branch of a stiff resonance, which
/// hugs the backbone at a lag near pi/2: on the light 2-DOF chain a lag 0.01 rad larger than
/// the tip's lies at W / w1 = 1.008, against 1.131 at the tip).
const PHASE_HOP_REACH: f64 = 0.02;

/// Scaled step below which a failing arc-length step gives way to a hop at fixed W.
const CORNER_STEP: f64 = 1e-3;

/// How far (in scaled distance, as a multiple of the hop's dW) a hop may land from the last
/// orbit: a corner turns the curve, it does not displace it.
const HOP_REACH: f64 = 20.0;

/// How far (as a multiple of the step) the corrector may land from the prediction. On a smooth
/// curve it lands within O(h^2) of it; at a corner of the sampled problem, where the curve turns
/// by a finite angle a, the arc hyperplane meets the curve at h / cos(a) (measured on the blade:
/// 1.88 h at every h from 1e-2 down to 1e-6, a = 58 degrees). Four accepts corners up to 75
/// degrees; a jump to another branch lands at a distance that does not shrink with h and is
/// refused once h is small.
const CORRECTOR_REACH: f64 = 4.0;

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

/// The largest turn (rad) of the first harmonic's phase between two consecutive points out of
/// contact (both without contact force). The
/// phase turns by pi through a resonance within its half-power bandwidth 2 zeta w: a step that
/// turns it by more than this has jumped across a resonance narrower than itself (at 0.03 %
/// damping the blade's curve at level 2 went from W/w1 = 0.984 to past the peak in one step and
/// missed it). Along the curve the phase turns by 0.01-0.3 rad per step.
const PHASE_REACH: f64 = 1.0;

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
    /// A fold is reported when the parameter retreats from its extremum by more than this
    /// fraction of p_ref (default 1e-3): hysteresis against the kinks of the sampled problem.
    pub fold_tolerance: f64,
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
            fold_tolerance: 1e-3,
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
        if !(self.fold_tolerance.is_finite() && self.fold_tolerance > 0.0) {
            return bad("fold_tolerance", self.fold_tolerance, "a finite value > 0");
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
        /// The lowest W the second piece reached (rad/s): where it met the first piece, the
        /// start of the range, or (`meets` false) the low end of the W it covers.
        met: f64,
        /// Whether the second piece met the first; otherwise the two overlap in W without
        /// meeting (two branches of the sampled problem) and together cover the range.
        meets: bool,
    },
}

impl FrfTermination {
    /// Whether the curve covers its whole range (complete, or two pieces that meet).
    pub fn covers_range(&self) -> bool {
        matches!(self, Self::Complete | Self::Joined { .. })
    }
}

/// What a change of stability between two points is, from the multiplier that crossed the unit
/// circle (its argument within 0.05 rad of 0 or pi, else a complex pair).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ForcedBifurcation {
    /// Through +1 (at a fold of the curve, or a branch point).
    Fold,
    /// Through -1.
    PeriodDoubling,
    /// A complex pair (quasi-periodic motion sets in).
    NeimarkSacker,
}

/// The Floquet stability of one point.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PointStability {
    /// Stable, unstable or undetermined (within the margin).
    pub verdict: Verdict,
    /// Largest multiplier modulus (`None` where the monodromy was not computed: the period
    /// check already made the point undetermined).
    pub largest_multiplier: Option<f64>,
    /// Argument of that multiplier (rad).
    pub argument: Option<f64>,
    /// Liouville error of the monodromy (see `nlmodes_hb::floquet`).
    pub liouville_error: Option<f64>,
    /// The change of stability since the previous point, if any.
    pub bifurcation: Option<ForcedBifurcation>,
    /// How far one period of time integration of the penalty equation from the orbit's start
    /// lands from it (relative; `period_check`); `None` for exact contact (not checked). Above
    /// `FrfSettings::period_tolerance` the verdict is undetermined.
    pub period_residual: Option<f64>,
    /// On the massless contact boundary (points in contact, docs/STABILITY.md Sec. 9): the
    /// scaled distance from the harmonic-balance orbit's start to the shot orbit's, whose
    /// multipliers these are; above `BOUNDARY_SHIFT_LIMIT` the verdict is undetermined. `None`
    /// where the massive model's monodromy and the period check were used.
    pub boundary_shift: Option<f64>,
}

impl PointStability {
    fn on_boundary(b: &crate::boundary::BoundaryMonodromy, margin: f64) -> Self {
        let mut st = Self::of(&b.monodromy, margin);
        st.boundary_shift = Some(b.shift);
        if b.shift > crate::boundary::BOUNDARY_SHIFT_LIMIT {
            st.verdict = Verdict::Undetermined;
        }
        st
    }

    fn of(mono: &SampledMonodromy, margin: f64) -> Self {
        let first = mono.multipliers.first().copied().unwrap_or([0.0, 0.0]);
        Self {
            verdict: mono.verdict(margin),
            largest_multiplier: Some(mono.largest()),
            argument: Some(first[1].atan2(first[0])),
            liouville_error: mono.liouville_error,
            bifurcation: None,
            period_residual: None,
            boundary_shift: None,
        }
    }

    /// Undetermined without a monodromy (see [`FrfSettings::period_tolerance`]).
    fn unchecked() -> Self {
        Self {
            verdict: Verdict::Undetermined,
            largest_multiplier: None,
            argument: None,
            liouville_error: None,
            bifurcation: None,
            period_residual: None,
            boundary_shift: None,
        }
    }

    /// The bifurcation between `previous` (the last determined point before this one) and this
    /// point, when this one is determined and differs.
    fn classify(&mut self, previous: &PointStability) {
        let determined = |v: Verdict| v != Verdict::Undetermined;
        if !(determined(self.verdict) && determined(previous.verdict))
            || self.verdict == previous.verdict
        {
            return;
        }
        let unstable = if self.verdict == Verdict::Unstable {
            *self
        } else {
            *previous
        };
        let arg = unstable.argument.unwrap_or(0.0).abs();
        self.bifurcation = Some(if arg < 0.05 {
            ForcedBifurcation::Fold
        } else if arg > std::f64::consts::PI - 0.05 {
            ForcedBifurcation::PeriodDoubling
        } else {
            ForcedBifurcation::NeimarkSacker
        });
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
    /// How the trace from the end of the range ended, when there is one and it did not meet
    /// the first piece (`end_text` words).
    pub second_piece: Option<String>,
}

impl FrequencyResponse {
    /// The swept parameter of a point (W in rad/s, or the load scale).
    pub fn parameter(&self, p: &ForcedPoint) -> f64 {
        match self.sweep {
            Sweep::Frequency => p.omega,
            Sweep::Level { .. } => p.level,
        }
    }

    /// Why the curve ended, as a sentence naming the parameter with its unit.
    pub fn end_text(&self) -> String {
        match &self.second_piece {
            Some(second) => format!(
                "{}; traced again from the end of the range: {second}",
                self.first_end_text()
            ),
            None => self.first_end_text(),
        }
    }

    fn first_end_text(&self) -> String {
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
            FrfTermination::Joined {
                stopped,
                met,
                meets: true,
            } => format!(
                "complete in two pieces: the trace from the start of the range {stopped}; the \
                 trace from its end went down to {}, where it met the first piece or the start \
                 of the range",
                at(*met)
            ),
            FrfTermination::Joined { stopped, met, .. } => format!(
                "covered by two pieces that do not meet: the trace from the start of the range \
                 {stopped}; the trace from its end covers {} up to the end (the two overlap in W \
                 on different branches of the sampled problem)",
                at(*met)
            ),
        }
    }
}

/// The continuation in progress (see module docs).
struct FrfTrace<'a, 's> {
    solver: &'a ForcedSolver<'s>,
    settings: &'a FrfSettings,
    y_scale: f64,
    /// p_ref: w_ref for W, the end of the range for the load scale.
    p_scale: f64,
    step: f64,
    /// Direction of travel in W (+1 or -1) and the index of the running extremum of W.
    travel: (f64, usize),
    /// +1 for the trace from the start of the range, -1 for the one from its end.
    direction: f64,
    /// The first piece's points in the scaled space, which the trace from the end stops on
    /// meeting.
    meet: Vec<Vec<f64>>,
    curve: FrequencyResponse,
}

impl<'a, 's> FrfTrace<'a, 's> {
    fn scaled(&self, p: &ForcedPoint) -> Vec<f64> {
        let mut v: Vec<f64> = p.contact.iter().map(|y| y / self.y_scale).collect();
        v.push(self.curve.parameter(p) / self.p_scale);
        v
    }

    /// The unit secant of the last two points in the scaled space.
    fn secant(&self) -> Vec<f64> {
        let n = self.curve.points.len();
        let (a, b) = (
            self.scaled(&self.curve.points[n - 2]),
            self.scaled(&self.curve.points[n - 1]),
        );
        let d: Vec<f64> = b.iter().zip(&a).map(|(x, y)| x - y).collect();
        let norm = d.iter().map(|v| v * v).sum::<f64>().sqrt();
        d.iter().map(|v| v / norm).collect()
    }

    /// The arc row of a step `h` along `tangent` from the last point.
    fn arc(&self, tangent: &[f64], h: f64) -> ArcRow {
        let last = self.curve.points.last().expect("two points");
        let l = last.contact.len();
        let parameter = self.curve.sweep.parameter();
        let mut predicted = OrbitState {
            y: last
                .contact
                .iter()
                .zip(tangent)
                .map(|(y, t)| y + h * t * self.y_scale)
                .collect(),
            omega: last.omega,
            level: last.level,
        };
        let p = self.curve.parameter(last) + h * tangent[l] * self.p_scale;
        predicted.set_parameter(parameter, p);
        ArcRow {
            parameter,
            tangent_y: tangent[..l].to_vec(),
            tangent_parameter: tangent[l],
            predicted,
            y_scale: self.y_scale,
            parameter_scale: self.p_scale,
        }
    }

    /// One accepted step, or the error of the smallest step tried. Below `CORNER_STEP` the
    /// arc-length step gives way to a hop at fixed W (see [`Self::hop`]).
    fn advance(&mut self) -> Result<(), String> {
        let tangent = self.secant();
        loop {
            if self.step < CORNER_STEP {
                if self.hop(tangent[tangent.len() - 1].signum()) || self.phase_hop() {
                    self.step = CORNER_STEP;
                    return Ok(());
                }
                if self.step < self.settings.min_step {
                    return Err("no arc-length step nor hop at fixed W converged".into());
                }
            }
            let arc = self.arc(&tangent, self.step);
            let last = self.curve.points.last().expect("two points");
            let start = ForcedStart {
                state: arc.predicted.clone(),
                multipliers: last.multipliers.clone(),
            };
            match self.solver.solve(start, Some(&arc)) {
                Ok(p) if self.leaps(&arc, &p) => {
                    tracing::debug!(
                        omega = p.omega,
                        step = self.step,
                        distance = self.corrector_distance(&arc, &p),
                        "forced response: corrector far from the prediction or the phase turned \
                         by more than PHASE_REACH, step halved"
                    );
                    // Converged far from the prediction (another piece of the curve, or a jump
                    // across a fold), or across a resonance narrower than the step: retry
                    // shorter.
                    self.step *= 0.5;
                    if self.step < self.settings.min_step {
                        return Err(format!(
                            "the corrector lands farther than the step from the prediction at \
                             {:.6e} (W in rad/s, or the load scale)",
                            self.curve.parameter(&p)
                        ));
                    }
                }
                Ok(p) => {
                    let easy = p.newton_iterations <= 6 * p.inner_solves.max(1);
                    self.curve.points.push(p);
                    self.note_fold();
                    if easy {
                        self.step = (self.step * 1.5).min(self.settings.max_step);
                    }
                    return Ok(());
                }
                Err(e) => {
                    tracing::debug!(
                        step = self.step,
                        "forced response: step failed ({e}), halved"
                    );
                    self.step *= 0.5;
                    if self.step < self.settings.min_step {
                        return Err(e.to_string());
                    }
                }
            }
        }
    }

    /// A corner of the sampled problem (contact setting in on a coordinate with mass, where the
    /// curve turns by a finite angle): solves at a fixed parameter p_k + `direction` dp from the
    /// last orbit for growing dp (1e-4, 1e-3, 5e-3 p_ref) and keeps the first that converges, flagged
    /// as a hop (`FrequencyResponse::hops`). Returns whether one did.
    fn hop(&mut self, direction: f64) -> bool {
        let last = self.curve.points.last().expect("two points").clone();
        for dw in [1e-4, 1e-3, 5e-3] {
            let mut start = ForcedSolver::start_from(&last);
            let p = self.curve.parameter(&last) + direction * dw * self.p_scale;
            start.state.set_parameter(self.curve.sweep.parameter(), p);
            let landed = self.solver.solve(start, None).ok().filter(|p| {
                // A hop stays on the curve: within a few dW of the last orbit, never on another
                // branch (the small orbit out of contact, say).
                self.distance(p, &last) <= HOP_REACH * dw
            });
            if let Some(p) = landed {
                tracing::debug!(
                    omega = p.omega,
                    "forced response: hop at fixed W past a corner"
                );
                self.curve.points.push(p);
                self.curve.hops.push(self.curve.points.len() - 1);
                self.note_fold();
                return true;
            }
        }
        false
    }

    /// A corner at the resonance tip (a lightly damped curve under a stiff law: the rising and
    /// the returning branches meet at nearly 180 degrees, so no arc hyperplane meets the
    /// returning branch near the tip and no orbit exists at a larger W): solves with the phase
    /// lag of the first harmonic of the contact coordinate that moves most fixed a little
    /// further than the last orbit's, W free, for growing steps (1e-4 .. 1e-2 rad), the first
    /// that lands within `PHASE_HOP_REACH` of the last orbit with the lag grown kept. The
    /// direction is physical, not read from the last steps: driven at W, the response lags the
    /// force by a phase that grows along a resonance through both of its folds (0 below it,
    /// pi/2 at phase resonance, towards pi past it; the phase-resonance parametrization of
    /// phase-locked-loop testing), so a larger lag is always forward on the curve (the phase
    /// read from the last two points turns the wrong way at a corner, and a hop in that
    /// direction sent the coarse blade's curve back out of its range in session 10). Only for a
    /// frequency sweep under a force at the first harmonic. The point is flagged as a hop.
    fn phase_hop(&mut self) -> bool {
        let first_harmonic_force = self.solver.load().harmonics.iter().all(|h| h.harmonic == 1);
        if self.curve.sweep.parameter() != Parameter::Frequency || !first_harmonic_force {
            return false;
        }
        let last = self.curve.points.last().expect("two points").clone();
        let row = self.phase_row(&last);
        let (lag, amplitude) = (self.phase(&last, row), self.amplitude(&last, row));
        for dphi in [1e-4, 3e-4, 1e-3, 3e-3, 1e-2] {
            let arc = self.phase_row_arc(&last, row, lag + self.direction * dphi, amplitude);
            let start = ForcedStart {
                state: arc.predicted.clone(),
                multipliers: last.multipliers.clone(),
            };
            let landed = self.solver.solve(start, Some(&arc)).ok().filter(|p| {
                let turn = wrap_angle(self.phase(p, row) - lag);
                let distance = self.distance(p, &last);
                tracing::debug!(omega = p.omega, dphi, turn, distance, "phase hop landed");
                turn * self.direction > 0.0 && distance <= PHASE_HOP_REACH
            });
            if let Some(p) = landed {
                tracing::debug!(omega = p.omega, dphi, "forced response: hop at fixed phase");
                self.curve.points.push(p);
                self.curve.hops.push(self.curve.points.len() - 1);
                self.note_fold();
                return true;
            }
        }
        false
    }

    /// The row "phase lag of contact coordinate `row`'s first harmonic = `lag`" (the first
    /// harmonic a cos + b sin held on the line -sin(lag) a + cos(lag) b = 0, W free), with the
    /// last orbit rotated to that lag as its prediction.
    fn phase_row_arc(&self, last: &ForcedPoint, row: usize, lag: f64, amplitude: f64) -> ArcRow {
        let t = self.solver.basis().terms();
        let (ic, is) = (FullBasis::cos_index(1), FullBasis::sin_index(1));
        let mut tangent_y = vec![0.0; last.contact.len()];
        tangent_y[row * t + ic] = -lag.sin();
        tangent_y[row * t + is] = lag.cos();
        let mut predicted = OrbitState {
            y: last.contact.clone(),
            omega: last.omega,
            level: last.level,
        };
        predicted.y[row * t + ic] = amplitude * lag.cos();
        predicted.y[row * t + is] = amplitude * lag.sin();
        ArcRow {
            parameter: self.curve.sweep.parameter(),
            tangent_y,
            tangent_parameter: 0.0,
            predicted,
            y_scale: self.y_scale,
            parameter_scale: self.p_scale,
        }
    }

    /// The distance between two points in the scaled space of the continuation.
    fn distance(&self, a: &ForcedPoint, b: &ForcedPoint) -> f64 {
        let (a, b) = (self.scaled(a), self.scaled(b));
        a.iter()
            .zip(&b)
            .map(|(x, y)| (x - y).powi(2))
            .sum::<f64>()
            .sqrt()
    }

    /// Whether the corrector's point `p` is too far from the last point to be the next one on
    /// the curve: farther than `CORRECTOR_REACH` steps from the prediction, or with the phase of
    /// the first harmonic turned by more than `PHASE_REACH`.
    fn leaps(&self, arc: &ArcRow, p: &ForcedPoint) -> bool {
        if self.corrector_distance(arc, p) > CORRECTOR_REACH * self.step {
            return true;
        }
        let last = self.curve.points.last().expect("two points");
        let touching = |q: &ForcedPoint| q.contact_force.iter().any(|&f| f > 0.0);
        if touching(last) || touching(p) {
            // In contact the corners and the small folds of the sampled problem turn the phase
            // quickly too (with the check there the coarse blade's level-2 curve of
            // tests/results_files.rs lost its way and left the range): linear steps only.
            return false;
        }
        let row = self.phase_row(last);
        let turn = self.phase(p, row) - self.phase(last, row);
        wrap_angle(turn).abs() > PHASE_REACH
    }

    /// The contact coordinate whose first harmonic is largest at `p`.
    fn phase_row(&self, p: &ForcedPoint) -> usize {
        let t = self.solver.basis().terms();
        (0..p.contact.len() / t)
            .max_by(|&a, &b| self.amplitude(p, a).total_cmp(&self.amplitude(p, b)))
            .unwrap_or(0)
    }

    /// Amplitude of the first harmonic of contact coordinate `row` at `p`.
    fn amplitude(&self, p: &ForcedPoint, row: usize) -> f64 {
        let t = self.solver.basis().terms();
        let (ic, is) = (FullBasis::cos_index(1), FullBasis::sin_index(1));
        p.contact[row * t + ic].hypot(p.contact[row * t + is])
    }

    /// Phase (rad) of the first harmonic of contact coordinate `row` at `p`: a cos + b sin =
    /// r cos(W t - phase).
    fn phase(&self, p: &ForcedPoint, row: usize) -> f64 {
        let t = self.solver.basis().terms();
        let (ic, is) = (FullBasis::cos_index(1), FullBasis::sin_index(1));
        p.contact[row * t + is].atan2(p.contact[row * t + ic])
    }

    /// Floquet stability of the points not assessed yet (when asked for): each point's period
    /// check and monodromy in parallel (they depend on the point alone, so the result is the
    /// same in any order), then the changes of stability in order.
    fn assess_stability(&mut self) -> Result<(), ForcedError> {
        use rayon::prelude::*;
        if !self.settings.stability {
            return Ok(());
        }
        let from = self.curve.stability.len();
        let (solver, settings) = (self.solver, self.settings);
        let assessed: Vec<Result<PointStability, ForcedError>> = self.curve.points[from..]
            .par_iter()
            .map(|point| {
                let touching = point.contact_force.iter().any(|&f| f > 0.0);
                if touching {
                    if let Some(b) = solver.boundary_monodromy(point, false)? {
                        return Ok(PointStability::on_boundary(&b, settings.stability_margin));
                    }
                }
                let residual = solver.period_residual(point);
                let mut st = if residual.is_some_and(|r| r > settings.period_tolerance) {
                    // Not a periodic solution of the equation the monodromy linearizes. Under a
                    // penalty law on a model whose modes are all resolved, the exact periodic
                    // orbit of that equation next to the point answers (its verdict, unless
                    // farther than the shift limit); otherwise no verdict to compute.
                    let exact = if touching && solver.every_mode_resolved(point.omega) {
                        solver.boundary_monodromy(point, true)?
                    } else {
                        None
                    };
                    exact.map_or_else(PointStability::unchecked, |b| {
                        PointStability::on_boundary(&b, settings.stability_margin)
                    })
                } else {
                    let mono = solver.monodromy(point)?;
                    PointStability::of(&mono, settings.stability_margin)
                };
                st.period_residual = residual;
                Ok(st)
            })
            .collect();
        for st in assessed {
            let mut st = st?;
            // A change of stability is between points of one piece.
            let piece = self
                .curve
                .pieces
                .iter()
                .copied()
                .filter(|&k| k <= self.curve.stability.len())
                .max()
                .unwrap_or(0);
            let determined = self.curve.stability[piece..]
                .iter()
                .rev()
                .find(|p| p.verdict != Verdict::Undetermined);
            if let Some(prev) = determined {
                st.classify(prev);
            }
            self.curve.stability.push(st);
        }
        Ok(())
    }

    /// Distance in the scaled space from the prediction of `arc` to the solution `p`.
    fn corrector_distance(&self, arc: &ArcRow, p: &ForcedPoint) -> f64 {
        let dy: f64 = p
            .contact
            .iter()
            .zip(&arc.predicted.y)
            .map(|(a, b)| ((a - b) / self.y_scale).powi(2))
            .sum();
        let dp = self.curve.parameter(p) - arc.predicted.parameter(arc.parameter);
        (dy + (dp / self.p_scale).powi(2)).sqrt()
    }

    /// Marks a fold when the parameter has retreated from its running extremum by more than
    /// `fold_tolerance` w_ref: a turn of the curve, not a kink of the sampled problem (where W
    /// wobbles by 1e-5 w_ref near a peak: the active samples switch one by one).
    fn note_fold(&mut self) {
        let n = self.curve.points.len();
        let w = |i: usize| self.curve.parameter(&self.curve.points[i]);
        let last = n - 1;
        let travel = self.travel.0;
        let extremum = self.travel.1;
        if (w(last) - w(extremum)) * travel > 0.0 {
            self.travel.1 = last;
        } else if (w(extremum) - w(last)) * travel > self.settings.fold_tolerance * self.p_scale {
            let kind = if travel > 0.0 {
                FoldKind::TurnsBack
            } else {
                FoldKind::TurnsForward
            };
            let at = if extremum > 0 && extremum + 1 < n {
                self.fold_parameter(extremum)
            } else {
                w(extremum)
            };
            self.curve.folds.push(Fold {
                point: extremum,
                at,
                kind,
            });
            self.travel = (-travel, last);
        }
    }

    /// The extremum of the parabola through (s, W) of points i - 1, i, i + 1 (s the scaled arc
    /// length along the polyline).
    fn fold_parameter(&self, i: usize) -> f64 {
        let p = |k: usize| self.scaled(&self.curve.points[k]);
        let dist = |a: &[f64], b: &[f64]| {
            a.iter()
                .zip(b)
                .map(|(x, y)| (x - y).powi(2))
                .sum::<f64>()
                .sqrt()
        };
        let (a, b, c) = (p(i - 1), p(i), p(i + 1));
        let (s0, s1, s2) = (0.0, dist(&a, &b), dist(&a, &b) + dist(&b, &c));
        let w = |k: usize| self.curve.parameter(&self.curve.points[k]);
        let (w0, w1, w2) = (w(i - 1), w(i), w(i + 1));
        // Divided differences of the interpolating parabola, then its vertex.
        let f01 = (w1 - w0) / (s1 - s0);
        let f12 = (w2 - w1) / (s2 - s1);
        let f012 = (f12 - f01) / (s2 - s0);
        if f012 == 0.0 {
            return w1;
        }
        let s_star = 0.5 * (s0 + s1) - f01 / (2.0 * f012);
        w0 + f01 * (s_star - s0) + f012 * (s_star - s0) * (s_star - s1)
    }
}

/// `angle` wrapped into (-pi, pi].
fn wrap_angle(angle: f64) -> f64 {
    use std::f64::consts::{PI, TAU};
    PI - (PI - angle).rem_euclid(TAU)
}

/// How close (scaled distance) the trace from the end of the range must come to a point of the
/// first piece to have met it: half the largest step.
const MEET_REACH: f64 = 0.01;

/// Traces the response curve of `solver` over the settings' range, in W or in the load scale
/// (see module docs); `progress` sees every accepted point. A frequency sweep whose trace from
/// the start of the range stops or turns back (a corner of the sampled problem it cannot pass)
/// is traced again from the end of the range, W falling, until it meets the first piece
/// (`FrfTermination::Joined`, two `pieces`) or stops too.
pub fn response_curve(
    solver: &ForcedSolver<'_>,
    settings: &FrfSettings,
    mut progress: impl FnMut(&ForcedPoint),
) -> Result<FrequencyResponse, ForcedError> {
    settings.validate()?;
    let mut trace = FrfTrace::begin(solver, settings, 1.0, Vec::new(), &mut progress)?;
    trace.run(&mut progress)?;
    let stopped = matches!(
        trace.curve.termination,
        FrfTermination::StepTooSmall { .. } | FrfTermination::LeftRange { .. }
    );
    if stopped && settings.sweep == Sweep::Frequency {
        let meet = trace.curve.points.iter().map(|p| trace.scaled(p)).collect();
        match FrfTrace::begin(solver, settings, -1.0, meet, &mut progress) {
            Ok(mut back) => {
                back.run(&mut progress)?;
                trace.append(back.curve);
            }
            Err(e) => tracing::debug!("forced response: no trace from the end of the range: {e}"),
        }
    }
    trace.assess_stability()?;
    Ok(trace.curve)
}

impl<'a, 's> FrfTrace<'a, 's> {
    /// The first two points from the linear solution at the start of the range (`direction`
    /// +1) or at its end (-1, W falling; for a frequency sweep only).
    fn begin(
        solver: &'a ForcedSolver<'s>,
        settings: &'a FrfSettings,
        direction: f64,
        meet: Vec<Vec<f64>>,
        progress: &mut impl FnMut(&ForcedPoint),
    ) -> Result<Self, ForcedError> {
        let system = solver.system();
        let from = if direction > 0.0 {
            settings.start
        } else {
            settings.end
        };
        let (omega, level, p_scale) = match settings.sweep {
            Sweep::Frequency => (from, 1.0, system.linear_frequencies()[0]),
            Sweep::Level { omega } => (omega, settings.start, settings.end),
        };
        let first = solver.solve(solver.linear_start(omega, level)?, None)?;
        progress(&first);
        let mut start = ForcedSolver::start_from(&first);
        let parameter = settings.sweep.parameter();
        start
            .state
            .set_parameter(parameter, from + direction * settings.step * p_scale);
        let second = solver.solve(start, None)?;
        progress(&second);
        Ok(Self {
            solver,
            settings,
            y_scale: system.gap_reference() * (system.n_contacts().max(1) as f64).sqrt(),
            p_scale,
            step: settings.step,
            travel: (direction, 1),
            direction,
            meet,
            curve: FrequencyResponse {
                sweep: settings.sweep,
                points: vec![first, second],
                folds: Vec::new(),
                hops: Vec::new(),
                stability: Vec::new(),
                termination: FrfTermination::Complete,
                pieces: vec![0],
                second_piece: None,
            },
        })
    }

    /// Steps until the far end of the range, the point limit, a failed step, a turn back past
    /// the near end, or (the trace from the end) a point that meets the first piece.
    fn run(&mut self, progress: &mut impl FnMut(&ForcedPoint)) -> Result<(), ForcedError> {
        let d = self.direction;
        let (near, far) = if d > 0.0 {
            (self.settings.start, self.settings.end)
        } else {
            (self.settings.end, self.settings.start)
        };
        loop {
            let last = self
                .curve
                .parameter(self.curve.points.last().expect("points"));
            if d * (last - far) >= 0.0 {
                return Ok(());
            }
            if self.curve.points.len() >= self.settings.max_points {
                self.curve.termination = FrfTermination::PointLimit;
                return Ok(());
            }
            if let Err(reason) = self.advance() {
                self.curve.termination = FrfTermination::StepTooSmall { at: last, reason };
                return Ok(());
            }
            let newest = self.curve.points.last().expect("just pushed");
            if d * (self.curve.parameter(newest) - near) < 0.0 {
                self.curve.points.pop();
                let n = self.curve.points.len();
                self.curve.hops.retain(|&h| h < n);
                self.curve.folds.retain(|f| f.point < n);
                self.curve.termination = FrfTermination::LeftRange { at: last };
                return Ok(());
            }
            progress(newest);
            let x = self.scaled(newest);
            let met = self.meet.iter().any(|m| {
                m.iter()
                    .zip(&x)
                    .map(|(a, b)| (a - b).powi(2))
                    .sum::<f64>()
                    .sqrt()
                    <= MEET_REACH
            });
            if met {
                let at = self.curve.parameter(newest);
                self.curve.termination = FrfTermination::Joined {
                    stopped: String::new(),
                    met: at,
                    meets: true,
                };
                return Ok(());
            }
        }
    }

    /// Appends the trace from the end of the range (`back`) as the second piece; the curve is
    /// joined when that trace met this one.
    fn append(&mut self, back: FrequencyResponse) {
        let offset = self.curve.points.len();
        let w = |r: &FrequencyResponse, pick: fn(f64, f64) -> f64, from: f64| {
            r.points.iter().map(|p| r.parameter(p)).fold(from, pick)
        };
        let (first_top, second_low) = (
            w(&self.curve, f64::max, f64::NEG_INFINITY),
            w(&back, f64::min, f64::INFINITY),
        );
        let stopped = self.curve.end_text();
        match back.termination {
            // It met the first piece, or crossed the whole range down to its start.
            FrfTermination::Joined { met, .. } => {
                self.curve.termination = FrfTermination::Joined {
                    stopped,
                    met,
                    meets: true,
                };
            }
            FrfTermination::Complete => {
                self.curve.termination = FrfTermination::Joined {
                    stopped,
                    met: second_low,
                    meets: true,
                };
            }
            // Between them the two pieces reach every W of the range.
            _ if second_low <= first_top => {
                self.curve.termination = FrfTermination::Joined {
                    stopped,
                    met: second_low,
                    meets: false,
                };
                self.curve.second_piece = Some(match back.termination {
                    FrfTermination::LeftRange { at } => {
                        format!("it turned back past the end of the range after W = {at:.6e} rad/s")
                    }
                    _ => back.end_text(),
                });
            }
            FrfTermination::LeftRange { at } => {
                self.curve.second_piece = Some(format!(
                    "it turned back past the end of the range after W = {at:.6e} rad/s"
                ));
            }
            _ => self.curve.second_piece = Some(back.end_text()),
        }
        self.curve.pieces.push(offset);
        self.curve
            .folds
            .extend(back.folds.into_iter().map(|f| Fold {
                point: f.point + offset,
                ..f
            }));
        self.curve
            .hops
            .extend(back.hops.into_iter().map(|h| h + offset));
        self.curve.points.extend(back.points);
    }
}
