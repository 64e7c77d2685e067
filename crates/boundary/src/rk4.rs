//! An independent integration of the massless-boundary model (free or driven), the check of the
//! shooting verdicts (docs/STABILITY.md, Sec. 9; `[stability] verify_every`).
//!
//! Classical RK4 on (q, q') and the variational matrix Y (2r x 2r, Y(0) = I) of
//! q'' + C_q q' + W^2 q = P(t) - B^T lambda, u_c = B q + D(t) - R lambda, with the contact
//! force of every stage from the linear complementarity problem solved afresh at that stage's q
//! (Murty's least-index pivoting on dense Cholesky solves, warm-started from the last stage's
//! set): no pieces, no eigenvectors. A step whose stages see two active sets is cut at the
//! change by bisection on its length, so each step integrates one linear piece and RK4 keeps its
//! fourth order; the check is accurate to about (h s_max)^4 per step, not to round-off.

use std::collections::HashMap;

use faer::linalg::matmul::matmul;
use faer::linalg::solvers::Solve;
use faer::reborrow::ReborrowMut;
use faer::{Accum, Mat, Par, Side};

use crate::driven_model::DrivenBoundary;
use crate::switch_scan::settle_active_set;
use nlmodes_dense::generalized_eigen;
use nlmodes_hb::HbError;

/// RK4 steps per period of the fastest motion of the model (all rows closed): h s_max = 2 pi /
/// this, about 0.03, local error ~ 1e-9 per step on the smooth stretches.
const STEPS_PER_FAST_PERIOD: f64 = 200.0;

/// A state (q, q') of the kept modes.
#[derive(Clone, Debug)]
pub struct Rk4State {
    pub q: Vec<f64>,
    pub v: Vec<f64>,
}

/// The drive at time t: P(t) on the kept modes and D(t) on the contact rows.
struct DriveAt {
    modal: Vec<f64>,
    contact: Vec<f64>,
}

fn drive_at(model: &DrivenBoundary, t: f64) -> DriveAt {
    let (r, c) = (model.omega2.len(), model.gaps.len());
    let mut out = DriveAt {
        modal: vec![0.0; r],
        contact: vec![0.0; c],
    };
    for d in &model.drive {
        let (s, co) = (d.harmonic as f64 * model.omega * t).sin_cos();
        for (i, m) in out.modal.iter_mut().enumerate() {
            *m += co * d.modal[0][i] + s * d.modal[1][i];
        }
        for (j, m) in out.contact.iter_mut().enumerate() {
            *m += co * d.contact[0][j] + s * d.contact[1][j];
        }
    }
    out
}

/// The active set and the contact forces lambda >= 0 (N) at displacement q and time t: the
/// solution of lambda_a = R_aa^-1 (B_a q + D_a(t) - g_a) >= 0,
/// p_f = B_f q + D_f(t) - R_fa lambda_a - g_f <= 0.
/// Murty's least-index principal pivoting terminates from any starting set for a P-matrix
/// (R is positive definite), so `start` (the last stage's set) only saves pivots.
pub fn contact_solution(
    model: &DrivenBoundary,
    t: f64,
    q: &[f64],
    start: Vec<usize>,
) -> Result<(Vec<usize>, Vec<f64>), HbError> {
    let c = model.gaps.len();
    let drive = drive_at(model, t);
    let free_gap: Vec<f64> = (0..c)
        .map(|j| row_dot(&model.contact_modal, j, q) + drive.contact[j] - model.gaps[j])
        .collect();
    let scale = model.gaps.iter().fold(0.0_f64, |a, &g| a.max(g)) * 1e-13;
    let mut mask = vec![false; c];
    start.iter().for_each(|&j| mask[j] = true);
    let mut lambda = Vec::new();
    let settled = settle_active_set(c, mask, UNSETTLED, |mask| {
        let active: Vec<usize> = (0..c).filter(|&j| mask[j]).collect();
        lambda = solve_on(model, &active, &free_gap)?;
        Ok((0..c).find(|&j| match active.iter().position(|&a| a == j) {
            Some(i) => lambda[i] * model.flexibility[(j, j)] < -scale,
            None => {
                let p = free_gap[j]
                    - (0..active.len())
                        .map(|i| model.flexibility[(j, active[i])] * lambda[i])
                        .sum::<f64>();
                p > scale
            }
        }))
    })?;
    Ok(((0..c).filter(|&j| settled[j]).collect(), lambda))
}

/// The error of a contact problem that does not settle.
const UNSETTLED: &str = "the contact problem of the massless boundary did not settle (RK4 check)";

fn row_dot(m: &Mat<f64>, j: usize, x: &[f64]) -> f64 {
    (0..x.len()).map(|k| m[(j, k)] * x[k]).sum()
}

/// lambda_a = R_aa^-1 (B_a q + D_a - g_a) given that free gap on every row.
fn solve_on(
    model: &DrivenBoundary,
    active: &[usize],
    free_gap: &[f64],
) -> Result<Vec<f64>, HbError> {
    let na = active.len();
    if na == 0 {
        return Ok(Vec::new());
    }
    let r_aa = Mat::from_fn(na, na, |i, k| model.flexibility[(active[i], active[k])]);
    let rhs = Mat::from_fn(na, 1, |i, _| free_gap[active[i]]);
    let llt = r_aa.llt(Side::Lower).map_err(|e| HbError::Decomposition {
        what: "Cholesky of the massless boundary's flexibility (RK4 check)",
        detail: format!("{e:?}"),
    })?;
    let x = llt.solve(&rhs);
    Ok((0..na).map(|i| x[(i, 0)]).collect())
}

/// The stiffness W^2 + B_a^T R_aa^-1 B_a of the active set `active` (r x r).
fn stiffness_on(model: &DrivenBoundary, active: &[usize]) -> Result<Mat<f64>, HbError> {
    let r = model.omega2.len();
    let na = active.len();
    let mut k = Mat::from_fn(r, r, |i, j| if i == j { model.omega2[i] } else { 0.0 });
    if na > 0 {
        let r_aa = Mat::from_fn(na, na, |i, l| model.flexibility[(active[i], active[l])]);
        let b_a = Mat::from_fn(na, r, |i, l| model.contact_modal[(active[i], l)]);
        let llt = r_aa.llt(Side::Lower).map_err(|e| HbError::Decomposition {
            what: "Cholesky of the massless boundary's flexibility (RK4 check)",
            detail: format!("{e:?}"),
        })?;
        k += b_a.transpose() * llt.solve(&b_a);
    }
    Ok(k)
}

/// The active set at q and the derivative of (q, q'): (q', -W^2 q - C_q q' + f - B^T lambda(q)).
type Derivative = (Vec<usize>, Vec<f64>, Vec<f64>);

/// The integrator's state across stages: the last active set (the next LCP's start) and the
/// stiffness of every set met.
struct Rk4<'m> {
    model: &'m DrivenBoundary,
    last_set: Vec<usize>,
    stiffness: HashMap<Vec<usize>, Mat<f64>>,
}

impl Rk4<'_> {
    fn derivative(&mut self, t: f64, q: &[f64], v: &[f64]) -> Result<Derivative, HbError> {
        let model = self.model;
        let r = q.len();
        let (active, lambda) = contact_solution(model, t, q, self.last_set.clone())?;
        self.last_set.clone_from(&active);
        let drive = drive_at(model, t);
        let accel: Vec<f64> = (0..r)
            .map(|k| {
                -model.omega2[k] * q[k] + drive.modal[k]
                    - (0..r).map(|l| model.damping[(k, l)] * v[l]).sum::<f64>()
                    - (0..active.len())
                        .map(|i| model.contact_modal[(active[i], k)] * lambda[i])
                        .sum::<f64>()
            })
            .collect();
        Ok((active, v.to_vec(), accel))
    }

    /// dY = A Y on the active set `active`, A = [[0, I], [-K_a, -C_q]]: [[Y_v], [-(K_a Y_q +
    /// C_q Y_v)]] as two products (the check's largest cost as indexed sums).
    fn variational(&mut self, active: &[usize], y: &Mat<f64>) -> Result<Mat<f64>, HbError> {
        let model = self.model;
        if !self.stiffness.contains_key(active) {
            let k = stiffness_on(model, active)?;
            self.stiffness.insert(active.to_vec(), k);
        }
        let k_a = &self.stiffness[active];
        let (r, n) = (y.nrows() / 2, y.nrows());
        let mut dy = Mat::zeros(n, n);
        let (y_q, y_v) = (y.as_ref().subrows(0, r), y.as_ref().subrows(r, r));
        dy.as_mut().subrows_mut(0, r).copy_from(y_v);
        let mut bottom = dy.as_mut().subrows_mut(r, r);
        matmul(
            bottom.rb_mut(),
            Accum::Replace,
            k_a.as_ref(),
            y_q,
            -1.0,
            Par::Seq,
        );
        matmul(
            bottom,
            Accum::Add,
            model.damping.as_ref(),
            y_v,
            -1.0,
            Par::Seq,
        );
        Ok(dy)
    }

    /// One classical RK4 step of (q, q') over h, and of Y when given (its stages on the
    /// active sets of the state's stages: the search for a switch within a step reads only
    /// whether the sets agree, and takes its steps without Y).
    fn rk4_step(
        &mut self,
        t: f64,
        q: &[f64],
        v: &[f64],
        y: Option<&Mat<f64>>,
        h: f64,
    ) -> Result<Rk4Step, HbError> {
        let axpy = |x: &[f64], a: f64, d: &[f64]| -> Vec<f64> {
            x.iter().zip(d).map(|(xi, di)| xi + a * di).collect()
        };
        let (s1, k1q, k1v) = self.derivative(t, q, v)?;
        let (q2, v2) = (axpy(q, 0.5 * h, &k1q), axpy(v, 0.5 * h, &k1v));
        let (s2, k2q, k2v) = self.derivative(t + 0.5 * h, &q2, &v2)?;
        let (q3, v3) = (axpy(q, 0.5 * h, &k2q), axpy(v, 0.5 * h, &k2v));
        let (s3, k3q, k3v) = self.derivative(t + 0.5 * h, &q3, &v3)?;
        let (q4, v4) = (axpy(q, h, &k3q), axpy(v, h, &k3v));
        let (s4, k4q, k4v) = self.derivative(t + h, &q4, &v4)?;
        let combine = |x: &[f64], a: &[f64], b: &[f64], c: &[f64], d: &[f64]| -> Vec<f64> {
            (0..x.len())
                .map(|i| x[i] + h / 6.0 * (a[i] + 2.0 * b[i] + 2.0 * c[i] + d[i]))
                .collect()
        };
        let y_new = match y {
            None => None,
            Some(y) => {
                let k1y = self.variational(&s1, y)?;
                let y2 = y + faer::Scale(0.5 * h) * &k1y;
                let k2y = self.variational(&s2, &y2)?;
                let y3 = y + faer::Scale(0.5 * h) * &k2y;
                let k3y = self.variational(&s3, &y3)?;
                let y4 = y + faer::Scale(h) * &k3y;
                let k4y = self.variational(&s4, &y4)?;
                Some(
                    y + faer::Scale(h / 6.0)
                        * (&k1y + faer::Scale(2.0) * &k2y + faer::Scale(2.0) * &k3y + &k4y),
                )
            }
        };
        Ok(Rk4Step {
            q: combine(q, &k1q, &k2q, &k3q, &k4q),
            v: combine(v, &k1v, &k2v, &k3v, &k4v),
            y: y_new,
            one_set: s1 == s2 && s1 == s3 && s1 == s4,
        })
    }
}

/// Number of RK4 steps for `duration` (s): STEPS_PER_FAST_PERIOD per period of the fastest
/// frequency of the model with every row closed.
pub fn rk4_steps(model: &DrivenBoundary, duration: f64) -> Result<usize, HbError> {
    let all: Vec<usize> = (0..model.gaps.len()).collect();
    let k = stiffness_on(model, &all)?;
    let r = k.nrows();
    let identity = Mat::<f64>::identity(r, r);
    let eig = generalized_eigen(k.as_ref(), identity.as_ref()).map_err(HbError::dense("I"))?;
    let s_max = eig.values.last().copied().unwrap_or(0.0).max(0.0).sqrt();
    let periods = duration * s_max / (2.0 * std::f64::consts::PI);
    Ok(((periods * STEPS_PER_FAST_PERIOD).ceil() as usize).max(1000))
}

/// Bisection steps locating a change of the active set within a step (h / 2^50).
const SWITCH_BISECTIONS: usize = 50;

/// One RK4 step of (q, q', Y): the new values and whether every stage had the active set of the
/// first.
struct Rk4Step {
    q: Vec<f64>,
    v: Vec<f64>,
    /// Y at the step's end, when it was carried.
    y: Option<Mat<f64>>,
    one_set: bool,
}

/// RK4 over `duration` from `start` in steps of at most duration / `steps`: the end state and the
/// transition matrix (2r x 2r). A step over which the active set changes is cut, by bisection,
/// at the change: one step on the old set up to it and one of h / 2^50 across it, so no step
/// mixes two linear pieces by more than that and the scheme keeps its order on each piece (the
/// field is continuous at a switch: nothing else happens there).
pub fn integrate(
    model: &DrivenBoundary,
    start: &Rk4State,
    duration: f64,
    steps: usize,
) -> Result<(Rk4State, Mat<f64>), HbError> {
    let r = start.q.len();
    let mut rk4 = Rk4 {
        model,
        last_set: Vec::new(),
        stiffness: HashMap::new(),
    };
    let h_max = duration / steps as f64;
    let (mut q, mut v) = (start.q.clone(), start.v.clone());
    let mut y = Mat::<f64>::identity(2 * r, 2 * r);
    let mut t = 0.0;
    while t < duration {
        let h = h_max.min(duration - t);
        let mut step = rk4.rk4_step(t, &q, &v, Some(&y), h)?;
        let mut taken = h;
        if !step.one_set {
            let (mut lo, mut hi) = (0.0, h);
            for _ in 0..SWITCH_BISECTIONS {
                let mid = 0.5 * (lo + hi);
                if rk4.rk4_step(t, &q, &v, None, mid)?.one_set {
                    lo = mid;
                } else {
                    hi = mid;
                }
            }
            // Up to the switch on the old set, then across it in a step of h / 2^50: the
            // variational equation's coefficient jumps there, and a stage evaluated past the
            // switch must not weigh on a long step.
            if lo > 0.0 {
                let before = rk4.rk4_step(t, &q, &v, Some(&y), lo)?;
                (q, v) = (before.q, before.v);
                y = before.y.expect("carried");
                t += lo;
            }
            taken = hi - lo;
            step = rk4.rk4_step(t, &q, &v, Some(&y), hi - lo)?;
        }
        (q, v) = (step.q, step.v);
        y = step.y.expect("carried");
        t += taken;
    }
    Ok((Rk4State { q, v }, y))
}
