//! The exact periodic orbit of the massless contact boundary at a harmonic-balance point's own
//! master amplitude q (issue 24 item 2; docs/STABILITY.md Sec. 9.4), one level of the converged
//! orbit (`converged`).
//!
//! The stability's shot orbit is the exact orbit *nearest* the harmonic-balance state (a
//! minimum-norm Newton step in (q0, T)); its amplitude differs from the point's by about as much
//! as its frequency does. Here one equation is added: the master's first
//! harmonic q(q0, T) = q_point, the harmonic balance's normalization e . u_1 = q (Sec. 2.6 of the
//! paper). The square system in z = (q0 / s, T / T_ref),
//!
//!   q'(T/2) / v_s = 0 (r rows),   (q(z) - q_point) / |q_point| = 0,
//!
//! is solved by Newton from the point's own state, each residual from one integration over half
//! the period (the orbit is even in time). The last row's derivatives come from the transition
//! matrix at each sample: d u_m(t_i) / d q0 = (d u_m / d q)(t_i) Phi_qq(t_i), and
//! d u_m(t_i) / dT = (i / M) (d u_m / d q)(t_i) q'(t_i), with u_m the master's displacement
//! (kept modes plus the discarded modes' static response to the contact forces, as the exact
//! backbone's `MasterRow`), linear in q on each contact set.

use faer::linalg::solvers::Solve;
use faer::Mat;
use serde::{Deserialize, Serialize};

use crate::free_flow::{BoundaryFlow, FlowState};
use crate::free_shooting::OrbitGuess;
use crate::master_row::{MasterRow, MASTER_SAMPLES};
use crate::model::{norm, BoundaryModel, ModalData};
use nlmodes_hb::HbError;

/// Newton's tolerance on the scaled residual (as the stability's shooting).
const NEWTON_TOLERANCE: f64 = 1e-10;
/// Newton iterations at most.
const NEWTON_ITERATIONS: usize = 30;
/// Step halvings of the line search at most.
const LINE_SEARCH_HALVINGS: usize = 10;
/// Residual evaluations (each an integration over half the period) at most when a finer level
/// starts from the coarser level's orbit: where it converges it takes 2-9 (default blade, 95
/// refinements to N = 40); a
/// level that does not converge within this is reported `solve_failed` instead of running the
/// 30 iterations x 11 trial steps of the first level (up to 20 s for one point of the default
/// blade at 4N; docs/BENCHMARKS.md).
const REFINEMENT_EVALUATIONS: usize = 40;
/// Relative step of the finite difference of the master's displacement in q (exact on a contact
/// set, where it is linear, to rounding).
const MASTER_DIFFERENCE: f64 = 1e-7;

/// One exact orbit of the boundary at a prescribed q.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ExactOrbitAtQ {
    /// The N whose modes were kept dynamic (w_k <= `shooting_cutoff` (N + 1) w).
    pub harmonics: usize,
    /// Modes kept dynamic.
    pub modes: usize,
    /// Circular frequency w (rad/s).
    pub omega: f64,
    /// Share of the period each contact row is closed (exact, from the switch instants).
    pub contact_shares: Vec<f64>,
    /// Contact switches per period.
    pub switches: usize,
    /// Kept modal coordinates at t = 0, where the orbit is at rest (the next level's start).
    #[serde(skip)]
    pub q0: Vec<f64>,
}

/// The exact orbit at `point`'s q with the first `r` modes of `modal` dynamic (those of
/// `harmonics`), from the point's state or from `start`; `None` where the model does not apply
/// (every mode dynamic, R not positive definite) or Newton does not converge.
pub(crate) fn exact_orbit_at_q(
    modal: &ModalData<'_>,
    r: usize,
    point: &OrbitGuess,
    harmonics: usize,
    start: Option<Start<'_>>,
) -> Result<Option<ExactOrbitAtQ>, HbError> {
    if r == modal.omega.len() {
        return Ok(None);
    }
    let Some(model) = modal.model(r, point.penalty.as_deref()) else {
        return Ok(None);
    };
    let mut q0 = modal.coordinates(&point.start, r);
    let mut period = point.period();
    match start {
        Some(Start::Period(t)) => period = t,
        Some(Start::Level(below)) => {
            // The coarser orbit's modes, the new ones from the point's state.
            q0[..below.q0.len()].copy_from_slice(&below.q0);
            period = 2.0 * std::f64::consts::PI / below.omega;
        }
        None => {}
    }
    let equations = AtQ {
        model: &model,
        master: MasterRow::new(modal, r),
        q_target: point.q,
        q_scale: norm(&q0),
        t_ref: point.period(),
        evaluations: match start {
            Some(Start::Level(_)) => REFINEMENT_EVALUATIONS,
            _ => usize::MAX,
        },
    };
    // One flow for the Newton iterations and the shares: its contact sets' pieces are cached.
    let mut flow = BoundaryFlow::new(&model);
    let Some((q0, period)) = equations.solve(&mut flow, q0, period)? else {
        tracing::debug!(q = point.q, harmonics, "exact orbit at q: no convergence");
        return Ok(None);
    };
    let (shares, switches) = equations.shares(&mut flow, &q0, period)?;
    Ok(Some(ExactOrbitAtQ {
        harmonics,
        modes: r,
        omega: 2.0 * std::f64::consts::PI / period,
        contact_shares: shares,
        switches,
        q0,
    }))
}

/// Where a level's Newton starts other than from the point's own state and period.
#[derive(Clone, Copy)]
pub(crate) enum Start<'a> {
    /// The point's modal state at this period (s).
    Period(f64),
    /// The coarser level's orbit (its modes' state and its period; the new modes from the point).
    Level(&'a ExactOrbitAtQ),
}

/// The square system of the module docs for one model and one target q.
struct AtQ<'m> {
    model: &'m BoundaryModel,
    master: MasterRow,
    /// The prescribed first harmonic of the master (m).
    q_target: f64,
    /// s: the norm of the starting q0.
    q_scale: f64,
    /// T_ref (s).
    t_ref: f64,
    /// Residual evaluations Newton may spend.
    evaluations: usize,
}

/// The residual and Jacobian of the square system at one z.
struct AtQResidual {
    value: Vec<f64>,
    jacobian: Mat<f64>,
}

impl AtQ<'_> {
    fn r(&self) -> usize {
        self.model.omega2.len()
    }

    /// Newton with a line search on the residual's norm, from (q0, T).
    fn solve(
        &self,
        flow: &mut BoundaryFlow<'_>,
        q0: Vec<f64>,
        period: f64,
    ) -> Result<Option<(Vec<f64>, f64)>, HbError> {
        let r = self.r();
        if !(self.q_scale > 0.0 && self.q_scale.is_finite() && period > 0.0) {
            return Ok(None);
        }
        let mut z: Vec<f64> = q0.iter().map(|v| v / self.q_scale).collect();
        z.push(period / self.t_ref);
        let mut at = self.residual(flow, &z)?;
        let mut res = norm(&at.value);
        let mut spent = 1;
        for _ in 0..NEWTON_ITERATIONS {
            if res < NEWTON_TOLERANCE {
                let (q, t) = self.state(&z);
                return Ok(Some((q, t)));
            }
            let rhs = Mat::from_fn(r + 1, 1, |i, _| -at.value[i]);
            let step = at.jacobian.partial_piv_lu().solve(&rhs);
            if (0..=r).any(|i| !step[(i, 0)].is_finite()) {
                return Ok(None);
            }
            let mut accepted = false;
            let mut factor = 1.0;
            for _ in 0..=LINE_SEARCH_HALVINGS {
                let trial_z: Vec<f64> = (0..=r).map(|i| z[i] + factor * step[(i, 0)]).collect();
                if spent >= self.evaluations {
                    return Ok(None);
                }
                if trial_z[r] > 0.0 {
                    spent += 1;
                    let trial = self.residual(flow, &trial_z)?;
                    let trial_res = norm(&trial.value);
                    if trial_res < res {
                        (z, at, res) = (trial_z, trial, trial_res);
                        accepted = true;
                        break;
                    }
                }
                factor *= 0.5;
            }
            if !accepted {
                return Ok(None);
            }
        }
        Ok((res < NEWTON_TOLERANCE).then(|| self.state(&z)))
    }

    fn state(&self, z: &[f64]) -> (Vec<f64>, f64) {
        let r = self.r();
        (
            z[..r].iter().map(|v| v * self.q_scale).collect(),
            z[r] * self.t_ref,
        )
    }

    /// The scaled residual and its Jacobian (module docs), from one integration over half the
    /// period: the orbit is even in time (u(T - t) = u(t)) at a solution, so the master's first
    /// harmonic is the trapezoid sum over t_i = i T / M, i = 0..M/2, with weights 2 at the
    /// interior instants, and q'(T/2) with its derivatives is where the same integration ends
    /// (d q'(T/2) / dT = q''(T/2) / 2).
    fn residual(&self, flow: &mut BoundaryFlow<'_>, z: &[f64]) -> Result<AtQResidual, HbError> {
        let r = self.r();
        let (q0, period) = self.state(z);
        let (m, half) = (MASTER_SAMPLES, MASTER_SAMPLES / 2);
        let dt = period / m as f64;
        let mut active = flow.active_set_at(&q0)?;
        let mut state = FlowState {
            q: q0.clone(),
            v: vec![0.0; r],
        };
        let mut transition = Mat::<f64>::identity(2 * r, 2 * r);
        let (mut q, mut d_q0, mut d_period) = (0.0, vec![0.0; r], 0.0);
        let mut accel = vec![0.0; r];
        for i in 0..=half {
            let u = self.master_at(flow, &state, &active)?;
            let gradient = self.master_gradient(flow, &state, &active, u)?;
            let interior = if i == 0 || i == half { 1.0 } else { 2.0 };
            let phase = 2.0 * std::f64::consts::PI * i as f64 / m as f64;
            let weight = interior * 2.0 / m as f64 * phase.cos();
            q += weight * u;
            for (k, d) in d_q0.iter_mut().enumerate() {
                let du: f64 = (0..r).map(|l| gradient[l] * transition[(l, k)]).sum();
                *d += weight * du;
            }
            let rate: f64 = gradient.iter().zip(&state.v).map(|(g, v)| g * v).sum();
            d_period += weight * rate * i as f64 / m as f64;
            if i < half {
                accel = flow.advance(&mut state, &mut active, dt, Some(&mut transition))?;
            }
        }
        let v_scale = self.q_scale * 2.0 * std::f64::consts::PI / self.t_ref;
        let qs = self.q_target.abs();
        let mut value: Vec<f64> = state.v.iter().map(|v| v / v_scale).collect();
        value.push((q - self.q_target) / qs);
        let jacobian = Mat::from_fn(r + 1, r + 1, |i, k| match (i < r, k < r) {
            (true, true) => transition[(r + i, k)] * self.q_scale / v_scale,
            (true, false) => 0.5 * accel[i] * self.t_ref / v_scale,
            (false, true) => d_q0[k] * self.q_scale / qs,
            (false, false) => d_period * self.t_ref / qs,
        });
        Ok(AtQResidual { value, jacobian })
    }

    fn master_at(
        &self,
        flow: &mut BoundaryFlow<'_>,
        state: &FlowState,
        active: &[bool],
    ) -> Result<f64, HbError> {
        let lambda = flow.contact_force(state, active)?;
        Ok(self.master.at(&state.q, &lambda))
    }

    /// d u_m / d q on the contact set `active` (linear there: a forward difference is exact to
    /// rounding).
    fn master_gradient(
        &self,
        flow: &mut BoundaryFlow<'_>,
        state: &FlowState,
        active: &[bool],
        u: f64,
    ) -> Result<Vec<f64>, HbError> {
        let h = MASTER_DIFFERENCE * self.q_scale;
        (0..self.r())
            .map(|k| {
                let mut shifted = state.clone();
                shifted.q[k] += h;
                Ok((self.master_at(flow, &shifted, active)? - u) / h)
            })
            .collect()
    }

    /// The exact contact shares and switches of the orbit from rest at q0 over one period.
    fn shares(
        &self,
        flow: &mut BoundaryFlow<'_>,
        q0: &[f64],
        period: f64,
    ) -> Result<(Vec<f64>, usize), HbError> {
        let mut active = flow.active_set_at(q0)?;
        let mut state = FlowState {
            q: q0.to_vec(),
            v: vec![0.0; q0.len()],
        };
        let (closed, switches) = (flow.closed_time.clone(), flow.switches);
        flow.advance(&mut state, &mut active, period, None)?;
        let shares = (flow.closed_time.iter().zip(&closed))
            .map(|(after, before)| (after - before) / period)
            .collect();
        Ok((shares, flow.switches - switches))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::test_models::{bilinear, bilinear_period, three_modes};

    /// The master's first harmonic of the orbit from rest at q0, over the full period with 4096
    /// samples (independent of the solver's half-period sum of 65).
    fn first_harmonic_full(model: &BoundaryModel, master: &MasterRow, q0: &[f64], t: f64) -> f64 {
        let m = 4096;
        let mut flow = BoundaryFlow::new(model);
        let mut active = flow.active_set_at(q0).expect("active set");
        let mut state = FlowState {
            q: q0.to_vec(),
            v: vec![0.0; q0.len()],
        };
        let mut sum = 0.0;
        for i in 0..m {
            let lambda = flow.contact_force(&state, &active).expect("forces");
            let phase = 2.0 * std::f64::consts::PI * i as f64 / m as f64;
            sum += master.at(&state.q, &lambda) * phase.cos();
            flow.advance(&mut state, &mut active, t / m as f64, None)
                .expect("advance");
        }
        2.0 * sum / m as f64
    }

    fn solve(
        model: &BoundaryModel,
        master: MasterRow,
        target: f64,
        q0: Vec<f64>,
        t: f64,
    ) -> (Vec<f64>, f64) {
        let equations = AtQ {
            model,
            master,
            q_target: target,
            q_scale: norm(&q0),
            t_ref: t,
            evaluations: usize::MAX,
        };
        let mut flow = BoundaryFlow::new(model);
        equations
            .solve(&mut flow, q0, t)
            .expect("solve")
            .expect("converged")
    }

    #[test]
    fn the_bilinear_orbit_at_a_prescribed_amplitude_has_the_exact_period() {
        for flex in [0.1, 1.0, 10.0] {
            let model = bilinear(flex);
            for target in [1.2, 2.0, 5.0] {
                let master = || MasterRow::from_coefficients(vec![1.0], vec![0.0]);
                // From 10 % off in amplitude and 5 % off in period.
                let start = 1.1 * target;
                let (q0, t) = solve(
                    &model,
                    master(),
                    target,
                    vec![start],
                    2.0 * std::f64::consts::PI * 0.95,
                );
                let exact = bilinear_period(flex, q0[0]);
                let q = first_harmonic_full(&model, &master(), &q0, t);
                println!(
                    "R = {flex}, q = {target}: q0 = {:.6}, T error {:.1e}, q error {:.1e}",
                    q0[0],
                    (t / exact - 1.0).abs(),
                    (q / target - 1.0).abs()
                );
                // Newton's tolerance 1e-10 on the scaled residual.
                assert!((t / exact - 1.0).abs() < 1e-9, "R = {flex}, q = {target}");
                // The half-period trapezoid sum of 65 instants against 4096 over the full
                // period: equal up to the aliasing of the harmonics near 127 of the orbit's kinks
                // (measured 3e-11 to 1.9e-8).
                assert!(
                    (q / target - 1.0).abs() < 1e-6,
                    "R = {flex}, q = {target}: {q}"
                );
                assert!(q0[0] > 1.0, "in contact");
            }
        }
    }

    #[test]
    fn a_three_mode_orbit_at_q_is_periodic_and_has_that_amplitude() {
        let model = three_modes();
        let master = || MasterRow::from_coefficients(vec![1.0, 0.5, 0.2], vec![0.1, 0.0, 0.05]);
        let target = 1.5;
        let (q0, t) = solve(
            &model,
            master(),
            target,
            vec![1.6, 0.0, 0.0],
            2.0 * std::f64::consts::PI,
        );
        // Periodic: back at q0 at rest after T.
        let mut flow = BoundaryFlow::new(&model);
        let mut active = flow.active_set_at(&q0).expect("active");
        let mut state = FlowState {
            q: q0.clone(),
            v: vec![0.0; 3],
        };
        flow.advance(&mut state, &mut active, t, None)
            .expect("advance");
        let back = state
            .q
            .iter()
            .zip(&q0)
            .map(|(a, b)| (a - b).abs())
            .fold(0.0, f64::max);
        let rest = state.v.iter().fold(0.0_f64, |a, v| a.max(v.abs()));
        let q = first_harmonic_full(&model, &master(), &q0, t);
        println!(
            "three modes: T = {t:.6}, return {back:.1e}, rest {rest:.1e}, q = {q:.6}, switches {}",
            flow.switches
        );
        assert!(back < 1e-8 && rest < 1e-8, "{back} {rest}");
        // As above, with the kinks of three modes' contact phases: measured 9e-6.
        assert!((q / target - 1.0).abs() < 1e-4, "{q}");
        assert!(flow.switches >= 2, "the orbit touches");
    }
}
