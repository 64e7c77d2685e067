//! Backbone continuation: from below grazing (where w = w_lin exactly and the shape is the linear
//! mode scaled to q) up to a maximum amplitude.
//!
//! Pseudo-arc-length continuation in the scaled space X = (q / g_ref, w / w_lin,
//! y / (g_ref sqrt(c + 1))), y the kept coordinates of every harmonic (contact coefficients A_j u_n
//! and master coefficients; an RMS over the c + 1 kept coordinates, so y weighs like q). The
//! predictor steps by ds along the secant of the last two points (along the linear mode at the
//! first step, where the backbone is flat), and the corrector solves Algorithm 1 with the parameter
//! row t . (X - X_pred) = 0 in place of q = const, so q is an unknown and the branch can turn back
//! in q (a fold: after grazing the first-harmonic amplitude of a coordinate may decrease for a while
//! as w rises). Using the state, not only (q, w), matters: near internal resonances the branch can
//! turn in the harmonics while q and w barely move, where a (q, w)-only row becomes singular. Folds (sign change of dq/ds) and jumps (corrector far from
//! the predictor) are flagged on the points. Warm start of every solve: coefficients extrapolated
//! along the secant, theta and kappa of the last point. Adaptive step: grow after an easy point,
//! halve and retry after a failure. Below `min_step` (typically at a corner of the branch, where a
//! new contact phase appears and the branch is not smooth), a few fixed-q "hops" ahead in the
//! current direction of q are tried (the point reached is flagged as a jump); if they fail too the
//! run stops and the points computed so far are returned with the reason.

use serde::{Deserialize, Serialize};

use crate::augmented_lagrangian::AlgorithmParams;
use crate::error::NnmError;
use crate::fourier::HarmonicSettings;
use crate::linear_model::ParameterRow;
use crate::point::BackbonePoint;
use crate::solver::{Guess, Solver, Start};
use crate::system::System;

/// Continuation settings. Amplitudes are in units of the reference gap g_ref (the mean initial
/// gap, [`System::gap_reference`]); steps are arc lengths in the scaled plane (q / g_ref, w / w_lin).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct ContinuationSettings {
    /// Linear mode the backbone starts from (0-based, default 0).
    pub mode: usize,
    /// First amplitude q / g_ref (default 0.5; choose it below grazing to start on the exact
    /// linear solution).
    pub q_start: f64,
    /// Last amplitude q / g_ref (default 10).
    pub q_max: f64,
    /// Initial arc-length step (default 0.25).
    pub step: f64,
    /// Smallest step before giving up (default 1e-4).
    pub min_step: f64,
    /// Largest step (default 1).
    pub max_step: f64,
    /// Maximum number of points (default 1000).
    pub max_points: usize,
    /// Step growth factor after an easy point (default 1.5).
    pub growth: f64,
    /// Step reduction factor after a failure (default 0.5).
    pub shrink: f64,
    /// A point is easy when it took at most this many Newton iterations in total (default 8).
    pub easy_iterations: usize,
    /// A point is flagged as a jump when the corrector lands farther than this times the step from
    /// the predictor (default 1).
    pub jump_factor: f64,
    /// Skip internal-resonance tongues (default true): a point whose largest secondary component
    /// (linear mode k, harmonic n >= 2) holds more energy than the primary one (starting mode,
    /// n = 1) while n w is within `resonance_tolerance` of w_k has left the backbone along a tongue
    /// where energy flows into mode k at a frequency locked to w_k / n. It is not kept; the run
    /// returns to the last point and hops ahead at fixed q (the point reached is a jump), and the
    /// skipped resonance is recorded in [`Backbone::internal_resonances`].
    pub skip_internal_resonances: bool,
    /// Relative detuning |n w - w_k| / w_k below which a component counts as resonant (default 0.02).
    pub resonance_tolerance: f64,
}

impl Default for ContinuationSettings {
    fn default() -> Self {
        Self {
            mode: 0,
            q_start: 0.5,
            q_max: 10.0,
            step: 0.25,
            min_step: 1e-4,
            max_step: 1.0,
            max_points: 1000,
            growth: 1.5,
            shrink: 0.5,
            easy_iterations: 8,
            jump_factor: 1.0,
            skip_internal_resonances: true,
            resonance_tolerance: 0.02,
        }
    }
}

impl ContinuationSettings {
    /// Checks the ranges; the error names the parameter.
    pub fn validate(&self) -> Result<(), NnmError> {
        let pos = |name, v: f64| {
            if v.is_finite() && v > 0.0 {
                Ok(())
            } else {
                Err(NnmError::InvalidParameter {
                    name,
                    value: v,
                    expected: "a finite value > 0",
                })
            }
        };
        pos("q_start", self.q_start)?;
        pos("q_max", self.q_max)?;
        pos("step", self.step)?;
        pos("min_step", self.min_step)?;
        pos("max_step", self.max_step)?;
        pos("jump_factor", self.jump_factor)?;
        pos("resonance_tolerance", self.resonance_tolerance)?;
        if self.q_max <= self.q_start {
            return Err(NnmError::InvalidParameter {
                name: "q_max",
                value: self.q_max,
                expected: "a value > q_start",
            });
        }
        if !(self.min_step <= self.step && self.step <= self.max_step) {
            return Err(NnmError::InvalidParameter {
                name: "step",
                value: self.step,
                expected: "min_step <= step <= max_step",
            });
        }
        if !(self.growth.is_finite() && self.growth >= 1.0) {
            return Err(NnmError::InvalidParameter {
                name: "growth",
                value: self.growth,
                expected: "a finite value >= 1",
            });
        }
        if !(self.shrink > 0.0 && self.shrink < 1.0) {
            return Err(NnmError::InvalidParameter {
                name: "shrink",
                value: self.shrink,
                expected: "0 < shrink < 1",
            });
        }
        if self.max_points == 0 {
            return Err(NnmError::InvalidParameter {
                name: "max_points",
                value: 0.0,
                expected: ">= 1",
            });
        }
        Ok(())
    }
}

/// Why a backbone run stopped.
#[derive(Clone, Debug, PartialEq, Serialize)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum Termination {
    /// The last point is at q_max.
    ReachedMaxAmplitude,
    /// `max_points` points were computed.
    MaxPoints,
    /// The step fell below `min_step`; `reason` is the last solver error.
    StepTooSmall {
        /// Master amplitude of the last converged point.
        q: f64,
        /// Step that failed.
        step: f64,
        /// Last error.
        reason: String,
    },
    /// The branch turned back and reached q <= 0 (the normalization degenerates).
    AmplitudeNotPositive,
    /// The branch entered an internal-resonance tongue and no hop past it converged.
    InternalResonance {
        /// Master amplitude of the last point before the tongue.
        q: f64,
        /// The resonating linear mode (0-based).
        mode: usize,
        /// The harmonic close to it.
        harmonic: usize,
    },
    /// The first point could not be computed.
    StartFailed {
        /// The error.
        reason: String,
    },
}

/// A computed backbone.
#[derive(Clone, Debug, Serialize)]
pub struct Backbone {
    /// Points in continuation order (not necessarily increasing in q after a fold).
    pub points: Vec<BackbonePoint>,
    /// Why the run stopped.
    pub termination: Termination,
    /// Linear frequency of the starting mode (rad/s).
    pub omega_linear: f64,
    /// Reference gap g_ref used for the amplitude scaling.
    pub gap_reference: f64,
    /// Master amplitude where the linear mode first touches (None if no contact row moves).
    pub grazing_amplitude: Option<f64>,
    /// Amplitude levels that could not be solved (amplitude sweep only), with the error.
    pub skipped: Vec<SkippedLevel>,
    /// Internal-resonance tongues met and skipped by [`crate::backbone`].
    pub internal_resonances: Vec<InternalResonance>,
}

/// An internal resonance met by the continuation: the branch turned into a tongue where linear
/// mode `mode` at harmonic `harmonic` took over the orbit (`harmonic` x w close to w_mode).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct InternalResonance {
    /// Master amplitude of the tongue point (length unit of the system).
    pub q: f64,
    /// w / w_lin at the tongue point.
    pub omega_ratio: f64,
    /// The resonating linear mode (0-based).
    pub mode: usize,
    /// The harmonic n with n w close to its frequency.
    pub harmonic: usize,
    /// Its share of the orbit's energy.
    pub share: f64,
    /// Relative detuning (n w - w_k) / w_k from the linear frequency of the mode (contact stiffens
    /// the modes, so the tongue may sit a few percent away from it).
    pub detuning: f64,
    /// Whether a hop past the tongue succeeded (the next point is flagged as a jump).
    pub hopped: bool,
}

/// An amplitude level of [`crate::amplitude_sweep`] that did not converge.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct SkippedLevel {
    /// Master amplitude q (length unit of the system).
    pub q: f64,
    /// The solver error.
    pub reason: String,
}

/// Traces the backbone of mode `cont.mode` from q_start to q_max (pseudo-arc-length), calling
/// `progress` after every converged point. Invalid settings are errors; solver failures end the
/// run with the points computed so far and a [`Termination`] saying why.
pub fn backbone<F>(
    system: &System,
    settings: HarmonicSettings,
    params: AlgorithmParams,
    cont: &ContinuationSettings,
    mut progress: F,
) -> Result<Backbone, NnmError>
where
    F: FnMut(&BackbonePoint),
{
    cont.validate()?;
    let mut solver = Solver::new(system, settings, params)?;
    let w1 = solver.linear_frequency(cont.mode)?;
    let g_ref = system.gap_reference();
    let grazing = system.grazing_amplitude(cont.mode)?;
    let mut result = Backbone {
        points: Vec::new(),
        termination: Termination::MaxPoints,
        omega_linear: w1,
        gap_reference: g_ref,
        grazing_amplitude: grazing,
        skipped: Vec::new(),
        internal_resonances: Vec::new(),
    };
    let c = system.n_contacts();
    let y_norm = ((c + 1) as f64).sqrt();
    let nh = settings.terms();
    // Scaled branch coordinates X = (q / g_ref, w / w_lin, y / (g_ref sqrt(c + 1))).
    let scaled = |p: &BackbonePoint| -> Vec<f64> {
        let mut x = vec![p.q / g_ref, p.omega / w1];
        x.extend(
            kept_coordinates(system, p, nh)
                .iter()
                .map(|y| y / (g_ref * y_norm)),
        );
        x
    };
    match solver.solve_point(cont.q_start * g_ref, Start::LinearMode(cont.mode)) {
        Ok(p) => {
            progress(&p);
            result.points.push(p);
        }
        Err(e) => {
            result.termination = Termination::StartFailed {
                reason: e.to_string(),
            };
            return Ok(result);
        }
    }
    // First tangent: the linear branch, X proportional to q at constant w.
    let mut tangent = scaled(&result.points[0]);
    tangent[1] = 0.0;
    normalize(&mut tangent);
    let mut ds = cont.step;
    let mut last_ds = ds;
    let mut last_dq_sign = 1.0;
    let omegas = system.linear_frequencies();
    loop {
        if result.points.len() >= cont.max_points {
            result.termination = Termination::MaxPoints;
            return Ok(result);
        }
        let xl = scaled(&result.points[result.points.len() - 1]);
        let mut step = ds;
        let final_step = tangent[0] > 0.0 && xl[0] + ds * tangent[0] >= cont.q_max;
        if final_step {
            // Shorten the step so the predictor lands on q_max, then solve at fixed q = q_max.
            step = (cont.q_max - xl[0]) / tangent[0];
        }
        let pred: Vec<f64> = xl.iter().zip(&tangent).map(|(x, t)| x + step * t).collect();
        let guess = extrapolate(&result.points, &pred, g_ref, w1, step / last_ds);
        let row = if final_step {
            ParameterRow::fixed_amplitude(cont.q_max * g_ref, g_ref, w1)
        } else {
            ParameterRow {
                a_q: tangent[0],
                a_w: tangent[1],
                a_y: tangent[2..].iter().map(|t| t / y_norm).collect(),
                q_p: pred[0] * g_ref,
                w_p: pred[1] * w1,
                y_p: pred[2..].iter().map(|y| y * g_ref * y_norm).collect(),
                q_scale: g_ref,
                w_scale: w1,
                y_scale: g_ref,
            }
        };
        // A point accepted by a fixed-q hop (past a tongue or a corner of the branch).
        let hopped = match solver.solve_with_row(row, guess) {
            Ok(mut p) => {
                let xn = scaled(&p);
                if xn[0] <= 0.0 {
                    result.termination = Termination::AmplitudeNotPositive;
                    return Ok(result);
                }
                if let Some(res) = cont.tongue(&p, &omegas) {
                    // The branch left the backbone along an internal-resonance tongue: drop the
                    // point and hop ahead at fixed q from the last point of the backbone.
                    tracing::warn!(
                        q_over_g0 = p.q / g_ref,
                        omega_ratio = p.omega_ratio,
                        mode = res.mode + 1,
                        harmonic = res.harmonic,
                        share = res.share,
                        "internal resonance: harmonic {} of the orbit is close to linear mode {}; \
                         skipping the tongue",
                        res.harmonic,
                        res.mode + 1
                    );
                    let last = &result.points[result.points.len() - 1];
                    let base = (last_ds * tangent[0].abs()).max(cont.step);
                    let hop = hop_ahead(&mut solver, last, 1.0, base, cont, &omegas);
                    result.internal_resonances.push(InternalResonance {
                        hopped: hop.is_some(),
                        ..res
                    });
                    match hop {
                        Some(h) => h,
                        None => {
                            result.termination = Termination::InternalResonance {
                                q: last.q,
                                mode: res.mode,
                                harmonic: res.harmonic,
                            };
                            return Ok(result);
                        }
                    }
                } else {
                    let mut delta: Vec<f64> = xn.iter().zip(&xl).map(|(a, b)| a - b).collect();
                    let len = normalize(&mut delta);
                    let miss = xn
                        .iter()
                        .zip(&pred)
                        .map(|(a, b)| (a - b).powi(2))
                        .sum::<f64>()
                        .sqrt();
                    p.jump = miss > cont.jump_factor * step;
                    if xn[0] != xl[0] {
                        let sign = (xn[0] - xl[0]).signum();
                        p.fold = sign != last_dq_sign;
                        last_dq_sign = sign;
                    }
                    if p.fold {
                        tracing::info!(
                            q = p.q,
                            omega = p.omega,
                            "turning point of q (fold) passed"
                        );
                    }
                    if p.jump {
                        tracing::warn!(
                            q = p.q,
                            omega = p.omega,
                            "corrector far from predictor: jump?"
                        );
                    }
                    if len > 0.0 {
                        tangent = delta;
                    }
                    last_ds = len.max(f64::MIN_POSITIVE);
                    if p.newton_iterations <= cont.easy_iterations {
                        ds = (ds * cont.growth).min(cont.max_step);
                    }
                    progress(&p);
                    let reached = final_step || xn[0] >= cont.q_max;
                    result.points.push(p);
                    if reached {
                        result.termination = Termination::ReachedMaxAmplitude;
                        return Ok(result);
                    }
                    continue;
                }
            }
            Err(e) => {
                ds *= cont.shrink;
                tracing::debug!(step = ds, error = %e, "continuation step failed, retrying");
                if ds >= cont.min_step {
                    continue;
                }
                // Last resort at a corner of the branch (a sample entering contact where the
                // branch is not smooth): hop over it at fixed q, in the current direction of q.
                let last = &result.points[result.points.len() - 1];
                let base = (last_ds * tangent[0].abs()).max(cont.min_step);
                match hop_ahead(&mut solver, last, last_dq_sign, base, cont, &omegas) {
                    Some(h) => {
                        tracing::warn!(
                            q = h.q,
                            omega = h.omega,
                            "hopped over a corner of the branch at fixed q"
                        );
                        h
                    }
                    None => {
                        result.termination = Termination::StepTooSmall {
                            q: last.q,
                            step: ds,
                            reason: e.to_string(),
                        };
                        return Ok(result);
                    }
                }
            }
        };
        // Restart the arc length from the hopped point, along the secant of the hop.
        let xn = scaled(&hopped);
        let mut delta: Vec<f64> = xn.iter().zip(&xl).map(|(a, b)| a - b).collect();
        last_ds = normalize(&mut delta).max(f64::MIN_POSITIVE);
        last_dq_sign = delta[0].signum();
        tangent = delta;
        ds = cont.step.min(cont.max_step).max(cont.min_step);
        progress(&hopped);
        let reached = xn[0] >= cont.q_max;
        result.points.push(hopped);
        if reached {
            result.termination = Termination::ReachedMaxAmplitude;
            return Ok(result);
        }
    }
}

impl ContinuationSettings {
    /// The internal resonance a point sits in, if tongues are skipped and the point's largest
    /// secondary component (mode k, harmonic n >= 2) outweighs the primary one (starting mode,
    /// n = 1): the orbit is then no longer the primary mode's. `omegas`: linear circular
    /// frequencies, for the detuning |n w - w_k| / w_k recorded with it.
    fn tongue(&self, p: &BackbonePoint, omegas: &[f64]) -> Option<InternalResonance> {
        let (k, n) = (p.secondary_mode, p.secondary_harmonic);
        if !self.skip_internal_resonances || n < 2 || p.secondary_share <= p.primary_share {
            return None;
        }
        let wk = *omegas.get(k)?;
        Some(InternalResonance {
            q: p.q,
            omega_ratio: p.omega_ratio,
            mode: k,
            harmonic: n,
            share: p.secondary_share,
            detuning: (n as f64 * p.omega - wk) / wk,
            hopped: false,
        })
    }
}

/// Fixed-q hops from `last`: q = last.q + sign base 2^i g_ref for i < `JUMP_ATTEMPTS` (within
/// (0, q_max]), warm-started from `last`, then, for a forward hop that failed, from the linear mode
/// scaled to q (with the penalty homotopy of the solver); the first converged point outside a
/// tongue is returned, flagged as a jump.
fn hop_ahead(
    solver: &mut Solver<'_>,
    last: &BackbonePoint,
    sign: f64,
    base: f64,
    cont: &ContinuationSettings,
    omegas: &[f64],
) -> Option<BackbonePoint> {
    let g_ref = solver.system().gap_reference();
    for i in 0..JUMP_ATTEMPTS {
        let q = last.q + sign * base * f64::from(1u32 << i) * g_ref;
        let q = if sign > 0.0 {
            q.min(cont.q_max * g_ref)
        } else {
            q
        };
        if q <= 0.0 || (sign > 0.0 && q <= last.q) {
            return None;
        }
        let mut starts = vec![Start::Point(last)];
        if sign > 0.0 {
            starts.push(Start::LinearMode(last.mode));
        }
        for start in starts {
            match solver.solve_point(q, start) {
                Ok(mut p) if cont.tongue(&p, omegas).is_none() => {
                    p.jump = true;
                    return Some(p);
                }
                Ok(p) => tracing::debug!(q = p.q, "hop landed in a tongue, hopping farther"),
                Err(e) => tracing::debug!(q, error = %e, "hop failed"),
            }
        }
    }
    None
}

/// Fixed-q hops tried when the arc-length step has shrunk below `min_step` or the branch entered
/// a tongue (the last one is 2^5 = 32 base steps ahead).
const JUMP_ATTEMPTS: u32 = 6;

/// Normalizes `v` to unit length in place and returns its former length.
fn normalize(v: &mut [f64]) -> f64 {
    let len = v.iter().map(|x| x * x).sum::<f64>().sqrt();
    if len > 0.0 {
        v.iter_mut().for_each(|x| *x /= len);
    }
    len
}

/// Kept coordinates of a point: A_j u_n (layout j (N+1) + n) then e_master . u_n (c (N+1) + n).
fn kept_coordinates(system: &System, p: &BackbonePoint, nh: usize) -> Vec<f64> {
    let c = system.n_contacts();
    let mut y = vec![0.0; (c + 1) * nh];
    for (h, u) in p.coefficients.iter().enumerate().take(nh) {
        for j in 0..c {
            y[j * nh + h] = system.contact_displacement(j, u);
        }
        y[c * nh + h] = u[system.master()];
    }
    y
}

/// Warm start at the predictor: coefficients extrapolated along the secant of the last two points
/// (ratio = predicted step / last step), theta and kappa of the last point.
fn extrapolate(points: &[BackbonePoint], pred: &[f64], g_ref: f64, w1: f64, ratio: f64) -> Guess {
    let last = &points[points.len() - 1];
    let coefficients = if points.len() >= 2 {
        let prev = &points[points.len() - 2];
        last.coefficients
            .iter()
            .zip(&prev.coefficients)
            .map(|(a, b)| a.iter().zip(b).map(|(x, y)| x + ratio * (x - y)).collect())
            .collect()
    } else {
        let s = pred[0] * g_ref / last.q;
        last.coefficients
            .iter()
            .map(|c| c.iter().map(|v| v * s).collect())
            .collect()
    };
    Guess {
        mode: last.mode,
        coefficients,
        omega: pred[1] * w1,
        q: pred[0] * g_ref,
        multipliers: last.multipliers.clone(),
    }
}
