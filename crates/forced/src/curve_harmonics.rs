//! The check of a whole curve's N under `HarmonicPolicy::Retrace` (DESIGN §10.8): the points
//! that carry what an engineer reads off the curve (its peak, its folds, its deepest contact)
//! and a few spread over its contact are solved again at 2N, each on the row through the point
//! normal to the curve there, so that a fold is checked where it is and a point far up a
//! steep branch is not compared with another W's orbit.

use crate::curve::{CurveHarmonics, ExactForce, ForceCheck, FrequencyResponse, FrfSettings};
use crate::exact_force::{climbed_exact, exact_largest_force};
use crate::harmonic_check::HarmonicCheck;
use crate::ladder::HarmonicLadder;
use crate::newton::{ArcRow, OrbitState};
use crate::solver::{ForcedPoint, ForcedSolver};
use crate::trace::{norm, scales};

/// Points spread evenly over the contact, checked beside the peak, the folds and the deepest
/// contact.
const SPREAD: usize = 4;

/// A checked point that moved by more than the tolerance at 2N, or whose 2N solve failed
/// (`P`: a frequency response's `ForcedPoint`, a speed sweep's `SpeedPoint`).
pub(crate) struct MovingPoint<P = ForcedPoint> {
    /// Its index in the curve.
    pub index: usize,
    /// Its solve at 2N on its normal row, when that converged on the same orbit.
    pub finer: Option<P>,
}

/// The touching point of `points` with the largest contact force (`None` when none touches):
/// always among `points_worth_checking`.
pub(crate) fn strongest_point(points: &[&ForcedPoint]) -> Option<usize> {
    (0..points.len())
        .filter(|&i| points[i].touches())
        .max_by(|&a, &b| {
            let force = |i: usize| points[i].largest_contact_force();
            force(a).total_cmp(&force(b))
        })
}

/// Of a curve's `points`: the peak in contact (largest first harmonic of the master) and the
/// point of the largest contact force (`strongest_point`), each once: where the largest force
/// of the exact orbits is looked for (`exact_force`).
pub(crate) fn force_candidates(points: &[&ForcedPoint], master: usize) -> Vec<usize> {
    let peak = (0..points.len())
        .filter(|&i| points[i].touches())
        .max_by(|&a, &b| {
            let q1 = |i: usize| points[i].first_harmonic(master);
            q1(a).total_cmp(&q1(b))
        });
    let mut out: Vec<usize> = peak.into_iter().chain(strongest_point(points)).collect();
    out.dedup();
    out
}

/// The force check of a trace whose strongest point `point` (`strongest_point`) was solved
/// again at 2N as `finer` (`None`: that solve failed or landed elsewhere).
pub(crate) fn force_check(
    point: usize,
    orbit: &ForcedPoint,
    finer: Option<&ForcedPoint>,
) -> ForceCheck {
    ForceCheck {
        point,
        force: orbit.largest_contact_force(),
        finer: finer.map(ForcedPoint::largest_contact_force),
        exact: None,
    }
}

/// Checks `curve` (traced at the base N of `ladder`, whose level 1, when there is one, is 2N)
/// at the points of the module docs, marks them, and says what it found, with the checked
/// points that moved (for `raised_segments`). With `until_one_moves` (the curve is traced
/// again at 2N as soon as one point moves) the check stops at the first point that moves: the
/// rest would be thrown away with the trace (`checked` lists the points checked).
pub(crate) fn check_curve(
    ladder: &HarmonicLadder<'_, '_>,
    settings: &FrfSettings,
    curve: &mut FrequencyResponse,
    until_one_moves: bool,
) -> (CurveHarmonics, Vec<MovingPoint>) {
    let base = ladder.solver(0);
    let checked = points_to_check(curve, base.system().master());
    let mut out = CurveHarmonics {
        harmonics: base.basis().harmonics(),
        checked: checked.clone(),
        not_converged: 0,
        largest_change: [0.0; 2],
        checkable: ladder.levels() > 1,
        force: None,
    };
    let mut moving = Vec::new();
    if !out.checkable {
        return (out, moving);
    }
    let strongest = strongest_point(&curve.points.iter().collect::<Vec<_>>());
    // The checks are independent solves: a batch at a time side by side (one per core where
    // the check stops at the first point that moves, all at once otherwise), taken in order.
    let batch = match until_one_moves {
        true => rayon::current_num_threads().max(1),
        false => checked.len().max(1),
    };
    let mut k = 0;
    for chunk in checked.chunks(batch) {
        for (&i, (point, finer)) in chunk
            .iter()
            .zip(check_batch(ladder, settings, curve, chunk))
        {
            record_check(&mut out, point.harmonic_check);
            if strongest == Some(i) {
                out.force = Some(force_check(i, &point, finer.as_ref()));
            }
            let moved = matches!(point.harmonic_check, HarmonicCheck::NotConverged { .. });
            if moved {
                moving.push(MovingPoint { index: i, finer });
            }
            curve.points[i] = point;
            k += 1;
            if moved && until_one_moves {
                out.checked.truncate(k);
                return (out, moving);
            }
        }
    }
    (out, moving)
}

/// The solves at 2N of the points `chunk` of `curve` (`check_curve`), in parallel, in their
/// order.
fn check_batch(
    ladder: &HarmonicLadder<'_, '_>,
    settings: &FrfSettings,
    curve: &FrequencyResponse,
    chunk: &[usize],
) -> Vec<(ForcedPoint, Option<ForcedPoint>)> {
    use rayon::prelude::*;
    let base = ladder.solver(0);
    let rows: Vec<ArcRow> = (chunk.iter())
        .map(|&i| normal_row(base, settings, curve, i))
        .collect();
    (chunk.par_iter().zip(&rows))
        .map(|(&i, row)| ladder.checked_with_solve(curve.points[i].clone(), 0, Some(row)))
        .collect()
}

/// The largest contact force on the exact orbits of `curve`, from its strongest point and its
/// peak (`force_candidates`) along the curve (`exact_force::climbed_exact`; each on the solver
/// of its N in `ladder`): the last trace's `ForceCheck::exact`, shot once the curve is final.
pub(crate) fn exact_force_of_curve(
    ladder: &HarmonicLadder<'_, '_>,
    curve: &FrequencyResponse,
) -> Option<ExactForce> {
    let points: Vec<&ForcedPoint> = curve.points.iter().collect();
    let master = ladder.solver(0).system().master();
    climbed_exact(
        points.len(),
        &force_candidates(&points, master),
        |i| points[i].touches(),
        |i| exact_largest_force(ladder.solver_of(points[i]), points[i]),
    )
}

/// Adds one checked point's verdict to `out` (its largest changes, its count of points not
/// converged). Shared with the speed sweeps' check (`speed_harmonics`).
pub(crate) fn record_check(out: &mut CurveHarmonics, check: HarmonicCheck) {
    let change = match check {
        HarmonicCheck::Converged { change } => Some(change),
        HarmonicCheck::NotConverged { change } => {
            out.not_converged += 1;
            change
        }
        _ => None,
    };
    if let Some(c) = change {
        out.largest_change[0] = out.largest_change[0].max(c[0]);
        out.largest_change[1] = out.largest_change[1].max(c[1]);
    }
}

/// The points of `curve` to check (`points_worth_checking`).
fn points_to_check(curve: &FrequencyResponse, master: usize) -> Vec<usize> {
    let points: Vec<&ForcedPoint> = curve.points.iter().collect();
    let folds: Vec<usize> = curve.folds.iter().map(|f| f.point).collect();
    points_worth_checking(&points, &folds, master)
}

/// Of a curve's `points` (with the points nearest its `folds`): the peak (largest first
/// harmonic of the master), the point nearest each fold, the point of the largest contact
/// force, and `SPREAD` points evenly spaced among those in contact; sorted, each once. None
/// when the curve never touches. Shared with the speed sweeps' check (`speed_harmonics`).
pub(crate) fn points_worth_checking(
    points: &[&ForcedPoint],
    folds: &[usize],
    master: usize,
) -> Vec<usize> {
    let touching: Vec<usize> = (0..points.len()).filter(|&i| points[i].touches()).collect();
    if touching.is_empty() {
        return Vec::new();
    }
    let mut out = force_candidates(points, master);
    out.extend(folds.iter().copied());
    let n = touching.len();
    out.extend((0..SPREAD).map(|k| touching[(2 * k + 1) * n / (2 * SPREAD)]));
    out.sort_unstable();
    out.dedup();
    out
}

/// The row through point `i` normal to the curve there: its tangent from the solver, oriented
/// (and, should the tangent fail, replaced) by the secant of its neighbours in its piece.
/// Every point of `curve` is at `solver`'s N.
pub(crate) fn normal_row(
    solver: &ForcedSolver<'_>,
    settings: &FrfSettings,
    curve: &FrequencyResponse,
    i: usize,
) -> ArcRow {
    let (y_scale, p_scale) = scales(solver.system(), settings);
    let scaled = |p: &ForcedPoint| {
        let mut v: Vec<f64> = p.contact.iter().map(|y| y / y_scale).collect();
        v.push(curve.parameter(p) / p_scale);
        v
    };
    let (piece_start, piece_end) = curve.piece_of(i);
    let before = if i == piece_start { i } else { i - 1 };
    let after = if i + 1 == piece_end { i } else { i + 1 };
    let (a, b) = (scaled(&curve.points[before]), scaled(&curve.points[after]));
    let secant: Vec<f64> = b.iter().zip(&a).map(|(x, y)| x - y).collect();
    let length = norm(&secant).max(f64::MIN_POSITIVE);
    let secant: Vec<f64> = secant.iter().map(|v| v / length).collect();
    let point = &curve.points[i];
    let along = row(point, &secant, settings, y_scale, p_scale);
    match solver.tangent(point, &along) {
        Ok(t) => row(point, &t, settings, y_scale, p_scale),
        Err(_) => along,
    }
}

/// The arc row through `point` (h = 0) along the unit `tangent` of the scaled space.
fn row(
    point: &ForcedPoint,
    tangent: &[f64],
    settings: &FrfSettings,
    y_scale: f64,
    p_scale: f64,
) -> ArcRow {
    let l = point.contact.len();
    ArcRow {
        parameter: settings.sweep.parameter(),
        tangent_y: tangent[..l].to_vec(),
        tangent_parameter: tangent[l],
        predicted: OrbitState {
            y: point.contact.clone(),
            omega: point.omega,
            level: point.level,
        },
        y_scale,
        parameter_scale: p_scale,
    }
}
