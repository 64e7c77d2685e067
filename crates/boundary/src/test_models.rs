//! Small massless-boundary models with known answers, shared by the crate's unit tests.

use faer::{c64, Mat};

use crate::driven_model::{BoundaryDrive, DrivenBoundary, GapHarmonic};
use crate::model::BoundaryModel;

/// One mode (w = 1) on one row of flexibility `flex`, gap 1: a bilinear oscillator.
pub(crate) fn bilinear(flex: f64) -> BoundaryModel {
    BoundaryModel {
        omega2: vec![1.0],
        contact_modal: Mat::from_fn(1, 1, |_, _| 1.0),
        flexibility: Mat::from_fn(1, 1, |_, _| flex),
        gaps: vec![1.0],
    }
}

/// The exact period of the bilinear oscillator released at rest from q0: 2 pi below the gap;
/// above it the contact phase q'' + k2 q = 1 / R (k2 = 1 + 1 / R) down to q = 1, then the free
/// oscillation q'' + q = 0 to its turning point, twice.
pub(crate) fn bilinear_period(flex: f64, q0: f64) -> f64 {
    if q0 <= 1.0 {
        return 2.0 * std::f64::consts::PI;
    }
    let k2 = 1.0 + 1.0 / flex;
    let s = k2.sqrt();
    let q_eq = 1.0 / (flex * k2);
    let t1 = ((1.0 - q_eq) / (q0 - q_eq)).acos() / s;
    let v1 = -(q0 - q_eq) * s * (s * t1).sin();
    let phi = (-v1).atan2(1.0);
    2.0 * (t1 + std::f64::consts::PI - phi)
}

/// Three modes on three rows with a coupled flexibility (a made-up but generic model).
pub(crate) fn three_modes() -> BoundaryModel {
    BoundaryModel {
        omega2: vec![1.0, 6.25, 20.0],
        contact_modal: Mat::from_fn(3, 3, |j, k| {
            [[1.0, 0.4, -0.3], [0.8, -0.6, 0.5], [0.5, 0.9, 0.7]][j][k]
        }),
        flexibility: Mat::from_fn(3, 3, |i, j| {
            [[0.30, 0.05, 0.02], [0.05, 0.25, 0.04], [0.02, 0.04, 0.20]][i][j]
        }),
        gaps: vec![1.0, 1.2, 1.5],
    }
}

/// `three_modes` damped, driven at two harmonics.
pub(crate) fn driven_three_modes(omega: f64) -> DrivenBoundary {
    let r = 3;
    DrivenBoundary {
        omega2: vec![1.0, 6.25, 20.0],
        damping: Mat::from_fn(r, r, |i, k| {
            [[0.02, 0.005, 0.0], [0.005, 0.05, 0.01], [0.0, 0.01, 0.08]][i][k]
        }),
        contact_modal: Mat::from_fn(3, r, |j, k| {
            [[1.0, 0.4, -0.3], [0.8, -0.6, 0.5], [0.5, 0.9, 0.7]][j][k]
        }),
        flexibility: Mat::from_fn(3, 3, |i, j| {
            [[0.30, 0.05, 0.02], [0.05, 0.25, 0.04], [0.02, 0.04, 0.20]][i][j]
        }),
        gaps: vec![1.0, 1.2, 1.5],
        drive: vec![
            BoundaryDrive {
                harmonic: 1,
                modal: [vec![0.3, 0.1, 0.0], vec![0.0, 0.05, 0.02]],
                contact: [vec![0.01, 0.0, 0.02], vec![0.0, 0.01, 0.0]],
            },
            BoundaryDrive {
                harmonic: 3,
                modal: [vec![0.0, 0.2, 0.1], vec![0.05, 0.0, 0.0]],
                contact: [vec![0.0, 0.005, 0.0], vec![0.005, 0.0, 0.0]],
            },
        ],
        omega,
        structure: Default::default(),
    }
}

/// `driven_three_modes` under a moving gap: the rows' gaps reduced by 0.3, 0.25 and 0.4
/// cos(W t + phi_j) (phases 0.3, -0.7, 1.9 rad), a harmonic the load holds, and by
/// 0.1 sin(2 W t) on the first row, one it lacks.
pub(crate) fn driven_three_modes_moving_gap(omega: f64) -> DrivenBoundary {
    let (amplitude, phase) = ([0.3, 0.25, 0.4], [0.3, -0.7, 1.9_f64]);
    let first = GapHarmonic {
        harmonic: 1,
        intrusion: [
            (0..3).map(|j| amplitude[j] * phase[j].cos()).collect(),
            (0..3).map(|j| -amplitude[j] * phase[j].sin()).collect(),
        ],
    };
    let second = GapHarmonic {
        harmonic: 2,
        intrusion: [vec![0.0; 3], vec![0.1, 0.0, 0.0]],
    };
    driven_three_modes(omega)
        .with_gap_motion(&[first, second])
        .expect("a gap motion that fits the rows")
}

/// A verdict for the tests: the multipliers exp(s T) without the two nearest +1 (the trivial
/// pair), stable when none lies outside the unit circle by more than 1e-6.
pub(crate) fn judge(exponents: &[c64], period: f64) -> (f64, &'static str) {
    let one = c64::new(1.0, 0.0);
    let mut mu: Vec<c64> = exponents.iter().map(|s| (s * period).exp()).collect();
    mu.sort_by(|a, b| (a - one).norm().total_cmp(&(b - one).norm()));
    let largest = mu.iter().skip(2).map(|m| m.norm()).fold(1.0, f64::max);
    let verdict = if largest <= 1.0 + 1e-6 {
        "stable"
    } else {
        "unstable"
    };
    (largest, verdict)
}
