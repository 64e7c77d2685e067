//! Pseudo-arc-length continuation of m equations in m + 1 scaled unknowns, in the
//! Moore-Penrose form (DESIGN §10.6; docs/STABILITY.md Sec. 9.2-9.3): the engine of the exact
//! curves of the massless contact boundary, forced (`driven_curve`, parameter W) and free
//! (`backbone_curve`, parameter T).
//!
//! From a point z of the curve F(z) = 0 the tangent t is the unit null vector of J = dF/dz (the
//! last tangent projected onto that null space), the predictor z_p = z + h t, and the corrector
//! Gauss-Newton's minimum-norm steps dz = -J^T (J J^T)^-1 F, which move (to first order) at
//! right angles to the curve. A step that does not converge within `CORRECTOR_ITERATIONS`, or
//! lands farther than `CORRECTOR_REACH` h from the prediction, or whose tangent turned by more
//! than `MAX_TURN`, is halved; one that converges in two iterations lets the next grow by 1.5. Below `CORNER_STEP` a kink of the curve (contact
//! setting in) is passed by a hop at a fixed value of the last unknown (the parameter). A fold
//! is where t's last component changes sign.

use faer::linalg::solvers::Solve;
use faer::Mat;

use nlmodes_hb::HbError;

/// A tangent whose last component is below this (in the unit tangent) leaves the parameter
/// still: a stretch at constant T (a backbone out of contact) is not a fold.
const STILL_PARAMETER: f64 = 1e-6;
/// The corrector stops below this scaled residual.
const CORRECTOR_TOLERANCE: f64 = 1e-10;
/// Gauss-Newton iterations before a step is declared failed.
const CORRECTOR_ITERATIONS: usize = 8;
/// How far (in steps) the corrector may land from the prediction: on a smooth curve it lands
/// within O(h^2); at a kink of the curve (contact setting in) at h / cos(angle); farther, it has
/// jumped to another piece of the curve. Four accepts kinks up to 75 degrees.
const CORRECTOR_REACH: f64 = 4.0;
/// Scaled step below which a failing arc-length step gives way to a hop at a fixed parameter.
const CORNER_STEP: f64 = 1e-3;
/// Largest turn of the unit tangent over one arc-length step (rad). The curves of the massless
/// boundary are continuously differentiable (the vector field is continuous at the switches);
/// where a contact phase appears (grazing) their curvature grows like the inverse square root of
/// the distance, but the turn over a step still shrinks with the step (like its square root).
/// A step whose tangent turned more met the curve elsewhere: at a grazing fold of a forced curve
/// (2-DOF chain at 0.5 % damping, W/w1 = 1.084) a step of 0.025 turned the tangent by 89
/// degrees onto the branch it came from, and the curve was traced back to the start of its
/// range.
const MAX_TURN: f64 = 0.5;
/// How far (as a multiple of the hop's change of the parameter) a hop may land from the last
/// point.
const HOP_REACH: f64 = 20.0;

/// Equations F(z) = 0, m of them in the m + 1 scaled unknowns z whose last is the parameter
/// a hop holds fixed (W for a forced curve, T for a backbone).
pub trait CurveEquations {
    /// What an accepted point keeps.
    type Point;
    /// The scaled residual F(z) (m) and the transition matrix computed with it (the monodromy,
    /// or whatever `jacobian` and `point` need).
    fn residual(&self, z: &[f64]) -> Result<(Vec<f64>, Mat<f64>), HbError>;
    /// J = dF/dz (m x (m + 1)) at z from its residual and transition matrix.
    fn jacobian(
        &self,
        z: &[f64],
        residual: &[f64],
        transition: &Mat<f64>,
    ) -> Result<Mat<f64>, HbError>;
    /// The point kept for a converged z; `fold` when the parameter turned since the last one.
    fn point(&self, z: &[f64], transition: &Mat<f64>, fold: bool) -> Result<Self::Point, HbError>;
    /// The quantity whose range bounds the curve (W in rad/s, an amplitude, ...).
    fn progress(point: &Self::Point) -> f64;
    /// Whether the curve has left the family the caller follows at this point (it then ends
    /// there, as [`CurveEnd::LeftFamily`]); never, by default.
    fn leaves(&self, _point: &Self::Point) -> bool {
        false
    }
    /// Whether the first point is corrected at the start's parameter before the minimum-norm
    /// corrector (a start only near the curve, whose parameter must not move: W at the start of
    /// a range). A start on a family whose square system at fixed parameter is singular (a
    /// linear mode at its own period) sets this to false.
    const FIRST_AT_FIXED_PARAMETER: bool = true;
}

/// Range and steps of one curve.
#[derive(Clone, Debug, PartialEq)]
pub struct CurveSettings {
    /// Start of the range of the progress quantity: a curve that turns back below it stops.
    pub start: f64,
    /// End of the range: the curve is complete once the progress quantity passes it.
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

impl CurveSettings {
    /// The range [start, end] of the progress quantity, defaults otherwise.
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

/// Why a curve ended.
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum CurveEnd {
    /// The progress quantity passed the end of the range.
    Complete,
    /// The curve turned back below the start of the range.
    LeftRange,
    /// No step down to `min_step` converged, at this value of the progress quantity.
    StepTooSmall { at: f64 },
    /// `max_points` reached.
    PointLimit,
    /// The curve left the followed family (`CurveEquations::leaves`).
    LeftFamily,
}

impl CurveEnd {
    /// Why the curve ended, as a sentence; `unit` names the progress quantity's value
    /// (`"W = {} rad/s"` style: a closure formatting it).
    pub fn text(&self, value: impl Fn(f64) -> String) -> String {
        match self {
            Self::Complete => "complete".into(),
            Self::LeftRange => "turned back below the start of the range".into(),
            Self::StepTooSmall { at } => format!(
                "stopped at {}: no step down to the smallest converged",
                value(*at)
            ),
            Self::PointLimit => "stopped at the point limit".into(),
            Self::LeftFamily => "left the family followed".into(),
        }
    }
}

/// A traced curve.
#[derive(Clone, Debug)]
pub struct Curve<P> {
    pub points: Vec<P>,
    pub end: CurveEnd,
}

/// A converged point: z, its transition matrix and its Jacobian.
struct Solved {
    z: Vec<f64>,
    transition: Mat<f64>,
    jacobian: Mat<f64>,
    iterations: usize,
}

/// The continuation in progress (module docs).
struct CurveTrace<'s, E: CurveEquations> {
    equations: E,
    settings: &'s CurveSettings,
    last: Solved,
    tangent: Vec<f64>,
    step: f64,
    points: Vec<E::Point>,
    /// The sign of the parameter's last significant change along the curve (0 before one).
    parameter_sign: f64,
}

impl<E: CurveEquations> CurveTrace<'_, E> {
    /// Gauss-Newton's minimum-norm iterations from z; `None` when they do not converge.
    fn correct(&self, mut z: Vec<f64>) -> Result<Option<Solved>, HbError> {
        for iterations in 0..=CORRECTOR_ITERATIONS {
            let (residual, transition) = self.equations.residual(&z)?;
            let norm = residual.iter().map(|v| v * v).sum::<f64>().sqrt();
            if !norm.is_finite() {
                return Ok(None);
            }
            let jacobian = self.equations.jacobian(&z, &residual, &transition)?;
            if norm < CORRECTOR_TOLERANCE {
                return Ok(Some(Solved {
                    z,
                    transition,
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

    /// Newton at a fixed parameter from z (the square system in the m other unknowns); `None`
    /// when it does not converge.
    fn correct_at_fixed_parameter(&self, mut z: Vec<f64>) -> Result<Option<Vec<f64>>, HbError> {
        let n = z.len() - 1;
        for _ in 0..=2 * CORRECTOR_ITERATIONS {
            let (residual, transition) = self.equations.residual(&z)?;
            let norm = residual.iter().map(|v| v * v).sum::<f64>().sqrt();
            if !norm.is_finite() {
                return Ok(None);
            }
            if norm < CORRECTOR_TOLERANCE {
                return Ok(Some(z));
            }
            let jacobian = self.equations.jacobian(&z, &residual, &transition)?;
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
    /// curve turns by nearly a right angle in the scaled unknowns): the point at a fixed
    /// parameter p_k + s dp from the last one, s the sign of the tangent's last component, for
    /// dp = 1e-4, 1e-3, 5e-3 (scaled); the first that lands within `HOP_REACH` dp is the next
    /// point, with the secant projected onto its null space as the tangent. Whether one did.
    fn hop(&mut self) -> Result<bool, HbError> {
        let n = self.tangent.len() - 1;
        let sign = self.tangent[n].signum();
        for dp in [1e-4, 1e-3, 5e-3] {
            let mut z = self.last.z.clone();
            z[n] += sign * dp;
            let Some(z) = self.correct_at_fixed_parameter(z).ok().flatten() else {
                continue;
            };
            if distance(&z, &self.last.z) > HOP_REACH * dp {
                continue;
            }
            let Some(solved) = self.correct(z).ok().flatten() else {
                continue;
            };
            let secant = sub(&solved.z, &self.last.z);
            let tangent = null_tangent(&solved.jacobian, &secant);
            if dot(&tangent, &self.tangent) <= 0.0 {
                // A hop turns the curve at a kink by less than a right angle; one that turns it
                // back has landed on the branch it came from.
                continue;
            }
            let fold = self.turned(&tangent);
            self.accept(solved, tangent, fold)?;
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
            if dot(&tangent, &self.tangent) < MAX_TURN.cos() {
                self.step *= 0.5;
                continue;
            }
            let fold = self.turned(&tangent);
            if solved.iterations <= 2 {
                self.step = (self.step * 1.5).min(self.settings.max_step);
            }
            self.accept(solved, tangent, fold)?;
            return Ok(true);
        }
        Ok(false)
    }

    /// Whether the parameter's direction of travel (the sign of the tangent's last component,
    /// counted where it is larger than `STILL_PARAMETER`) turned with `tangent`.
    fn turned(&self, tangent: &[f64]) -> bool {
        let t = tangent[tangent.len() - 1];
        t.abs() > STILL_PARAMETER && t * self.parameter_sign < 0.0
    }

    fn accept(&mut self, solved: Solved, tangent: Vec<f64>, fold: bool) -> Result<(), HbError> {
        let t = tangent[tangent.len() - 1];
        if t.abs() > STILL_PARAMETER {
            self.parameter_sign = t.signum();
        }
        let point = self.equations.point(&solved.z, &solved.transition, fold)?;
        self.points.push(point);
        self.tangent = tangent;
        self.last = solved;
        Ok(())
    }

    /// Steps until the range's end, the point limit, a failed step or a turn below the start.
    fn run(&mut self) -> Result<CurveEnd, HbError> {
        loop {
            let at = self.points.last().map_or(0.0, E::progress);
            if at >= self.settings.end {
                return Ok(CurveEnd::Complete);
            }
            if at < self.settings.start {
                return Ok(CurveEnd::LeftRange);
            }
            if self.points.last().is_some_and(|p| self.equations.leaves(p)) {
                return Ok(CurveEnd::LeftFamily);
            }
            if self.points.len() >= self.settings.max_points {
                return Ok(CurveEnd::PointLimit);
            }
            if !self.advance()? {
                return Ok(CurveEnd::StepTooSmall { at });
            }
        }
    }
}

/// The curve of `equations` from the scaled unknowns `z0` (near the curve: its first point is
/// found at z0's parameter exactly, then on the curve), leaving it along the null direction
/// nearest `direction`, over the settings' range. `None` when the first point does not
/// converge.
pub fn trace_curve<E: CurveEquations>(
    equations: E,
    z0: Vec<f64>,
    direction: &[f64],
    settings: &CurveSettings,
) -> Result<Option<Curve<E::Point>>, HbError> {
    let mut trace = CurveTrace {
        equations,
        settings,
        last: Solved {
            z: z0.clone(),
            transition: Mat::zeros(0, 0),
            jacobian: Mat::zeros(0, 0),
            iterations: 0,
        },
        tangent: Vec::new(),
        step: settings.step,
        points: Vec::new(),
        parameter_sign: 0.0,
    };
    // The first point at the start's parameter exactly (a harmonic-balance start is only near
    // the curve, and the minimum-norm corrector could move the parameter out of the range).
    let first = if E::FIRST_AT_FIXED_PARAMETER {
        trace.correct_at_fixed_parameter(z0)?
    } else {
        Some(z0)
    };
    let Some(first) = first else {
        return Ok(None);
    };
    let Some(first) = trace.correct(first)? else {
        return Ok(None);
    };
    let tangent = null_tangent(&first.jacobian, direction);
    trace.accept(first, tangent, false)?;
    let end = trace.run()?;
    Ok(Some(Curve {
        points: trace.points,
        end,
    }))
}

/// The minimum-norm solution of J d = -F (J of full row rank), `None` when not finite.
pub fn min_norm_step(jac: &Mat<f64>, residual: &[f64]) -> Option<Vec<f64>> {
    let rhs = Mat::from_fn(jac.nrows(), 1, |i, _| -residual[i]);
    let jjt = jac * jac.transpose();
    let step = jac.transpose() * jjt.partial_piv_lu().solve(&rhs);
    let step: Vec<f64> = (0..jac.ncols()).map(|i| step[(i, 0)]).collect();
    step.iter().all(|v| v.is_finite()).then_some(step)
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
