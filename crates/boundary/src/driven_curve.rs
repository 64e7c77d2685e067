//! The exact response curve of a driven massless boundary (DESIGN §10.6; docs/STABILITY.md
//! Sec. 9.2): its periodic orbits continued in (x0, W) by shooting, a second method beside the
//! harmonic balance that needs no truncation.
//!
//! The periodic orbits of `DrivenBoundary` at varying W are the zeros of the 2r shooting
//! equations F(z) = x(T) - x(0) in the 2r + 1 scaled unknowns z = (q / s, q' / (s W_ref),
//! W / W_ref) (`ShootingEquations`): a curve, followed by the pseudo-arc-length continuation of
//! `arc_length` with W as its parameter (kinks hopped at fixed W, folds where W turns).
//! The flow being exact, so is every point, to the shooting tolerance.

use faer::Mat;

use crate::arc_length::{trace_curve, Curve, CurveEnd, CurveEquations, CurveSettings};
use crate::driven_model::DrivenBoundary;
use crate::driven_shooting::ShootingEquations;
use nlmodes_hb::HbError;

/// One exact periodic orbit of the curve.
#[derive(Clone, Debug)]
pub struct DrivenCurvePoint {
    /// (q, q') at t = 0.
    pub start: Vec<f64>,
    /// Excitation frequency W (rad/s).
    pub omega: f64,
    /// Monodromy in (q, q') (2r x 2r).
    pub monodromy: Mat<f64>,
    /// Whether W turned between the previous point and this one.
    pub fold: bool,
}

/// The exact response curve.
pub type DrivenCurve = Curve<DrivenCurvePoint>;

/// Why a driven curve ended, as a sentence (W in rad/s).
pub fn driven_end_text(end: &CurveEnd) -> String {
    end.text(|w| format!("W = {w:.6e} rad/s"))
}

impl CurveEquations for ShootingEquations<'_> {
    type Point = DrivenCurvePoint;

    fn residual(&self, z: &[f64]) -> Result<(Vec<f64>, Mat<f64>), HbError> {
        ShootingEquations::residual(self, z)
    }

    fn jacobian(&self, z: &[f64], residual: &[f64], phi: &Mat<f64>) -> Result<Mat<f64>, HbError> {
        ShootingEquations::jacobian(self, z, residual, phi)
    }

    fn point(&self, z: &[f64], phi: &Mat<f64>, fold: bool) -> Result<DrivenCurvePoint, HbError> {
        let (start, omega) = self.state(z);
        Ok(DrivenCurvePoint {
            start,
            omega,
            monodromy: phi.clone(),
            fold,
        })
    }

    fn progress(point: &DrivenCurvePoint) -> f64 {
        point.omega
    }
}

/// The exact response curve of `model` from the periodic orbit (q, q') = `start` at W =
/// `model.omega` (W increasing first) over the settings' range of W (rad/s); `q_scale` scales
/// the modal coordinates (their size near the resonance, in their units). `None` when the
/// first orbit does not converge.
pub fn trace_driven_curve(
    model: &DrivenBoundary,
    start: &[f64],
    q_scale: f64,
    settings: &CurveSettings,
) -> Result<Option<DrivenCurve>, HbError> {
    let equations = ShootingEquations {
        model,
        q_scale,
        w_ref: model.omega,
    };
    let z0 = equations.unknowns(start, model.omega);
    let mut rising = vec![0.0; z0.len()];
    *rising.last_mut().expect("unknowns") = 1.0;
    trace_curve(equations, z0, &rising, settings)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::driven_model::BoundaryDrive;
    use crate::driven_shooting::shoot_driven;
    use crate::rk4::{integrate, Rk4State};

    /// One damped mode (w = 1, 2 zeta = 0.02) on a penalty spring of stiffness 20 behind a gap
    /// of 1, driven at 0.05 cos(W t): linear peak 2.5 gaps, a hardening resonance with two folds.
    fn bilinear(omega: f64, gap: f64) -> DrivenBoundary {
        DrivenBoundary {
            omega2: vec![1.0],
            damping: Mat::from_fn(1, 1, |_, _| 0.02),
            contact_modal: Mat::from_fn(1, 1, |_, _| 1.0),
            flexibility: Mat::from_fn(1, 1, |_, _| 1.0 / 20.0),
            gaps: vec![gap],
            drive: vec![BoundaryDrive {
                harmonic: 1,
                modal: [vec![0.05], vec![0.0]],
                contact: [vec![0.0], vec![0.0]],
            }],
            omega,
            structure: Default::default(),
        }
    }

    /// The linear response (q, q') at t = 0 of the bilinear model out of contact.
    fn linear_start(omega: f64) -> Vec<f64> {
        let (re, im) = (1.0 - omega * omega, 0.02 * omega);
        let d = re * re + im * im;
        // q = a cos + b sin with (re + i im)(a - i b) = f.
        let (a, b) = (0.05 * re / d, 0.05 * im / d);
        vec![a, b * omega]
    }

    #[test]
    fn the_exact_curve_out_of_contact_is_the_linear_frf() {
        let model = bilinear(0.5, 1e3);
        let curve = trace_driven_curve(
            &model,
            &linear_start(0.5),
            2.5,
            &CurveSettings::new(0.5, 1.5),
        )
        .expect("trace")
        .expect("first orbit");
        assert_eq!(curve.end, CurveEnd::Complete);
        let worst = curve
            .points
            .iter()
            .map(|p| {
                let exact = linear_start(p.omega);
                (p.start[0] - exact[0])
                    .abs()
                    .max((p.start[1] - exact[1]).abs() / p.omega)
            })
            .fold(0.0, f64::max);
        println!("{} points, worst {worst:.1e}", curve.points.len());
        assert!(curve.points.len() > 20);
        // The corrector's tolerance 1e-10 (scaled by 2.5) times the resonance's amplification
        // 1 / (2 zeta) = 50: about 1e-8 at most; measured 9.5e-10.
        assert!(worst < 1e-8, "{worst}");
        assert!(curve.points.iter().all(|p| !p.fold));
    }

    #[test]
    fn the_exact_curve_through_contact_is_periodic_for_rk4_and_turns_at_two_folds() {
        let model = bilinear(0.5, 1.0);
        let first = shoot_driven(&model, &linear_start(0.5))
            .expect("shoot")
            .expect("first orbit");
        let curve = trace_driven_curve(&model, &first.start, 2.5, &CurveSettings::new(0.5, 2.5))
            .expect("trace")
            .expect("first orbit");
        assert_eq!(curve.end, CurveEnd::Complete);
        let folds: Vec<f64> = curve
            .points
            .iter()
            .filter(|p| p.fold)
            .map(|p| p.omega)
            .collect();
        println!("{} points, folds at {folds:?}", curve.points.len());
        assert_eq!(folds.len(), 2, "{folds:?}");
        assert!(folds[0] > folds[1], "turns back, then forward: {folds:?}");
        let mut worst = 0.0_f64;
        let mut liouville = 0.0_f64;
        for p in curve.points.iter().step_by(7) {
            let mut at = model.clone();
            at.omega = p.omega;
            let period = 2.0 * std::f64::consts::PI / p.omega;
            let start = Rk4State {
                q: p.start[..1].to_vec(),
                v: p.start[1..].to_vec(),
            };
            let (end, _) = integrate(&at, &start, period, 20_000).expect("rk4");
            worst = worst.max((end.q[0] - start.q[0]).abs() + (end.v[0] - start.v[0]).abs());
            let det = p.monodromy.determinant();
            liouville = liouville.max((det / (-0.02 * period).exp() - 1.0).abs());
        }
        println!("RK4 period gap {worst:.1e}, Liouville {liouville:.1e}");
        assert!(worst < 1e-8, "{worst}");
        assert!(liouville < 1e-10, "{liouville}");
    }
}
