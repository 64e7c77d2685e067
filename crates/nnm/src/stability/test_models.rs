//! Small massless-boundary models with known answers, shared by the unit tests of
//! `boundary_shooting` and `boundary_backbone`.

use faer::Mat;

use super::boundary_flow::BoundaryModel;

/// One mode (w = 1) on one row of flexibility `flex`, gap 1: a bilinear oscillator.
pub(super) fn bilinear(flex: f64) -> BoundaryModel {
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
pub(super) fn bilinear_period(flex: f64, q0: f64) -> f64 {
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
pub(super) fn three_modes() -> BoundaryModel {
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
