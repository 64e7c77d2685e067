//! The speed column of the bordered Newton solve of a speed sweep (`following::Following`,
//! DESIGN §10.10) against a central difference of its residual along W = e Omega.
//!
//! A 3-DOF system turning (K(Omega) = K0 + S Omega^2 M, modal damping on the modes at each
//! speed, the running gap g0 (1 - a (Omega / Omega_r)^2)) in contact under the penalty law: the
//! column e dR/dW + dR/dOmega|_W the Newton matrix carries (as dR/dW along the speed line, the
//! row's parameter being W) must be the derivative of R(y, W; structure at W / e) at fixed y.

use faer::Mat;
use nlmodes_hb::penalty_integral::ContactPhases;
use nlmodes_hb::{FullBasis, HarmonicSettings, Multipliers, System};

use crate::damping::Damping;
use crate::dynamics::ModalDynamics;
use crate::error::ForcedError;
use crate::following::{Following, MovingStructure};
use crate::load::Load;
use crate::newton::{ArcRow, ForceIntegration, InnerNewton, InnerTolerance, OrbitState, Parameter};

/// Engine order, N, speed scale Omega_r (rad/s), S, gap shrink a, penalty k (N/m).
const E: f64 = 3.0;
const N: usize = 3;
const SPEED_REF: f64 = 0.4;
const S: f64 = 0.3;
const SHRINK: f64 = 0.2;
const GAP: f64 = 0.05;
const PENALTY: f64 = 40.0;

/// The turning 3-DOF system at W / e, or frozen at one speed (`frozen`).
struct Turning {
    frozen: Option<f64>,
}

impl Turning {
    fn system(speed: f64) -> System {
        let m = [[2.0, 0.3, 0.0], [0.3, 1.0, 0.2], [0.0, 0.2, 1.5]];
        let k = [[3.0, -1.0, 0.0], [-1.0, 2.5, -1.0], [0.0, -1.0, 1.2]];
        let (m, k0) = (
            Mat::from_fn(3, 3, |i, j| m[i][j]),
            Mat::from_fn(3, 3, |i, j| k[i][j]),
        );
        let k = Mat::from_fn(3, 3, |i, j| k0[(i, j)] + S * speed * speed * m[(i, j)]);
        let rows = Mat::from_fn(1, 3, |_, j| [0.2, 0.0, 1.0][j]);
        let gap = GAP * (1.0 - SHRINK * (speed / SPEED_REF).powi(2));
        System::new(m, k, rows, vec![gap], 2).expect("3-DOF system")
    }
}

impl MovingStructure for Turning {
    fn at(&self, omega: f64) -> Result<(ModalDynamics, Vec<f64>), ForcedError> {
        let system = Turning::system(self.frozen.unwrap_or(omega / E));
        let damping = Damping::ModalRatios(vec![0.02, 0.05]).matrix(&system)?;
        let load = Load::fundamental(vec![0.0, 0.0, 0.04]);
        let dynamics = ModalDynamics::new(&system, &damping, &load, N)?;
        Ok((dynamics, system.gaps().to_vec()))
    }
}

/// (R, dR/dW column) at W for the structure `moving`, at the orbit `y`.
/// The inner Newton of the test's penalty problem on `dynamics` at gaps `g0`, following the
/// structure's motion when `following` is given.
fn inner_newton<'p>(
    dynamics: &'p ModalDynamics,
    basis: &'p FullBasis,
    g0: &'p [f64],
    following: Option<Following<'p>>,
) -> InnerNewton<'p> {
    InnerNewton {
        dynamics,
        basis,
        g0,
        y_scale: GAP,
        settings: InnerTolerance {
            tolerance: 1e-10,
            max_iterations: 30,
        },
        cache: None,
        blended: Default::default(),
        smoothing: 0.0,
        integration: ForceIntegration::ExactPenalty {
            stiffness: PENALTY,
            phases: ContactPhases::new(basis.harmonics(), basis.samples()),
        },
        casing: &[],
        following,
    }
}

fn residual_and_column(
    moving: &Turning,
    basis: &FullBasis,
    y: &[f64],
    omega: f64,
) -> (Vec<f64>, Vec<f64>) {
    let (dynamics, g0) = moving.at(omega).unwrap();
    let mut newton = inner_newton(&dynamics, basis, &g0, Some(Following::new(moving)));
    let mu = Multipliers::uniform(&[PENALTY], basis.samples());
    let state = OrbitState {
        y: y.to_vec(),
        omega,
        level: 1.0,
    };
    newton.residual_and_column(&state, &mu).unwrap()
}

/// An orbit well in contact: mean near the gap, a first harmonic of 0.6 gap and a second.
fn orbit_in_contact(basis: &FullBasis) -> Vec<f64> {
    let mut y = vec![0.0; basis.terms()];
    y[0] = 0.7 * GAP;
    y[FullBasis::cos_index(1)] = 0.5 * GAP;
    y[FullBasis::sin_index(1)] = 0.3 * GAP;
    y[FullBasis::cos_index(2)] = 0.1 * GAP;
    y
}

/// The column against the central difference of R over W +- 1e-5 W (the law is integrated
/// exactly: R is C^1 in W, and the difference's error, O(1e-10) of the column from its
/// O(h^2) truncation and round-off, is far below the tolerance); the column of the frozen
/// structure (dR/dW alone) misses the structure's motion by far more than the tolerance.
#[test]
fn speed_column_is_the_derivative_along_the_speed_line() {
    let basis = FullBasis::new(HarmonicSettings::with_default_samples(N).unwrap()).unwrap();
    let speed = 0.35;
    let omega = E * speed;
    let y = orbit_in_contact(&basis);
    let moving = Turning { frozen: None };
    let (_, column) = residual_and_column(&moving, &basis, &y, omega);
    let h = 1e-5 * omega;
    let (rp, _) = residual_and_column(&moving, &basis, &y, omega + h);
    let (rm, _) = residual_and_column(&moving, &basis, &y, omega - h);
    let fd: Vec<f64> = rp
        .iter()
        .zip(&rm)
        .map(|(a, b)| (a - b) / (2.0 * h))
        .collect();
    let scale = fd.iter().fold(0.0_f64, |a, v| a.max(v.abs()));
    let error = column
        .iter()
        .zip(&fd)
        .fold(0.0_f64, |a, (c, f)| a.max((c - f).abs()));
    eprintln!("column error {error:e} of {scale:e}");
    assert!(
        scale > 0.0 && error <= 1e-6 * scale,
        "error {error:e} of {scale:e}"
    );

    // The frozen structure's dR/dW (no motion of K, C and the gap) is far off.
    let frozen = Turning {
        frozen: Some(speed),
    };
    let (dynamics, g0) = frozen.at(omega).unwrap();
    let mut fixed = inner_newton(&dynamics, &basis, &g0, None);
    let mu = Multipliers::uniform(&[PENALTY], basis.samples());
    let state = OrbitState {
        y: y.clone(),
        omega,
        level: 1.0,
    };
    let (_, frozen_column) = fixed.residual_and_column(&state, &mu).unwrap();
    let miss = frozen_column
        .iter()
        .zip(&fd)
        .fold(0.0_f64, |a, (c, f)| a.max((c - f).abs()));
    eprintln!("frozen miss {miss:e}");
    assert!(
        miss > 1e-2 * scale,
        "the structure's motion is {miss:e} of {scale:e}"
    );
}

/// The Newton direction of a following structure away from the W it was linearized at: one
/// `InnerNewton` whose structure is built at W_s, evaluated at W = 1.02 W_s (inside a run the
/// iterates move W), on an arc row with W free. With the exact Newton matrix of R,
/// R(y + t dy, W + t dW) = (1 - t) R(y, W) + O(t^2): the first-order error over t falls with t.
/// Before session 25 the matrix carried S_s's compliance alone where R carries the blend of the
/// two structures: the error over t stayed at 3e-2 of |R| (measured here) however small t, and
/// on the blade the line search stalled ("no step along the Newton direction decreases the
/// residual").
#[test]
fn following_newton_direction_is_that_of_its_residual_away_from_the_linearization() {
    let basis = FullBasis::new(HarmonicSettings::with_default_samples(N).unwrap()).unwrap();
    let speed = 0.35;
    let omega_s = E * speed;
    let t = basis.terms();
    let y = orbit_in_contact(&basis);
    let moving = Turning { frozen: None };
    let (dynamics, g0) = moving.at(omega_s).unwrap();
    let mut newton = inner_newton(&dynamics, &basis, &g0, Some(Following::new(&moving)));
    let mu = Multipliers::uniform(&[PENALTY], basis.samples());
    let at = |y: Vec<f64>, omega: f64| OrbitState {
        y,
        omega,
        level: 1.0,
    };
    // Builds the structure at W_s.
    newton.residual_only(&at(y.clone(), omega_s), &mu).unwrap();
    let omega = 1.02 * omega_s;
    let mut tangent_y = vec![0.0; t];
    tangent_y[FullBasis::cos_index(1)] = 0.6;
    let arc = ArcRow {
        parameter: Parameter::Frequency,
        tangent_y,
        tangent_parameter: 0.8,
        predicted: at(y.clone(), omega),
        y_scale: GAP,
        parameter_scale: omega_s,
    };
    let state = at(y.clone(), omega);
    let (r, dy, dw) = newton
        .residual_and_direction(&state, &mu, Some(&arc))
        .unwrap();
    let size = r.iter().fold(0.0_f64, |a, v| a.max(v.abs()));
    let mut error_over_t = |step: f64| {
        let moved: Vec<f64> = y.iter().zip(&dy).map(|(a, d)| a + step * d).collect();
        let rt = newton
            .residual_only(&at(moved, omega + step * dw), &mu)
            .unwrap();
        let e =
            (rt.iter().zip(&r)).fold(0.0_f64, |a, (x, r0)| a.max((x - (1.0 - step) * r0).abs()));
        e / step / size
    };
    let (coarse, fine) = (error_over_t(1e-3), error_over_t(1e-6));
    eprintln!("first-order error over t: {coarse:e} at 1e-3, {fine:e} at 1e-6 (|R| {size:e})");
    assert!(
        size > 1e-3 * GAP,
        "the orbit is not off its curve: |R| {size:e}"
    );
    // O(t): three decades of t take three off (5e-6 here); a wrong matrix leaves a floor (5e-3).
    assert!(
        fine <= 1e-4,
        "error over t {fine:e} at t = 1e-6 ({coarse:e} at 1e-3)"
    );
}
