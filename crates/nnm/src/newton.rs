//! Semi-smooth Newton solve of the inner problem, Eq. (20) in DESIGN 3's physically consistent
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
//! conditions Eq. (12b) are the same (DESIGN 3).
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
use crate::error::NnmError;
use crate::fourier::Aft;

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
    pub(crate) fn validate(&self) -> Result<(), NnmError> {
        if !(self.tolerance > 0.0 && self.tolerance < 1.0) {
            return Err(NnmError::InvalidParameter {
                name: "newton.tolerance",
                value: self.tolerance,
                expected: "0 < tolerance < 1",
            });
        }
        if self.max_iterations == 0 {
            return Err(NnmError::InvalidParameter {
                name: "newton.max_iterations",
                value: 0.0,
                expected: ">= 1",
            });
        }
        if !(self.resonance_window > 0.0 && self.resonance_window < 1.0) {
            return Err(NnmError::InvalidParameter {
                name: "newton.resonance_window",
                value: self.resonance_window,
                expected: "0 < window < 1",
            });
        }
        Ok(())
    }
}

/// The parameter row a_q (q - q_p)/q_s + a_w (w - w_p)/w_s + a_y . (y - y_p)/y_s = 0.
///
/// y are the kept coordinates of every harmonic: the contact coefficients A_j u_n (layout
/// j (N+1) + n) followed by the master coefficients e . u_n (layout c (N+1) + n). Fixed q:
/// a_q = 1, everything else 0 (a_y empty). Pseudo-arc-length: (a_q, a_w, a_y) is the unit tangent
/// of the branch in the scaled space (q / g_ref, w / w_lin, y / (g_ref sqrt(c + 1))).
#[derive(Clone, Debug)]
pub(crate) struct ParameterRow {
    pub a_q: f64,
    pub a_w: f64,
    pub a_y: Vec<f64>,
    pub q_p: f64,
    pub w_p: f64,
    pub y_p: Vec<f64>,
    pub q_scale: f64,
    pub w_scale: f64,
    pub y_scale: f64,
}

impl ParameterRow {
    pub fn fixed_amplitude(q: f64, q_scale: f64, w_scale: f64) -> Self {
        Self {
            a_q: 1.0,
            a_w: 0.0,
            a_y: Vec::new(),
            q_p: q,
            w_p: 0.0,
            y_p: Vec::new(),
            q_scale,
            w_scale,
            y_scale: 1.0,
        }
    }
}

/// Newton unknowns: coefficients (model coordinates, harmonic-major: x[n * d + i]), w, q.
#[derive(Clone, Debug)]
pub(crate) struct NewtonState {
    pub x: Vec<f64>,
    pub omega: f64,
    pub q: f64,
}

/// What a Jacobian solve needs besides the model's own data.
pub(crate) struct JacobianData<'a> {
    pub harmonics: usize,
    pub omega: f64,
    pub x: &'a [f64],
    /// Contact rows with at least one active sample.
    pub active: &'a [usize],
    /// Cosine moments D_p (p = 0..=2N) of kappa * active, one block of 2N + 1 per active row.
    pub moments: &'a [f64],
    /// d R_norm / d(e . u_1) (and minus d R_norm / dq).
    pub norm_scale: f64,
    /// d R_arc / dw.
    pub arc_w: f64,
    /// d R_arc / dq.
    pub arc_q: f64,
    /// d R_arc / dy (layout of [`ParameterRow`]; empty when the row does not involve y).
    pub arc_y: &'a [f64],
}

/// Contact Jacobian entry J_{n,n'} of one contact row from its cosine moments (see module docs).
#[inline]
pub(crate) fn contact_jacobian(moments: &[f64], n: usize, np: usize) -> f64 {
    if n == 0 {
        moments[np]
    } else {
        moments[n + np] + moments[n.abs_diff(np)]
    }
}

/// The linear part of Eq. (20) in some coordinates (physical, or the exact condensation).
pub(crate) trait LinearModel {
    /// Coordinates per harmonic d.
    fn dim(&self) -> usize;
    /// Contact coefficients A_j u_n -> `out[j * (N+1) + n]`.
    fn contact_coefficients(&self, x: &[f64], harmonics: usize, out: &mut [f64]);
    /// e_master in model coordinates (length d).
    fn master_row(&self) -> &[f64];
    /// Harmonic rows (K - (n w)^2 M) x_n + A^T lambda_n, `lambda_coef[j * (N+1) + n]`.
    fn harmonic_residual(
        &mut self,
        omega: f64,
        x: &[f64],
        harmonics: usize,
        lambda_coef: &[f64],
        out: &mut [f64],
    );
    /// Merit weights of the harmonic rows (1 / sqrt(diagonal stiffness)), length d.
    fn row_weights(&self) -> &[f64];
    /// Solves J step = rhs in place (`rhs` has d (N+1) + 2 entries: harmonic rows, norm, arc).
    fn solve_step(&mut self, jac: &JacobianData<'_>, rhs: &mut [f64]) -> Result<(), NnmError>;
    /// Physical coefficient vectors of `count` harmonics (n x count, column-major) from model
    /// coordinates (d x count).
    fn model_to_physical(&self, x: &[f64], count: usize, u: &mut [f64]);
    /// Model coordinates (d x count) of `count` physical coefficient vectors (n x count).
    fn physical_to_model(&self, u: &[f64], count: usize, x: &mut [f64]);
}

/// Residual and contact samples at one Newton iterate.
#[derive(Clone, Default)]
pub(crate) struct Evaluation {
    /// Contact coefficients, c x (N+1).
    pub coef: Vec<f64>,
    /// Gap samples g_{j,k} = A_j u(t_k) - g0_j, c x m.
    pub gaps: Vec<f64>,
    /// Contact force samples lambda_{j,k}, c x m.
    pub lambda: Vec<f64>,
    /// Slopes d lambda / d g, c x m.
    pub slope: Vec<f64>,
    /// Cosine coefficients of lambda, c x (N+1).
    pub lambda_coef: Vec<f64>,
    /// Residual: d (N+1) harmonic rows, then normalization, then parameter row.
    pub residual: Vec<f64>,
    /// Weighted residual norm (square root of an energy).
    pub merit: f64,
}

/// Buffers of the Newton loop, reused between solves.
#[derive(Default)]
pub(crate) struct NewtonWork {
    /// Newton iterations performed since creation, successful solves or not.
    pub spent: usize,
    pub current: Evaluation,
    trial: Evaluation,
    step: Vec<f64>,
    first_step: Vec<f64>,
    trial_x: Vec<f64>,
    slopes: Vec<f64>,
    direction: DirectionWork,
}

/// Fixed data of an inner problem.
pub(crate) struct InnerProblem<'a> {
    pub harmonics: usize,
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
pub(crate) struct NewtonReport {
    pub iterations: usize,
}

fn evaluate(
    model: &mut dyn LinearModel,
    aft: &mut Aft,
    p: &InnerProblem<'_>,
    x: &[f64],
    omega: f64,
    q: f64,
    ev: &mut Evaluation,
) {
    let (nh, m, c, d) = (p.harmonics + 1, p.samples, p.g0.len(), model.dim());
    ev.coef.resize(c * nh, 0.0);
    ev.gaps.resize(c * m, 0.0);
    ev.lambda.resize(c * m, 0.0);
    ev.slope.resize(c * m, 0.0);
    ev.lambda_coef.resize(c * nh, 0.0);
    ev.residual.resize(d * nh + 2, 0.0);
    model.contact_coefficients(x, p.harmonics, &mut ev.coef);
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
    model.harmonic_residual(
        omega,
        x,
        p.harmonics,
        &ev.lambda_coef,
        &mut ev.residual[..d * nh],
    );
    let master: f64 = model
        .master_row()
        .iter()
        .zip(&x[d..2 * d])
        .map(|(e, v)| e * v)
        .sum();
    ev.residual[d * nh] = p.norm_scale * (master - q);
    let r = p.row;
    let mut arc = r.a_q * (q - r.q_p) / r.q_scale + r.a_w * (omega - r.w_p) / r.w_scale;
    if !r.a_y.is_empty() {
        let e = model.master_row();
        for h in 0..nh {
            let mh: f64 = e
                .iter()
                .zip(&x[h * d..(h + 1) * d])
                .map(|(a, b)| a * b)
                .sum();
            arc += r.a_y[c * nh + h] * (mh - r.y_p[c * nh + h]) / r.y_scale;
        }
        for i in 0..c * nh {
            arc += r.a_y[i] * (ev.coef[i] - r.y_p[i]) / r.y_scale;
        }
    }
    ev.residual[d * nh + 1] = p.arc_scale * arc;
    let w = model.row_weights();
    let mut sum = 0.0;
    for block in ev.residual[..d * nh].chunks(d) {
        for (r, wi) in block.iter().zip(w) {
            sum += (r * wi) * (r * wi);
        }
    }
    sum += ev.residual[d * nh].powi(2) + ev.residual[d * nh + 1].powi(2);
    ev.merit = if sum.is_finite() {
        sum.sqrt()
    } else {
        f64::INFINITY
    };
}

/// Newton direction for the given per-sample slopes (d lambda / d g, c x m): J step = -R.
#[allow(clippy::too_many_arguments)]
fn newton_direction(
    model: &mut dyn LinearModel,
    aft: &mut Aft,
    p: &InnerProblem<'_>,
    state: &NewtonState,
    residual: &[f64],
    slopes: &[f64],
    work: &mut DirectionWork,
    step: &mut Vec<f64>,
) -> Result<(), NnmError> {
    let (m, np, c) = (p.samples, 2 * p.harmonics + 1, p.g0.len());
    work.active.clear();
    for j in 0..c {
        if slopes[j * m..(j + 1) * m].iter().any(|&s| s > 0.0) {
            work.active.push(j);
        }
    }
    work.slopes_active.clear();
    for &j in &work.active {
        work.slopes_active
            .extend_from_slice(&slopes[j * m..(j + 1) * m]);
    }
    work.moments.resize(work.active.len() * np, 0.0);
    aft.cosine_moments(&work.slopes_active, work.active.len(), &mut work.moments);
    step.clear();
    step.extend(residual.iter().map(|r| -r));
    let r = p.row;
    work.arc_y.clear();
    work.arc_y
        .extend(r.a_y.iter().map(|a| p.arc_scale * a / r.y_scale));
    let jac = JacobianData {
        harmonics: p.harmonics,
        omega: state.omega,
        x: &state.x,
        active: &work.active,
        moments: &work.moments,
        norm_scale: p.norm_scale,
        arc_w: p.arc_scale * r.a_w / r.w_scale,
        arc_q: p.arc_scale * r.a_q / r.q_scale,
        arc_y: &work.arc_y,
    };
    model.solve_step(&jac, step)?;
    if step.iter().any(|v| !v.is_finite()) {
        return Err(NnmError::Decomposition {
            what: "Newton step",
            detail: "non-finite step (singular Newton matrix)".to_string(),
        });
    }
    Ok(())
}

/// Secant slopes along a step: for each sample, kappa times the fraction of the segment
/// [s, s + ds] (s = g + theta) on which the sample is in contact, so that the linear model of
/// lambda is exact at the end of the step. Returns how many samples differ from `slopes`.
fn secant_slopes(
    model: &dyn LinearModel,
    aft: &mut Aft,
    p: &InnerProblem<'_>,
    ev: &Evaluation,
    step: &[f64],
    work: &mut DirectionWork,
    slopes: &mut [f64],
) -> usize {
    let (nh, m, c) = (p.harmonics + 1, p.samples, p.g0.len());
    work.dcoef.resize(c * nh, 0.0);
    work.dgap.resize(c * m, 0.0);
    model.contact_coefficients(step, p.harmonics, &mut work.dcoef);
    aft.synthesize(&work.dcoef, c, &mut work.dgap);
    let mut changed = 0;
    for (i, slope) in slopes.iter_mut().enumerate().take(c * m) {
        let s0 = ev.gaps[i] + p.multipliers.theta[i];
        let s1 = s0 + work.dgap[i];
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

/// Buffers of the direction computations.
#[derive(Default)]
pub(crate) struct DirectionWork {
    active: Vec<usize>,
    slopes_active: Vec<f64>,
    moments: Vec<f64>,
    dcoef: Vec<f64>,
    dgap: Vec<f64>,
    arc_y: Vec<f64>,
}

/// Backtracking line search along `step`; on success the state and `current` are updated.
#[allow(clippy::too_many_arguments)]
fn line_search(
    model: &mut dyn LinearModel,
    aft: &mut Aft,
    p: &InnerProblem<'_>,
    settings: &NewtonSettings,
    state: &mut NewtonState,
    current: &mut Evaluation,
    trial: &mut Evaluation,
    trial_x: &mut Vec<f64>,
    step: &[f64],
    full_step_only: bool,
) -> bool {
    let len = step.len();
    let merit0 = current.merit;
    let mut alpha = 1.0;
    let halvings = if full_step_only {
        0
    } else {
        settings.max_halvings
    };
    for _ in 0..=halvings {
        let omega = state.omega + alpha * step[len - 2];
        if omega > 0.0 {
            let q = state.q + alpha * step[len - 1];
            trial_x.clear();
            trial_x.extend(state.x.iter().zip(step).map(|(x, s)| x + alpha * s));
            evaluate(model, aft, p, trial_x, omega, q, trial);
            if trial.merit <= (1.0 - 1e-4 * alpha) * merit0 {
                std::mem::swap(&mut state.x, trial_x);
                state.omega = omega;
                state.q = q;
                std::mem::swap(current, trial);
                return true;
            }
        }
        alpha *= 0.5;
    }
    false
}

/// Iterations over which the residual must at least halve.
const STAGNATION_WINDOW: usize = 5;

/// Number of secant-slope refinements of a rejected Newton step.
const SECANT_PASSES: usize = 4;

/// Solves the inner problem from `state` (updated in place). On success `work.current` holds the
/// gap and force samples of the solution.
///
/// Each iteration takes the semi-smooth Newton step; if the full step does not decrease the
/// residual (typically a sample changing contact state within the step, where the one-sided
/// generalized Jacobian mispredicts and can even fail to give a descent direction at a kink), the
/// step is recomputed with secant slopes (see `secant_slopes`), a few passes, before backtracking.
pub(crate) fn solve_inner(
    model: &mut dyn LinearModel,
    aft: &mut Aft,
    p: &InnerProblem<'_>,
    settings: &NewtonSettings,
    state: &mut NewtonState,
    work: &mut NewtonWork,
) -> Result<NewtonReport, NnmError> {
    let reference = |q: f64| p.norm_scale * q.abs().max(f64::MIN_POSITIVE);
    evaluate(
        model,
        aft,
        p,
        &state.x,
        state.omega,
        state.q,
        &mut work.current,
    );
    let mut iterations = 0;
    let mut history: Vec<f64> = Vec::new();
    loop {
        let rel = work.current.merit / reference(state.q);
        let fail = |reason: String, iterations: usize| NnmError::NewtonFailed {
            iterations,
            residual: rel,
            tolerance: settings.tolerance,
            reason,
        };
        if !rel.is_finite() {
            return Err(fail("non-finite residual".to_string(), iterations));
        }
        if rel <= settings.tolerance {
            return Ok(NewtonReport { iterations });
        }
        if iterations >= settings.max_iterations {
            return Err(fail(
                "maximum number of iterations reached".to_string(),
                iterations,
            ));
        }
        // Stagnation: a semi-smooth Newton that converges does so fast; five iterations that do
        // not halve the residual mean it is cycling between contact states.
        history.push(work.current.merit);
        if history.len() > STAGNATION_WINDOW
            && work.current.merit > 0.5 * history[history.len() - 1 - STAGNATION_WINDOW]
        {
            return Err(fail(
                "stagnation (residual not halved in 5 iterations)".to_string(),
                iterations,
            ));
        }
        iterations += 1;
        work.spent += 1;
        work.slopes.clear();
        work.slopes.extend_from_slice(&work.current.slope);
        newton_direction(
            model,
            aft,
            p,
            state,
            &work.current.residual,
            &work.slopes,
            &mut work.direction,
            &mut work.step,
        )
        .map_err(|e| fail(e.to_string(), iterations))?;
        let mut accepted = line_search(
            model,
            aft,
            p,
            settings,
            state,
            &mut work.current,
            &mut work.trial,
            &mut work.trial_x,
            &work.step,
            true,
        );
        if !accepted && p.smoothing == 0.0 {
            work.first_step.clear();
            work.first_step.extend_from_slice(&work.step);
            for pass in 0..SECANT_PASSES {
                let changed = secant_slopes(
                    model,
                    aft,
                    p,
                    &work.current,
                    &work.step,
                    &mut work.direction,
                    &mut work.slopes,
                );
                if changed == 0 && pass > 0 {
                    break;
                }
                newton_direction(
                    model,
                    aft,
                    p,
                    state,
                    &work.current.residual,
                    &work.slopes,
                    &mut work.direction,
                    &mut work.step,
                )
                .map_err(|e| fail(e.to_string(), iterations))?;
                accepted = line_search(
                    model,
                    aft,
                    p,
                    settings,
                    state,
                    &mut work.current,
                    &mut work.trial,
                    &mut work.trial_x,
                    &work.step,
                    true,
                );
                if accepted {
                    break;
                }
            }
        }
        if !accepted && p.smoothing > 0.0 {
            accepted = line_search(
                model,
                aft,
                p,
                settings,
                state,
                &mut work.current,
                &mut work.trial,
                &mut work.trial_x,
                &work.step,
                false,
            );
        } else if !accepted {
            // Backtrack along the secant step, then along the plain Newton step.
            accepted = line_search(
                model,
                aft,
                p,
                settings,
                state,
                &mut work.current,
                &mut work.trial,
                &mut work.trial_x,
                &work.step,
                false,
            ) || line_search(
                model,
                aft,
                p,
                settings,
                state,
                &mut work.current,
                &mut work.trial,
                &mut work.trial_x,
                &work.first_step,
                false,
            );
        }
        if !accepted {
            return Err(fail(
                "line search found no decrease of the residual".to_string(),
                iterations,
            ));
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::condensed::CondensedModel;
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
            harmonics: 6,
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
        let mut work = DirectionWork::default();
        let mut step = Vec::new();
        newton_direction(
            model,
            &mut aft,
            &p,
            &state,
            &ev.residual,
            &ev.slope,
            &mut work,
            &mut step,
        )
        .expect("direction");
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
        let mut full = FullModel::new(&sys);
        let df = direction(&mut full, &sys, smoothing);
        // window 0.9: many "other" modes are kept near resonance, exercising that path
        for window in [0.5, 0.9] {
            let mut cond = CondensedModel::new(&sys, window).expect("condensed");
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
