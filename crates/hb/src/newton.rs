//! Semi-smooth Newton solve of the inner problem, Eq. (20) in docs/DESIGN.md §3's physically consistent
//! reading, at fixed augmented-Lagrangian variables (theta, kappa):
//!
//! ```text
//! R_n = (K - (n w)^2 M) u_n + A^T lambda_n = 0,   n = 0..N
//! e_master . u_1 - q = 0                             (normalization, Sec. 2.6)
//! a_q (q - q_p)/q_s + a_w (w - w_p)/w_s + a_y . (y - y_p)/y_s = 0   (parameter row)
//! lambda_{j,k} = kappa_{j,k} max(0, g_j(t_k) + theta_{j,k})   (Eqs. 13-15)
//! ```
//!
//! Why the harmonic balance of the equations of motion and not the paper's printed Eq. (20): the
//! paper multiplies the linear part of harmonic n by 2 m(u_n, u_n)^-1, the gradient of the
//! Rayleigh quotient of Eq. (9) taken harmonic by harmonic. A contact force acting in time must enter
//! every harmonic with the same weight as the inertia and stiffness forces it balances, otherwise
//! the computed orbit does not satisfy M u'' + K u + A^T lambda = 0. We therefore solve the harmonic
//! balance of the equations of motion; at convergence of Algorithm 1 (G -> 0) the complementarity
//! conditions Eq. (12b) are the same (docs/DESIGN.md §3).
//!
//! Unknowns: the N + 1 coefficient vectors (in the coordinates of a [`LinearModel`]), w and q.
//! max(0, .) is piecewise linear, so Newton uses its generalized Jacobian: kappa on active samples,
//! 0 elsewhere; projected on the cosines it gives, per contact row, an (N+1) x (N+1) block
//! J_{n,n'} = D_{n+n'} + D_{|n-n'|} (n >= 1), J_{0,n'} = D_{n'} with
//! D_p = (1/m) sum_k kappa_k active_k cos(2 pi p k / m), one FFT per active contact row. The
//! derivative of the linear part with respect to w is -2 n^2 w M u_n. Globalization: backtracking
//! line search on the weighted residual norm (Armijo).

use serde::{Deserialize, Serialize};

use crate::contact::{apply_contact_law, Multipliers};
use crate::error::HbError;
use crate::fourier::Aft;
use crate::linear_model::{JacobianData, LinearModel, ParameterRow};

/// Settings of the inner semi-smooth Newton solver.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct NewtonSettings {
    /// Convergence when the weighted residual (square root of an energy, see below) divided by
    /// sqrt(K_mm) |q| is at most this (default 1e-10). Rows of harmonic equations are weighted by
    /// 1/sqrt(diagonal stiffness), so every term is the square root of an energy.
    pub tolerance: f64,
    /// Maximum Newton iterations per inner solve (default 50).
    pub max_iterations: usize,
    /// Maximum step halvings in the line search (default 30).
    pub max_halvings: usize,
    /// Exact condensation only: an "other" mode i stays an explicit unknown of harmonic n when
    /// |Lambda_i - (n w)^2| < window * Lambda_i (default 0.5), so that no pole of the Schur
    /// complement is ever divided by (see `condensation`).
    pub resonance_window: f64,
}

impl Default for NewtonSettings {
    fn default() -> Self {
        Self {
            tolerance: 1e-10,
            max_iterations: 50,
            max_halvings: 30,
            resonance_window: 0.5,
        }
    }
}

impl NewtonSettings {
    pub fn validate(&self) -> Result<(), HbError> {
        if !(self.tolerance > 0.0 && self.tolerance < 1.0) {
            return Err(HbError::InvalidParameter {
                name: "newton.tolerance",
                value: self.tolerance,
                expected: "0 < tolerance < 1",
            });
        }
        if self.max_iterations == 0 {
            return Err(HbError::InvalidParameter {
                name: "newton.max_iterations",
                value: 0.0,
                expected: ">= 1",
            });
        }
        if !(self.resonance_window > 0.0 && self.resonance_window < 1.0) {
            return Err(HbError::InvalidParameter {
                name: "newton.resonance_window",
                value: self.resonance_window,
                expected: "0 < window < 1",
            });
        }
        Ok(())
    }
}

/// Newton unknowns: coefficients (model coordinates, harmonic-major: x[n * d + i]), w, q.
#[derive(Clone, Debug)]
pub struct NewtonState {
    pub x: Vec<f64>,
    pub omega: f64,
    pub q: f64,
}

/// Residual and contact samples at one Newton iterate.
#[derive(Clone, Default)]
pub struct Evaluation {
    /// Contact coefficients A_j u_n, signal-major c x (N+1).
    pub coef: Vec<f64>,
    /// Gap samples g_{j,k} = A_j u(t_k) - g0_j, c x m.
    pub gaps: Vec<f64>,
    /// Contact force samples lambda_{j,k}, c x m.
    pub lambda: Vec<f64>,
    /// Slopes d lambda / d g, c x m.
    pub slope: Vec<f64>,
    /// Cosine coefficients of lambda, signal-major c x (N+1).
    pub lambda_coef: Vec<f64>,
    /// Residual: d (N+1) harmonic rows, then normalization, then parameter row.
    pub residual: Vec<f64>,
    /// Weighted residual norm (square root of an energy).
    pub merit: f64,
}

/// Buffers of the Newton loop, reused between solves.
#[derive(Default)]
pub struct NewtonWork {
    /// Newton iterations performed since creation, successful solves or not.
    pub spent: usize,
    pub current: Evaluation,
    trial: Evaluation,
    /// The latest Newton step (coefficients, dw, dq).
    step: Vec<f64>,
    /// The plain semi-smooth step of the iteration, kept while secant steps are tried.
    first_step: Vec<f64>,
    trial_x: Vec<f64>,
    /// Per-sample slopes d lambda / d g the next direction is computed with.
    slopes: Vec<f64>,
    direction: DirectionWork,
}

/// Buffers of the direction computations.
#[derive(Default)]
pub struct DirectionWork {
    active: Vec<usize>,
    slopes_active: Vec<f64>,
    moments: Vec<f64>,
    dcoef: Vec<f64>,
    dgap: Vec<f64>,
    arc_y: Vec<f64>,
}

/// Fixed data of an inner problem.
pub struct InnerProblem<'a> {
    /// Time samples per period m.
    pub samples: usize,
    pub g0: &'a [f64],
    pub multipliers: &'a Multipliers,
    pub row: &'a ParameterRow,
    /// sqrt(K_mm): scales the normalization row to sqrt(energy) units.
    pub norm_scale: f64,
    /// sqrt(K_mm) g_ref: scales the parameter row.
    pub arc_scale: f64,
    /// Smoothing width mu of the contact law (length); 0 = the exact law.
    pub smoothing: f64,
}

/// Outcome of a converged inner solve.
#[derive(Clone, Copy, Debug)]
pub struct NewtonReport {
    pub iterations: usize,
}

/// Residual of the inner problem at (x, w, q), written to `ev`: AFT of the contact coefficients,
/// the sampled law (Eqs. 13-15), back to cosine coefficients (Eq. 19), harmonic rows, the
/// normalization row and the parameter row, and the weighted merit.
fn evaluate(
    model: &mut dyn LinearModel,
    aft: &mut Aft,
    p: &InnerProblem<'_>,
    x: &[f64],
    omega: f64,
    q: f64,
    ev: &mut Evaluation,
) {
    let layout = model.layout();
    let (m, c, d) = (p.samples, p.g0.len(), layout.dim());
    let signals = layout.signals(c);
    ev.coef.resize(signals.len(), 0.0);
    ev.gaps.resize(c * m, 0.0);
    ev.lambda.resize(c * m, 0.0);
    ev.slope.resize(c * m, 0.0);
    ev.lambda_coef.resize(signals.len(), 0.0);
    ev.residual.resize(layout.newton_len(), 0.0);
    model.contact_coefficients(x, &mut ev.coef);
    aft.synthesize(&ev.coef, c, &mut ev.gaps);
    for (j, g0) in p.g0.iter().enumerate() {
        ev.gaps[j * m..(j + 1) * m]
            .iter_mut()
            .for_each(|g| *g -= g0);
    }
    apply_contact_law(
        &ev.gaps,
        p.multipliers,
        p.smoothing,
        &mut ev.lambda,
        &mut ev.slope,
    );
    aft.analyze(&ev.lambda, c, &mut ev.lambda_coef);
    let (rows, tail) = ev.residual.split_at_mut(layout.len());
    model.harmonic_residual(omega, x, &ev.lambda_coef, rows);
    let e = model.master_row();
    let dot = |v: &[f64]| -> f64 { e.iter().zip(v).map(|(a, b)| a * b).sum() };
    tail[0] = p.norm_scale * (dot(layout.harmonic(x, 1)) - q);
    let r = p.row;
    let mut arc = r.a_q * (q - r.q_p) / r.q_scale + r.a_w * (omega - r.w_p) / r.w_scale;
    if !r.a_y.is_empty() {
        let nh = layout.count();
        for h in 0..nh {
            arc += r.a_y[c * nh + h] * (dot(layout.harmonic(x, h)) - r.y_p[c * nh + h]) / r.y_scale;
        }
        for i in 0..signals.len() {
            arc += r.a_y[i] * (ev.coef[i] - r.y_p[i]) / r.y_scale;
        }
    }
    tail[1] = p.arc_scale * arc;
    let w = model.row_weights();
    let mut sum = 0.0;
    for block in rows.chunks(d) {
        for (r, wi) in block.iter().zip(w) {
            sum += (r * wi) * (r * wi);
        }
    }
    sum += tail[0].powi(2) + tail[1].powi(2);
    ev.merit = if sum.is_finite() {
        sum.sqrt()
    } else {
        f64::INFINITY
    };
}

/// Iterations over which the residual must at least halve.
const STAGNATION_WINDOW: usize = 5;

/// Number of secant-slope refinements of a rejected Newton step.
const SECANT_PASSES: usize = 4;

/// Which stored step a line search follows.
#[derive(Clone, Copy, PartialEq, Eq)]
enum StepKind {
    /// The latest direction (`NewtonWork::step`).
    Latest,
    /// The plain semi-smooth direction of this iteration (`NewtonWork::first_step`).
    First,
}

/// One inner solve in progress: the model, the transforms, the problem and the buffers that
/// every step of the semi-smooth Newton iteration uses.
pub struct NewtonSolve<'a, 'p> {
    pub model: &'a mut dyn LinearModel,
    pub aft: &'a mut Aft,
    pub problem: &'a InnerProblem<'p>,
    pub settings: &'a NewtonSettings,
    pub work: &'a mut NewtonWork,
}

impl NewtonSolve<'_, '_> {
    /// Evaluates the residual at `state` into `work.current`.
    fn evaluate_current(&mut self, state: &NewtonState) {
        evaluate(
            self.model,
            self.aft,
            self.problem,
            &state.x,
            state.omega,
            state.q,
            &mut self.work.current,
        );
    }

    /// Newton direction J step = -R at `state` for the per-sample slopes `work.slopes`
    /// (d lambda / d g, c x m), written to `work.step`.
    fn direction(&mut self, state: &NewtonState) -> Result<(), HbError> {
        let p = self.problem;
        let layout = self.model.layout();
        let (m, np, c) = (p.samples, layout.moments(), p.g0.len());
        let (w, slopes) = (&mut self.work.direction, &self.work.slopes);
        w.active.clear();
        w.active
            .extend((0..c).filter(|&j| slopes[j * m..(j + 1) * m].iter().any(|&s| s > 0.0)));
        w.slopes_active.clear();
        for &j in &w.active {
            w.slopes_active
                .extend_from_slice(&slopes[j * m..(j + 1) * m]);
        }
        w.moments.resize(w.active.len() * np, 0.0);
        self.aft
            .cosine_moments(&w.slopes_active, w.active.len(), &mut w.moments);
        let step = &mut self.work.step;
        step.clear();
        step.extend(self.work.current.residual.iter().map(|r| -r));
        let r = p.row;
        w.arc_y.clear();
        w.arc_y
            .extend(r.a_y.iter().map(|a| p.arc_scale * a / r.y_scale));
        let jac = JacobianData {
            omega: state.omega,
            x: &state.x,
            active: &w.active,
            moments: &w.moments,
            norm_scale: p.norm_scale,
            arc_w: p.arc_scale * r.a_w / r.w_scale,
            arc_q: p.arc_scale * r.a_q / r.q_scale,
            arc_y: &w.arc_y,
        };
        self.model.solve_step(&jac, step)?;
        if step.iter().any(|v| !v.is_finite()) {
            return Err(HbError::Decomposition {
                what: "Newton step",
                detail: "non-finite step (singular Newton matrix)".to_string(),
            });
        }
        Ok(())
    }

    /// Secant slopes along `work.step`: for each sample, kappa times the fraction of the segment
    /// [s, s + ds] (s = g + theta) on which the sample is in contact, so that the linear model of
    /// lambda is exact at the end of the step. Returns how many samples changed slope.
    fn secant_slopes(&mut self) -> usize {
        let p = self.problem;
        let layout = self.model.layout();
        let (m, c) = (p.samples, p.g0.len());
        let w = &mut self.work.direction;
        w.dcoef.resize(layout.signals(c).len(), 0.0);
        w.dgap.resize(c * m, 0.0);
        self.model
            .contact_coefficients(&self.work.step, &mut w.dcoef);
        self.aft.synthesize(&w.dcoef, c, &mut w.dgap);
        let gaps = &self.work.current.gaps;
        let mut changed = 0;
        for (i, slope) in self.work.slopes.iter_mut().enumerate().take(c * m) {
            let s0 = gaps[i] + p.multipliers.theta[i];
            let s1 = s0 + w.dgap[i];
            let fraction = if s0 > 0.0 && s1 >= 0.0 {
                1.0
            } else if s0 <= 0.0 && s1 <= 0.0 {
                0.0
            } else if s0 > 0.0 {
                s0 / (s0 - s1)
            } else {
                s1 / (s1 - s0)
            };
            let new = p.multipliers.kappa[i] * fraction;
            if new != *slope {
                changed += 1;
            }
            *slope = new;
        }
        changed
    }

    /// Line search along a stored step: the full step only, or backtracking by halvings (Armijo
    /// on the merit). On success `state` and `work.current` move to the accepted point.
    fn line_search(&mut self, state: &mut NewtonState, kind: StepKind, backtrack: bool) -> bool {
        let work = &mut *self.work;
        let step = match kind {
            StepKind::Latest => &work.step,
            StepKind::First => &work.first_step,
        };
        let len = step.len();
        let merit0 = work.current.merit;
        let mut alpha = 1.0;
        let halvings = if backtrack {
            self.settings.max_halvings
        } else {
            0
        };
        for _ in 0..=halvings {
            let omega = state.omega + alpha * step[len - 2];
            if omega > 0.0 {
                let q = state.q + alpha * step[len - 1];
                work.trial_x.clear();
                work.trial_x
                    .extend(state.x.iter().zip(step).map(|(x, s)| x + alpha * s));
                evaluate(
                    self.model,
                    self.aft,
                    self.problem,
                    &work.trial_x,
                    omega,
                    q,
                    &mut work.trial,
                );
                if work.trial.merit <= (1.0 - 1e-4 * alpha) * merit0 {
                    std::mem::swap(&mut state.x, &mut work.trial_x);
                    state.omega = omega;
                    state.q = q;
                    std::mem::swap(&mut work.current, &mut work.trial);
                    return true;
                }
            }
            alpha *= 0.5;
        }
        false
    }

    /// After the full semi-smooth step was rejected: recompute the step with secant slopes (a few
    /// passes, each tried as a full step). Returns whether a step was accepted.
    fn secant_refinement(&mut self, state: &mut NewtonState) -> Result<bool, HbError> {
        self.work.first_step.clone_from(&self.work.step);
        for pass in 0..SECANT_PASSES {
            if self.secant_slopes() == 0 && pass > 0 {
                break;
            }
            self.direction(state)?;
            if self.line_search(state, StepKind::Latest, false) {
                return Ok(true);
            }
        }
        Ok(false)
    }

    /// One Newton iteration from `state`: the semi-smooth step, then (exact law) secant steps,
    /// then backtracking along the last step and along the plain one. Returns whether a step
    /// decreased the merit.
    fn iterate(&mut self, state: &mut NewtonState) -> Result<bool, HbError> {
        self.work.slopes.clone_from(&self.work.current.slope);
        self.direction(state)?;
        if self.line_search(state, StepKind::Latest, false) {
            return Ok(true);
        }
        if self.problem.smoothing > 0.0 {
            return Ok(self.line_search(state, StepKind::Latest, true));
        }
        if self.secant_refinement(state)? {
            return Ok(true);
        }
        Ok(self.line_search(state, StepKind::Latest, true)
            || self.line_search(state, StepKind::First, true))
    }

    /// Solves the inner problem from `state` (updated in place). On success `work.current` holds
    /// the gap and force samples of the solution.
    ///
    /// Each iteration takes the semi-smooth Newton step; if the full step does not decrease the
    /// residual (typically a sample changing contact state within the step, where the one-sided
    /// generalized Jacobian mispredicts and can even fail to give a descent direction at a kink),
    /// the step is recomputed with secant slopes, a few passes, before backtracking.
    pub fn run(&mut self, state: &mut NewtonState) -> Result<NewtonReport, HbError> {
        self.evaluate_current(state);
        let mut iterations = 0;
        let mut history: Vec<f64> = Vec::new();
        loop {
            let reference = self.problem.norm_scale * state.q.abs().max(f64::MIN_POSITIVE);
            let rel = self.work.current.merit / reference;
            let tolerance = self.settings.tolerance;
            let fail = |reason: String, iterations: usize| HbError::NewtonFailed {
                iterations,
                residual: rel,
                tolerance,
                reason,
            };
            if !rel.is_finite() {
                return Err(fail("non-finite residual".to_string(), iterations));
            }
            if rel <= tolerance {
                return Ok(NewtonReport { iterations });
            }
            if iterations >= self.settings.max_iterations {
                return Err(fail(
                    "maximum number of iterations reached".to_string(),
                    iterations,
                ));
            }
            // Stagnation: a semi-smooth Newton that converges does so fast; five iterations that
            // do not halve the residual mean it is cycling between contact states.
            history.push(self.work.current.merit);
            if history.len() > STAGNATION_WINDOW
                && self.work.current.merit > 0.5 * history[history.len() - 1 - STAGNATION_WINDOW]
            {
                return Err(fail(
                    "stagnation (residual not halved in 5 iterations)".to_string(),
                    iterations,
                ));
            }
            iterations += 1;
            self.work.spent += 1;
            match self.iterate(state) {
                Ok(true) => {}
                Ok(false) => {
                    return Err(fail(
                        "line search found no decrease of the residual".to_string(),
                        iterations,
                    ))
                }
                Err(e) => return Err(fail(e.to_string(), iterations)),
            }
        }
    }
}

/// Solves the inner problem from `state` (see [`NewtonSolve::run`]).
pub fn solve_inner(
    model: &mut dyn LinearModel,
    aft: &mut Aft,
    problem: &InnerProblem<'_>,
    settings: &NewtonSettings,
    state: &mut NewtonState,
    work: &mut NewtonWork,
) -> Result<NewtonReport, HbError> {
    NewtonSolve {
        model,
        aft,
        problem,
        settings,
        work,
    }
    .run(state)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::condensed_newton::CondensedModel;
    use crate::fourier::HarmonicSettings;
    use crate::full::FullModel;
    use crate::system::System;
    use faer::Mat;

    /// Deterministic pseudo-random numbers in [-1, 1].
    fn noise(i: usize) -> f64 {
        ((i as f64 * 12.9898).sin() * 43758.5453).fract() * 2.0 - 1.0
    }

    fn chain() -> System {
        let n = 6;
        let m = Mat::from_fn(n, n, |i, j| if i == j { 1.0 + 0.1 * i as f64 } else { 0.0 });
        let k = Mat::from_fn(n, n, |i, j| {
            if i == j {
                if i + 1 < n {
                    2.0
                } else {
                    1.0
                }
            } else if i.abs_diff(j) == 1 {
                -1.0
            } else {
                0.0
            }
        });
        let a = Mat::from_fn(2, n, |r, c| match (r, c) {
            (0, 5) => 1.0,
            (1, 2) => 0.8,
            (1, 3) => 0.6,
            _ => 0.0,
        });
        System::new(m, k, a, vec![0.3, 0.2], 0).expect("chain")
    }

    /// Newton direction check: with the smoothed (C^1) law, R(x + e d) = (1 - e) R(x) + O(e^2) if
    /// the Jacobian is exact. Returns the direction (physical coordinates, w, q).
    fn direction(model: &mut dyn LinearModel, sys: &System, smoothing: f64) -> Vec<f64> {
        let settings = HarmonicSettings::new(6, 64).expect("settings");
        let mut aft = Aft::new(settings);
        let (nh, m, n) = (7, 64, sys.n_dofs());
        let mut mult = Multipliers::uniform(&[3.0, 2.0], m);
        mult.theta
            .iter_mut()
            .enumerate()
            .for_each(|(i, t)| *t = 0.05 * noise(i).max(0.0));
        let c = sys.n_contacts();
        let a_y: Vec<f64> = (0..(c + 1) * nh).map(|i| 0.2 * noise(100 + i)).collect();
        let y_p: Vec<f64> = (0..(c + 1) * nh).map(|i| 0.1 * noise(200 + i)).collect();
        let w1 = sys.linear_frequencies()[0];
        let row = ParameterRow {
            a_q: 0.6,
            a_w: 0.5,
            a_y,
            q_p: 0.4,
            w_p: 1.05 * w1,
            y_p,
            q_scale: 0.25,
            w_scale: w1,
            y_scale: 0.25,
        };
        let p = InnerProblem {
            samples: m,
            g0: sys.gaps(),
            multipliers: &mult,
            row: &row,
            norm_scale: 1.3,
            arc_scale: 0.7,
            smoothing,
        };
        let d = model.dim();
        let mut x = vec![0.0; d * nh];
        let u: Vec<f64> = (0..n * nh)
            .map(|i| 0.3 * noise(i) / (1 + (i / n) * (i / n)) as f64)
            .collect();
        model.physical_to_model(&u, nh, &mut x);
        let state = NewtonState {
            x,
            omega: 1.1 * w1,
            q: 0.35,
        };
        let mut ev = Evaluation::default();
        evaluate(model, &mut aft, &p, &state.x, state.omega, state.q, &mut ev);
        assert!(
            ev.slope.iter().filter(|&&s| s > 0.0).count() > 10,
            "some samples in contact"
        );
        let settings = NewtonSettings::default();
        let mut work = NewtonWork::default();
        let step = {
            let mut solve = NewtonSolve {
                model: &mut *model,
                aft: &mut aft,
                problem: &p,
                settings: &settings,
                work: &mut work,
            };
            solve.evaluate_current(&state);
            solve.work.slopes.clone_from(&ev.slope);
            solve.direction(&state).expect("direction");
            solve.work.step.clone()
        };
        // Remainder of the linearization along d, relative to e |R|, for two step lengths: it must
        // be O(e) (halving with e down to round-off); an error in the Jacobian would leave an O(1)
        // mismatch independent of e.
        let len = step.len();
        let scale = ev.residual.iter().fold(0.0_f64, |a, r| a.max(r.abs()));
        let mut remainder = |eps: f64| {
            let xt: Vec<f64> = state
                .x
                .iter()
                .zip(&step)
                .map(|(a, b)| a + eps * b)
                .collect();
            let mut ev2 = Evaluation::default();
            let (wt, qt) = (
                state.omega + eps * step[len - 2],
                state.q + eps * step[len - 1],
            );
            evaluate(model, &mut aft, &p, &xt, wt, qt, &mut ev2);
            let err = ev
                .residual
                .iter()
                .zip(&ev2.residual)
                .fold(0.0_f64, |a, (r0, r1)| a.max((r1 - (1.0 - eps) * r0).abs()));
            err / (eps * scale)
        };
        let (r1, r2) = (remainder(1e-4), remainder(1e-5));
        assert!(r1 < 0.1, "linearization off by {r1} at e = 1e-4");
        assert!(
            r2 < 0.2 * r1 || r2 < 1e-7,
            "remainder not O(e): {r1:e} -> {r2:e}"
        );
        let mut out = vec![0.0; n * nh];
        model.model_to_physical(&step[..d * nh], nh, &mut out);
        out.extend_from_slice(&step[len - 2..]);
        out
    }

    #[test]
    fn newton_directions_are_exact_and_identical_in_both_models() {
        let sys = chain();
        // The smoothed law (mu = 0.02, about 10 % of the gaps) is C^1, so the directional check
        // is clean; the exact law has the same Jacobian away from the kinks.
        let smoothing = 0.02;
        let mut full = FullModel::new(&sys, 6);
        let df = direction(&mut full, &sys, smoothing);
        // window 0.9: many "other" modes are kept near resonance, exercising that path
        for window in [0.5, 0.9] {
            let mut cond = CondensedModel::new(&sys, window, 6).expect("condensed");
            let dc = direction(&mut cond, &sys, smoothing);
            let scale = df.iter().fold(0.0_f64, |a, v| a.max(v.abs()));
            // Same linear system solved two ways (dense, and two-level elimination): agreement
            // to round-off amplified by the conditioning (~1e4 here).
            for (a, b) in df.iter().zip(&dc) {
                assert!((a - b).abs() <= 1e-9 * scale, "{a} vs {b}");
            }
        }
    }
}
