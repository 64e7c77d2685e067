//! Amplitude sweep: the backbone at given amplitude levels by natural-parameter (fixed-q)
//! continuation with adaptive sub-steps. Unlike [`crate::backbone`] it cannot follow a fold of q,
//! but it returns exactly the requested levels (the paper's way of plotting w against q).

use crate::continuation::{Backbone, ContinuationSettings, SkippedLevel, Termination};
use crate::point::BackbonePoint;
use crate::solver::{Guess, Solver, Start};
use crate::NnmError;
use nlmodes_hb::fourier::HarmonicSettings;
use nlmodes_hb::linear_model::ParameterRow;
use nlmodes_hb::solver_settings::SolverSettings;
use nlmodes_hb::system::System;

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
    params: impl Into<SolverSettings>,
    cont: &ContinuationSettings,
    levels: &[f64],
    mut progress: F,
) -> Result<Backbone, NnmError>
where
    F: FnMut(&BackbonePoint),
{
    cont.validate()?;
    check_levels(levels)?;
    let mut sweep = Sweep::new(Solver::new(system, settings, params)?, cont)?;
    for (index, &level) in levels.iter().enumerate() {
        match sweep.reach(level) {
            Ok(p) => {
                progress(&p);
                sweep.result.points.push(p);
                if index + 1 == levels.len() {
                    sweep.result.termination = Termination::ReachedMaxAmplitude;
                }
            }
            Err(last_error) => {
                if !sweep.skip(level, last_error) {
                    break;
                }
            }
        }
    }
    Ok(sweep.result)
}

/// The levels must be finite, positive and increasing.
fn check_levels(levels: &[f64]) -> Result<(), NnmError> {
    for (i, &l) in levels.iter().enumerate() {
        if !(l.is_finite() && l > 0.0) || (i > 0 && l <= levels[i - 1]) {
            return Err(NnmError::InvalidParameter {
                name: "levels",
                value: l,
                expected: "finite, positive and increasing amplitudes",
            });
        }
    }
    Ok(())
}

/// The state of a sweep between levels.
struct Sweep<'s, 'c> {
    solver: Solver<'s>,
    cont: &'c ContinuationSettings,
    /// Linear frequency of `cont.mode` (rad/s) and the gap reference g_ref.
    w1: f64,
    g_ref: f64,
    /// Last two converged states (not necessarily at levels).
    history: Vec<BackbonePoint>,
    /// Next sub-step (units of g_ref).
    h: f64,
    /// After a skipped level the continuation is stuck (typically at a fold of q): the following
    /// levels are only tried from the linear mode directly (cold starts), until one converges.
    stuck: bool,
    result: Backbone,
}

impl<'s, 'c> Sweep<'s, 'c> {
    fn new(solver: Solver<'s>, cont: &'c ContinuationSettings) -> Result<Self, NnmError> {
        let system = solver.system();
        let w1 = solver.linear_frequency(cont.mode)?;
        let g_ref = system.gap_reference();
        let result = Backbone::empty(
            Termination::ReachedMaxAmplitude,
            w1,
            g_ref,
            system.grazing_amplitude(cont.mode)?,
        );
        Ok(Self {
            solver,
            cont,
            w1,
            g_ref,
            history: Vec::new(),
            h: cont.step,
            stuck: false,
            result,
        })
    }

    /// The point at `level` (units of g_ref), or the last error's message.
    fn reach(&mut self, level: f64) -> Result<BackbonePoint, String> {
        if self.stuck {
            self.cold_start(level)
        } else {
            self.substeps_to(level)
        }
    }

    /// Solves at `level` from the linear mode; on success the sweep goes on from there.
    fn cold_start(&mut self, level: f64) -> Result<BackbonePoint, String> {
        let mut p = self
            .solver
            .solve_point(level * self.g_ref, Start::LinearMode(self.cont.mode))
            .map_err(|e| e.to_string())?;
        p.jump = true;
        self.history.clear();
        self.history.push(p.clone());
        self.stuck = false;
        self.h = self.cont.step;
        Ok(p)
    }

    /// Fixed-q sub-steps up to `level`, shrinking the sub-step after a failure; the sweep is
    /// stuck when it falls below `cont.min_step`.
    fn substeps_to(&mut self, level: f64) -> Result<BackbonePoint, String> {
        loop {
            let target = match self.history.last() {
                None => level,
                Some(p) => level.min(p.q / self.g_ref + self.h),
            };
            match self.substep(target) {
                Ok(p) => {
                    self.accept(p);
                    if target >= level {
                        return Ok(self.history[self.history.len() - 1].clone());
                    }
                }
                Err(e) => {
                    if self.history.is_empty() {
                        return Err(e.to_string());
                    }
                    self.h *= self.cont.shrink;
                    if self.h < self.cont.min_step {
                        self.h = self.cont.step;
                        self.stuck = true;
                        return Err(e.to_string());
                    }
                }
            }
        }
    }

    /// One solve at `target` (units of g_ref): from the linear mode first, then extrapolated.
    fn substep(&mut self, target: f64) -> Result<BackbonePoint, NnmError> {
        let q = target * self.g_ref;
        if self.history.is_empty() {
            return self
                .solver
                .solve_point(q, Start::LinearMode(self.cont.mode));
        }
        let guess = extrapolate_in_q(&self.history, q);
        let row = ParameterRow::fixed_amplitude(q, self.g_ref, self.w1);
        self.solver.solve_with_row(row, guess, None)
    }

    /// Flags a jump of w, grows the sub-step and keeps the point in the history.
    fn accept(&mut self, mut p: BackbonePoint) {
        match self.history.last() {
            Some(prev) => {
                p.jump = (p.omega - prev.omega).abs() > SWEEP_JUMP_RATIO * prev.omega;
                self.h = (self.h * self.cont.growth).min(self.cont.max_step);
            }
            None => p.jump = !self.result.points.is_empty(),
        }
        self.history.push(p);
        if self.history.len() > 2 {
            self.history.remove(0);
        }
    }

    /// Records `level` as skipped and the termination so far; false when nothing has converged
    /// yet (the sweep then ends).
    fn skip(&mut self, level: f64, last_error: String) -> bool {
        let q = level * self.g_ref;
        tracing::warn!(q_over_g0 = level, "amplitude level skipped: {last_error}");
        self.result.termination = match self.history.last() {
            None => Termination::StartFailed {
                reason: last_error.clone(),
            },
            Some(p) => Termination::StepTooSmall {
                q: p.q,
                step: level - p.q / self.g_ref,
                reason: last_error.clone(),
            },
        };
        self.result.skipped.push(SkippedLevel {
            q,
            reason: last_error,
        });
        !self.history.is_empty()
    }
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
