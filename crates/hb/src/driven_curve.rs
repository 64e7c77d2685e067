//! The exact response curve of a driven massless boundary (DESIGN §10.6; docs/STABILITY.md
//! Sec. 9.2): its periodic orbits continued in (x0, W) by shooting, a second method beside the
//! harmonic balance that needs no truncation.
//!
//! The periodic orbits of `DrivenBoundary` at varying W are the zeros of the 2r shooting
//! equations F(z) = x(T) - x(0) in the 2r + 1 scaled unknowns z = (q / s, q' / (s W_ref),
//! W / W_ref) (`ShootingEquations`): a curve. From a periodic orbit it is followed by
//! pseudo-arc-length steps in the Moore-Penrose form: the tangent t is the unit null vector of
//! J = dF/dz (the last tangent projected onto that null space), the predictor z_p = z + h t, and
//! the corrector Gauss-Newton's minimum-norm steps dz = -J^T (J J^T)^-1 F, which move
//! (to first order) at right angles to the curve. A step that does not converge within
//! `CORRECTOR_ITERATIONS`, or lands farther than `CORRECTOR_REACH` h from the prediction, is
//! halved; one that converges in two iterations lets the next grow by 1.5. A fold is where t's
//! W component changes sign. The flow being exact, so is every point, to the shooting
//! tolerance.

use faer::linalg::solvers::Solve;
use faer::Mat;

use crate::driven_boundary::{min_norm_step, DrivenBoundary, ShootingEquations};
use crate::error::HbError;

/// The corrector stops below this scaled residual (as `shoot_driven`).
const CORRECTOR_TOLERANCE: f64 = 1e-10;
/// Gauss-Newton iterations before a step is declared failed.
const CORRECTOR_ITERATIONS: usize = 8;
/// How far (in steps) the corrector may land from the prediction: on a smooth curve it lands
/// within O(h^2); at a kink of the curve (contact setting in) at h / cos(angle); farther, it has
/// jumped to another piece of the curve. Four accepts kinks up to 75 degrees.
const CORRECTOR_REACH: f64 = 4.0;
/// Scaled step below which a failing arc-length step gives way to a hop at fixed W.
const CORNER_STEP: f64 = 1e-3;
/// How far (as a multiple of the hop's dW / W_ref) a hop may land from the last orbit.
const HOP_REACH: f64 = 20.0;

/// Settings of one exact curve.
#[derive(Clone, Debug, PartialEq)]
pub struct DrivenCurveSettings {
    /// Start of the range (rad/s): a curve that turns back below it stops there.
    pub start: f64,
    /// End of the range (rad/s): the curve is complete once W passes it.
    pub end: f64,
    /// First step in the scaled unknowns (default 0.01).
    pub step: f64,
    /// Smallest step before giving up (default 1e-6).
    pub min_step: f64,
    /// Largest step (default 0.05).
    pub max_step: f64,
    /// Most points (default 2000).
    pub max_points: usize,
}

impl DrivenCurveSettings {
    /// The range [start, end] (rad/s), defaults otherwise.
    pub fn new(start: f64, end: f64) -> Self {
        Self {
            start,
            end,
            step: 0.01,
            min_step: 1e-6,
            max_step: 0.05,
            max_points: 2000,
        }
    }
}

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

/// Why the curve ended.
#[derive(Clone, Debug, PartialEq)]
pub enum DrivenCurveEnd {
    /// W passed the end of the range.
    Complete,
    /// The curve turned back below the start of the range.
    LeftRange,
    /// No step down to `min_step` converged, at W (rad/s).
    StepTooSmall { omega: f64 },
    /// `max_points` reached.
    PointLimit,
}

impl DrivenCurveEnd {
    /// Why the curve ended, as a sentence (W in rad/s).
    pub fn text(&self) -> String {
        match self {
            Self::Complete => "complete".into(),
            Self::LeftRange => "turned back below the start of the range".into(),
            Self::StepTooSmall { omega } => {
                format!("stopped at W = {omega:.6e} rad/s: no step down to the smallest converged")
            }
            Self::PointLimit => "stopped at the point limit".into(),
        }
    }
}

/// The exact response curve.
#[derive(Clone, Debug)]
pub struct DrivenCurve {
    pub points: Vec<DrivenCurvePoint>,
    pub end: DrivenCurveEnd,
}

/// A converged point: z, its monodromy and its Jacobian.
struct Solved {
    z: Vec<f64>,
    monodromy: Mat<f64>,
    jacobian: Mat<f64>,
    iterations: usize,
}

/// The continuation in progress (module docs).
struct CurveTrace<'m, 's> {
    equations: ShootingEquations<'m>,
    settings: &'s DrivenCurveSettings,
    last: Solved,
    tangent: Vec<f64>,
    step: f64,
    points: Vec<DrivenCurvePoint>,
}

impl CurveTrace<'_, '_> {
    /// Gauss-Newton's minimum-norm iterations from z; `None` when they do not converge.
    fn correct(&self, mut z: Vec<f64>) -> Result<Option<Solved>, HbError> {
        for iterations in 0..=CORRECTOR_ITERATIONS {
            let (residual, phi) = self.equations.residual(&z)?;
            let norm = residual.iter().map(|v| v * v).sum::<f64>().sqrt();
            if !norm.is_finite() {
                return Ok(None);
            }
            let jacobian = self.equations.jacobian(&z, &residual, &phi)?;
            if norm < CORRECTOR_TOLERANCE {
                return Ok(Some(Solved {
                    z,
                    monodromy: phi,
                    jacobian,
                    iterations,
                }));
            }
            let Some(dz) = min_norm_step(&jacobian, &residual) else {
                return Ok(None);
            };
            z.iter_mut().zip(&dz).for_each(|(v, d)| *v += d);
        }
        Ok(None)
    }

    /// Newton at fixed W from z (the square system in the 2r state unknowns); `None` when it
    /// does not converge.
    fn correct_at_fixed_omega(&self, mut z: Vec<f64>) -> Result<Option<Vec<f64>>, HbError> {
        let n = z.len() - 1;
        for _ in 0..=2 * CORRECTOR_ITERATIONS {
            let (residual, phi) = self.equations.residual(&z)?;
            let norm = residual.iter().map(|v| v * v).sum::<f64>().sqrt();
            if !norm.is_finite() {
                return Ok(None);
            }
            if norm < CORRECTOR_TOLERANCE {
                return Ok(Some(z));
            }
            let jacobian = self.equations.jacobian(&z, &residual, &phi)?;
            let square = jacobian.subcols(0, n).to_owned();
            let rhs = Mat::from_fn(n, 1, |i, _| -residual[i]);
            let dz = square.partial_piv_lu().solve(&rhs);
            if (0..n).any(|i| !dz[(i, 0)].is_finite()) {
                return Ok(None);
            }
            (0..n).for_each(|i| z[i] += dz[(i, 0)]);
        }
        Ok(None)
    }

    /// A kink of the curve the arc-length step cannot pass (contact setting in, where the
    /// curve turns by nearly a right angle in the scaled unknowns): the orbit at fixed W =
    /// W_k + s dW from the last one, s the sign of the tangent's W component, for dW = 1e-4,
    /// 1e-3, 5e-3 (x W_ref); the first that lands within `HOP_REACH` dW is the next point, with
    /// the secant projected onto its null space as the tangent. Whether one did.
    fn hop(&mut self) -> Result<bool, HbError> {
        let n = self.tangent.len() - 1;
        let sign = self.tangent[n].signum();
        for dw in [1e-4, 1e-3, 5e-3] {
            let mut z = self.last.z.clone();
            z[n] += sign * dw;
            let Some(z) = self.correct_at_fixed_omega(z).ok().flatten() else {
                continue;
            };
            if distance(&z, &self.last.z) > HOP_REACH * dw {
                continue;
            }
            let Some(solved) = self.correct(z).ok().flatten() else {
                continue;
            };
            let secant = sub(&solved.z, &self.last.z);
            let tangent = null_tangent(&solved.jacobian, &secant);
            let fold = tangent[n] * self.tangent[n] < 0.0;
            self.push(&solved, fold);
            self.tangent = tangent;
            self.last = solved;
            return Ok(true);
        }
        Ok(false)
    }

    /// One accepted step, or `false` once the step fell below `min_step`.
    fn advance(&mut self) -> Result<bool, HbError> {
        while self.step >= self.settings.min_step {
            if self.step < CORNER_STEP && self.hop()? {
                self.step = CORNER_STEP;
                return Ok(true);
            }
            let h = self.step;
            let predicted: Vec<f64> = (self.last.z.iter().zip(&self.tangent))
                .map(|(z, t)| z + h * t)
                .collect();
            // A failure of the flow (a chattering contact set, a singular piece) is a failed
            // step like a corrector that does not converge.
            let solved = self.correct(predicted.clone()).ok().flatten().filter(|s| {
                distance(&s.z, &predicted) <= CORRECTOR_REACH * h
                    && dot(&sub(&s.z, &self.last.z), &self.tangent) > 0.0
            });
            let Some(solved) = solved else {
                self.step *= 0.5;
                continue;
            };
            let tangent = null_tangent(&solved.jacobian, &self.tangent);
            let n = tangent.len() - 1;
            let fold = tangent[n] * self.tangent[n] < 0.0;
            if solved.iterations <= 2 {
                self.step = (self.step * 1.5).min(self.settings.max_step);
            }
            self.push(&solved, fold);
            self.tangent = tangent;
            self.last = solved;
            return Ok(true);
        }
        Ok(false)
    }

    fn push(&mut self, solved: &Solved, fold: bool) {
        let (start, omega) = self.equations.state(&solved.z);
        self.points.push(DrivenCurvePoint {
            start,
            omega,
            monodromy: solved.monodromy.clone(),
            fold,
        });
    }

    /// Steps until the range's end, the point limit, a failed step or a turn below the start.
    fn run(&mut self) -> Result<DrivenCurveEnd, HbError> {
        loop {
            let omega = self.points.last().map_or(0.0, |p| p.omega);
            if omega >= self.settings.end {
                return Ok(DrivenCurveEnd::Complete);
            }
            if omega < self.settings.start {
                return Ok(DrivenCurveEnd::LeftRange);
            }
            if self.points.len() >= self.settings.max_points {
                return Ok(DrivenCurveEnd::PointLimit);
            }
            if !self.advance()? {
                return Ok(DrivenCurveEnd::StepTooSmall { omega });
            }
        }
    }
}

/// The exact response curve of `model` from the periodic orbit (q, q') = `start` at W =
/// `model.omega` (W increasing first) over the settings' range; `q_scale` scales the modal
/// coordinates (their size near the resonance, in their units). `None` when the first orbit
/// does not converge.
pub fn trace_driven_curve(
    model: &DrivenBoundary,
    start: &[f64],
    q_scale: f64,
    settings: &DrivenCurveSettings,
) -> Result<Option<DrivenCurve>, HbError> {
    let equations = ShootingEquations {
        model,
        q_scale,
        w_ref: model.omega,
    };
    let z0 = equations.unknowns(start, model.omega);
    let mut trace = CurveTrace {
        equations,
        settings,
        last: Solved {
            z: z0.clone(),
            monodromy: Mat::zeros(0, 0),
            jacobian: Mat::zeros(0, 0),
            iterations: 0,
        },
        tangent: Vec::new(),
        step: settings.step,
        points: Vec::new(),
    };
    // The first orbit at the start's W exactly (a harmonic-balance start in contact is only
    // near the curve, and the minimum-norm corrector could move W out of the range).
    let Some(first) = trace.correct_at_fixed_omega(z0)? else {
        return Ok(None);
    };
    let Some(first) = trace.correct(first)? else {
        return Ok(None);
    };
    let mut rising = vec![0.0; first.z.len()];
    *rising.last_mut().expect("unknowns") = 1.0;
    trace.tangent = null_tangent(&first.jacobian, &rising);
    trace.push(&first, false);
    trace.last = first;
    let end = trace.run()?;
    Ok(Some(DrivenCurve {
        points: trace.points,
        end,
    }))
}

/// The unit null vector of J (m x (m + 1), full row rank) on the side of `previous`: previous
/// projected onto the null space, previous - J^T (J J^T)^-1 J previous, normalized.
fn null_tangent(jacobian: &Mat<f64>, previous: &[f64]) -> Vec<f64> {
    let jp: Vec<f64> = (0..jacobian.nrows())
        .map(|i| {
            (0..previous.len())
                .map(|j| jacobian[(i, j)] * previous[j])
                .sum()
        })
        .collect();
    let projected = match min_norm_step(jacobian, &jp) {
        // min_norm_step solves J d = -jp: d = -J^T (J J^T)^-1 J previous.
        Some(d) => previous.iter().zip(&d).map(|(p, d)| p + d).collect(),
        None => previous.to_vec(),
    };
    let norm = dot(&projected, &projected).sqrt();
    projected.iter().map(|v| v / norm).collect()
}

fn dot(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| x * y).sum()
}

fn sub(a: &[f64], b: &[f64]) -> Vec<f64> {
    a.iter().zip(b).map(|(x, y)| x - y).collect()
}

fn distance(a: &[f64], b: &[f64]) -> f64 {
    let d = sub(a, b);
    dot(&d, &d).sqrt()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::boundary_rk4::{integrate, Rk4State};
    use crate::driven_boundary::{shoot_driven, BoundaryDrive};

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
            &DrivenCurveSettings::new(0.5, 1.5),
        )
        .expect("trace")
        .expect("first orbit");
        assert_eq!(curve.end, DrivenCurveEnd::Complete);
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
        let curve = trace_driven_curve(
            &model,
            &first.start,
            2.5,
            &DrivenCurveSettings::new(0.5, 2.5),
        )
        .expect("trace")
        .expect("first orbit");
        assert_eq!(curve.end, DrivenCurveEnd::Complete);
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
