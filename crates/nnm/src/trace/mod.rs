//! [`backbone`] and the continuation engine behind it (docs/DESIGN.md §8): a [`Continuation`]
//! owns the solver and the growing [`Backbone`]; each branch being traced is a [`Trace`] (its
//! points, unit tangent and step), advanced by predict / correct / accept (`step`). The main
//! branch meets tongues and corners (`tongue`) and is continued past them (`passage`).

mod passage;
mod step;
mod tongue;

use crate::continuation::{
    Backbone, Branch, BranchKind, ContinuationSettings, InternalResonance, Termination,
};
use crate::point::BackbonePoint;
use crate::solver::{Solver, Start};
use crate::NnmError;
use nlmodes_hb::fourier::HarmonicSettings;
use nlmodes_hb::solver_settings::SolverSettings;
use nlmodes_hb::system::System;

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
    /// The q interval the last passage past a tongue left unjoined and why (`land_past`).
    unjoined: Option<([f64; 2], String)>,
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
            unjoined: None,
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

    fn last_point(&self, trace: &Trace) -> &BackbonePoint {
        &self.result.points[trace.points[trace.points.len() - 1]]
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
