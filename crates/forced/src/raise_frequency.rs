//! The frequency response as a [`RaiseTarget`] (DESIGN §10.8): its points are `ForcedPoint`s,
//! its levels `ForcedSolver`s at N, 2N, 4N, ..., its rows normal to the trace at N through a
//! point (`curve_harmonics::normal_row`), its parameter W (or the force level of a level
//! sweep: `FrfSettings::sweep`).

use crate::curve::{FrequencyResponse, FrfSettings};
use crate::curve_harmonics::normal_row;
use crate::error::ForcedError;
use crate::ladder::{relative_change, resize_signals, solve_same_orbit, start_at};
use crate::raised_segments::RaiseTarget;
use crate::solver::{ForcedPoint, ForcedSolver, ForcedStart};

/// A traced frequency response (a copy of the trace: its rows stay those of the trace at N
/// while `Raising` writes the raised points into the curve) and the solver of its N.
pub(crate) struct FrequencyTarget<'a, 's> {
    /// The solver at the trace's N (its tangents give the normal rows).
    pub base: &'a ForcedSolver<'s>,
    pub settings: &'a FrfSettings,
    /// The curve as traced at N.
    pub trace: FrequencyResponse,
}

impl<'s> RaiseTarget for FrequencyTarget<'_, 's> {
    type Point = ForcedPoint;
    type Level = ForcedSolver<'s>;
    const WHAT: &'static str = "forced response";

    fn orbit(p: &ForcedPoint) -> &ForcedPoint {
        p
    }

    fn orbit_mut(p: &mut ForcedPoint) -> &mut ForcedPoint {
        p
    }

    fn harmonics(level: &ForcedSolver<'s>) -> usize {
        level.basis().harmonics()
    }

    fn level(&self, harmonics: usize) -> Result<ForcedSolver<'s>, ForcedError> {
        self.base.with_harmonics(harmonics)
    }

    fn change(&self, a: &ForcedPoint, b: &ForcedPoint) -> [f64; 2] {
        relative_change(a, b, self.base.system().master())
    }

    /// On the row normal to the trace at `i`, or at the point's W (`fixed_first`: the row
    /// failed at the neighbour, where the curve at N may turn in a way 2N does not: the
    /// stalled end of the blade's first piece at level 5).
    fn solve_finer(
        &self,
        finer: &ForcedSolver<'s>,
        i: usize,
        point: &ForcedPoint,
        (neighbour, neighbour_fine): (&ForcedPoint, &ForcedPoint),
        fixed_first: bool,
    ) -> Option<(ForcedPoint, [f64; 2], bool)> {
        let shifted = shifted_start(point, neighbour, neighbour_fine, finer);
        let on_row = || {
            let row = normal_row(self.base, self.settings, &self.trace, i);
            solve_same_orbit(finer, point, Some(&row), Some(shifted.clone()))
                .map(|(p, c)| (p, c, false))
        };
        let at_w = || {
            let mut start = shifted.clone();
            start.state.omega = point.omega;
            start.state.level = point.level;
            solve_same_orbit(finer, point, None, Some(start)).map(|(p, c)| (p, c, true))
        };
        if fixed_first {
            at_w().or_else(on_row)
        } else {
            on_row().or_else(at_w)
        }
    }

    fn solve_again(
        &self,
        level: &ForcedSolver<'s>,
        i: usize,
        point: &ForcedPoint,
    ) -> Option<(ForcedPoint, [f64; 2])> {
        let row = normal_row(self.base, self.settings, &self.trace, i);
        solve_same_orbit(level, point, Some(&row), None)
    }
}

/// The start at `finer`'s N of `point` from a neighbour solved at the point's N and at
/// `finer`'s: the neighbour's finer orbit plus the difference of the two points.
fn shifted_start(
    point: &ForcedPoint,
    neighbour: &ForcedPoint,
    neighbour_fine: &ForcedPoint,
    finer: &ForcedSolver<'_>,
) -> ForcedStart {
    let rows = finer.system().n_contacts().max(1);
    let (from, to) = (point.contact.len() / rows, finer.basis().terms());
    let difference: Vec<f64> = point
        .contact
        .iter()
        .zip(&neighbour.contact)
        .map(|(a, b)| a - b)
        .collect();
    let difference = resize_signals(&difference, rows, from, to);
    let mut start = start_at(point, finer);
    start.state.y = neighbour_fine
        .contact
        .iter()
        .zip(&difference)
        .map(|(y, d)| y + d)
        .collect();
    start.state.omega = neighbour_fine.omega + (point.omega - neighbour.omega);
    start.state.level = neighbour_fine.level + (point.level - neighbour.level);
    start
}
