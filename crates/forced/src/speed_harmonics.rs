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
//! under `SpeedHarmonics::Retrace` the whole sweep is then traced again at 2N,
//! while 4N is within `max_harmonics`, so that the sweep's folds are those of one truncation.
//! When the last trace's check still finds points moving (4N beyond `max_harmonics`), N is
//! raised around them alone (`raised_segments`, as the frequency response does: to 2N in
//! segments grown along the sweep until two points in a row are converged, checked at 4N, and
//! again one level up while a check moves); each point carries its N.

use rayon::prelude::*;

use crate::curve::CurveHarmonics;
use crate::curve_harmonics::{points_worth_checking, record_check, MovingPoint};
use crate::error::ForcedError;
use crate::harmonic_check::HarmonicCheck;
use crate::ladder::verdict;
use crate::raise_speed::{at_harmonics, SpeedTarget};
use crate::raised_segments::{RaiseTarget, Raising};
use crate::solver::ForcedPoint;
use crate::speed_curve::{SpeedHarmonics, SpeedPoint, SpeedSweepSettings};
use crate::speed_step::{assess, problem_at, SpeedFamily};
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
        let finer = match 2 * n <= top {
            true => Some(target.level(2 * n)?),
            false => None,
        };
        let (check, moving) = check_sweep(&target, finer.as_ref(), &mut sweep);
        let touches = sweep.points.iter().any(|p| p.point.touches());
        let again = settings.harmonic_policy == SpeedHarmonics::Retrace
            && !check.converged()
            && 4 * n <= top
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
            let raise = settings.harmonic_policy == SpeedHarmonics::Retrace && !moving.is_empty();
            if let (true, Some(finer)) = (raise, finer.as_ref()) {
                sweep.raised = Some(raise_segments(&target, finer, top, &mut sweep, moving)?);
                refold_raised(&mut sweep, current.speed_scale);
            }
            sweep.retraces = retraces;
            return Ok((sweep, current));
        }
        current = finer.unwrap_or(current);
    }
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
    };
    let Some(finer) = finer else {
        return (out, Vec::new());
    };
    // The points are independent: checked in parallel.
    let solves: Vec<Option<(SpeedPoint, [f64; 2])>> = checked
        .par_iter()
        .map(|&i| target.solve_again(finer, i, &sweep.points[i]))
        .collect();
    let mut moving = Vec::new();
    for (&i, solve) in checked.iter().zip(solves) {
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
