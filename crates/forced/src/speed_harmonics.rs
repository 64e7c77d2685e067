//! N converged in a speed sweep (DESIGN §10.10; the frequency sweep's `HarmonicPolicy::Retrace`
//! of §10.8): the sweep is traced at one N; its peak, the point nearest each fold, the point of
//! the largest contact force and four points spread over its contact
//! (`curve_harmonics::points_worth_checking`) are solved again at 2N, each on the row through
//! the point normal to the sweep (the central secant of its neighbours in the scaled space of
//! `speed_sweep`), as the trace's own steps are (`SpeedStepper::on_speed_row`: under the
//! penalty law the structure follows W = e Omega inside the Newton solve; the structure frozen
//! at one speed and that speed corrected only where that fails, or under exact contact). The
//! row is normal to the speed line's curve, not to a frozen structure's response: frozen, the
//! default blade's check failed at 5 of its 8 points (docs/ROTATION.md, session 22). A point
//! whose 2N solve moves the master's first harmonic or the speed by more than
//! `harmonic_tolerance` (relative), or fails, or lands on another orbit, has not converged;
//! under `SpeedHarmonics::Retrace` the whole sweep is then traced again at 2N, while 2N is
//! within `max_harmonics` (the largest N of a whole trace), so that the sweep's folds are those
//! of one truncation; at 4N instead when the moving points' 2N solves move again at 4N
//! (`next_trace_harmonics`: the trace at 2N would be thrown away by its own check). The
//! largest contact force of each trace is reported with its solve at 2N (`ForceCheck`).
//! When the last trace's check still finds points moving (2N beyond `max_harmonics`), N is
//! raised around them alone (`raised_segments`, as the frequency response does: to 2N in
//! segments grown along the sweep until two points in a row are converged, checked at 4N, and
//! again one level up while a check moves); each point carries its N.

use rayon::prelude::*;

use crate::curve::{CurveHarmonics, ExactForce};
use crate::curve_harmonics::{
    force_candidates, force_check, points_worth_checking, record_check, strongest_point,
    MovingPoint,
};
use crate::error::ForcedError;
use crate::exact_force::climbed_exact;
use crate::harmonic_check::HarmonicCheck;
use crate::ladder::verdict;
use crate::raise_speed::{at_harmonics, SpeedTarget};
use crate::raised_segments::{RaiseTarget, Raising, RAISE_BEYOND};
use crate::solver::ForcedPoint;
use crate::speed_curve::{SpeedHarmonics, SpeedPoint, SpeedSweepSettings};
use crate::speed_step::{assess, exact_force_at, problem_at, SpeedFamily};
use crate::speed_sweep::{classify_changes, refold_raised, trace_sweep, SpeedSweep};

/// Traces the forced response of `family` at W = e Omega over the settings' speed range
/// (module docs), N converged under the settings' `SpeedHarmonics` (`speed_harmonics`), then
/// the stability of every point; `progress` sees every accepted point of every trace.
pub fn speed_sweep(
    family: &dyn SpeedFamily,
    settings: &SpeedSweepSettings,
    mut progress: impl FnMut(&SpeedPoint),
) -> Result<SpeedSweep, ForcedError> {
    settings.validate()?;
    let (mut sweep, settings) = converged_sweep(family, settings, &mut progress)?;
    classify_stability(family, &settings, &mut sweep)?;
    Ok(sweep)
}

/// The Floquet stability of every point of `sweep` (when asked for; in parallel, each on the
/// problem at its own speed and at its own N), then the changes of stability between
/// consecutive determined points.
fn classify_stability(
    family: &dyn SpeedFamily,
    settings: &SpeedSweepSettings,
    sweep: &mut SpeedSweep,
) -> Result<(), ForcedError> {
    if !settings.stability {
        return Ok(());
    }
    let mut levels: Vec<SpeedSweepSettings> = vec![settings.clone()];
    for p in &sweep.points {
        let n = p.point.harmonics;
        if !levels.iter().any(|l| l.solver.harmonics.harmonics == n) {
            levels.push(at_harmonics(family, settings, n)?);
        }
    }
    let level_of = |p: &SpeedPoint| {
        (levels.iter())
            .find(|l| l.solver.harmonics.harmonics == p.point.harmonics)
            .unwrap_or(settings)
    };
    sweep
        .points
        .par_iter_mut()
        .for_each(|p| p.stability = Some(assess(family, level_of(p), p)));
    classify_changes(sweep.points.iter_mut().filter_map(|p| p.stability.as_mut()));
    Ok(())
}

/// The sweep of `family` with N converged under `settings.harmonic_policy` (module docs),
/// without its stability, and the settings of its last trace (its N).
pub(crate) fn converged_sweep(
    family: &dyn SpeedFamily,
    settings: &SpeedSweepSettings,
    progress: &mut impl FnMut(&SpeedPoint),
) -> Result<(SpeedSweep, SpeedSweepSettings), ForcedError> {
    let top = settings.top_harmonics();
    let mut current = settings.clone();
    let mut retraces = Vec::new();
    loop {
        let mut sweep = trace_sweep(family, &current, progress)?;
        if settings.harmonic_policy == SpeedHarmonics::Fixed {
            return Ok((sweep, current));
        }
        let n = current.solver.harmonics.harmonics;
        let target = SpeedTarget {
            family,
            base: &current,
            trace: sweep.points.clone(),
            master: problem_at(family, &current, current.start)?.system.master(),
        };
        let finer = match 2 * n <= RAISE_BEYOND * top {
            true => Some(target.level(2 * n)?),
            false => None,
        };
        let (check, moving) = check_sweep(&target, finer.as_ref(), &mut sweep);
        let touches = sweep.points.iter().any(|p| p.point.touches());
        let again = settings.harmonic_policy == SpeedHarmonics::Retrace
            && !check.converged()
            && 2 * n <= top
            && touches;
        tracing::info!(
            harmonics = n,
            checked = check.checked.len(),
            not_converged = check.not_converged,
            change_q1 = check.largest_change[0],
            change_speed = check.largest_change[1],
            "speed sweep: the sweep at N = {n} checked at 2N{}",
            if again { "; traced again at 2N" } else { "" }
        );
        retraces.push(check);
        if !again {
            // Points whose 2N solve failed seed no segment: with no other, nothing is raised
            // and the check says which failed.
            let raise = settings.harmonic_policy == SpeedHarmonics::Retrace
                && moving.iter().any(|m| m.finer.is_some());
            if let (true, Some(finer)) = (raise, finer.as_ref()) {
                sweep.raised = Some(raise_segments(&target, finer, top, &mut sweep, moving)?);
                refold_raised(&mut sweep, current.speed_scale);
            }
            if let Some(f) = retraces.last_mut().and_then(|c| c.force.as_mut()) {
                f.exact = exact_force_of_sweep(&target, &sweep);
            }
            sweep.retraces = retraces;
            return Ok((sweep, current));
        }
        let next = next_trace_harmonics(&target, &moving, top)?;
        current = match (next == 2 * n, finer) {
            (true, Some(finer)) => finer,
            _ => target.level(next)?,
        };
    }
}

/// The largest contact force on the exact orbits of `sweep`, from its strongest point and its
/// peak (`curve_harmonics::force_candidates`) along the sweep (`exact_force::climbed_exact`;
/// each on the problem at its speed): the last trace's `ForceCheck::exact`, shot once the
/// sweep is final.
fn exact_force_of_sweep(target: &SpeedTarget<'_>, sweep: &SpeedSweep) -> Option<ExactForce> {
    let points: Vec<&ForcedPoint> = sweep.points.iter().map(|p| &p.point).collect();
    climbed_exact(
        points.len(),
        &force_candidates(&points, target.master),
        |i| points[i].touches(),
        |i| exact_force_at(target.family, target.base, &sweep.points[i]),
    )
}

/// N of the next trace of a sweep traced at `target`'s N whose check moved at 2N (the
/// `moving` points, with their solves at 2N): 4N when one of those solves moves again at 4N by
/// more than the tolerance (or fails there) and 4N is within `top`, else 2N. A trace at 2N
/// would then be traced again: on the default blade's EO 3 sweep the trace at N = 20 winds
/// through loops near 7973 rpm (a grazing of a second impact) that N = 40 does not have, with
/// contact forces 50 % high there, and its check moves at 40 as the one at N = 10 did
/// (docs/ROTATION.md, session 26).
fn next_trace_harmonics(
    target: &SpeedTarget<'_>,
    moving: &[MovingPoint<SpeedPoint>],
    top: usize,
) -> Result<usize, ForcedError> {
    let n = target.base.solver.harmonics.harmonics;
    if 4 * n > top {
        return Ok(2 * n);
    }
    let finest = target.level(4 * n)?;
    let tolerance = target.base.harmonic_tolerance;
    let still_moving = moving
        .par_iter()
        .filter_map(|m| m.finer.as_ref().map(|f| (m.index, f)))
        .any(|(i, finer)| match target.solve_again(&finest, i, finer) {
            Some((_, change)) => change.iter().any(|&c| c > tolerance),
            None => true,
        });
    tracing::info!(
        harmonics = n,
        "speed sweep: the points that moved at 2N {} at 4N",
        if still_moving {
            "move again (or fail)"
        } else {
            "are converged"
        }
    );
    Ok(if still_moving { 4 * n } else { 2 * n })
}

/// N raised around the `moving` points of the last trace's check (`raised_segments`): to
/// `finer` (2N), checked at 4N, and so on.
fn raise_segments(
    target: &SpeedTarget<'_>,
    finer: &SpeedSweepSettings,
    top: usize,
    sweep: &mut SpeedSweep,
    moving: Vec<MovingPoint<SpeedPoint>>,
) -> Result<crate::curve::RaisedSegments, ForcedError> {
    let n = target.base.solver.harmonics.harmonics;
    let tolerance = target.base.harmonic_tolerance;
    let raising = Raising::new(target, n, finer, top, tolerance)?;
    let raised = raising.raise(&mut sweep.points, &[], moving)?;
    Ok(raised)
}

/// Checks the points of `sweep` (traced at the target's N) worth checking at `finer` (2N;
/// `None` above `max_harmonics`: not checkable), marks them and says what it found, with the
/// points that moved (and their solves at 2N, for `raise_segments`).
fn check_sweep(
    target: &SpeedTarget<'_>,
    finer: Option<&SpeedSweepSettings>,
    sweep: &mut SpeedSweep,
) -> (CurveHarmonics, Vec<MovingPoint<SpeedPoint>>) {
    let points: Vec<&ForcedPoint> = sweep.points.iter().map(|p| &p.point).collect();
    let folds: Vec<usize> = sweep.folds.iter().map(|f| f.point).collect();
    let checked = points_worth_checking(&points, &folds, target.master);
    let mut out = CurveHarmonics {
        harmonics: target.base.solver.harmonics.harmonics,
        checked: checked.clone(),
        not_converged: 0,
        largest_change: [0.0; 2],
        checkable: finer.is_some(),
        force: None,
    };
    let Some(finer) = finer else {
        return (out, Vec::new());
    };
    // The points are independent: checked in parallel.
    let solves: Vec<Option<(SpeedPoint, [f64; 2])>> = checked
        .par_iter()
        .map(|&i| target.solve_again(finer, i, &sweep.points[i]))
        .collect();
    let strongest = strongest_point(&points);
    let mut moving = Vec::new();
    for (&i, solve) in checked.iter().zip(solves) {
        if strongest == Some(i) {
            let fine = solve.as_ref().map(|s| &s.0.point);
            out.force = Some(force_check(i, &sweep.points[i].point, fine));
        }
        let check = verdict(solve.as_ref().map(|s| s.1), target.base.harmonic_tolerance);
        record_check(&mut out, check);
        sweep.points[i].point.harmonic_check = check;
        if matches!(check, HarmonicCheck::NotConverged { .. }) {
            moving.push(MovingPoint {
                index: i,
                finer: solve.map(|s| s.0),
            });
        }
    }
    (out, moving)
}
