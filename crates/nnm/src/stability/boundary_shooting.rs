//! The periodic orbit of the massless-boundary model next to a harmonic-balance orbit, by
//! shooting, and its exact monodromy (docs/STABILITY.md, Sec. 9).
//!
//! A backbone orbit is a cosine series: it is symmetric in time and at rest at t = 0 (q' = 0).
//! The model is reversible, so a motion that starts at rest, q(0) = q0, and is at rest again at
//! T / 2 is T-periodic. The unknowns are (q0, T) (r + 1), the equations q'(T / 2) = 0 (r): the
//! periodic orbits form a one-parameter family (the backbone) and the minimum-norm Newton step
//! (Gauss-Newton on the under-determined system, in the scaled unknowns q0 / |q0|, T / T_hb)
//! goes to the member of the family nearest the start, the harmonic-balance orbit. Its Jacobian
//! is exact: d q'(T/2) / d q0 is the velocity-displacement block of the transition matrix over
//! T / 2 (the flow is Lipschitz, no saltation), d q'(T/2) / dT = q''(T/2) / 2.

use faer::linalg::solvers::Solve;
use faer::{Mat, Side};

use super::boundary_flow::{BoundaryFlow, BoundaryModel, FlowState};
use crate::NnmError;

/// Newton stops when |q'(T/2)| < this x w |q0| (the scaled residual).
const NEWTON_TOLERANCE: f64 = 1e-10;
/// Newton iterations before giving up.
const NEWTON_ITERATIONS: usize = 30;
/// Step halvings when a step does not reduce the residual.
const LINE_SEARCH_HALVINGS: usize = 10;

/// A periodic orbit of the massless-boundary model and its monodromy.
pub(crate) struct ShotOrbit {
    /// Modal displacement at t = 0 (at rest).
    pub q0: Vec<f64>,
    /// Period (s).
    pub period: f64,
    /// Monodromy matrix over one period in (q, q') (2r x 2r).
    pub monodromy: Mat<f64>,
    /// Contact switches over the period.
    pub switches: usize,
}

/// Residual q'(T/2) of a start q0 and period T, with its Jacobian blocks.
struct HalfPeriod {
    velocity: Vec<f64>,
    /// d q'(T/2) / d q0 (r x r).
    d_q0: Mat<f64>,
    /// d q'(T/2) / dT (r).
    d_period: Vec<f64>,
}

fn half_period(
    flow: &mut BoundaryFlow<'_>,
    q0: &[f64],
    period: f64,
) -> Result<HalfPeriod, NnmError> {
    let r = q0.len();
    let mut active = flow.active_set_at(q0)?;
    let mut state = FlowState {
        q: q0.to_vec(),
        v: vec![0.0; r],
    };
    let mut transition = Mat::<f64>::identity(2 * r, 2 * r);
    let accel = flow.advance(&mut state, &mut active, 0.5 * period, Some(&mut transition))?;
    Ok(HalfPeriod {
        velocity: state.v,
        d_q0: Mat::from_fn(r, r, |i, k| transition[(r + i, k)]),
        d_period: accel.iter().map(|a| 0.5 * a).collect(),
    })
}

fn norm(x: &[f64]) -> f64 {
    x.iter().map(|v| v * v).sum::<f64>().sqrt()
}

/// The periodic orbit nearest (q0, T) and its monodromy, or `None` when Newton does not
/// converge (the caller then has no shooting verdict for the point).
pub(crate) fn shoot(
    model: &BoundaryModel,
    q0: Vec<f64>,
    period: f64,
) -> Result<Option<ShotOrbit>, NnmError> {
    let r = q0.len();
    let mut flow = BoundaryFlow::new(model);
    let (q_scale, t_scale) = (norm(&q0), period);
    if !(q_scale > 0.0 && period > 0.0) {
        return Ok(None);
    }
    let v_scale = q_scale * 2.0 * std::f64::consts::PI / period;
    let (mut q, mut t) = (q0, period);
    let mut hp = half_period(&mut flow, &q, t)?;
    let mut res = norm(&hp.velocity) / v_scale;
    let mut converged = res < NEWTON_TOLERANCE;
    for _ in 0..NEWTON_ITERATIONS {
        if converged {
            break;
        }
        // Scaled Jacobian J = [d_q0 q_scale, d_period t_scale] / v_scale (r x (r + 1)).
        let jac = Mat::from_fn(r, r + 1, |i, k| {
            if k < r {
                hp.d_q0[(i, k)] * q_scale / v_scale
            } else {
                hp.d_period[i] * t_scale / v_scale
            }
        });
        let rhs = Mat::from_fn(r, 1, |i, _| -hp.velocity[i] / v_scale);
        let jjt = &jac * jac.transpose();
        let Ok(llt) = jjt.llt(Side::Lower) else {
            return Ok(None);
        };
        let step = jac.transpose() * llt.solve(&rhs);
        let mut accepted = false;
        let mut factor = 1.0;
        for _ in 0..=LINE_SEARCH_HALVINGS {
            let q_try: Vec<f64> = (0..r)
                .map(|i| q[i] + factor * step[(i, 0)] * q_scale)
                .collect();
            let t_try = t + factor * step[(r, 0)] * t_scale;
            if t_try > 0.0 {
                let trial = half_period(&mut flow, &q_try, t_try)?;
                let res_try = norm(&trial.velocity) / v_scale;
                if res_try < res {
                    (q, t, hp, res) = (q_try, t_try, trial, res_try);
                    accepted = true;
                    break;
                }
            }
            factor *= 0.5;
        }
        if !accepted {
            return Ok(None);
        }
        converged = res < NEWTON_TOLERANCE;
    }
    if !converged {
        return Ok(None);
    }
    let mut active = flow.active_set_at(&q)?;
    let mut state = FlowState {
        q: q.clone(),
        v: vec![0.0; r],
    };
    let mut monodromy = Mat::<f64>::identity(2 * r, 2 * r);
    let before = flow.switches;
    flow.advance(&mut state, &mut active, t, Some(&mut monodromy))?;
    Ok(Some(ShotOrbit {
        q0: q,
        period: t,
        monodromy,
        switches: flow.switches - before,
    }))
}

/// What [`boundary_stability`] needs of the system's linear modes.
pub(crate) struct ModalData<'a> {
    /// w_k of every mode (rad/s), ascending.
    pub omega: &'a [f64],
    /// A Phi (c x n).
    pub contact_modal: faer::MatRef<'a, f64>,
    /// Phi^T M (n x n).
    pub projection: faer::MatRef<'a, f64>,
}

/// The massless-boundary model keeping the first `r` modes: R from the others, plus 1 / kc on
/// the diagonal of a penalty orbit's rows. `None` when R is not positive definite (the discarded
/// modes do not reach every contact row: no massless boundary to build).
pub(crate) fn boundary_model(
    modal: &ModalData<'_>,
    gaps: &[f64],
    r: usize,
    penalty: Option<&[f64]>,
) -> Option<BoundaryModel> {
    let c = gaps.len();
    let b = modal.contact_modal;
    let omega = modal.omega;
    let mut flexibility = Mat::from_fn(c, c, |i, j| {
        (r..omega.len())
            .map(|k| b[(i, k)] * b[(j, k)] / (omega[k] * omega[k]))
            .sum::<f64>()
    });
    if let Some(kc) = penalty {
        for (j, k) in kc.iter().enumerate() {
            flexibility[(j, j)] += 1.0 / k;
        }
    }
    // Positive definite with some margin: a row the discarded modes barely reach would make a
    // near-rigid, near-massive contact (an impact) of the boundary.
    let scale = (0..c).fold(0.0_f64, |a, j| a.max(flexibility[(j, j)]));
    let shifted = Mat::from_fn(c, c, |i, j| {
        flexibility[(i, j)] - if i == j { 1e-10 * scale } else { 0.0 }
    });
    if !(scale > 0.0) || shifted.llt(Side::Lower).is_err() {
        return None;
    }
    Some(BoundaryModel {
        omega2: omega[..r].iter().map(|w| w * w).collect(),
        contact_modal: Mat::from_fn(c, r, |i, k| b[(i, k)]),
        flexibility,
        gaps: gaps.to_vec(),
    })
}

/// Modal coordinates q = (Phi^T M u)_k, k < r, of a displacement u.
pub(crate) fn modal_coordinates(modal: &ModalData<'_>, u: &[f64], r: usize) -> Vec<f64> {
    let p = modal.projection;
    (0..r)
        .map(|k| (0..u.len()).map(|i| p[(k, i)] * u[i]).sum())
        .collect()
}

/// The multipliers (as exponents, 1/s) of a shot orbit's monodromy.
pub(crate) fn exponents_of(orbit: &ShotOrbit) -> Result<Vec<faer::c64>, NnmError> {
    let values = orbit
        .monodromy
        .eigenvalues()
        .map_err(|e| NnmError::Decomposition {
            what: "eigenvalues of the massless boundary's monodromy",
            detail: format!("{e:?}"),
        })?;
    let t = orbit.period;
    Ok(values
        .iter()
        .map(|mu| faer::c64::new(mu.norm().ln() / t, mu.arg() / t))
        .collect())
}
