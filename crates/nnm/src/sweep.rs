//! Amplitude sweep: the backbone at given amplitude levels by natural-parameter (fixed-q)
//! continuation with adaptive sub-steps. Unlike [`crate::backbone`] it cannot follow a fold of q,
//! but it returns exactly the requested levels (the paper's way of plotting w against q).

use crate::augmented_lagrangian::AlgorithmParams;
use crate::continuation::{Backbone, ContinuationSettings, SkippedLevel, Termination};
use crate::error::NnmError;
use crate::fourier::HarmonicSettings;
use crate::linear_model::ParameterRow;
use crate::point::BackbonePoint;
use crate::solver::{Guess, Solver, Start};
use crate::system::System;

/// Natural-parameter sweep: solves at the given master amplitudes `levels` (units of g_ref, increasing),
/// by a fixed-q continuation with adaptive sub-steps between levels (secant predictor of u and w
/// from the last two converged points, theta and kappa of the last one; the sub-step starts at
/// `cont.step`, grows by `cont.growth` after a success up to `cont.max_step` and shrinks by
/// `cont.shrink` after a failure). Only the requested levels are returned. It does not follow folds
/// (use [`crate::backbone`] for that): where w(q) folds it may land on another branch, which the `jump`
/// flag marks (w changed by more than 5 % between sub-steps). A level whose sub-step falls below
/// `cont.min_step` is recorded in `skipped`; the sweep is then stuck (typically at a fold of q)
/// and the following levels are tried from the linear mode directly (cold starts, flagged as
/// jumps since they may land on another branch) until one converges, from which it goes on. Termination: `StartFailed` if nothing converged, `ReachedMaxAmplitude`
/// if the last level converged, `StepTooSmall` otherwise. `cont.q_start`, `cont.q_max` are unused.
pub fn amplitude_sweep<F>(
    system: &System,
    settings: HarmonicSettings,
    params: AlgorithmParams,
    cont: &ContinuationSettings,
    levels: &[f64],
    mut progress: F,
) -> Result<Backbone, NnmError>
where
    F: FnMut(&BackbonePoint),
{
    cont.validate()?;
    for (i, &l) in levels.iter().enumerate() {
        if !(l.is_finite() && l > 0.0) || (i > 0 && l <= levels[i - 1]) {
            return Err(NnmError::InvalidParameter {
                name: "levels",
                value: l,
                expected: "finite, positive and increasing amplitudes",
            });
        }
    }
    let mode = cont.mode;
    let mut solver = Solver::new(system, settings, params)?;
    let w1 = solver.linear_frequency(mode)?;
    let g_ref = system.gap_reference();
    let mut result = Backbone {
        points: Vec::new(),
        termination: Termination::ReachedMaxAmplitude,
        omega_linear: w1,
        gap_reference: g_ref,
        grazing_amplitude: system.grazing_amplitude(mode)?,
        skipped: Vec::new(),
        internal_resonances: Vec::new(),
        branches: Vec::new(),
    };
    // Last two converged states (not necessarily at levels).
    let mut history: Vec<BackbonePoint> = Vec::new();
    let mut h = cont.step;
    // After a skipped level the continuation is stuck (typically at a fold of q): the following
    // levels are only tried from the linear mode directly (cold starts), until one converges.
    let mut stuck = false;
    for (index, &level) in levels.iter().enumerate() {
        let mut last_error = String::new();
        let mut reached = None;
        if stuck {
            match solver.solve_point(level * g_ref, Start::LinearMode(mode)) {
                Ok(mut p) => {
                    p.jump = true;
                    history.clear();
                    history.push(p.clone());
                    reached = Some(p);
                    stuck = false;
                    h = cont.step;
                }
                Err(e) => last_error = e.to_string(),
            }
        }
        while reached.is_none() && !stuck {
            let from = history.last().map(|p| p.q / g_ref);
            let target = match from {
                None => level,
                Some(f) => level.min(f + h),
            };
            let attempt = match history.len() {
                0 => solver.solve_point(target * g_ref, Start::LinearMode(mode)),
                _ => {
                    let guess = extrapolate_in_q(&history, target * g_ref);
                    let row = ParameterRow::fixed_amplitude(target * g_ref, g_ref, w1);
                    solver.solve_with_row(row, guess)
                }
            };
            match attempt {
                Ok(mut p) => {
                    match history.last() {
                        Some(prev) => {
                            p.jump = (p.omega - prev.omega).abs() > SWEEP_JUMP_RATIO * prev.omega;
                            h = (h * cont.growth).min(cont.max_step);
                        }
                        None => p.jump = !result.points.is_empty(),
                    }
                    history.push(p);
                    if history.len() > 2 {
                        history.remove(0);
                    }
                    if target >= level {
                        reached = history.last().cloned();
                    }
                }
                Err(e) => {
                    last_error = e.to_string();
                    if history.is_empty() {
                        break;
                    }
                    h *= cont.shrink;
                    if h < cont.min_step {
                        h = cont.step;
                        stuck = true;
                    }
                }
            }
        }
        match reached {
            Some(p) => {
                progress(&p);
                result.points.push(p);
                if index + 1 == levels.len() {
                    result.termination = Termination::ReachedMaxAmplitude;
                }
            }
            None => {
                tracing::warn!(q = level * g_ref, "amplitude level skipped: {last_error}");
                result.skipped.push(SkippedLevel {
                    q: level * g_ref,
                    reason: last_error.clone(),
                });
                result.termination = match history.last() {
                    None => Termination::StartFailed {
                        reason: last_error.clone(),
                    },
                    Some(p) => Termination::StepTooSmall {
                        q: p.q,
                        step: level - p.q / g_ref,
                        reason: last_error.clone(),
                    },
                };
                if history.is_empty() {
                    return Ok(result);
                }
            }
        }
    }
    Ok(result)
}

/// Warm start at amplitude `q` extrapolated linearly in q from the last two points of `history`.
fn extrapolate_in_q(history: &[BackbonePoint], q: f64) -> Guess {
    let last = &history[history.len() - 1];
    let (coefficients, omega) = if history.len() >= 2 && history[0].q != last.q {
        let prev = &history[0];
        let r = (q - last.q) / (last.q - prev.q);
        let c = last
            .coefficients
            .iter()
            .zip(&prev.coefficients)
            .map(|(a, b)| a.iter().zip(b).map(|(x, y)| x + r * (x - y)).collect())
            .collect();
        (c, last.omega + r * (last.omega - prev.omega))
    } else {
        let s = q / last.q;
        (
            last.coefficients
                .iter()
                .map(|c| c.iter().map(|v| v * s).collect())
                .collect(),
            last.omega,
        )
    };
    Guess {
        mode: last.mode,
        coefficients,
        omega,
        q,
        multipliers: last.multipliers.clone(),
    }
}

/// Relative change of w between consecutive sweep levels flagged as a jump.
const SWEEP_JUMP_RATIO: f64 = 0.05;
