//! Fallback of the inner Newton solve when the semi-smooth Newton stalls: a smoothing path.

use crate::error::HbError;
use crate::fourier::Aft;
use crate::linear_model::LinearModel;
use crate::newton::{
    solve_inner, InnerProblem, NewtonReport, NewtonSettings, NewtonState, NewtonWork,
};

/// Smoothing widths (relative to the reference gap) from which the fallback path starts, smallest
/// first; each path then divides mu by 100 per stage down to 1e-8 and ends with the exact law.
const SMOOTHING_STARTS: [f64; 3] = [1e-6, 1e-4, 1e-2];

/// [`solve_inner`] with a fallback: if the semi-smooth Newton fails from `state` (typically cycling
/// between two contact states of a few samples), the contact law is smoothed with a width mu
/// (1e-6 g_ref first, larger if that fails) and mu is then driven to 0 through stages, each solved
/// by Newton from the previous one, the last one with the exact law (a smoothing-Newton path).
#[allow(clippy::too_many_arguments)]
pub fn solve_inner_robust(
    model: &mut dyn LinearModel,
    aft: &mut Aft,
    p: &InnerProblem<'_>,
    g_ref: f64,
    settings: &NewtonSettings,
    state: &mut NewtonState,
    work: &mut NewtonWork,
    allow_smoothing: bool,
) -> Result<NewtonReport, HbError> {
    let start = state.clone();
    let first = match solve_inner(model, aft, p, settings, state, work) {
        Ok(rep) => return Ok(rep),
        Err(e) => e,
    };
    if !allow_smoothing {
        return Err(first);
    }
    for &mu0 in &SMOOTHING_STARTS {
        *state = start.clone();
        let mut total = 0;
        let mut mu = mu0;
        let mut ok = true;
        loop {
            let stage = InnerProblem {
                smoothing: mu * g_ref,
                ..*p
            };
            let stage_settings = if mu > 0.0 {
                NewtonSettings {
                    tolerance: settings.tolerance.max(1e-8),
                    ..settings.clone()
                }
            } else {
                settings.clone()
            };
            match solve_inner(model, aft, &stage, &stage_settings, state, work) {
                Ok(rep) => total += rep.iterations,
                Err(_) => {
                    ok = false;
                    break;
                }
            }
            if mu == 0.0 {
                break;
            }
            mu = if mu > 1e-8 { mu * 1e-2 } else { 0.0 };
        }
        if ok {
            return Ok(NewtonReport { iterations: total });
        }
    }
    Err(first)
}
