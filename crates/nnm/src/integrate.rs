//! Time integration with a penalty contact law, independent of harmonic balance (docs/DESIGN.md §5: any
//! computed orbit, integrated from its own t = 0 state, must come back to itself after one period).
//!
//! Equation: M u'' + K u + A^T lambda = 0 with lambda_j = kc_j max(0, A_j u - g0_j), integrated by
//! the classical fourth-order Runge-Kutta scheme with a fixed step. The right-hand side is
//! continuous and piecewise linear in u, so the solution is C^2 in time and the scheme keeps at
//! least third order at the (finitely many) contact transitions.

use faer::{Mat, MatRef, Par};
use serde::Serialize;

use crate::point::BackbonePoint;
use crate::NnmError;
use nlmodes_dense::{cholesky_lower, generalized_eigen};
use nlmodes_hb::check::{at_least_one, require};
use nlmodes_hb::system::System;

/// Displacement and velocity.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct MotionState {
    /// Displacements u (length unit of the system).
    pub u: Vec<f64>,
    /// Velocities du/dt (length per second).
    pub v: Vec<f64>,
}

/// RK4 stability bound on the imaginary axis is 2 sqrt(2) ~ 2.83; we require h w_max <= 2.5.
const RK4_LIMIT: f64 = 2.5;

/// Errors when the RK4 step `h` exceeds the stability limit of the stiffest mode of
/// (`stiffness`, M) over an integration of `duration` seconds (the error says how many steps
/// would do).
pub(crate) fn check_rk4_step(
    system: &System,
    stiffness: faer::MatRef<'_, f64>,
    h: f64,
    duration: f64,
) -> Result<(), NnmError> {
    let eig = generalized_eigen(stiffness, system.mass()).map_err(NnmError::dense("M"))?;
    let omega_max = eig.values.last().copied().unwrap_or(0.0).max(0.0).sqrt();
    if h * omega_max > RK4_LIMIT {
        let max_step = RK4_LIMIT / omega_max;
        return Err(NnmError::StepTooLarge {
            step: h,
            omega_max,
            max_step,
            min_steps: (duration / max_step).ceil() as usize,
        });
    }
    Ok(())
}

/// Integrates `duration` seconds in `steps` RK4 steps from `initial`, with penalty stiffnesses
/// `penalty[j]` (force per length, one per contact row). Errors on inconsistent sizes, and when
/// the step exceeds the RK4 stability limit of the stiffest mode of (K + A^T kc A, M).
pub fn integrate_penalty(
    system: &System,
    penalty: &[f64],
    initial: &MotionState,
    duration: f64,
    steps: usize,
) -> Result<MotionState, NnmError> {
    check_integration_inputs(system, penalty, initial, duration, steps)?;
    let h = duration / steps as f64;
    // Stiffest mode of the penalized system.
    let kp = penalized_stiffness(system, penalty);
    check_rk4_step(system, kp.as_ref(), h, duration)?;
    let dynamics = PenaltyDynamics::new(system, penalty)?;
    let mut rk4 = Rk4Stages::new(system.n_dofs(), system.n_contacts());
    let mut u = initial.u.clone();
    let mut v = initial.v.clone();
    for _ in 0..steps {
        rk4.step(&dynamics, &mut u, &mut v, h);
    }
    if u.iter().chain(&v).any(|x| !x.is_finite()) {
        return Err(NnmError::NonFiniteResult {
            what: "time integration",
        });
    }
    Ok(MotionState { u, v })
}

/// The arguments of [`integrate_penalty`]: one finite penalty >= 0 per contact row, states of
/// length n, a finite duration > 0 and at least one step.
fn check_integration_inputs(
    system: &System,
    penalty: &[f64],
    initial: &MotionState,
    duration: f64,
    steps: usize,
) -> Result<(), NnmError> {
    let (n, c) = (system.n_dofs(), system.n_contacts());
    let rows = penalty.len();
    require(
        "penalty",
        rows as f64,
        rows == c,
        "one penalty stiffness per contact row",
    )?;
    if let Some(&bad) = penalty.iter().find(|v| !(v.is_finite() && **v >= 0.0)) {
        require("penalty", bad, false, "finite penalty stiffnesses >= 0")?;
    }
    require(
        "initial state length",
        initial.u.len().max(initial.v.len()) as f64,
        initial.u.len() == n && initial.v.len() == n,
        "u and v of length n (the number of DOFs)",
    )?;
    let finite_positive = duration.is_finite() && duration > 0.0;
    require(
        "duration",
        duration,
        finite_positive,
        "a finite duration > 0",
    )?;
    at_least_one("steps", steps)
}

/// K + A^T diag(kc) A: the stiffness with every contact row closed (N/m).
fn penalized_stiffness(system: &System, penalty: &[f64]) -> Mat<f64> {
    let (n, c) = (system.n_dofs(), system.n_contacts());
    let a = system.contact_rows();
    Mat::from_fn(n, n, |i, j| {
        system.stiffness()[(i, j)]
            + (0..c)
                .map(|l| penalty[l] * a[(l, i)] * a[(l, j)])
                .sum::<f64>()
    })
}

/// u'' = -M^-1 K u - M^-1 A^T lambda(u) with lambda_j = kc_j max(0, A_j u - g0_j).
struct PenaltyDynamics<'a> {
    contact_rows: MatRef<'a, f64>,
    gaps: &'a [f64],
    penalty: &'a [f64],
    /// M^-1 K and M^-1 A^T.
    mk: Mat<f64>,
    ma: Mat<f64>,
}

impl<'a> PenaltyDynamics<'a> {
    fn new(system: &'a System, penalty: &'a [f64]) -> Result<Self, NnmError> {
        let a = system.contact_rows();
        let l = cholesky_lower(system.mass()).map_err(NnmError::dense("M"))?;
        let solve_m = |mut b: Mat<f64>| {
            faer::linalg::triangular_solve::solve_lower_triangular_in_place(
                l.as_ref(),
                b.as_mut(),
                Par::Seq,
            );
            faer::linalg::triangular_solve::solve_upper_triangular_in_place(
                l.transpose(),
                b.as_mut(),
                Par::Seq,
            );
            b
        };
        Ok(Self {
            contact_rows: a,
            gaps: system.gaps(),
            penalty,
            mk: solve_m(system.stiffness().to_owned()),
            ma: solve_m(a.transpose().to_owned()),
        })
    }

    /// Writes the acceleration at displacement `u` into `out` (`lam`: contact-force scratch).
    fn acceleration(&self, u: &[f64], out: &mut [f64], lam: &mut [f64]) {
        let (a, n) = (self.contact_rows, u.len());
        for j in 0..lam.len() {
            let g: f64 = (0..n).map(|i| a[(j, i)] * u[i]).sum::<f64>() - self.gaps[j];
            lam[j] = self.penalty[j] * g.max(0.0);
        }
        for (i, o) in out.iter_mut().enumerate() {
            let mut v = 0.0;
            for (jj, uj) in u.iter().enumerate() {
                v -= self.mk[(i, jj)] * uj;
            }
            for (j, l) in lam.iter().enumerate() {
                v -= self.ma[(i, j)] * l;
            }
            *o = v;
        }
    }
}

/// The stages of the classical RK4 scheme (reused between steps).
struct Rk4Stages {
    k1: (Vec<f64>, Vec<f64>),
    k2: (Vec<f64>, Vec<f64>),
    k3: (Vec<f64>, Vec<f64>),
    k4: (Vec<f64>, Vec<f64>),
    tmp: Vec<f64>,
    lam: Vec<f64>,
}

impl Rk4Stages {
    fn new(n: usize, c: usize) -> Self {
        let pair = || (vec![0.0; n], vec![0.0; n]);
        Self {
            k1: pair(),
            k2: pair(),
            k3: pair(),
            k4: pair(),
            tmp: vec![0.0; n],
            lam: vec![0.0; c],
        }
    }

    /// One step of length `h` (s) of (u, v).
    fn step(&mut self, dynamics: &PenaltyDynamics<'_>, u: &mut [f64], v: &mut [f64], h: f64) {
        let n = u.len();
        let Self {
            k1: (k1u, k1v),
            k2: (k2u, k2v),
            k3: (k3u, k3v),
            k4: (k4u, k4v),
            tmp,
            lam,
        } = self;
        k1u.copy_from_slice(v);
        dynamics.acceleration(u, k1v, lam);
        for i in 0..n {
            tmp[i] = u[i] + 0.5 * h * k1u[i];
            k2u[i] = v[i] + 0.5 * h * k1v[i];
        }
        dynamics.acceleration(tmp, k2v, lam);
        for i in 0..n {
            tmp[i] = u[i] + 0.5 * h * k2u[i];
            k3u[i] = v[i] + 0.5 * h * k2v[i];
        }
        dynamics.acceleration(tmp, k3v, lam);
        for i in 0..n {
            tmp[i] = u[i] + h * k3u[i];
            k4u[i] = v[i] + h * k3v[i];
        }
        dynamics.acceleration(tmp, k4v, lam);
        for i in 0..n {
            u[i] += h / 6.0 * (k1u[i] + 2.0 * k2u[i] + 2.0 * k3u[i] + k4u[i]);
            v[i] += h / 6.0 * (k1v[i] + 2.0 * k2v[i] + 2.0 * k3v[i] + k4v[i]);
        }
    }
}

/// Result of integrating a computed orbit over one period.
#[derive(Clone, Debug, Serialize)]
pub struct PeriodicityCheck {
    /// max_i |u_i(T) - u_i(0)| / max_i |u_i(0)|.
    pub displacement_error: f64,
    /// max_i |v_i(T)| / (w max_i |u_i(0)|) (v(0) = 0 at the turning point).
    pub velocity_error: f64,
    /// State reached after one period.
    pub end: MotionState,
}

/// Integrates `point` from its t = 0 state (u(0) = sum_n u_n, v(0) = 0) over one period
/// T = 2 pi / w with the penalty law `penalty` and `steps` RK4 steps, and compares.
pub fn check_periodicity(
    system: &System,
    penalty: &[f64],
    point: &BackbonePoint,
    steps: usize,
) -> Result<PeriodicityCheck, NnmError> {
    let n = system.n_dofs();
    let u0 = point.displacement_at(0.0);
    if u0.len() != n {
        return Err(NnmError::WarmStart {
            detail: format!("the point has {} DOFs, the system {n}", u0.len()),
        });
    }
    let start = MotionState {
        u: u0.clone(),
        v: vec![0.0; n],
    };
    let end = integrate_penalty(system, penalty, &start, point.period(), steps)?;
    let scale = u0
        .iter()
        .fold(0.0_f64, |a, v| a.max(v.abs()))
        .max(f64::MIN_POSITIVE);
    let du = end
        .u
        .iter()
        .zip(&u0)
        .fold(0.0_f64, |a, (x, y)| a.max((x - y).abs()));
    let dv = end.v.iter().fold(0.0_f64, |a, v| a.max(v.abs()));
    Ok(PeriodicityCheck {
        displacement_error: du / scale,
        velocity_error: dv / (point.omega * scale),
        end,
    })
}
