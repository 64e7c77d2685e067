//! Passing grazing in a speed sweep, as the frequency sweep does (`grazing`, DESIGN §10.7):
//! where a contact row starts or stops touching, the exactly integrated penalty law's Jacobian
//! changes like k sqrt(penetration) and the arc-length corrector fails at every step (on the
//! default blade at 7661 rpm, EO 3, down to steps of 1e-6). At a prescribed largest
//! penetration of the grazing row the problem is regular: the passage solves the orbits whose
//! row reaches its running gap plus a penetration growing geometrically from 1e-7 of it
//! (entering contact) or shrinking to it and then below the gap (leaving contact), each from
//! the last, at its own speed (`SpeedStepper::on_row`: the row "largest value of y_j over the
//! period = g0_j(Omega) (1 + delta)" at the frozen speed, the phase of the largest value
//! updated until the value is the target to 1e-9 g0_j), then hands back to arc length.
//!
//! Where no step down to the smallest converges and no row is grazing, the sweep hops as the
//! frequency sweep does past a corner (`corner`): at a fixed speed a little further on (1e-4,
//! 1e-3, 5e-3 Omega_ref), from the last orbit, the first that lands within `HOP_REACH` of it
//! (on the default blade, EO 3 at 2 x grazing, the arc-length corrector fails at 7661 rpm at
//! every step down to 1e-6 while the orbit at a fixed speed 0.8 rpm further converges).

use nlmodes_hb::FullBasis;

use crate::grazing::series_max;
use crate::newton::{ArcRow, OrbitState, Parameter};
use crate::solver::{ForcedPoint, ForcedSolver, ForcedStart};
use crate::speed_curve::SpeedPoint;
use crate::speed_sweep::SpeedTrace;

/// A row within this fraction of its gap (below or above) is grazing (`grazing::GRAZING_BAND`).
const GRAZING_BAND: f64 = 0.05;

/// Penetrations (fractions of the gap) of the passage into contact; leaving contact, the same
/// down to the smallest, then `BELOW` (the frequency sweep's, `grazing`).
const PENETRATIONS: [f64; 7] = [1e-7, 1e-6, 1e-5, 1e-4, 1e-3, 1e-2, 3e-2];
const BELOW: [f64; 3] = [-1e-4, -1e-3, -1e-2];

/// How far (relative to Omega_ref) the speed of a passage point may lie from the last point's:
/// the passage's penetrations move the orbit along the curve by far less.
const PASSAGE_REACH: f64 = 0.02;

/// Points after a passage that did not get across before it is tried again on the same row
/// (each try costs a dozen solves; on the default blade the same row was tried at 20
/// consecutive points, never across).
const PASSAGE_RETRY: usize = 10;

/// How far (in scaled distance, as a multiple of the hop's speed step) a hop may land from
/// the last orbit (`corner::HOP_REACH`).
const HOP_REACH: f64 = 20.0;

/// The basis functions of `FullBasis` at phase `theta` (`terms` of them).
fn basis_at(theta: f64, terms: usize) -> Vec<f64> {
    (0..terms)
        .map(|p| {
            let mut unit = vec![0.0; terms];
            unit[p] = 1.0;
            FullBasis::value_at(&unit, theta)
        })
        .collect()
}

/// The row closest to its running gap at `p` (in contact or not: on the blade rows enter and
/// leave contact one by one while others stay in): (row, largest value minus the gap as a
/// fraction of the gap).
fn grazing_row(p: &SpeedPoint) -> (usize, f64) {
    let gaps = &p.running_gaps;
    let t = p.point.contact.len() / gaps.len().max(1);
    (0..gaps.len())
        .map(|j| {
            let (_, top) = series_max(&p.point.contact[j * t..(j + 1) * t]);
            (j, (top - gaps[j]) / gaps[j])
        })
        .min_by(|a, b| a.1.abs().total_cmp(&b.1.abs()))
        .unwrap_or((0, -1.0))
}

/// The row phi(theta) . y_row = `level` at the phase theta of the row's largest value in
/// `state` (`terms` coefficients per row), as an arc row with W free (`scales`: y_s and the
/// W scale), `state` moved onto it as the prediction.
fn penetration_row(
    state: &OrbitState,
    (row, terms): (usize, usize),
    level: f64,
    (y_scale, parameter_scale): (f64, f64),
) -> ArcRow {
    let (theta, _) = series_max(&state.y[row * terms..(row + 1) * terms]);
    let phi = basis_at(theta, terms);
    let now: f64 = (0..terms).map(|p| phi[p] * state.y[row * terms + p]).sum();
    let n2: f64 = phi.iter().map(|v| v * v).sum();
    let mut predicted = state.clone();
    let mut tangent_y = vec![0.0; state.y.len()];
    for p in 0..terms {
        predicted.y[row * terms + p] += phi[p] * (level - now) / n2;
        tangent_y[row * terms + p] = phi[p];
    }
    ArcRow {
        parameter: Parameter::Frequency,
        tangent_y,
        tangent_parameter: 0.0,
        predicted,
        y_scale,
        parameter_scale,
    }
}

impl SpeedTrace<'_> {
    /// Passes grazing by prescribed penetrations (module docs) when the last point's grazing
    /// row is within `GRAZING_BAND` of its gap; whether it got across.
    pub(crate) fn pass_grazing(&mut self, tangent: &[f64]) -> bool {
        let last = self.sweep.points.last().expect("two points").clone();
        let (row, penetration) = grazing_row(&last);
        let n = self.sweep.points.len();
        let retried = self
            .failed_passage
            .is_some_and(|(r, at)| r == row && n < at + PASSAGE_RETRY);
        if penetration.abs() > GRAZING_BAND || retried {
            return false;
        }
        let terms = last.point.contact.len() / last.running_gaps.len().max(1);
        let series = &last.point.contact[row * terms..(row + 1) * terms];
        let (theta, _) = series_max(series);
        let phi = basis_at(theta, terms);
        let rate: f64 = (0..terms).map(|p| phi[p] * tangent[row * terms + p]).sum();
        let targets: Vec<f64> = if rate > 0.0 {
            PENETRATIONS
                .iter()
                .copied()
                .filter(|&d| d > penetration)
                .collect()
        } else {
            let mut down: Vec<f64> = (PENETRATIONS.iter().rev())
                .copied()
                .filter(|&d| d < penetration)
                .collect();
            down.extend(BELOW.iter().copied().filter(|&d| d < penetration));
            down
        };
        let mut crossed = false;
        for target in targets {
            let from = self.sweep.points.last().expect("points");
            match self.solve_at_penetration(from, row, target) {
                Some(p) => self.push(p),
                None => break,
            }
            crossed |= (target > 0.0) != (penetration > 0.0);
        }
        tracing::debug!(row, penetration, crossed, "speed sweep: grazing passage");
        if !crossed {
            self.failed_passage = Some((row, n));
        }
        crossed
    }

    /// The orbit whose row `row` reaches its running gap times 1 + `target`, from `from`.
    fn solve_at_penetration(
        &self,
        from: &SpeedPoint,
        row: usize,
        target: f64,
    ) -> Option<SpeedPoint> {
        let scales = (self.y_scale, self.stepper.settings.speed_scale);
        let e = self.stepper.fundamental();
        let level = |solver: &ForcedSolver<'_>| solver.system().gaps()[row] * (1.0 + target);
        let make = |solver: &ForcedSolver<'_>, state: &OrbitState| {
            let terms = solver.basis().terms();
            penetration_row(state, (row, terms), level(solver), (scales.0, e * scales.1))
        };
        let settled = |solver: &ForcedSolver<'_>, p: &ForcedPoint| {
            let t = solver.basis().terms();
            let (_, top) = series_max(&p.contact[row * t..(row + 1) * t]);
            (top - level(solver)).abs() <= 1e-9 * solver.system().gaps()[row]
        };
        let start = ForcedStart {
            state: OrbitState {
                y: from.point.contact.clone(),
                omega: from.point.omega,
                level: 1.0,
            },
            multipliers: from.point.multipliers.clone(),
        };
        self.stepper
            .on_row(start, from.speed, &make, &settled, PASSAGE_REACH * scales.1)
            .map_err(|e| tracing::debug!("speed sweep: no passage point at {target:e}: {e}"))
            .ok()
    }

    /// Solves at the fixed speed Omega_k + `direction` d (d = 1e-4, 1e-3, 5e-3 Omega_ref) from
    /// the last orbit and keeps the first that converges within `HOP_REACH` d of it, flagged
    /// as a hop (`SpeedSweep::hops`). Returns whether one did.
    pub(crate) fn hop(&mut self, direction: f64) -> bool {
        let last = self.sweep.points.last().expect("two points").clone();
        let scale = self.stepper.settings.speed_scale;
        for d in [1e-4, 1e-3, 5e-3] {
            let speed = last.speed + direction * d * scale;
            let Ok(p) = self.stepper.at_speed(speed, Some(&last)) else {
                continue;
            };
            let (_, distance) = self.secant(&last, &p);
            if distance <= HOP_REACH * d {
                tracing::debug!(speed, "speed sweep: hop at a fixed speed");
                self.sweep.hops.push(self.sweep.points.len());
                self.push(p);
                return true;
            }
        }
        false
    }
}
