//! The forced response over a range (DESIGN §10.5): [`response_curve`] (the curve, its settings
//! and folds are `curve`), which traces it from the linear response at the start of
//! the range, through folds, to its end, where p is W (the frequency response at a fixed load,
//! [`Sweep::Frequency`]) or the load scale s at a fixed W (the response to a growing force,
//! [`Sweep::Level`]). The continuation itself is `trace` (pseudo-arc-length along the exact
//! tangent), N is converged point by point by `ladder`, the folds are located by `fold`, the
//! stability of every point is `point_stability`.
//!
//! A fold is where p turns: `FoldKind::TurnsBack` (p rising, then falling: on a sweep up the
//! response jumps down there) and `FoldKind::TurnsForward` (on a sweep down it jumps up there).
//! A frequency sweep whose trace from the start of the range stops is traced again from its end;
//! the curve covers its range only when one trace crosses it or the two meet
//! ([`FrfTermination::covers_range`]); two that do not meet leave the branch between their last
//! points uncomputed ([`FrfTermination::Gap`]).

use crate::curve::{Fold, FrequencyResponse, FrfSettings, FrfTermination, HarmonicPolicy, Sweep};
use crate::curve_harmonics::{check_curve, exact_force_of_curve};
use crate::curve_stability::assess_stability;
use crate::error::ForcedError;
use crate::ladder::HarmonicLadder;
use crate::raise_frequency::FrequencyTarget;
use crate::raised_segments::Raising;
use crate::solver::{ForcedPoint, ForcedSolver};
use crate::trace::FrfTrace;

/// Traces the response curve of `solver` over the settings' range, in W or in the load scale
/// (see module docs), N converged up to `max_harmonics` under the settings' `HarmonicPolicy`
/// (point by point through `ladder`, or the whole curve again at 2N while its checked points
/// have not converged: `curve_harmonics`); `progress` sees every accepted point. A frequency
/// sweep whose trace from the start of the range stops or turns back is traced again from the
/// end of the range, W falling, until it meets the first piece (`FrfTermination::Joined`, two
/// `pieces`) or stops too (`FrfTermination::Gap`).
pub fn response_curve(
    solver: &ForcedSolver<'_>,
    settings: &FrfSettings,
    mut progress: impl FnMut(&ForcedPoint),
) -> Result<FrequencyResponse, ForcedError> {
    settings.validate()?;
    let base = solver.basis().harmonics();
    let top = settings.max_harmonics.unwrap_or(4 * base).max(base);
    if settings.harmonic_policy == HarmonicPolicy::Retrace {
        return retraced_curve(solver, settings, top, &mut progress);
    }
    let ladder = HarmonicLadder::new(solver, top, settings.harmonic_tolerance)?
        .with_policy(settings.harmonic_policy);
    let mut curve = trace_range(&ladder, settings, &mut progress)?;
    assess_stability(&ladder, settings, &mut curve)?;
    Ok(curve)
}

/// The curve at one N after another (`HarmonicPolicy::Retrace`): traced at the solver's N,
/// checked at 2N (`curve_harmonics::check_curve`), traced again at 2N while a checked point
/// moved by more than the tolerance and 4N is within `top`. The last trace is the curve; every
/// trace is listed in its `retraces`. When the last trace's check still finds points moving and
/// 2N is within `top`, N is raised to 2N around them alone (`raised_segments`, checked at 4N).
fn retraced_curve(
    solver: &ForcedSolver<'_>,
    settings: &FrfSettings,
    top: usize,
    progress: &mut impl FnMut(&ForcedPoint),
) -> Result<FrequencyResponse, ForcedError> {
    let mut retraces = Vec::new();
    let mut finer: Option<ForcedSolver<'_>> = None;
    loop {
        let current = finer.as_ref().unwrap_or(solver);
        let n = current.basis().harmonics();
        let ladder = HarmonicLadder::new(current, (2 * n).min(top), settings.harmonic_tolerance)?
            .with_policy(HarmonicPolicy::Retrace);
        let mut curve = trace_range(&ladder, settings, progress)?;
        let touches = curve.points.iter().any(|p| p.touches());
        let may_retrace = 4 * n <= top && touches && ladder.levels() > 1;
        let (check, moving) = check_curve(&ladder, settings, &mut curve, may_retrace);
        let again = !check.converged() && may_retrace;
        tracing::info!(
            harmonics = n,
            checked = check.checked.len(),
            not_converged = check.not_converged,
            change_q1 = check.largest_change[0],
            change_omega = check.largest_change[1],
            "forced response: the curve at N = {n} checked at 2N{}",
            if again { "; traced again at 2N" } else { "" }
        );
        retraces.push(check);
        if !again {
            // Points whose 2N solve failed seed no segment: with no other, nothing is raised
            // and the check says which failed.
            if moving.iter().any(|m| m.finer.is_some()) && ladder.levels() > 1 {
                let target = FrequencyTarget {
                    base: current,
                    settings,
                    trace: curve.clone(),
                };
                let finer = ladder.solver(1);
                let tolerance = settings.harmonic_tolerance;
                let raising = Raising::new(&target, n, finer, top, tolerance)?;
                let pieces = curve.pieces.clone();
                let raised = raising.raise(&mut curve.points, &pieces, moving)?;
                curve.raised = Some(raised);
            }
            // Every point is assessed by the solver of its N: up to the last round's when
            // points were raised beyond 2N.
            let raised_to = curve.raised.as_ref().map_or(0, |r| r.check.harmonics);
            let stability = match raised_to > 2 * n {
                true => HarmonicLadder::new(current, raised_to, settings.harmonic_tolerance)?,
                false => ladder,
            };
            if let Some(f) = retraces.last_mut().and_then(|c| c.force.as_mut()) {
                f.exact = exact_force_of_curve(&stability, &curve);
            }
            assess_stability(&stability, settings, &mut curve)?;
            curve.retraces = retraces;
            return Ok(curve);
        }
        finer = Some(solver.with_harmonics(2 * n)?);
    }
}

/// The curve over the range by `ladder` (see `response_curve`), without its stability.
fn trace_range(
    ladder: &HarmonicLadder<'_, '_>,
    settings: &FrfSettings,
    progress: &mut impl FnMut(&ForcedPoint),
) -> Result<FrequencyResponse, ForcedError> {
    let mut trace = FrfTrace::begin(ladder, settings, 1.0, Vec::new(), progress)?;
    trace.run(progress);
    let stopped = matches!(
        trace.curve.termination,
        FrfTermination::StepTooSmall { .. } | FrfTermination::LeftRange { .. }
    );
    if stopped && settings.sweep == Sweep::Frequency {
        let meet = trace
            .curve
            .points
            .iter()
            .map(|p| trace.scaled_base(p))
            .collect();
        let back = FrfTrace::begin(ladder, settings, -1.0, meet, progress).map(|mut back| {
            back.run(progress);
            back.curve
        });
        append(&mut trace.curve, back);
    } else if stopped {
        let stopped = trace.curve.end_text();
        trace.curve.termination = FrfTermination::Gap {
            stopped,
            second: "was not traced (a level sweep is traced from its start only)".into(),
            from: trace.curve.points.len() - 1,
            to: None,
        };
    }
    Ok(trace.curve)
}

/// Appends the trace from the end of the range (`back`, or why it could not start) as the
/// second piece: joined when it met the first piece, a gap otherwise.
fn append(curve: &mut FrequencyResponse, back: Result<FrequencyResponse, ForcedError>) {
    let stopped = curve.end_text();
    let from = curve.points.len() - 1;
    let back = match back {
        Ok(back) => back,
        Err(e) => {
            curve.termination = FrfTermination::Gap {
                stopped,
                second: format!("could not start ({e})"),
                from,
                to: None,
            };
            return;
        }
    };
    let offset = curve.points.len();
    curve.termination = match back.termination {
        FrfTermination::Joined { met, .. } => FrfTermination::Joined { stopped, met },
        FrfTermination::LeftRange { at } => FrfTermination::Gap {
            stopped,
            second: format!("turned back past the end of the range after W = {at:.6e} rad/s"),
            from,
            to: Some(offset + back.points.len() - 1),
        },
        _ => FrfTermination::Gap {
            stopped,
            second: match back.termination {
                FrfTermination::Complete => {
                    "crossed the range on another branch without meeting it".into()
                }
                _ => back.end_text(),
            },
            from,
            to: Some(offset + back.points.len() - 1),
        },
    };
    curve.pieces.push(offset);
    curve.folds.extend(back.folds.into_iter().map(|f| Fold {
        point: f.point + offset,
        ..f
    }));
    curve.hops.extend(back.hops.into_iter().map(|h| h + offset));
    curve.points.extend(back.points);
}
