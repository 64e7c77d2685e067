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
use nlmodes_dense::{eigenvalues_checked, DenseError};

use crate::free_flow::{BoundaryFlow, FlowState};
use crate::model::{norm, BoundaryModel, ModalData};
use nlmodes_hb::HbError;

/// Newton stops when |q'(T/2)| < this x w |q0| (the scaled residual).
const NEWTON_TOLERANCE: f64 = 1e-10;
/// Newton iterations before giving up.
const NEWTON_ITERATIONS: usize = 30;
/// Step halvings when a step does not reduce the residual.
const LINE_SEARCH_HALVINGS: usize = 10;

/// A periodic orbit of the massless-boundary model and its monodromy.
pub struct ShotOrbit {
    /// Modal displacement at t = 0 (at rest).
    pub q0: Vec<f64>,
    /// Period (s).
    pub period: f64,
    /// Monodromy matrix over one period in (q, q') (2r x 2r).
    pub monodromy: Mat<f64>,
    /// Contact switches over the period.
    pub switches: usize,
    /// Share of the period each contact row is closed (exact: from the switch instants).
    pub contact_shares: Vec<f64>,
}

/// Residual q'(T/2) of a start q0 and period T, with its Jacobian blocks.
pub(crate) struct HalfPeriod {
    pub velocity: Vec<f64>,
    /// d q'(T/2) / d q0 (r x r).
    pub d_q0: Mat<f64>,
    /// d q'(T/2) / dT (r).
    pub d_period: Vec<f64>,
}

/// The velocity at T / 2 of the motion released at rest from q0, and its derivatives.
pub(crate) fn half_period(
    flow: &mut BoundaryFlow<'_>,
    q0: &[f64],
    period: f64,
) -> Result<HalfPeriod, HbError> {
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

/// The periodic orbit nearest (q0, T) and its monodromy, or `None` when Newton does not
/// converge (the caller then has no shooting verdict for the point).
pub fn shoot(
    model: &BoundaryModel,
    q0: Vec<f64>,
    period: f64,
) -> Result<Option<ShotOrbit>, HbError> {
    let mut flow = BoundaryFlow::new(model);
    let q_scale = norm(&q0);
    if q_scale.is_nan() || q_scale <= 0.0 || period.is_nan() || period <= 0.0 {
        return Ok(None);
    }
    let scales = Scales {
        q: q_scale,
        t: period,
        v: q_scale * 2.0 * std::f64::consts::PI / period,
    };
    let Some((q, t)) = newton(&mut flow, &scales, q0, period)? else {
        return Ok(None);
    };
    one_period(&mut flow, q, t).map(Some)
}

/// The scales of the shooting problem: of q0 (the start's norm), of T (the start's period) and
/// of the residual q'(T/2) (q_scale 2 pi / T).
struct Scales {
    q: f64,
    t: f64,
    v: f64,
}

impl Scales {
    /// The minimum-norm Newton step of the scaled system J dz = -q'(T/2) / v_scale, J = [d_q0
    /// q_scale, d_period t_scale] / v_scale (r x (r + 1)): dz = J^T (J J^T)^-1 rhs ((r + 1) x
    /// 1, in q0 / q_scale and T / t_scale); `None` when J J^T is not positive definite.
    fn newton_step(&self, hp: &HalfPeriod) -> Option<Mat<f64>> {
        let r = hp.velocity.len();
        let jac = Mat::from_fn(r, r + 1, |i, k| {
            if k < r {
                hp.d_q0[(i, k)] * self.q / self.v
            } else {
                hp.d_period[i] * self.t / self.v
            }
        });
        let rhs = Mat::from_fn(r, 1, |i, _| -hp.velocity[i] / self.v);
        let jjt = &jac * jac.transpose();
        let llt = jjt.llt(Side::Lower).ok()?;
        Some(jac.transpose() * llt.solve(&rhs))
    }
}

/// One Newton iterate: (q0, T), its half-period residual and the residual's scaled norm.
struct Iterate {
    q: Vec<f64>,
    t: f64,
    hp: HalfPeriod,
    res: f64,
}

impl Iterate {
    fn at(
        flow: &mut BoundaryFlow<'_>,
        scales: &Scales,
        q: Vec<f64>,
        t: f64,
    ) -> Result<Self, HbError> {
        let hp = half_period(flow, &q, t)?;
        let res = norm(&hp.velocity) / scales.v;
        Ok(Self { q, t, hp, res })
    }
}

/// Gauss-Newton on q'(T/2) = 0 from (q0, T) (module docs), at most `NEWTON_ITERATIONS` steps,
/// each with its line search: the converged (q0, T), or `None`.
fn newton(
    flow: &mut BoundaryFlow<'_>,
    scales: &Scales,
    q0: Vec<f64>,
    period: f64,
) -> Result<Option<(Vec<f64>, f64)>, HbError> {
    let mut current = Iterate::at(flow, scales, q0, period)?;
    for _ in 0..NEWTON_ITERATIONS {
        if current.res < NEWTON_TOLERANCE {
            break;
        }
        let Some(step) = scales.newton_step(&current.hp) else {
            return Ok(None);
        };
        let Some(next) = line_search(flow, scales, &current, &step)? else {
            return Ok(None);
        };
        current = next;
    }
    Ok((current.res < NEWTON_TOLERANCE).then_some((current.q, current.t)))
}

/// The first of the steps `step`, `step` / 2, ... (at most `LINE_SEARCH_HALVINGS` halvings)
/// from `current` to a positive period and a smaller residual, or `None`.
fn line_search(
    flow: &mut BoundaryFlow<'_>,
    scales: &Scales,
    current: &Iterate,
    step: &Mat<f64>,
) -> Result<Option<Iterate>, HbError> {
    let r = current.q.len();
    let mut factor = 1.0;
    for _ in 0..=LINE_SEARCH_HALVINGS {
        let q_try: Vec<f64> = (0..r)
            .map(|i| current.q[i] + factor * step[(i, 0)] * scales.q)
            .collect();
        let t_try = current.t + factor * step[(r, 0)] * scales.t;
        if t_try > 0.0 {
            let trial = Iterate::at(flow, scales, q_try, t_try)?;
            if trial.res < current.res {
                return Ok(Some(trial));
            }
        }
        factor *= 0.5;
    }
    Ok(None)
}

/// The orbit released at rest from q over one period T: its monodromy, switches and contact
/// shares.
fn one_period(flow: &mut BoundaryFlow<'_>, q: Vec<f64>, t: f64) -> Result<ShotOrbit, HbError> {
    let r = q.len();
    let mut active = flow.active_set_at(&q)?;
    let mut state = FlowState {
        q: q.clone(),
        v: vec![0.0; r],
    };
    let mut monodromy = Mat::<f64>::identity(2 * r, 2 * r);
    let before = flow.switches;
    let closed_before = flow.closed_time.clone();
    flow.advance(&mut state, &mut active, t, Some(&mut monodromy))?;
    let contact_shares = flow
        .closed_time
        .iter()
        .zip(&closed_before)
        .map(|(after, before)| (after - before) / t)
        .collect();
    Ok(ShotOrbit {
        q0: q,
        period: t,
        monodromy,
        switches: flow.switches - before,
        contact_shares,
    })
}

/// Largest relative distance |w_shot - w| / w between the harmonic-balance orbit and the shot
/// orbit of the massless boundary at which the shot orbit's verdict is the point's. The two
/// orbits differ by the truncation to N harmonics and by the inertia of the discarded modes
/// (O(((N + 1) w / w_k)^2) of their quasi-static response); further apart, the shot orbit is
/// another member of the family (or of a tongue) and says nothing of this point.
pub const SHOOTING_SHIFT_LIMIT: f64 = 1e-2;

/// A harmonic-balance orbit of the free problem, where the boundary's orbits start (a backbone
/// point of `nlmodes-nnm`).
#[derive(Clone, Debug)]
pub struct OrbitGuess {
    /// Its master amplitude q (m).
    pub q: f64,
    /// Its circular frequency w (rad/s).
    pub omega: f64,
    /// Its displacement u(0) (n), where it is at rest.
    pub start: Vec<f64>,
    /// The penalty stiffness kc of each row (N/m) of a penalty orbit; `None` for the augmented
    /// Lagrangian (rigid contact).
    pub penalty: Option<Vec<f64>>,
}

impl OrbitGuess {
    /// Its period 2 pi / w (s).
    pub fn period(&self) -> f64 {
        2.0 * std::f64::consts::PI / self.omega
    }
}

/// The massless-boundary model of `modal` with the first `r` modes dynamic and `guess`'s contact
/// law, and its periodic orbit next to `guess`, by shooting; `None` where the model does not
/// apply (every mode dynamic, R not positive definite) or Newton does not converge.
pub fn shot_orbit(
    modal: &ModalData<'_>,
    r: usize,
    guess: &OrbitGuess,
) -> Result<Option<(BoundaryModel, ShotOrbit)>, HbError> {
    if r == modal.omega.len() {
        return Ok(None);
    }
    let Some(model) = modal.model(r, guess.penalty.as_deref()) else {
        return Ok(None);
    };
    let q0 = modal.coordinates(&guess.start, r);
    match shoot(&model, q0, guess.period())? {
        Some(orbit) => Ok(Some((model, orbit))),
        None => {
            tracing::debug!(
                w = guess.omega,
                "massless-boundary shooting did not converge"
            );
            Ok(None)
        }
    }
}

/// The multipliers (as exponents, 1/s) of a shot orbit's monodromy; `None` when the monodromy
/// or a multiplier is not a finite nonzero number, or its determinant is not 1 within 1e-6 (the
/// flow is Hamiltonian: a monodromy that is not symplectic to that accuracy is not trusted), or
/// no eigen-decomposition of it passes `nlmodes_dense`'s check.
pub fn exponents_of(orbit: &ShotOrbit) -> Result<Option<Vec<faer::c64>>, HbError> {
    let m = &orbit.monodromy;
    if m.col_iter().any(|col| col.iter().any(|v| !v.is_finite())) {
        return Ok(None);
    }
    let what = "eigenvalues of the massless boundary's monodromy";
    let values = match eigenvalues_checked(m.as_ref(), what) {
        Ok(values) => values,
        // No decomposition passed its check: no shooting verdict (the caller falls back).
        Err(e @ DenseError::Unchecked { .. }) => {
            tracing::debug!(error = %e, "massless-boundary multipliers not trusted");
            return Ok(None);
        }
        Err(e) => return Err(HbError::dense(what)(e)),
    };
    let t = orbit.period;
    let log_det: f64 = values.iter().map(|mu| mu.norm().ln()).sum();
    if !(log_det.is_finite() && log_det.abs() <= 1e-6) {
        return Ok(None);
    }
    Ok(Some(
        values
            .iter()
            .map(|mu| faer::c64::new(mu.norm().ln() / t, mu.arg() / t))
            .collect(),
    ))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::driven_model::DrivenBoundary;
    use crate::rk4::{integrate, Rk4State};
    use crate::test_models::{bilinear, bilinear_period, three_modes};

    #[test]
    fn the_shot_bilinear_orbit_has_the_exact_period_and_a_trivial_pair_at_one() {
        for flex in [0.1, 1.0, 10.0] {
            for q0 in [1.05, 1.5, 3.0] {
                // Start 2 % off in amplitude and 5 % off in period.
                let model = bilinear(flex);
                let guess_t = 1.05 * bilinear_period(flex, q0);
                let orbit = shoot(&model, vec![1.02 * q0], guess_t)
                    .expect("shooting")
                    .expect("converges");
                let exact = bilinear_period(flex, orbit.q0[0]);
                assert!(
                    (orbit.period / exact - 1.0).abs() < 1e-10,
                    "R = {flex}, q0 = {q0}: T = {} vs {exact}",
                    orbit.period
                );
                // One contact phase: two switches per period.
                assert_eq!(orbit.switches, 2);
                let exponents = exponents_of(&orbit).expect("multipliers").expect("finite");
                for s in exponents {
                    let mu = (s * orbit.period).exp();
                    assert!((mu - faer::c64::new(1.0, 0.0)).norm() < 1e-4, "{mu:?}");
                }
            }
        }
    }

    #[test]
    fn the_exact_flow_agrees_with_rk4_and_is_symplectic() {
        let model = three_modes();
        let mut flow = BoundaryFlow::new(&model);
        for (q0, v0) in [
            ([2.5, 0.3, -0.2], [0.0, 0.5, 1.0]),
            ([-1.0, 2.0, 0.5], [3.0, 0.0, -1.0]),
            ([1.2, -0.8, 1.1], [0.0, 0.0, 0.0]),
        ] {
            let start = FlowState {
                q: q0.to_vec(),
                v: v0.to_vec(),
            };
            let mut end = start.clone();
            let mut active = flow.active_set_at(&q0).expect("set");
            // The set at rest is the set of the state: the LCP does not depend on the velocity.
            let mut transition = Mat::<f64>::identity(6, 6);
            let before = flow.switches;
            flow.advance(&mut end, &mut active, 7.0, Some(&mut transition))
                .expect("flow");
            let switches = flow.switches - before;
            let rk_start = Rk4State {
                q: start.q.clone(),
                v: start.v.clone(),
            };
            let (rk, rk_transition) = integrate(
                &DrivenBoundary::undriven(&model, 7.0),
                &rk_start,
                7.0,
                20_000,
            )
            .expect("rk4");
            let state_error = (0..3)
                .map(|i| (end.q[i] - rk.q[i]).abs().max((end.v[i] - rk.v[i]).abs()))
                .fold(0.0, f64::max);
            let matrix_error = (0..6)
                .flat_map(|i| (0..6).map(move |j| (i, j)))
                .map(|(i, j)| (transition[(i, j)] - rk_transition[(i, j)]).abs())
                .fold(0.0, f64::max);
            // J-orthogonality Phi^T J Phi = J of the exact transition (every piece is the flow of
            // a symmetric stiffness).
            let mut j = Mat::<f64>::zeros(6, 6);
            for i in 0..3 {
                j[(i, 3 + i)] = 1.0;
                j[(3 + i, i)] = -1.0;
            }
            let defect = transition.transpose() * &j * &transition - &j;
            let symplectic = (0..6)
                .flat_map(|i| (0..6).map(move |k| (i, k)))
                .map(|(i, k)| defect[(i, k)].abs())
                .fold(0.0, f64::max);
            // Finite differences of the exact flow's end state (central, step 1e-6).
            let mut fd_error: f64 = 0.0;
            let mut fd_rk: f64 = 0.0;
            for col in 0..6 {
                let shifted = |sign: f64| {
                    let mut s = start.clone();
                    if col < 3 {
                        s.q[col] += sign * 1e-6
                    } else {
                        s.v[col - 3] += sign * 1e-6
                    }
                    let mut flow = BoundaryFlow::new(&model);
                    let mut active = flow.active_set_at(&s.q).expect("set");
                    flow.advance(&mut s, &mut active, 7.0, None).expect("flow");
                    s
                };
                let (p, m) = (shifted(1.0), shifted(-1.0));
                for i in 0..6 {
                    let d = if i < 3 {
                        (p.q[i] - m.q[i]) / 2e-6
                    } else {
                        (p.v[i - 3] - m.v[i - 3]) / 2e-6
                    };
                    fd_error = fd_error.max((d - transition[(i, col)]).abs());
                    fd_rk = fd_rk.max((d - rk_transition[(i, col)]).abs());
                }
            }
            println!(
                "{switches} switches: state {state_error:.1e}, transition {matrix_error:.1e}, \
                 symplectic defect {symplectic:.1e}, finite differences - exact {fd_error:.1e}, \
                 - rk4 {fd_rk:.1e}"
            );
            assert!(switches >= 2, "the test must cross switches");
            assert!(state_error < 1e-8, "{state_error}");
            // Observed: states 3e-11, transitions 3e-10, finite differences 1e-8 (their own
            // truncation at step 1e-6), symplectic defect 7e-15.
            assert!(matrix_error < 1e-8, "{matrix_error}");
            assert!(fd_error < 1e-6 && fd_rk < 1e-6, "{fd_error} {fd_rk}");
            assert!(symplectic < 1e-9, "{symplectic}");
        }
    }
}
