//! [`backbone`] and the continuation engine behind it (docs/DESIGN.md §8): a [`Continuation`]
//! owns the solver and the growing [`Backbone`]; each branch being traced is a [`Trace`] (its
//! points, unit tangent and step), advanced by predict / correct / accept.

use crate::continuation::{
    Backbone, Branch, BranchKind, ContinuationSettings, InternalResonance, Passage, Termination,
};
use crate::error::NnmError;
use crate::fourier::HarmonicSettings;
use crate::linear_model::ParameterRow;
use crate::point::BackbonePoint;
use crate::solver::{Guess, Solver, Start};
use crate::solver_settings::SolverSettings;
use crate::system::System;

/// Smallest base distance (scaled arc length, i.e. about g_ref in q) of the predictors and hops
/// past a tongue: a tongue's width does not scale with the continuation step, so neither may the
/// distance tried to get past it (with step = 0.05 the passes would otherwise stay inside it).
const PASS_BASE: f64 = 0.25;

/// Predictors on the local tangent past a tongue (at 2, 4, ... 2^TANGENT_PASSES x the base
/// distance).
const TANGENT_PASSES: u32 = 5;

/// Fixed-q hops past a tongue, at 1, 2, ... 2^(HOPS - 1) x the base distance ahead (capped at
/// q_max, which is tried last).
const HOPS: u32 = 8;

/// Predictors on the secant past a tongue, at 1.5^k x the base distance, k = 1 ..= SECANT_PASSES
/// (0.375 to 9.6 g_ref from the smallest base).
const SECANT_PASSES: u32 = 8;

/// Points at most traced backwards from the landing point past a tongue toward it.
const BACKFILL_POINTS: usize = 200;

/// Span of q (in g_ref) over which the main branch's direction before a tongue is taken.
const PASS_SPAN: f64 = 1.0;

/// Traces the backbone family of mode `cont.mode` from q_start to q_max (docs/DESIGN.md §8),
/// calling `progress` after every computed point. Invalid settings are errors; solver failures
/// end the run with the points computed so far and a [`Termination`] saying why.
pub fn backbone<F>(
    system: &System,
    settings: HarmonicSettings,
    params: impl Into<SolverSettings>,
    cont: &ContinuationSettings,
    progress: F,
) -> Result<Backbone, NnmError>
where
    F: FnMut(&BackbonePoint),
{
    cont.validate()?;
    let solver = Solver::new(system, settings, params)?;
    Continuation::new(solver, cont, progress)?.run()
}

/// A branch being traced.
struct Trace {
    /// Index in `Backbone::branches`.
    id: usize,
    /// Indices of its points in `Backbone::points` (the first may belong to the parent branch).
    points: Vec<usize>,
    /// Unit tangent in the scaled space.
    tangent: Vec<f64>,
    /// Next step and the last accepted one (scaled arc length).
    ds: f64,
    last_ds: f64,
    /// Sign of dq/ds along the last accepted step.
    dq_sign: f64,
    /// Folds passed so far.
    folds: usize,
    /// Start the first corrector from the last orbit amplified by (1 + step), in contact: at the
    /// grazing orbit the contact is inactive, so the plain Newton step at w != w_lin goes to the
    /// trivial orbit u = 0; from a penetrating guess it sees the one-sided (contact-active)
    /// Jacobian and goes to the nonlinear branch.
    penetrate: bool,
}

/// Result of one predictor-corrector step.
/// What the main branch met at a new point (`Continuation::tongue_entry`).
enum Entry {
    /// An internal-resonance tongue (by its energy shares, or a fold of q toward another mode's
    /// harmonic n >= 2).
    Tongue(InternalResonance),
    /// q turned back without another mode taking the energy (no harmonic n >= 2 of another mode
    /// is the largest secondary component), or by a step accepted as a jump: a corner of the
    /// sampled branch, passed like one where no step converges.
    Corner,
}

enum Advance {
    /// A converged corrector, its scaled coordinates and the step taken.
    Converged(Box<BackbonePoint>, Vec<f64>, f64),
    /// Rejected (no convergence, or too far from the predictor): the step was shrunk, try again.
    Retry,
    /// The step fell below `min_step`; the last error.
    Stuck(String),
}

/// A backbone run in progress.
pub(crate) struct Continuation<'s, 'c, F> {
    solver: Solver<'s>,
    cont: &'c ContinuationSettings,
    g_ref: f64,
    w_lin: f64,
    /// sqrt(c + 1): the kept coordinates are scaled to an RMS so that y weighs like q.
    y_norm: f64,
    omegas: Vec<f64>,
    result: Backbone,
    progress: F,
}

impl<'s, 'c, F: FnMut(&BackbonePoint)> Continuation<'s, 'c, F> {
    pub fn new(
        solver: Solver<'s>,
        cont: &'c ContinuationSettings,
        progress: F,
    ) -> Result<Self, NnmError> {
        let system = solver.system();
        let w_lin = solver.linear_frequency(cont.mode)?;
        let g_ref = system.gap_reference();
        let result = Backbone::empty(
            Termination::MaxPoints,
            w_lin,
            g_ref,
            system.grazing_amplitude(cont.mode)?,
        );
        Ok(Self {
            y_norm: ((system.n_contacts() + 1) as f64).sqrt(),
            omegas: system.linear_frequencies(),
            solver,
            cont,
            g_ref,
            w_lin,
            result,
            progress,
        })
    }

    /// The linear segment, then the main branch with its tongues.
    pub fn run(mut self) -> Result<Backbone, NnmError> {
        let grazing = self.result.grazing_amplitude.map(|q| q / self.g_ref);
        let trace = match grazing {
            Some(q_g) if q_g > self.cont.q_start && q_g < self.cont.q_max => {
                match self.linear_segment(q_g) {
                    Ok(()) => self.start_at_grazing(),
                    Err(e) => return Ok(self.stop_at_start(e)),
                }
            }
            Some(q_g) if q_g <= self.cont.q_start => match self.start_at_q_start() {
                Ok(t) => t,
                Err(e) => return Ok(self.stop_at_start(e)),
            },
            // The mode does not touch below q_max: the whole range is linear.
            _ => {
                return Ok(match self.linear_segment(self.cont.q_max) {
                    Ok(()) => {
                        self.result.termination = Termination::ReachedMaxAmplitude;
                        self.result
                    }
                    Err(e) => self.stop_at_start(e),
                })
            }
        };
        self.trace_main(trace);
        Ok(self.result)
    }

    fn stop_at_start(mut self, e: NnmError) -> Backbone {
        self.result.termination = Termination::StartFailed {
            reason: e.to_string(),
        };
        self.result
    }

    fn new_branch(&mut self, parent: Option<usize>, kind: BranchKind) -> usize {
        let id = self.result.branches.len();
        self.result.branches.push(Branch {
            id,
            parent,
            kind,
            end: String::new(),
        });
        id
    }

    fn end_branch(&mut self, id: usize, why: &str) {
        self.result.branches[id].end = why.to_string();
    }

    fn push(&mut self, mut p: BackbonePoint, branch: usize) -> usize {
        p.branch = branch;
        (self.progress)(&p);
        self.result.points.push(p);
        self.result.points.len() - 1
    }

    /// Linear points from q_start to `q_end` (scaled), spaced by at most `max_step`, the last
    /// exactly at `q_end` (the grazing orbit when it is the grazing amplitude).
    fn linear_segment(&mut self, q_end: f64) -> Result<(), NnmError> {
        let id = self.new_branch(None, BranchKind::Linear);
        let span = q_end - self.cont.q_start;
        let count = (span / self.cont.max_step).ceil().max(1.0) as usize;
        for i in 0..=count {
            let q = self.cont.q_start + span * i as f64 / count as f64;
            let p = self
                .solver
                .solve_point(q * self.g_ref, Start::LinearMode(self.cont.mode))?;
            self.push(p, id);
        }
        self.end_branch(id, "grazing");
        Ok(())
    }

    /// The main branch from the grazing orbit (the last point): the first predictor along w.
    fn start_at_grazing(&mut self) -> Trace {
        let id = self.new_branch(Some(0), BranchKind::Main);
        let last = self.result.points.len() - 1;
        let dim = self.scaled(&self.result.points[last]).len();
        let mut tangent = vec![0.0; dim];
        tangent[1] = 1.0;
        Trace {
            id,
            points: vec![last],
            tangent,
            ds: self.cont.grazing_step.min(self.cont.max_step),
            last_ds: self.cont.grazing_step,
            dq_sign: 1.0,
            folds: 0,
            penetrate: true,
        }
    }

    /// The main branch from q_start when q_start is at or above grazing: first tangent along the
    /// linear mode (X proportional to q at constant w).
    fn start_at_q_start(&mut self) -> Result<Trace, NnmError> {
        let id = self.new_branch(None, BranchKind::Main);
        let p = self.solver.solve_point(
            self.cont.q_start * self.g_ref,
            Start::LinearMode(self.cont.mode),
        )?;
        let mut tangent = self.scaled(&p);
        tangent[1] = 0.0;
        normalize(&mut tangent);
        let index = self.push(p, id);
        Ok(Trace {
            id,
            points: vec![index],
            tangent,
            ds: self.cont.step,
            last_ds: self.cont.step,
            dq_sign: 1.0,
            folds: 0,
            penetrate: false,
        })
    }

    /// Traces the main branch to q_max (or until it stops), following the tongues it meets.
    fn trace_main(&mut self, mut trace: Trace) {
        loop {
            if self.result.points.len() >= self.cont.max_points {
                self.result.termination = Termination::MaxPoints;
                self.end_branch(trace.id, "point limit");
                return;
            }
            let (p, xn, step) = match self.advance(&mut trace, true) {
                Advance::Retry => continue,
                Advance::Stuck(reason) => {
                    // At a corner of the branch where no arc-length step converges: past it as
                    // past a tongue (secant predictors, then fixed-q hops as the last resort).
                    if trace.dq_sign > 0.0 && self.pass_corner(&mut trace) {
                        if self.ends_at_q_max(&trace) {
                            return;
                        }
                        continue;
                    }
                    let q = self.last_point(&trace).q;
                    self.result.termination = Termination::StepTooSmall {
                        q,
                        step: trace.ds,
                        reason,
                    };
                    self.end_branch(trace.id, "step too small");
                    return;
                }
                Advance::Converged(p, xn, step) => (p, xn, step),
            };
            if xn[0] <= 0.0 {
                self.result.termination = Termination::AmplitudeNotPositive;
                self.end_branch(trace.id, "amplitude not positive");
                return;
            }
            let corner = match self.tongue_entry(&trace, &p, &xn) {
                Some(Entry::Tongue(res)) => {
                    if !self.pass_tongue(&mut trace, *p, res) || self.ends_at_q_max(&trace) {
                        return;
                    }
                    continue;
                }
                Some(Entry::Corner) => true,
                None => false,
            };
            // A corner not passed: the point is taken as it is (a fold of the main branch).
            if corner && self.pass_corner(&mut trace) {
                if self.ends_at_q_max(&trace) {
                    return;
                }
                continue;
            }
            let xl = self.scaled(self.last_point(&trace));
            let moved = distance(&xn, &xl);
            self.accept(&mut trace, *p, &xn, step);
            if moved <= 1e-12 * step {
                let q = self.last_point(&trace).q;
                self.result.termination = Termination::NoProgress { q };
                self.end_branch(trace.id, "no progress");
                return;
            }
            if xn[0] >= self.cont.q_max * (1.0 - 1e-12) {
                self.result.termination = Termination::ReachedMaxAmplitude;
                self.end_branch(trace.id, "q_max reached");
                return;
            }
        }
    }

    /// Whether the main branch's last point (after a passage) is at q_max: then the run ends
    /// there, as reaching q_max.
    fn ends_at_q_max(&mut self, trace: &Trace) -> bool {
        let done = self.last_point(trace).q >= self.cont.q_max * self.g_ref * (1.0 - 1e-12);
        if done {
            self.result.termination = Termination::ReachedMaxAmplitude;
            self.end_branch(trace.id, "q_max reached");
        }
        done
    }

    /// Continues the main branch past a corner (no arc-length step converges there, or q turns
    /// back by a jump or with no other mode taking the energy) as past a tongue, without
    /// recording an internal resonance. Returns whether it got past.
    fn pass_corner(&mut self, trace: &mut Trace) -> bool {
        let passed = self.step_past(trace).is_some();
        if passed {
            tracing::info!(
                q = self.last_point(trace).q,
                "continued past a corner of the main branch"
            );
        }
        passed
    }

    /// Whether the main branch enters an internal-resonance tongue at `p`: its energy has moved
    /// into another mode at a harmonic n >= 2 (`ContinuationSettings::tongue`), or q turns back
    /// (a fold from rising to falling q; the main branch of a stiffening contact mode rises in q
    /// except in the tongues, where the energy flows into another mode while q passes a maximum).
    fn tongue_entry(&self, trace: &Trace, p: &BackbonePoint, xn: &[f64]) -> Option<Entry> {
        if let Some(res) = self.cont.tongue(p, &self.omegas) {
            return Some(Entry::Tongue(res));
        }
        let xl = self.scaled(self.last_point(trace));
        let turns_back = trace.points.len() > 1 && trace.dq_sign > 0.0 && xn[0] < xl[0];
        if !turns_back || self.cont.skip_folds {
            return None;
        }
        let resonant = p.secondary_harmonic >= 2 && p.secondary_mode != p.mode;
        if p.jump || !resonant {
            return Some(Entry::Corner);
        }
        let wk = self
            .omegas
            .get(p.secondary_mode)
            .copied()
            .unwrap_or(f64::NAN);
        Some(Entry::Tongue(InternalResonance {
            q: p.q,
            omega_ratio: p.omega_ratio,
            mode: p.secondary_mode,
            harmonic: p.secondary_harmonic,
            share: p.secondary_share,
            detuning: (p.secondary_harmonic as f64 * p.omega - wk) / wk,
            passed: None,
            branch: None,
        }))
    }

    fn last_point(&self, trace: &Trace) -> &BackbonePoint {
        &self.result.points[trace.points[trace.points.len() - 1]]
    }

    /// Predictor along the tangent, corrector on the arc-length row (a fixed-q row for the step
    /// that lands on q_max when `to_q_max`), step control.
    fn advance(&mut self, trace: &mut Trace, to_q_max: bool) -> Advance {
        let xl = self.scaled(self.last_point(trace));
        let mut step = trace.ds;
        let final_step = to_q_max
            && trace.tangent[0] > 0.0
            && xl[0] + step * trace.tangent[0] >= self.cont.q_max;
        if final_step {
            step = (self.cont.q_max - xl[0]) / trace.tangent[0];
        }
        let pred: Vec<f64> = xl
            .iter()
            .zip(&trace.tangent)
            .map(|(x, t)| x + step * t)
            .collect();
        let mut guess = self.extrapolate(trace, &pred, step / trace.last_ds);
        if trace.penetrate && trace.points.len() == 1 {
            let s = 1.0 + step;
            guess
                .coefficients
                .iter_mut()
                .for_each(|c| c.iter_mut().for_each(|v| *v *= s));
        }
        let row = if final_step {
            ParameterRow::fixed_amplitude(self.cont.q_max * self.g_ref, self.g_ref, self.w_lin)
        } else {
            self.arc_row(&trace.tangent, &pred)
        };
        let shrunk = trace.ds * self.cont.shrink;
        match self.solver.solve_with_row(row, guess) {
            Err(e) => {
                tracing::debug!(step = trace.ds, error = %e, "continuation step failed");
                trace.ds = shrunk;
                if trace.ds < self.cont.min_step {
                    Advance::Stuck(e.to_string())
                } else {
                    Advance::Retry
                }
            }
            Ok(mut p) => {
                let xn = self.scaled(&p);
                let first_from_grazing = trace.penetrate && trace.points.len() == 1;
                if first_from_grazing {
                    // The row w = w_pred crosses the branch transversally (its tangent is not yet
                    // known), so the corrector may land O(step) away; only the trivial orbit
                    // (q -> 0, also a solution at any w) is refused.
                    if xn[0] < 0.5 * xl[0] {
                        trace.ds = shrunk;
                        return if trace.ds < self.cont.min_step {
                            Advance::Stuck("the first step from grazing found only u = 0".into())
                        } else {
                            Advance::Retry
                        };
                    }
                    return Advance::Converged(Box::new(p), xn, step);
                }
                let far = !final_step && distance(&xn, &pred) > self.cont.jump_factor * step;
                if far && shrunk >= self.cont.min_step {
                    tracing::debug!(step, "corrector far from the predictor: step shrunk");
                    trace.ds = shrunk;
                    return Advance::Retry;
                }
                p.jump = far;
                Advance::Converged(Box::new(p), xn, step)
            }
        }
    }

    /// Accepts a converged point on `trace`: fold flag, tangent = secant, step growth.
    fn accept(&mut self, trace: &mut Trace, mut p: BackbonePoint, xn: &[f64], step: f64) {
        let xl = self.scaled(self.last_point(trace));
        let mut delta: Vec<f64> = xn.iter().zip(&xl).map(|(a, b)| a - b).collect();
        let len = normalize(&mut delta);
        if xn[0] != xl[0] {
            let sign = (xn[0] - xl[0]).signum();
            p.fold = trace.points.len() > 1 && sign != trace.dq_sign;
            if trace.points.len() == 1 {
                trace.dq_sign = sign;
            }
            if p.fold {
                trace.folds += 1;
                tracing::info!(q = p.q, omega = p.omega, "turning point of q (fold) passed");
            }
            trace.dq_sign = sign;
        }
        // Main-branch points that leave grazing toward smaller q, up to the first fold.
        p.pre_fold = trace.id == 1 && trace.folds == 0 && trace.dq_sign < 0.0 && !p.fold;
        if p.jump {
            tracing::debug!(
                q = p.q,
                omega = p.omega,
                "step at its minimum: accepted a jump"
            );
        }
        if len > 0.0 {
            trace.tangent = delta;
        }
        trace.last_ds = len.max(f64::MIN_POSITIVE).max(1e-3 * step);
        if p.jump {
            // Accepted at the smallest step (a corner of the sampled branch): restart the step.
            trace.ds = self.cont.step.min(self.cont.max_step);
        } else if p.newton_iterations <= self.cont.easy_iterations {
            trace.ds = (trace.ds * self.cont.growth).min(self.cont.max_step);
        }
        let index = self.push(p, trace.id);
        trace.points.push(index);
    }

    /// The main branch met a tongue at `p`: record it, follow the tongue as its own branch
    /// (unless skipped), then continue the main branch past it. Returns false if the run ends.
    fn pass_tongue(&mut self, main: &mut Trace, p: BackbonePoint, res: InternalResonance) -> bool {
        tracing::info!(
            q_over_g0 = p.q / self.g_ref,
            omega_ratio = p.omega_ratio,
            "internal resonance: harmonic {} of the orbit is near linear mode {}",
            res.harmonic,
            res.mode + 1
        );
        let record = self.result.internal_resonances.len();
        self.result.internal_resonances.push(res.clone());
        if !self.cont.skip_internal_resonances {
            let branch = self.follow_tongue(main, p, &res);
            self.result.internal_resonances[record].branch = Some(branch);
        }
        let passed = self.step_past(main);
        self.result.internal_resonances[record].passed = passed;
        if passed.is_none() {
            let q = self.last_point(main).q;
            self.result.termination = Termination::InternalResonance {
                q,
                mode: res.mode,
                harmonic: res.harmonic,
            };
            self.end_branch(main.id, "internal resonance not passed");
        }
        passed.is_some()
    }

    /// Follows a tongue from the main branch's last point through its first point `p`, for at
    /// most `tongue_points` points, until it leaves the resonance (its energy shares no longer
    /// show it, and, for a tongue entered by a fold of q, q no longer falls while the primary
    /// component's share shrinks), turns to q <= 0 or passes q_max. Returns the branch id.
    fn follow_tongue(&mut self, main: &Trace, p: BackbonePoint, res: &InternalResonance) -> usize {
        let kind = BranchKind::Tongue {
            mode: res.mode,
            harmonic: res.harmonic,
        };
        let id = self.new_branch(Some(main.id), kind);
        let mut trace = Trace {
            id,
            points: vec![main.points[main.points.len() - 1]],
            tangent: main.tangent.clone(),
            ds: main.ds,
            last_ds: main.last_ds,
            dq_sign: main.dq_sign,
            folds: 0,
            penetrate: false,
        };
        // Entered by a fold of q before the energy shares show the resonance: followed while q
        // keeps falling and the primary component's share keeps shrinking (energy flowing out of
        // the traced mode; a fold of the main branch itself, traced back, gains it back), as well
        // as while the shares show it.
        let by_fold = self.cont.tongue(&p, &self.omegas).is_none();
        let mut primary = p.primary_share;
        let xn = self.scaled(&p);
        let step = distance(&xn, &self.scaled(self.last_point(&trace)));
        self.accept(&mut trace, p, &xn, step);
        let mut why = "tongue point limit";
        for _ in 1..self.cont.tongue_points {
            if self.result.points.len() >= self.cont.max_points {
                why = "point limit";
                break;
            }
            let (p, xn, step) = match self.advance(&mut trace, false) {
                Advance::Retry => continue,
                Advance::Stuck(_) => {
                    why = "step too small";
                    break;
                }
                Advance::Converged(p, xn, step) => (p, xn, step),
            };
            if xn[0] <= 0.0 || xn[0] >= self.cont.q_max {
                why = "left the amplitude range";
                break;
            }
            let falling = xn[0] < self.scaled(self.last_point(&trace))[0];
            let draining = p.primary_share < primary;
            primary = p.primary_share;
            let inside =
                self.cont.tongue(&p, &self.omegas).is_some() || (by_fold && falling && draining);
            self.accept(&mut trace, *p, &xn, step);
            if !inside {
                why = "left the resonance";
                break;
            }
        }
        self.end_branch(id, why);
        id
    }

    /// Continues the main branch past a tongue by branch switching (docs/DESIGN.md §8.3), from
    /// its last point where q was still rising:
    /// 1. predictors on its local tangent at base 2^k ahead (k = 1..=5), each corrected on the
    ///    arc-length row there, kept when out of the tongue, ahead in q and near the predictor;
    /// 2. predictors on its secant over its last `PASS_SPAN` g_ref of q (its direction before the
    ///    interaction bent it: near a tongue the local tangent can turn toward the tongue, and
    ///    the row normal to it lets the corrector slide down the tongue to q -> 0), at base
    ///    1.5^k ahead (k = 1..=9), kept when near the predictor in (q, w) (across a tongue the
    ///    orbit's shape changes more than its amplitude and frequency);
    /// 3. as the last resort, fixed-q hops.
    ///
    /// A predictor's point is then filled back toward the tongue ([`Self::land_past`]).
    fn step_past(&mut self, main: &mut Trace) -> Option<Passage> {
        self.roll_back_to_ascent(main);
        let base = main.last_ds.max(PASS_BASE);
        let (from, secant) = self.pass_secant(main);
        let growing = (1..=SECANT_PASSES).map(|k| base * 1.5f64.powi(k as i32));
        if self.predict_past(main, Some(from), &secant, growing) {
            return Some(Passage::Predictor);
        }
        let tangent = main.tangent.clone();
        let doubling = (1..=TANGENT_PASSES).map(|k| base * f64::from(1u32 << k));
        if self.predict_past(main, None, &tangent, doubling) {
            return Some(Passage::Predictor);
        }
        if self.hop_past(main) {
            tracing::info!(
                q_over_g0 = self.last_point(main).q / self.g_ref,
                "no predictor got past the tongue: hopped ahead at fixed q"
            );
            return Some(Passage::FixedQHop);
        }
        None
    }

    /// Predictors along `direction` at the distances `steps` beyond the main branch's last
    /// point, each corrected on the arc-length row normal to `direction`; the first acceptable
    /// one is landed on ([`Self::land_past`]). `from`: the secant's first point (the guess is
    /// extrapolated along the secant and nearness judged in (q, w)), or None for the local
    /// tangent (the guess from the last two points, nearness in the whole scaled space).
    fn predict_past(
        &mut self,
        main: &mut Trace,
        from: Option<usize>,
        direction: &[f64],
        steps: impl Iterator<Item = f64>,
    ) -> bool {
        let xl = self.scaled(self.last_point(main));
        for step in steps {
            let pred: Vec<f64> = xl
                .iter()
                .zip(direction)
                .map(|(x, t)| x + step * t)
                .collect();
            if pred[0] >= self.cont.q_max {
                break;
            }
            let mut guesses = vec![match from {
                Some(f) => {
                    let span = distance(&xl, &self.scaled(&self.result.points[f]));
                    self.extrapolate_between(f, main, &pred, step / span)
                }
                None => self.extrapolate(main, &pred, step / main.last_ds),
            }];
            if from.is_some() {
                // Far from the branch the secant extrapolation of the orbit may be poor: the
                // last orbit scaled to the predicted amplitude is the second guess.
                guesses.push(self.scaled_guess(main, &pred));
            }
            for guess in guesses {
                let row = self.arc_row(direction, &pred);
                match self.solver.solve_with_row(row, guess) {
                    Ok(p) => {
                        let xn = self.scaled(&p);
                        let ahead = xn[0] > xl[0] && xn[0] <= self.cont.q_max;
                        let dims = if from.is_some() { 2 } else { xn.len() };
                        let near = distance(&xn[..dims], &pred[..dims]) <= step;
                        if ahead && near && self.cont.tongue(&p, &self.omegas).is_none() {
                            self.land_past(main, p, direction, &xl);
                            return true;
                        }
                        tracing::debug!(
                            q = p.q,
                            ahead,
                            near,
                            step,
                            "predictor past the tongue rejected"
                        );
                    }
                    Err(e) => {
                        tracing::debug!(step, error = %e, "predictor past the tongue failed")
                    }
                }
            }
        }
        false
    }

    /// Lands the main branch on `p` past a tongue, after filling the stretch between the tongue
    /// and `p`: the branch is traced backwards from `p` (against `direction`) until it comes
    /// within a step of `top` in (q, w) (the scaled last rising point before the tongue), turns
    /// in q, enters the tongue or stops, so
    /// that what the main branch is past the tongue does not depend on how far the predictor
    /// that found it reached. The filled points join the main branch in rising order.
    fn land_past(&mut self, main: &mut Trace, p: BackbonePoint, direction: &[f64], top: &[f64]) {
        let start = self.result.points.len();
        self.push(p, main.id);
        let mut back = Trace {
            id: main.id,
            points: vec![start],
            tangent: direction.iter().map(|t| -t).collect(),
            ds: self.cont.step.min(self.cont.max_step),
            last_ds: self.cont.step.min(self.cont.max_step),
            dq_sign: -1.0,
            // Not the pre-fold stretch after grazing (`accept` flags that on the main branch).
            folds: 1,
            penetrate: false,
        };
        for _ in 0..BACKFILL_POINTS {
            let (p, xn, step) = match self.advance(&mut back, false) {
                Advance::Retry => continue,
                Advance::Stuck(_) => break,
                Advance::Converged(p, xn, step) => (p, xn, step),
            };
            let xl = self.scaled(self.last_point(&back));
            let turns = xn[0] >= xl[0];
            let bridged = distance(&xn[..2], &top[..2]) <= step.max(PASS_BASE);
            if turns || bridged || xn[0] <= 0.0 || self.cont.tongue(&p, &self.omegas).is_some() {
                break;
            }
            self.accept(&mut back, *p, &xn, step);
        }
        // Reorder [p, b1, ..., bk] into [bk, ..., b1, p] (rising q) at the end of the points.
        let mut filled = self.result.points.split_off(start);
        filled.reverse();
        for f in &mut filled {
            f.fold = false;
        }
        let count = filled.len();
        self.result.points.extend(filled);
        main.points.extend(start..start + count);
        let n = main.points.len();
        let a = self.scaled(&self.result.points[main.points[n - 2]]);
        let b = self.scaled(&self.result.points[main.points[n - 1]]);
        let mut t: Vec<f64> = b.iter().zip(&a).map(|(x, y)| x - y).collect();
        let len = normalize(&mut t);
        main.tangent = if count > 1 { t } else { direction.to_vec() };
        main.last_ds = if count > 1 {
            len.max(1e-3)
        } else {
            self.cont.step
        };
        main.dq_sign = 1.0;
        main.ds = self.cont.step.min(self.cont.max_step);
        if count > 1 {
            tracing::info!(
                points = count - 1,
                q_over_g0 = self.result.points[start].q / self.g_ref,
                "main branch past the tongue filled back toward it"
            );
        }
    }

    /// The main-branch point about `PASS_SPAN` g_ref of q below its last point (or its first
    /// point) and the unit secant from it to the last point, in the scaled space.
    fn pass_secant(&self, main: &Trace) -> (usize, Vec<f64>) {
        let last = self.last_point(main);
        let q_from = last.q / self.g_ref - PASS_SPAN;
        let from = main.points[..main.points.len() - 1]
            .iter()
            .rev()
            .copied()
            .find(|&i| self.result.points[i].q / self.g_ref <= q_from)
            .unwrap_or(main.points[0]);
        let xl = self.scaled(last);
        let mut t: Vec<f64> = xl
            .iter()
            .zip(self.scaled(&self.result.points[from]))
            .map(|(a, b)| a - b)
            .collect();
        if normalize(&mut t) == 0.0 {
            return (from, main.tangent.clone());
        }
        (from, t)
    }

    /// Last resort past a tongue: fixed-q solves ahead of the last ascending point, at q + base
    /// 2^k g_ref (k < HOPS, the last at q_max), warm-started from it, then from the linear mode
    /// scaled to q (with the solver's penalty homotopy). The point reached is flagged as a jump
    /// (explained by the tongue recorded in `Backbone::internal_resonances`) and the branch is
    /// filled back from it toward the tongue ([`Self::land_past`]).
    fn hop_past(&mut self, main: &mut Trace) -> bool {
        let last = self.last_point(main).clone();
        let xl = self.scaled(&last);
        let base = main.last_ds.max(PASS_BASE);
        let mut previous = last.q / self.g_ref;
        for k in 0..HOPS {
            let q = (last.q / self.g_ref + base * f64::from(1u32 << k)).min(self.cont.q_max);
            if q <= previous {
                break;
            }
            previous = q;
            for start in [Start::Point(&last), Start::LinearMode(last.mode)] {
                match self.solver.solve_point(q * self.g_ref, start) {
                    Ok(mut p) if self.cont.tongue(&p, &self.omegas).is_none() => {
                        p.jump = true;
                        let mut along_q = vec![0.0; xl.len()];
                        along_q[0] = 1.0;
                        self.land_past(main, p, &along_q, &xl);
                        return true;
                    }
                    Ok(p) => tracing::debug!(q = p.q, "hop landed in a tongue"),
                    Err(e) => tracing::debug!(q, error = %e, "hop failed"),
                }
            }
        }
        false
    }

    /// A main branch may turn back in q as it enters a tongue, before the energy shares show it:
    /// continue past the tongue from the last point where q was still rising, along the secant
    /// that reached it (the points after it stay on the output, flagged by their fold).
    fn roll_back_to_ascent(&self, main: &mut Trace) {
        let pts = &main.points;
        let Some(top) = (1..pts.len())
            .rev()
            .find(|&i| self.result.points[pts[i]].q > self.result.points[pts[i - 1]].q)
        else {
            return;
        };
        if top + 1 == pts.len() {
            return;
        }
        let a = self.scaled(&self.result.points[pts[top - 1]]);
        let b = self.scaled(&self.result.points[pts[top]]);
        let mut t: Vec<f64> = b.iter().zip(&a).map(|(x, y)| x - y).collect();
        let len = normalize(&mut t);
        main.points.truncate(top + 1);
        main.tangent = t;
        main.last_ds = len.max(f64::MIN_POSITIVE);
        main.dq_sign = 1.0;
    }

    /// Scaled branch coordinates X = (q / g_ref, w / w_lin, y / (g_ref sqrt(c + 1))).
    fn scaled(&self, p: &BackbonePoint) -> Vec<f64> {
        let mut x = vec![p.q / self.g_ref, p.omega / self.w_lin];
        let scale = self.g_ref * self.y_norm;
        x.extend(self.kept_coordinates(p).iter().map(|y| y / scale));
        x
    }

    /// Kept coordinates of a point: A_j u_n (signal-major, j (N+1) + n) then e_master . u_n.
    fn kept_coordinates(&self, p: &BackbonePoint) -> Vec<f64> {
        let system = self.solver.system();
        let (c, nh) = (system.n_contacts(), self.solver.settings().terms());
        let mut y = vec![0.0; (c + 1) * nh];
        for (h, u) in p.coefficients.iter().enumerate().take(nh) {
            for j in 0..c {
                y[j * nh + h] = system.contact_displacement(j, u);
            }
            y[c * nh + h] = u[system.master()];
        }
        y
    }

    /// The pseudo-arc-length row t . (X - X_pred) = 0 in the solver's units.
    fn arc_row(&self, tangent: &[f64], pred: &[f64]) -> ParameterRow {
        let (g, y) = (self.g_ref, self.y_norm);
        ParameterRow {
            a_q: tangent[0],
            a_w: tangent[1],
            a_y: tangent[2..].iter().map(|t| t / y).collect(),
            q_p: pred[0] * g,
            w_p: pred[1] * self.w_lin,
            y_p: pred[2..].iter().map(|v| v * g * y).collect(),
            q_scale: g,
            w_scale: self.w_lin,
            y_scale: g,
        }
    }

    /// Warm start at a predictor: the branch's last orbit scaled to the predicted amplitude, at
    /// the predicted frequency.
    fn scaled_guess(&self, trace: &Trace, pred: &[f64]) -> Guess {
        let last = self.last_point(trace);
        let s = pred[0] * self.g_ref / last.q;
        let coefficients = last
            .coefficients
            .iter()
            .map(|c| c.iter().map(|v| v * s).collect())
            .collect();
        self.guess_at(last, coefficients, pred)
    }

    /// Warm start at a predictor: coefficients extrapolated along the secant from point `from`
    /// to the branch's last point (ratio = predicted step / secant length).
    fn extrapolate_between(&self, from: usize, trace: &Trace, pred: &[f64], ratio: f64) -> Guess {
        let last = self.last_point(trace);
        let prev = &self.result.points[from];
        let coefficients = last
            .coefficients
            .iter()
            .zip(&prev.coefficients)
            .map(|(a, b)| a.iter().zip(b).map(|(x, y)| x + ratio * (x - y)).collect())
            .collect();
        self.guess_at(last, coefficients, pred)
    }

    /// Warm start at the predictor: coefficients extrapolated along the secant of the branch's
    /// last two points (ratio = predicted step / last step), or the last orbit scaled to the
    /// predicted amplitude on a one-point branch; theta and kappa of the last point.
    fn extrapolate(&self, trace: &Trace, pred: &[f64], ratio: f64) -> Guess {
        let pts = &trace.points;
        if pts.len() >= 2 {
            self.extrapolate_between(pts[pts.len() - 2], trace, pred, ratio)
        } else {
            self.scaled_guess(trace, pred)
        }
    }

    /// The guess at predictor `pred` with `coefficients`, the mode and multipliers of `last`.
    fn guess_at(&self, last: &BackbonePoint, coefficients: Vec<Vec<f64>>, pred: &[f64]) -> Guess {
        Guess {
            mode: last.mode,
            coefficients,
            omega: pred[1] * self.w_lin,
            q: pred[0] * self.g_ref,
            multipliers: last.multipliers.clone(),
        }
    }
}

/// Euclidean distance.
fn distance(a: &[f64], b: &[f64]) -> f64 {
    a.iter()
        .zip(b)
        .map(|(x, y)| (x - y).powi(2))
        .sum::<f64>()
        .sqrt()
}

/// Normalizes `v` to unit length in place and returns its former length.
fn normalize(v: &mut [f64]) -> f64 {
    let len = v.iter().map(|x| x * x).sum::<f64>().sqrt();
    if len > 0.0 {
        v.iter_mut().for_each(|x| *x /= len);
    }
    len
}
