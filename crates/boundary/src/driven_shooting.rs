//! The periodic orbit of the driven massless boundary next to a forced harmonic-balance orbit,
//! by shooting with W free, and the shooting equations its exact response curve continues
//! (`driven_curve`; DESIGN §10.6).
//!
//! The forced periodic orbits form a curve in (x0, W): the 2r equations x(T) - x(0) = 0 in the
//! 2r + 1 scaled unknowns z = (q / s, q' / (s W_ref), W / W_ref). Their Jacobian is the exact
//! monodromy of `driven_flow` minus the identity for the x0 columns (the flow is Lipschitz: no
//! saltation) and a finite difference for the W column.

use faer::linalg::solvers::Solve;
use faer::Mat;

use crate::arc_length::min_norm_step;
use crate::driven_flow::DrivenFlow;
use crate::driven_model::DrivenBoundary;
use nlmodes_hb::HbError;

/// Newton on x(T) = x(0) stops below this scaled residual.
const SHOOTING_TOLERANCE: f64 = 1e-10;
/// Newton iterations before giving up.
const SHOOTING_ITERATIONS: usize = 20;
/// Newton gives up when the scaled residual exceeds this: the period map misses the start by
/// ten times the orbit's own size, Newton has left the orbit it started next to. Out there
/// the flow crosses contact many times a period and each iterate costs up to 1 s on the blade
/// (measured, session 25: shootings at the point's own W on the EO 3 sweep climbed from
/// 8e-3 to 1e2..2e3 and spent 11-21 s each over their 20 iterations without converging).
const SHOOTING_DIVERGED: f64 = 10.0;

/// A periodic orbit of the driven boundary and its monodromy.
#[derive(Clone, Debug)]
pub struct DrivenOrbit {
    /// (q, q') at t = 0.
    pub start: Vec<f64>,
    /// Its excitation frequency W (rad/s).
    pub omega: f64,
    /// Monodromy in (q, q') (2r x 2r).
    pub monodromy: Mat<f64>,
    /// Newton iterations taken.
    pub iterations: usize,
    /// Distance from the guess in the scaled unknowns (q / |q|, q' / (W |q|), W / W_guess).
    pub shift: f64,
}

/// x(T) - x(0) at (x0, W) in the scaled state, and the monodromy.
fn period_map(
    model: &DrivenBoundary,
    x0: &[f64],
    q_scale: f64,
) -> Result<(Vec<f64>, Mat<f64>), HbError> {
    let r = model.r();
    let scale = |i: usize| {
        if i < r {
            q_scale
        } else {
            q_scale * model.omega
        }
    };
    let mut flow = DrivenFlow::new(model);
    let mut x = model.augmented(&x0[..r], &x0[r..], 0.0);
    let mut active = flow.active_set_at(&x)?;
    let mut phi = Mat::<f64>::identity(2 * r, 2 * r);
    let period = 2.0 * std::f64::consts::PI / model.omega;
    flow.advance(&mut x, &mut active, period, Some(&mut phi))?;
    let residual = (0..2 * r).map(|i| (x[i] - x0[i]) / scale(i)).collect();
    Ok((residual, phi))
}

/// Relative step of W for the finite-difference column d(x(T) - x0) / dW.
const OMEGA_STEP: f64 = 1e-7;

/// The shooting equations of a driven boundary in scaled unknowns z = (q / s, q' / (s W_ref),
/// W / W_ref) (2r + 1 of them; s = `q_scale` in the modal coordinates' units, W_ref in rad/s)
/// and scaled equations x(T) - x(0) (q part / s, q' part / (s W); 2r of them). Shared by the
/// shooting next to a harmonic-balance orbit and the continuation of the exact response curve
/// (`crate::driven_curve`).
pub(crate) struct ShootingEquations<'m> {
    pub model: &'m DrivenBoundary,
    pub q_scale: f64,
    pub w_ref: f64,
}

impl ShootingEquations<'_> {
    fn scale(&self, i: usize) -> f64 {
        if i < self.model.r() {
            self.q_scale
        } else {
            self.q_scale * self.w_ref
        }
    }

    /// z from (q, q') and W.
    pub fn unknowns(&self, x0: &[f64], omega: f64) -> Vec<f64> {
        let mut z: Vec<f64> = x0
            .iter()
            .enumerate()
            .map(|(i, v)| v / self.scale(i))
            .collect();
        z.push(omega / self.w_ref);
        z
    }

    /// ((q, q'), W) from z.
    pub fn state(&self, z: &[f64]) -> (Vec<f64>, f64) {
        let n = z.len() - 1;
        let x0 = (0..n).map(|i| z[i] * self.scale(i)).collect();
        (x0, z[n] * self.w_ref)
    }

    /// The scaled residual at z and the monodromy (2r x 2r).
    pub fn residual(&self, z: &[f64]) -> Result<(Vec<f64>, Mat<f64>), HbError> {
        let (x0, omega) = self.state(z);
        period_map(&self.model.at(omega), &x0, self.q_scale)
    }

    /// The Jacobian (2r x (2r + 1)) at z, from its residual and monodromy: the exact monodromy
    /// for the x0 columns, a finite difference of relative step `OMEGA_STEP` for the W column.
    pub fn jacobian(
        &self,
        z: &[f64],
        residual: &[f64],
        phi: &Mat<f64>,
    ) -> Result<Mat<f64>, HbError> {
        let r = self.model.r();
        let (x0, omega) = self.state(z);
        let (res_w, _) = period_map(
            &self.model.at(omega * (1.0 + OMEGA_STEP)),
            &x0,
            self.q_scale,
        )?;
        let state = self.state_columns(phi, omega);
        Ok(Mat::from_fn(2 * r, 2 * r + 1, |i, j| {
            if j < 2 * r {
                state[(i, j)]
            } else {
                (res_w[i] - residual[i]) / (OMEGA_STEP * omega / self.w_ref)
            }
        }))
    }

    /// The Jacobian's x0 columns (2r x 2r) at W = `omega` from the monodromy: (phi - I) in the
    /// scaled unknowns and equations.
    fn state_columns(&self, phi: &Mat<f64>, omega: f64) -> Mat<f64> {
        let r = self.model.r();
        // The residual's velocity part is scaled by the current W, the unknowns by W_ref.
        let vel = |i: usize| if i < r { 1.0 } else { self.w_ref / omega };
        Mat::from_fn(2 * r, 2 * r, |i, j| {
            (phi[(i, j)] - if i == j { 1.0 } else { 0.0 }) * self.scale(j) / self.scale(i) * vel(i)
        })
    }
}

/// The periodic orbit of the driven boundary nearest the guess (q, q') at t = 0 and W =
/// `model.omega`. The forced periodic orbits form a curve in (x0, W), so W is an unknown too and
/// the minimum-norm Newton step (scaled unknowns q / |q|, q' / (W |q|), W / W_guess; the exact
/// monodromy for the x0 columns, a finite difference of relative step 1e-7 for the W column)
/// goes to the point of that curve nearest the harmonic-balance orbit: on a steep flank the
/// boundary model's curve is reached by a small change of W, not of the amplitude. `None` when
/// Newton does not converge.
pub fn shoot_driven(model: &DrivenBoundary, guess: &[f64]) -> Result<Option<DrivenOrbit>, HbError> {
    shoot(model, guess, FrequencyUnknown::Free)
}

/// The periodic orbit of the driven boundary at W = `model.omega` itself nearest the guess
/// (q, q') at t = 0: Newton on x(T) = x(0) in (q, q') alone. Where the multipliers change fast
/// along the curve (next to a bifurcation), the orbit of `shoot_driven`, at a nearby W, may
/// have another verdict than the orbit at the point's own W: `boundary_monodromy` compares
/// the two. `None` when Newton does not converge.
pub fn shoot_driven_at_fixed_frequency(
    model: &DrivenBoundary,
    guess: &[f64],
) -> Result<Option<DrivenOrbit>, HbError> {
    shoot(model, guess, FrequencyUnknown::Fixed)
}

/// Whether W is an unknown of the shooting.
#[derive(Clone, Copy, PartialEq, Eq)]
enum FrequencyUnknown {
    Free,
    Fixed,
}

/// Newton (minimum-norm with W free) on the scaled shooting equations from `guess`.
fn shoot(
    model: &DrivenBoundary,
    guess: &[f64],
    frequency: FrequencyUnknown,
) -> Result<Option<DrivenOrbit>, HbError> {
    let r = model.r();
    let q_scale = guess[..r].iter().map(|v| v * v).sum::<f64>().sqrt();
    if q_scale.is_nan() || q_scale <= 0.0 {
        return Ok(None);
    }
    let equations = ShootingEquations {
        model,
        q_scale,
        w_ref: model.omega,
    };
    let z_guess = equations.unknowns(guess, model.omega);
    let mut z = z_guess.clone();
    for iteration in 0..=SHOOTING_ITERATIONS {
        let (residual, phi) = equations.residual(&z)?;
        let norm = residual.iter().map(|v| v * v).sum::<f64>().sqrt();
        if norm < SHOOTING_TOLERANCE {
            let shift = z
                .iter()
                .zip(&z_guess)
                .map(|(a, b)| (a - b).powi(2))
                .sum::<f64>();
            let (start, omega) = equations.state(&z);
            return Ok(Some(DrivenOrbit {
                start,
                omega,
                monodromy: phi,
                iterations: iteration,
                shift: shift.sqrt(),
            }));
        }
        if iteration == SHOOTING_ITERATIONS || !norm.is_finite() || norm > SHOOTING_DIVERGED {
            break;
        }
        let step = match frequency {
            FrequencyUnknown::Free => {
                min_norm_step(&equations.jacobian(&z, &residual, &phi)?, &residual)
            }
            FrequencyUnknown::Fixed => {
                square_step(&equations.state_columns(&phi, model.omega), &residual)
            }
        };
        let Some(step) = step else {
            break;
        };
        // At a fixed W the step has 2r entries and leaves z's last (W) alone.
        z.iter_mut().zip(&step).for_each(|(v, d)| *v += d);
    }
    Ok(None)
}

/// The Newton step d of J d = -residual for a square J, `None` where it is not finite.
fn square_step(jac: &Mat<f64>, residual: &[f64]) -> Option<Vec<f64>> {
    let rhs = Mat::from_fn(jac.nrows(), 1, |i, _| -residual[i]);
    let step = jac.partial_piv_lu().solve(&rhs);
    let step: Vec<f64> = (0..jac.ncols()).map(|i| step[(i, 0)]).collect();
    step.iter().all(|v| v.is_finite()).then_some(step)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rk4::{integrate, Rk4State};
    use crate::test_models::driven_three_modes as model;

    /// How far RK4 (40000 steps over the period of `at`, the model at the orbit's W) brings
    /// the three-mode orbit back to its start: the largest difference of q or q'.
    fn rk4_period_gap(at: &DrivenBoundary, orbit: &DrivenOrbit) -> f64 {
        let period = 2.0 * std::f64::consts::PI / at.omega;
        let start = Rk4State {
            q: orbit.start[..3].to_vec(),
            v: orbit.start[3..].to_vec(),
        };
        let (end, _) = integrate(at, &start, period, 40_000).expect("rk4");
        (0..3)
            .map(|i| {
                (end.q[i] - start.q[i])
                    .abs()
                    .max((end.v[i] - start.v[i]).abs())
            })
            .fold(0.0, f64::max)
    }

    #[test]
    fn the_orbit_shot_at_a_fixed_frequency_keeps_it_and_is_periodic_for_rk4() {
        let m = model(0.9);
        let guess = [2.0, 0.2, -0.1, 0.1, 0.3, 0.5];
        let orbit = shoot_driven_at_fixed_frequency(&m, &guess)
            .expect("shooting")
            .expect("converges");
        assert_eq!(orbit.omega, m.omega);
        let gap = rk4_period_gap(&m, &orbit);
        assert!(gap < 1e-8, "{gap:e}");
    }

    #[test]
    fn the_shot_driven_orbit_is_periodic_for_rk4_and_lies_on_the_curve() {
        let m = model(0.9);
        // A start off the periodic orbit: Newton must find the curve nearby.
        let guess = [2.0, 0.2, -0.1, 0.1, 0.3, 0.5];
        let orbit = shoot_driven(&m, &guess)
            .expect("shooting")
            .expect("converges");
        let gap = rk4_period_gap(&m.at(orbit.omega), &orbit);
        println!(
            "W = {:.6} (guess 0.9), {} iterations, shift {:.3}, RK4 period gap {gap:.1e}",
            orbit.omega, orbit.iterations, orbit.shift
        );
        assert!(gap < 1e-8, "{gap}");
    }

    /// Under a moving gap (`driven_three_modes_moving_gap`) the shot orbit is periodic for RK4
    /// and the RK4 check (`check_driven_by_rk4`: the contact problem solved at every stage with
    /// that instant's gaps, 200 steps per fastest period) gives its multipliers within
    /// `SHOOTING_CHECK_LIMIT`: the check a moving-gap verdict on a model gets.
    #[test]
    fn the_shot_orbit_under_a_moving_gap_is_confirmed_by_the_rk4_check() {
        let m = crate::test_models::driven_three_modes_moving_gap(0.9);
        let guess = [2.0, 0.2, -0.1, 0.1, 0.3, 0.5];
        let orbit = shoot_driven(&m, &guess)
            .expect("shooting")
            .expect("converges");
        let at = m.at(orbit.omega);
        let trace = 0.15;
        let period = 2.0 * std::f64::consts::PI / orbit.omega;
        let b = crate::driven_stability::BoundaryMonodromy {
            monodromy: nlmodes_hb::floquet::multipliers_of(orbit.monodromy, trace, period)
                .expect("multipliers"),
            shift: orbit.shift,
            modes: 3,
            model: at,
            start: orbit.start,
            fixed_frequency_largest: None,
        };
        let check = crate::rk4_check::check_driven_by_rk4(&b).expect("rk4");
        let samples = crate::driven_flow::sample_orbit(&b.model, &b.start, 2000).expect("orbit");
        let touching = samples
            .iter()
            .filter(|s| s.lambda.iter().any(|l| *l > 0.0))
            .count();
        println!(
            "moving gap: W = {:.6} (guess 0.9), {} iterations, |mu| = {:.6}, in contact at \
             {touching} of 2000 instants; RK4 ({} steps): periodic to {:.1e}, |mu| {:.6} \
             ({:.1e}), multipliers within {:.1e}",
            orbit.omega,
            orbit.iterations,
            b.monodromy.largest(),
            check.steps,
            check.periodicity,
            check.max_multiplier_abs,
            check.max_multiplier_change,
            check.multiplier_distance
        );
        assert!(touching > 0 && touching < 2000, "{touching}");
        assert!(check.agrees(), "{check:?}");
        assert!(check.multiplier_distance < 1e-6, "{check:?}");
    }
}
