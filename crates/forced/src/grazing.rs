//! Passing grazing (DESIGN §10.5): where a contact phase appears or vanishes, the exactly
//! integrated penalty law's Jacobian changes like k sqrt(penetration), so next to a lightly
//! damped resonance under a stiff law Newton's basin in the arc-length step shrinks with the
//! penetration (on the 2-DOF chain at 0.3 % damping and k = 1000 x the static contact
//! stiffness, the curve turns by a right angle within 3e-6 of W and the arc-length corrector
//! fails at every step down to 1e-6). At a prescribed largest penetration of the grazing row the
//! problem is regular: the passage solves the orbits whose row reaches the gap plus a
//! penetration growing geometrically from 1e-7 g0 (entering contact) or shrinking to it and
//! then below the gap (leaving contact), each from the last, then hands back to arc length.
//!
//! The row "largest value of y_j over the period = g0_j + delta" is linear in y at a fixed phase
//! theta* of the largest value: phi(theta*) . y_j = g0_j + delta, phi the basis functions of
//! `FullBasis` at theta*. Since dy_j/dtheta = 0 there, a phase off by e changes the largest
//! value by O(e^2): the solve is repeated with the phase of its orbit until the largest value
//! is the target to 1e-9 g0 (two or three solves).

use crate::ladder::start_at;
use crate::newton::{ArcRow, OrbitState};
use crate::solver::{ForcedPoint, ForcedStart};
use crate::trace::{norm, FrfTrace};
use nlmodes_hb::FullBasis;

/// A row within this fraction of its gap (below or above) is grazing.
const GRAZING_BAND: f64 = 0.05;

/// Penetrations (fractions of the gap) of the passage into contact; leaving contact, the same
/// down to the smallest, then these below the gap.
const PENETRATIONS: [f64; 7] = [1e-7, 1e-6, 1e-5, 1e-4, 1e-3, 1e-2, 3e-2];
const BELOW: [f64; 3] = [-1e-4, -1e-3, -1e-2];

/// Solves per passage point (each with the phase of the last orbit's largest value).
const PHASE_SOLVES: usize = 5;

/// The largest value of a series over the period and its phase: on a grid of 8 (2N + 1)
/// points, refined by bisection of the derivative.
pub(crate) fn series_max(series: &[f64]) -> (f64, f64) {
    let grid = 8 * series.len();
    let h = std::f64::consts::TAU / grid as f64;
    let k = (0..grid)
        .max_by(|&a, &b| {
            FullBasis::value_at(series, a as f64 * h)
                .total_cmp(&FullBasis::value_at(series, b as f64 * h))
        })
        .unwrap_or(0);
    let (mut lo, mut hi) = ((k as f64 - 1.0) * h, (k as f64 + 1.0) * h);
    for _ in 0..60 {
        let mid = 0.5 * (lo + hi);
        if FullBasis::value_and_slope_at(series, mid).1 > 0.0 {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    let theta = 0.5 * (lo + hi);
    (theta, FullBasis::value_at(series, theta))
}

/// The basis functions [1, cos t, sin t, cos 2t, ...] at phase `theta` (`terms` of them).
fn basis_at(theta: f64, terms: usize) -> Vec<f64> {
    (0..terms)
        .map(|p| {
            let n = FullBasis::harmonic_of(p) as f64;
            match p {
                0 => 1.0,
                _ if p % 2 == 1 => (n * theta).cos(),
                _ => (n * theta).sin(),
            }
        })
        .collect()
}

impl FrfTrace<'_, '_, '_> {
    /// The row closest to its gap at the last point: (row, phase of its largest value, largest
    /// value minus the gap, as a fraction of the gap).
    fn grazing_row(&self, p: &ForcedPoint) -> (usize, f64, f64) {
        let gaps = self.solver().system().gaps();
        let rows = gaps.len();
        let t = p.contact.len() / rows.max(1);
        (0..rows)
            .map(|j| {
                let (theta, top) = series_max(&p.contact[j * t..(j + 1) * t]);
                (j, theta, (top - gaps[j]) / gaps[j])
            })
            .max_by(|a, b| a.2.total_cmp(&b.2))
            .unwrap_or((0, 0.0, -1.0))
    }

    /// Passes grazing by prescribed penetrations (module docs) when the last point's grazing
    /// row is within `GRAZING_BAND` of its gap; whether it got across.
    pub(crate) fn pass_grazing(&mut self) -> bool {
        let last = self.curve.points.last().expect("two points").clone();
        let (row, theta, penetration) = self.grazing_row(&last);
        if penetration.abs() > GRAZING_BAND {
            return false;
        }
        // Which way the curve runs: the penetration's rate along the tangent.
        let t = self.solver().basis().terms();
        let phi = basis_at(theta, t);
        let rate: f64 = (0..t).map(|p| phi[p] * self.tangent[row * t + p]).sum();
        let targets: Vec<f64> = if rate > 0.0 {
            PENETRATIONS
                .iter()
                .copied()
                .filter(|&d| d > penetration)
                .collect()
        } else {
            let mut down: Vec<f64> = PENETRATIONS
                .iter()
                .rev()
                .copied()
                .filter(|&d| d < penetration)
                .collect();
            down.extend(BELOW.iter().copied().filter(|&d| d < penetration));
            down
        };
        let mut crossed = false;
        for target in targets {
            let Some((p, arc)) = self.solve_at_penetration(row, target) else {
                break;
            };
            if !self.push_passage(p, &arc) {
                break;
            }
            crossed |= (target > 0.0) != (penetration > 0.0);
        }
        tracing::debug!(
            row,
            penetration,
            crossed,
            "forced response: grazing passage by prescribed penetrations"
        );
        crossed
    }

    /// The orbit whose row `row` reaches its gap plus `target` times it, from the last point
    /// (module docs), with the row it was solved on.
    fn solve_at_penetration(&self, row: usize, target: f64) -> Option<(ForcedPoint, ArcRow)> {
        let solver = self.solver();
        let g0 = solver.system().gaps()[row];
        let t = solver.basis().terms();
        let mut start = start_at(self.curve.points.last().expect("two points"), solver);
        for _ in 0..PHASE_SOLVES {
            let series = &start.state.y[row * t..(row + 1) * t];
            let (theta, _) = series_max(series);
            let arc = self.penetration_row(&start.state, row, theta, g0 * (1.0 + target));
            let p = solver.solve(
                ForcedStart {
                    state: arc.predicted.clone(),
                    multipliers: start.multipliers.clone(),
                },
                Some(&arc),
            );
            let p = p.ok()?;
            let (_, top) = series_max(&p.contact[row * t..(row + 1) * t]);
            if (top - g0 * (1.0 + target)).abs() <= 1e-9 * g0 {
                return Some((p, arc));
            }
            start = crate::solver::ForcedSolver::start_from(&p);
        }
        None
    }

    /// The row phi(theta) . y_row = `level` as an arc row (tangent phi on that row, none on the
    /// parameter), with `state` moved onto it as the prediction.
    fn penetration_row(&self, state: &OrbitState, row: usize, theta: f64, level: f64) -> ArcRow {
        let t = self.solver().basis().terms();
        let phi = basis_at(theta, t);
        let now: f64 = (0..t).map(|p| phi[p] * state.y[row * t + p]).sum();
        let n2: f64 = phi.iter().map(|v| v * v).sum();
        let mut predicted = state.clone();
        let mut tangent_y = vec![0.0; state.y.len()];
        for p in 0..t {
            predicted.y[row * t + p] += phi[p] * (level - now) / n2;
            tangent_y[row * t + p] = phi[p];
        }
        ArcRow {
            parameter: self.curve.sweep.parameter(),
            tangent_y,
            tangent_parameter: 0.0,
            predicted,
            y_scale: self.y_scale,
            parameter_scale: self.p_scale,
        }
    }

    /// Pushes a passage point with its tangent oriented along the secant from the last point
    /// (and its N checked); false when the tangent cannot be solved for.
    fn push_passage(&mut self, p: ForcedPoint, arc: &ArcRow) -> bool {
        let last = self.curve.points.last().expect("two points");
        let (a, b) = (self.scaled(last), self.scaled(&p));
        let d: Vec<f64> = b.iter().zip(&a).map(|(x, y)| x - y).collect();
        let length = norm(&d);
        if length.is_nan() || length <= 0.0 {
            return false;
        }
        let secant: Vec<f64> = d.iter().map(|v| v / length).collect();
        let along = self.arc(&secant, 0.0);
        let Ok(next) = self.solver().tangent(&p, &along) else {
            return false;
        };
        self.accept(p, arc, next);
        true
    }
}
