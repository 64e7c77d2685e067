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
//! while 4N is within `max_harmonics`. Every point of the kept sweep shares one N, so its folds
//! are those of one truncation.

use rayon::prelude::*;

use crate::curve::CurveHarmonics;
use crate::curve_harmonics::{points_worth_checking, record_check};
use crate::error::ForcedError;
use crate::harmonic_check::HarmonicCheck;
use crate::ladder::{resize_signals, start_at};
use crate::solver::ForcedPoint;
use crate::speed_curve::{SpeedHarmonics, SpeedPoint, SpeedSweepSettings};
use crate::speed_step::{assess, problem_at, SpeedArc, SpeedFamily, SpeedStepper};
use crate::speed_sweep::{classify_changes, trace_sweep, SpeedSweep};
use crate::trace::norm;

/// The largest relative change of the master's first harmonic or of the speed between a point
/// and its solve at 2N for the two to be the same orbit (the frequency sweep's
/// `ladder::REFINE_REACH`): beyond it the 2N solve walked to another orbit.
const SAME_ORBIT: f64 = 0.05;

/// How far (relative to Omega_ref) the frozen speed of a 2N solve may move from the point's:
/// as far as a change of `SAME_ORBIT`.
const CHECK_REACH: f64 = SAME_ORBIT;

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
    classify_stability(family, &settings, &mut sweep);
    Ok(sweep)
}

/// The Floquet stability of every point of `sweep` (when asked for; in parallel, each on the
/// problem at its own speed), then the changes of stability between consecutive determined
/// points.
fn classify_stability(
    family: &dyn SpeedFamily,
    settings: &SpeedSweepSettings,
    sweep: &mut SpeedSweep,
) {
    use rayon::prelude::*;
    if !settings.stability {
        return;
    }
    sweep
        .points
        .par_iter_mut()
        .for_each(|p| p.stability = Some(assess(family, settings, p)));
    classify_changes(sweep.points.iter_mut().filter_map(|p| p.stability.as_mut()));
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
        let check = check_sweep(family, &current, &mut sweep, 2 * n <= top)?;
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
            sweep.retraces = retraces;
            return Ok((sweep, current));
        }
        current = at_harmonics(family, &current, 2 * n)?;
    }
}

/// `settings` on N = `harmonics`, the time samples grown as the solver grows them
/// (`ForcedSolver::with_harmonics`).
fn at_harmonics(
    family: &dyn SpeedFamily,
    settings: &SpeedSweepSettings,
    harmonics: usize,
) -> Result<SpeedSweepSettings, ForcedError> {
    let problem = problem_at(family, settings, settings.start)?;
    let finer = problem
        .solver(&settings.solver_settings())?
        .with_harmonics(harmonics)?;
    let mut out = settings.clone();
    out.solver.harmonics = finer.settings().harmonics;
    Ok(out)
}

/// Checks the points of `sweep` (traced at `settings`' N) worth checking at 2N (when
/// `checkable`), marks them and says what it found.
fn check_sweep(
    family: &dyn SpeedFamily,
    settings: &SpeedSweepSettings,
    sweep: &mut SpeedSweep,
    checkable: bool,
) -> Result<CurveHarmonics, ForcedError> {
    let n = settings.solver.harmonics.harmonics;
    let master = problem_at(family, settings, settings.start)?
        .system
        .master();
    let points: Vec<&ForcedPoint> = sweep.points.iter().map(|p| &p.point).collect();
    let folds: Vec<usize> = sweep.folds.iter().map(|f| f.point).collect();
    let checked = points_worth_checking(&points, &folds, master);
    let mut out = CurveHarmonics {
        harmonics: n,
        checked: checked.clone(),
        not_converged: 0,
        largest_change: [0.0; 2],
        checkable,
    };
    if !checkable {
        return Ok(out);
    }
    let finer = at_harmonics(family, settings, 2 * n)?;
    // The points are independent: checked in parallel, each by a stepper of its own (the
    // stepper keeps the last point's slope of the speed mismatch).
    let view: &SpeedSweep = sweep;
    let verdicts: Vec<HarmonicCheck> = checked
        .par_iter()
        .map(|&i| check_point(&SpeedStepper::new(family, &finer), view, i, master))
        .collect();
    for (&i, check) in checked.iter().zip(verdicts) {
        record_check(&mut out, check);
        sweep.points[i].point.harmonic_check = check;
    }
    Ok(out)
}

/// The verdict of point `i` of `sweep` solved again by `finer` (at 2N) on the row through it
/// normal to the sweep (module docs).
fn check_point(
    finer: &SpeedStepper<'_>,
    sweep: &SpeedSweep,
    i: usize,
    master: usize,
) -> HarmonicCheck {
    let p = &sweep.points[i];
    let arc = normal_arc(finer, sweep, i);
    let solved = problem_at(finer.family, finer.settings, p.speed)
        .and_then(|problem| {
            let solver = problem.solver(&finer.solver)?;
            let start = start_at(&p.point, &solver);
            let row = arc.row(finer.fundamental());
            let reach = CHECK_REACH * finer.settings.speed_scale;
            // The check has no step to halve: where the structure-following solve fails (under
            // the penalty law an impact a few samples long can stall its inner Newton), the
            // frozen speed corrected on the same row is the second way to the same point.
            finer
                .on_speed_row(start.clone(), &row, p.speed, reach)
                .or_else(|e| {
                    tracing::debug!(speed = p.speed, "speed sweep: the check at 2N: {e}; frozen");
                    finer.on_row(start, p.speed, &|_, _| row.clone(), &|_, _| true, reach)
                })
        })
        .map_err(|e| tracing::debug!(speed = p.speed, "speed sweep: the check at 2N: {e}"));
    let Ok(fine) = solved else {
        return HarmonicCheck::NotConverged { change: None };
    };
    let (q, qf) = (
        p.point.first_harmonic(master),
        fine.point.first_harmonic(master),
    );
    let change = [
        (q - qf).abs() / qf.abs().max(f64::MIN_POSITIVE),
        (p.speed - fine.speed).abs() / fine.speed,
    ];
    tracing::debug!(
        point = i,
        speed = p.speed,
        speed_2n = fine.speed,
        q1 = q,
        q1_2n = qf,
        solves = fine.corrections,
        "speed sweep: the check at 2N solved"
    );
    if change.iter().any(|&c| c > SAME_ORBIT) || fine.point.touches() != p.point.touches() {
        tracing::debug!(
            speed = p.speed,
            ?change,
            "speed sweep: the check landed elsewhere"
        );
        return HarmonicCheck::NotConverged { change: None };
    }
    if change
        .iter()
        .all(|&c| c <= finer.settings.harmonic_tolerance)
    {
        HarmonicCheck::Converged { change }
    } else {
        HarmonicCheck::NotConverged {
            change: Some(change),
        }
    }
}

/// The row through point `i` normal to the sweep, at `finer`'s N: the unit secant of its
/// neighbours (the point itself at an end) in the scaled space of `speed_sweep` (contact
/// coordinates over g_ref sqrt(c), the speed over Omega_ref), padded with zero harmonics.
fn normal_arc(finer: &SpeedStepper<'_>, sweep: &SpeedSweep, i: usize) -> SpeedArc {
    let pts = &sweep.points;
    let p = &pts[i];
    let rows = p.running_gaps.len().max(1);
    let y_scale = pts[0].gap_reference * (rows as f64).sqrt();
    let speed_scale = finer.settings.speed_scale;
    let (a, b) = (&pts[i.saturating_sub(1)], &pts[(i + 1).min(pts.len() - 1)]);
    let mut t: Vec<f64> = (b.point.contact.iter().zip(&a.point.contact))
        .map(|(x, y)| (x - y) / y_scale)
        .collect();
    t.push((b.speed - a.speed) / speed_scale);
    let length = norm(&t).max(f64::MIN_POSITIVE);
    t.iter_mut().for_each(|v| *v /= length);
    let speed_t = t.pop().unwrap_or(0.0);
    let (from, to) = (
        p.point.contact.len() / rows,
        2 * finer.solver.harmonics.harmonics + 1,
    );
    let mut tangent = resize_signals(&t, rows, from, to);
    tangent.push(speed_t);
    SpeedArc {
        tangent,
        y: resize_signals(&p.point.contact, rows, from, to),
        speed: p.speed,
        step: 0.0,
        y_scale,
        speed_scale,
    }
}
