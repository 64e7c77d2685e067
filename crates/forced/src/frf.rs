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

use crate::curve::{Fold, FrequencyResponse, FrfSettings, FrfTermination, Sweep};
use crate::curve_stability::assess_stability;
use crate::error::ForcedError;
use crate::ladder::HarmonicLadder;
use crate::solver::{ForcedPoint, ForcedSolver};
use crate::trace::FrfTrace;

/// Traces the response curve of `solver` over the settings' range, in W or in the load scale
/// (see module docs), N raised point by point up to `max_harmonics` (`ladder`); `progress` sees
/// every accepted point. A frequency sweep whose trace from the start of the range stops or
/// turns back is traced again from the end of the range, W falling, until it meets the first
/// piece (`FrfTermination::Joined`, two `pieces`) or stops too (`FrfTermination::Gap`).
pub fn response_curve(
    solver: &ForcedSolver<'_>,
    settings: &FrfSettings,
    mut progress: impl FnMut(&ForcedPoint),
) -> Result<FrequencyResponse, ForcedError> {
    settings.validate()?;
    let base = solver.basis().harmonics();
    let top = settings.max_harmonics.unwrap_or(4 * base).max(base);
    let ladder = HarmonicLadder::new(solver, top, settings.harmonic_tolerance)?
        .following(settings.follow_harmonics);
    let mut trace = FrfTrace::begin(&ladder, settings, 1.0, Vec::new(), &mut progress)?;
    trace.run(&mut progress);
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
        let back = FrfTrace::begin(&ladder, settings, -1.0, meet, &mut progress).map(|mut back| {
            back.run(&mut progress);
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
    assess_stability(&ladder, settings, &mut trace.curve)?;
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
