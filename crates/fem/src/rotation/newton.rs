//! The Newton iterations of one load step of the static centrifugal solve (DESIGN §9,
//! [`crate::rotation::static_solve`]): r(u) = f_int(u) - f_c(u, Omega) = 0 on the free DOFs.
//!
//! Two kinds of correction du, u <- u + du:
//! - a **Newton step**: K_T(u) du = -r(u), the tangent assembled at u and factorized (on the
//!   default blade, 93k DOFs: assembly with the residual about 0.9 s, factorization about 1 s);
//! - a **chord step**: K_old du = -r(u) on the factor the solver kept from its last
//!   factorization ([`LinearSolver::solve_with_last_factor`]: the tangent of an earlier iterate
//!   of this step), with the residual alone evaluated (on the blade 0.13 s CPU against 0.87 s
//!   for the residual with the tangent, `crates/fem/examples/bench_rotation.rs`).
//!
//! The error of a chord step contracts by I - K_old^-1 K_T(u): near the solution and with a
//! tangent of a nearby state the contraction is small, and a chord step costs a fraction of a
//! Newton step. The rule: the first correction is a Newton step; then a chord step is tried on
//! its factor; a chord step is kept when it reduces the residual norm at least by
//! [`CHORD_RATE`], and chord steps follow while they do; otherwise it is undone, a Newton step
//! is taken from the state before it, and chord steps are tried again on its fresh factor.
//! The converged state's tangent is assembled at the end (the stiffness at speed, the same
//! bits as [`crate::rotation::RotatingModel::stiffness_at_speed`]). A solver that keeps no
//! factor (MPI) makes every step a Newton step: the iterations of plain Newton.
//!
//! Convergence criterion and divergence test: [`crate::rotation::NewtonOptions`] (the limit
//! on iterations counts Newton steps; chord steps are bounded by [`MAX_CHORD_STEPS_PER_NEWTON`]
//! times it).

use sprs::CsMat;

use nlmodes_sparse::LinearSolver;

use crate::rotation::error::{NewtonIteration, StopReason};
use crate::rotation::model::RotatingModel;
use crate::rotation::static_solve::NewtonOptions;

/// A chord step is kept when it gains at least a digit, ||r_new|| <= CHORD_RATE ||r||;
/// otherwise it is undone and a Newton step is taken from the state before it. A chord step
/// costs about a fifth of a Newton step on the blade (the residual alone and two triangular
/// solves, against the assembly of the tangent and its factorization), so a digit per chord
/// step is worth it; a slower one, far from the solution, has reduced the stiff components of
/// the residual while the soft modes' error may have grown (measured on the blade at 4000 rpm
/// from rest: a Newton step after a kept chord step of ratio 0.3 gained one digit instead of
/// three).
pub const CHORD_RATE: f64 = 0.1;

/// Chord steps allowed per allowed Newton step (a safeguard: each kept chord step gains a
/// digit).
pub const MAX_CHORD_STEPS_PER_NEWTON: usize = 4;

/// A Newton solve's history and converged tangent, or why it stopped with the history so far.
pub type NewtonOutcome =
    Result<(Vec<NewtonIteration>, CsMat<f64>), (StopReason, Vec<NewtonIteration>)>;

/// A state of the iteration: the free displacement (m), its residual (N), the norms, and the
/// tangent there (N/m) when it was assembled with the residual.
struct Iterate {
    u: Vec<f64>,
    residual: Vec<f64>,
    residual_norm: f64,
    load_norm: f64,
    tangent: Option<CsMat<f64>>,
}

/// The iterations of one load step at one speed.
struct NewtonStep<'a, 'm> {
    model: &'a RotatingModel<'m>,
    omega: f64,
    options: &'a NewtonOptions,
    history: Vec<NewtonIteration>,
    newton_steps: usize,
    chord_steps: usize,
    /// Residual norm at the start of the step (N), for the divergence test.
    initial: f64,
}

fn norm(v: &[f64]) -> f64 {
    v.iter().map(|x| x * x).sum::<f64>().sqrt()
}

impl RotatingModel<'_> {
    /// Newton and chord iterations at speed `omega` from `u` (updated in place) (module docs);
    /// the history and the tangent at the converged `u`, or why it stopped with the history.
    pub(crate) fn newton_step(
        &self,
        omega: f64,
        u: &mut [f64],
        options: &NewtonOptions,
        solver: &mut dyn LinearSolver,
    ) -> NewtonOutcome {
        let mut step = NewtonStep {
            model: self,
            omega,
            options,
            history: Vec::new(),
            newton_steps: 0,
            chord_steps: 0,
            initial: 0.0,
        };
        let result = step.run(u.to_vec(), solver);
        match result {
            Ok((state, tangent)) => {
                u.copy_from_slice(&state.u);
                Ok((step.history, tangent))
            }
            Err(reason) => Err((reason, step.history)),
        }
    }
}

impl NewtonStep<'_, '_> {
    /// Iterates from `u0` to convergence: the converged state and its tangent.
    fn run(
        &mut self,
        u0: Vec<f64>,
        solver: &mut dyn LinearSolver,
    ) -> Result<(Iterate, CsMat<f64>), StopReason> {
        // With the tangent: the first correction is a Newton step (below).
        let mut state = self.evaluate_with_tangent(u0)?;
        self.record(&state, None, false);
        self.initial = state.residual_norm;
        // A Newton step first: a factor kept from another speed has the soft modes' stiffness
        // of that speed, and a chord step on it cuts the residual (the stiff components) while
        // the soft modes' error contracts slowly (measured on the blade's march: after such a
        // step the Newton step gained one digit instead of four).
        let mut try_chord = false;
        loop {
            if self.converged(&state) {
                return self.finish(state);
            }
            if try_chord && self.chord_steps < self.max_chord_steps() {
                if let Some(next) = self.chord(&state, solver) {
                    state = next;
                    continue;
                }
            }
            // A Newton step; a chord step is tried again on its fresh factor.
            state = self.newton(state, solver)?;
            try_chord = true;
        }
    }

    fn max_chord_steps(&self) -> usize {
        MAX_CHORD_STEPS_PER_NEWTON * self.options.max_iterations
    }

    /// The residual at `u` (no tangent).
    fn evaluate(&self, u: Vec<f64>) -> Result<Iterate, StopReason> {
        let (residual, load) = self
            .model
            .residual(self.omega, &u)
            .map_err(|e| StopReason::SingularTangent(e.to_string()))?;
        Self::iterate(u, residual, &load, None)
    }

    /// The residual and the tangent at `u`.
    fn evaluate_with_tangent(&self, u: Vec<f64>) -> Result<Iterate, StopReason> {
        let rt = self
            .model
            .residual_and_tangent(self.omega, &u)
            .map_err(|e| StopReason::SingularTangent(e.to_string()))?;
        Self::iterate(u, rt.residual, &rt.load, Some(rt.tangent))
    }

    fn iterate(
        u: Vec<f64>,
        residual: Vec<f64>,
        load: &[f64],
        tangent: Option<CsMat<f64>>,
    ) -> Result<Iterate, StopReason> {
        let (residual_norm, load_norm) = (norm(&residual), norm(load));
        if !residual_norm.is_finite() {
            return Err(StopReason::NonFinite);
        }
        Ok(Iterate {
            u,
            residual,
            residual_norm,
            load_norm,
            tangent,
        })
    }

    fn converged(&self, state: &Iterate) -> bool {
        state.residual_norm <= self.options.relative_tolerance * state.load_norm
    }

    fn record(&mut self, state: &Iterate, correction: Option<f64>, chord: bool) {
        self.history.push(NewtonIteration {
            iteration: self.history.len(),
            residual_norm: state.residual_norm,
            load_norm: state.load_norm,
            correction_norm: correction,
            chord,
        });
    }

    /// A chord step from `state`: the kept state, or `None` when the solver keeps no factor,
    /// the solve fails or the step is too slow (undone).
    fn chord(&mut self, state: &Iterate, solver: &mut dyn LinearSolver) -> Option<Iterate> {
        let rhs: Vec<f64> = state.residual.iter().map(|r| -r).collect();
        let du = solver.solve_with_last_factor(&rhs)?.ok()?;
        self.chord_steps += 1;
        let u: Vec<f64> = state.u.iter().zip(&du).map(|(a, d)| a + d).collect();
        let next = self.evaluate(u).ok()?;
        if next.residual_norm > CHORD_RATE * state.residual_norm {
            return None;
        }
        self.record(&next, Some(norm(&du)), true);
        Some(next)
    }

    /// A Newton step from `state`: the tangent at its u (assembled unless it is known) solved.
    fn newton(
        &mut self,
        state: Iterate,
        solver: &mut dyn LinearSolver,
    ) -> Result<Iterate, StopReason> {
        if self.newton_steps == self.options.max_iterations {
            return Err(StopReason::MaxIterations {
                iterations: self.options.max_iterations,
                residual: state.residual_norm,
                tolerance: self.options.relative_tolerance * state.load_norm,
            });
        }
        self.newton_steps += 1;
        let (state, tangent) = self.with_tangent(state)?;
        let rhs: Vec<f64> = state.residual.iter().map(|r| -r).collect();
        let du = solver
            .solve(&tangent, &rhs)
            .map_err(|e| StopReason::SingularTangent(e.0))?;
        let u = state.u.iter().zip(&du).map(|(a, d)| a + d).collect();
        let next = self.evaluate(u)?;
        self.record(&next, Some(norm(&du)), false);
        if next.residual_norm > self.options.divergence_factor * self.initial {
            return Err(StopReason::Diverged {
                residual: next.residual_norm,
                initial: self.initial,
                factor: self.options.divergence_factor,
            });
        }
        Ok(next)
    }

    /// The converged state with its tangent K_T(u) - Omega^2 M_spin (assembled unless known).
    fn finish(&mut self, state: Iterate) -> Result<(Iterate, CsMat<f64>), StopReason> {
        self.with_tangent(state)
    }

    /// `state` and the tangent at its u: the one assembled with its residual, or assembled now
    /// (the residual is the same, bit for bit).
    fn with_tangent(&self, mut state: Iterate) -> Result<(Iterate, CsMat<f64>), StopReason> {
        if let Some(tangent) = state.tangent.take() {
            return Ok((state, tangent));
        }
        let rt = self
            .model
            .residual_and_tangent(self.omega, &state.u)
            .map_err(|e| StopReason::SingularTangent(e.to_string()))?;
        Ok((state, rt.tangent))
    }
}
