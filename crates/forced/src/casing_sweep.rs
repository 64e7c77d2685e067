//! The response to a growing casing distortion at one speed (issue 39, item 6; DESIGN §10.11):
//! the structure at a speed Omega, W the lobe-passing frequency n Omega (the orbit's
//! fundamental, the gap at its harmonic h = 1), no load, and the casing's intrusion delta (m)
//! stepped over a grid of amplitudes. Each orbit is solved at the fixed W from the last one
//! carried along the secant in delta (natural-parameter continuation). Below the smallest
//! running gap the casing never reaches the blade, which stays at rest (the orbit measured
//! from the casing is y~ = delta cos(h W t + phase) on every row, exactly); above it the
//! casing strikes the blade at every lobe.
//!
//! A step whose solve fails, or lands farther from its prediction than the step (in the scaled
//! space y / (g_ref sqrt(c)), delta / g_ref), is halved down to `MIN_STEP` g_ref; a point that
//! still lands that far at the smallest step is kept and flagged `jump`: the response jumps
//! between the two amplitudes (a fold in delta, which this continuation does not follow). Where
//! no solve converges at the smallest step (next to a row starting to touch) the sweep hops
//! further on (`HOPS`); only when no hop converges does it stop.
//! The points worth checking (the largest response and contact force, the jumps, four points
//! spread over the contact: `curve_harmonics::points_worth_checking`) are solved again at 2N
//! (same delta and W); under
//! `SpeedHarmonics::Retrace`, while one moves by more than `harmonic_tolerance` (its master's
//! first harmonic or its largest contact force, relative) and 4N is within `max_harmonics`,
//! the grid is solved again at 2N (`Check`: the first grid kept, its points flagged).

use faer::Mat;
use nlmodes_hb::System;
use rayon::prelude::*;

use crate::curve_harmonics::points_worth_checking;
use crate::distortion::CasingDistortion;
use crate::error::ForcedError;
use crate::ladder::start_at;
use crate::load::Load;
use crate::point_stability::{assess_point_with, Assessment, PointStability};
use crate::solver::{ForcedPoint, ForcedSettings, ForcedSolver, ForcedStart};
use crate::speed_curve::SpeedHarmonics;
use crate::trace::norm;

/// Smallest step in delta, relative to the gap reference g_ref.
const MIN_STEP: f64 = 1e-4;

/// The hops past a point where no step converges, in multiples of `MIN_STEP` g_ref.
const HOPS: [f64; 6] = [3.0, 10.0, 30.0, 100.0, 300.0, 1000.0];

/// Settings of a distortion sweep.
#[derive(Clone, Debug)]
pub struct CasingSweepSettings {
    /// W (rad/s): the orbit's fundamental (the lobe-passing frequency n Omega).
    pub omega: f64,
    /// The harmonic h of W at which the gap varies (1 when W is n Omega).
    pub harmonic: usize,
    /// The intrusion's phase (rad): the gap is smallest at h W t + phase = 0.
    pub phase: f64,
    /// The amplitudes delta (m): finite, >= 0, ascending.
    pub amplitudes: Vec<f64>,
    /// N, the samples and the contact law (its `distortion` is set at each delta).
    pub solver: ForcedSettings,
    /// Floquet stability of every point (default true), its margin and period tolerance
    /// (`FrfSettings::stability_margin`, `period_tolerance`).
    pub stability: bool,
    pub stability_margin: f64,
    pub period_tolerance: f64,
    /// Every k-th point in contact has its verdict on the massless boundary (moving gaps,
    /// docs/STABILITY.md Sec. 9.5) checked by one period of RK4 of that model
    /// (`PointStability::rk4_change`; a disagreement makes it undetermined); 0: none. Default 4.
    pub verify_every: usize,
    /// How N is converged (default `SpeedHarmonics::Retrace`: module docs; `Check`: the first
    /// grid's points checked at 2N, not solved again; `Fixed`: none checked).
    pub harmonic_policy: SpeedHarmonics,
    /// The largest N of a retrace (0: four times the solver's N).
    pub max_harmonics: usize,
    /// A point's N is enough when doubling it moves its master's first harmonic and its largest
    /// contact force by at most this (relative; default 1e-3).
    pub harmonic_tolerance: f64,
}

impl CasingSweepSettings {
    /// A sweep over `amplitudes` (m) at W = `omega` (rad/s), gap at harmonic 1, defaults
    /// otherwise.
    pub fn new(omega: f64, amplitudes: Vec<f64>, solver: ForcedSettings) -> Self {
        Self {
            omega,
            harmonic: 1,
            phase: 0.0,
            amplitudes,
            solver,
            stability: true,
            stability_margin: 1e-3,
            period_tolerance: 1e-3,
            verify_every: 4,
            harmonic_policy: SpeedHarmonics::Retrace,
            max_harmonics: 0,
            harmonic_tolerance: 1e-3,
        }
    }

    /// Checks W, the amplitudes and the tolerance; errors name the setting.
    pub fn validate(&self) -> Result<(), ForcedError> {
        let bad = |name, value, expected| {
            Err(ForcedError::Parameter {
                name,
                value,
                expected,
            })
        };
        if !(self.omega.is_finite() && self.omega > 0.0) {
            return bad("omega", self.omega, "a finite frequency > 0 (rad/s)");
        }
        if self.amplitudes.is_empty() {
            return bad("amplitudes", 0.0, "at least one amplitude (m)");
        }
        for (i, &a) in self.amplitudes.iter().enumerate() {
            if !(a.is_finite() && a >= 0.0) || (i > 0 && a <= self.amplitudes[i - 1]) {
                return bad("amplitudes", a, "finite amplitudes >= 0 (m), ascending");
            }
        }
        if !(self.harmonic_tolerance.is_finite() && self.harmonic_tolerance > 0.0) {
            return bad("harmonic_tolerance", self.harmonic_tolerance, "a value > 0");
        }
        self.distortion(0.0)
            .validate(self.solver.harmonics.harmonics)
    }

    /// The casing at amplitude `delta` (m).
    fn distortion(&self, delta: f64) -> CasingDistortion {
        CasingDistortion {
            harmonic: self.harmonic,
            amplitude: delta,
            phase: self.phase,
        }
    }
}

/// A point of a distortion sweep.
#[derive(Clone, Debug)]
pub struct CasingPoint {
    /// delta (m).
    pub amplitude: f64,
    /// The orbit (`ForcedPoint::contact` measured from the casing).
    pub point: ForcedPoint,
    /// Floquet stability (when asked for).
    pub stability: Option<PointStability>,
    /// Whether the response jumped from the previous point (module docs).
    pub jump: bool,
    /// [|dq1| / q1, |dF| / F] of the master's first harmonic and the largest contact force
    /// when the point was solved again at 2N (`None`: not among the points checked, or that
    /// solve failed: see `harmonic_failed`).
    pub harmonic_change: Option<[f64; 2]>,
    /// Whether the solve at 2N failed.
    pub harmonic_failed: bool,
}

/// A traced distortion sweep.
#[derive(Clone, Debug)]
pub struct CasingSweep {
    /// The points, delta ascending (the grid's and the halved steps').
    pub points: Vec<CasingPoint>,
    /// N of every point (the last trace's) and the N of every trace in order.
    pub harmonics: usize,
    pub traced: Vec<usize>,
    /// Whether 2N was within `max_harmonics` to check the last trace.
    pub checked: bool,
    /// Where the sweep stopped before its last amplitude: delta (m) and why.
    pub stopped: Option<(f64, String)>,
}

impl CasingSweep {
    /// Points in contact whose check at 2N moved them by more than `tolerance` or failed.
    pub fn not_converged(&self, tolerance: f64) -> usize {
        (self.points.iter())
            .filter(|p| {
                p.harmonic_failed
                    || p.harmonic_change
                        .is_some_and(|c| c.iter().any(|&v| v > tolerance))
            })
            .count()
    }
}

/// The distortion sweep of the structure `system` with damping `damping` (N s/m), N converged
/// (module docs); `progress` sees every accepted point.
pub fn casing_sweep(
    system: &System,
    damping: &Mat<f64>,
    settings: &CasingSweepSettings,
    mut progress: impl FnMut(&CasingPoint),
) -> Result<CasingSweep, ForcedError> {
    settings.validate()?;
    let base = settings.solver.harmonics.harmonics;
    let top = match settings.max_harmonics {
        0 => 4 * base,
        m => m.max(base),
    };
    let problem = Problem {
        system,
        damping,
        load: Load::fundamental(vec![0.0; system.n_dofs()]),
        settings,
    };
    let mut solver = settings.solver.clone();
    let mut traced = Vec::new();
    loop {
        let n = solver.harmonics.harmonics;
        traced.push(n);
        let mut sweep = problem.trace(&solver, &mut progress)?;
        let checkable = 2 * n <= top && settings.harmonic_policy != SpeedHarmonics::Fixed;
        let finer = checkable
            .then(|| problem.solver(&solver, 0.0)?.with_harmonics(2 * n))
            .transpose()?
            .map(|s| s.settings().clone());
        if let Some(f) = &finer {
            problem.check(f, &mut sweep);
        }
        let moved = sweep.not_converged(settings.harmonic_tolerance) > 0;
        let again = moved
            && settings.harmonic_policy == SpeedHarmonics::Retrace
            && 4 * n <= top
            && sweep.points.iter().any(|p| p.point.touches());
        tracing::info!(
            harmonics = n,
            not_converged = sweep.not_converged(settings.harmonic_tolerance),
            "casing distortion sweep at N = {n} checked at 2N{}",
            if again { "; solved again at 2N" } else { "" }
        );
        match (again, finer) {
            (true, Some(f)) => solver = f,
            _ => {
                sweep.traced = traced;
                sweep.checked = checkable;
                problem.assess(&solver, &mut sweep);
                return Ok(sweep);
            }
        }
    }
}

/// What every solve of the sweep shares.
struct Problem<'a> {
    system: &'a System,
    damping: &'a Mat<f64>,
    load: Load,
    settings: &'a CasingSweepSettings,
}

impl Problem<'_> {
    /// The solver at amplitude `delta` (m) on `solver`'s N.
    fn solver(&self, solver: &ForcedSettings, delta: f64) -> Result<ForcedSolver<'_>, ForcedError> {
        let settings = ForcedSettings {
            distortion: Some(self.settings.distortion(delta)),
            ..solver.clone()
        };
        ForcedSolver::new(self.system, self.damping, &self.load, settings)
    }

    /// The orbits over the grid (module docs).
    fn trace(
        &self,
        solver: &ForcedSettings,
        progress: &mut impl FnMut(&CasingPoint),
    ) -> Result<CasingSweep, ForcedError> {
        let amplitudes = &self.settings.amplitudes;
        let first = self.solver(solver, amplitudes[0])?;
        let start = first.linear_start(self.settings.omega, 1.0)?;
        let point = self.point(amplitudes[0], first.solve(start, None)?);
        progress(&point);
        let mut sweep = CasingSweep {
            points: vec![point],
            harmonics: solver.harmonics.harmonics,
            traced: Vec::new(),
            checked: false,
            stopped: None,
        };
        let g = self.system.gap_reference();
        for pair in amplitudes.windows(2) {
            let mut step = pair[1] - pair[0];
            while let Some(last) = sweep.points.last().map(|p| p.amplitude) {
                if last >= pair[1] {
                    break;
                }
                let to = (last + step).min(pair[1]);
                match self.step(solver, &sweep.points, to, step <= MIN_STEP * g) {
                    Ok(p) => {
                        progress(&p);
                        sweep.points.push(p);
                        step = (2.0 * step).min(pair[1] - pair[0]);
                    }
                    Err(why) if step > MIN_STEP * g => {
                        tracing::debug!("casing sweep: step to {to:e} m halved ({why})");
                        step *= 0.5;
                    }
                    Err(why) => match self.hop(solver, &sweep.points, pair[1]) {
                        Some(p) => {
                            progress(&p);
                            sweep.points.push(p);
                        }
                        None => {
                            sweep.stopped = Some((last, why));
                            return Ok(sweep);
                        }
                    },
                }
            }
        }
        Ok(sweep)
    }

    /// The orbit at `delta` from the last points (module docs); `smallest`: the step cannot be
    /// halved again, so a point far from its prediction is kept as a jump.
    fn step(
        &self,
        solver: &ForcedSettings,
        points: &[CasingPoint],
        delta: f64,
        smallest: bool,
    ) -> Result<CasingPoint, String> {
        let last = points.last().expect("a first point");
        let h = delta - last.amplitude;
        let predicted: Vec<f64> = match points.len() {
            1 => {
                let unit = self.settings.distortion(1.0);
                let rows = self.system.n_contacts();
                let terms = last.point.contact.len() / rows.max(1);
                let c = unit.offsets(rows, terms);
                (last.point.contact.iter().zip(c))
                    .map(|(y, c)| y + h * c)
                    .collect()
            }
            n => {
                let before = &points[n - 2];
                let r = h / (last.amplitude - before.amplitude);
                (last.point.contact.iter().zip(&before.point.contact))
                    .map(|(y, b)| y + r * (y - b))
                    .collect()
            }
        };
        let s = self.solver(solver, delta).map_err(|e| e.to_string())?;
        let mut start = ForcedSolver::start_from(&last.point);
        start.state.y.clone_from(&predicted);
        let point = s.solve(start, None).map_err(|e| e.to_string())?;
        let g = self.system.gap_reference();
        let scale = g * (self.system.n_contacts().max(1) as f64).sqrt();
        let d: Vec<f64> = (point.contact.iter().zip(&predicted))
            .map(|(a, b)| (a - b) / scale)
            .collect();
        let (distance, reach) = (norm(&d), h / g);
        if distance > reach && !smallest {
            return Err(format!(
                "the orbit lands {distance:.3e} from its prediction (step {reach:.3e} g0)"
            ));
        }
        let mut p = self.point(delta, point);
        p.jump = distance > reach;
        Ok(p)
    }

    /// Past a point where no step down to the smallest converges (a row starting to touch:
    /// the exactly integrated law's Jacobian changes like the square root of its penetration
    /// there, and the semi-smooth Newton may stall next to it): the orbit at delta further on
    /// by `HOPS` x `MIN_STEP` g_ref (each from the secant prediction, no further than `end`),
    /// the first that converges.
    fn hop(
        &self,
        solver: &ForcedSettings,
        points: &[CasingPoint],
        end: f64,
    ) -> Option<CasingPoint> {
        let last = points.last()?.amplitude;
        let g = self.system.gap_reference();
        HOPS.iter().find_map(|&k| {
            let to = (last + k * MIN_STEP * g).min(end);
            let p = self.step(solver, points, to, true);
            tracing::debug!("casing sweep: hop to {to:e} m: {}", p.is_ok());
            p.ok()
        })
    }

    fn point(&self, amplitude: f64, point: ForcedPoint) -> CasingPoint {
        CasingPoint {
            amplitude,
            point,
            stability: None,
            jump: false,
            harmonic_change: None,
            harmonic_failed: false,
        }
    }

    /// Solves again at `finer`'s N the points worth checking (the largest response, the
    /// largest contact force, the jumps and four points spread over the contact:
    /// `curve_harmonics::points_worth_checking`, as the frequency and speed sweeps) and
    /// records their change.
    fn check(&self, finer: &ForcedSettings, sweep: &mut CasingSweep) {
        let master = self.system.master();
        let points: Vec<&ForcedPoint> = sweep.points.iter().map(|p| &p.point).collect();
        let jumps: Vec<usize> = (0..points.len())
            .filter(|&i| sweep.points[i].jump)
            .collect();
        let checked = points_worth_checking(&points, &jumps, master);
        let view: &CasingSweep = sweep;
        let changes: Vec<Option<[f64; 2]>> = checked
            .par_iter()
            .map(|&i| {
                let p = &view.points[i];
                let fine = self.solver(finer, p.amplitude).and_then(|s| {
                    let start: ForcedStart = start_at(&p.point, &s);
                    s.solve(start, None)
                });
                let rel = |a: f64, b: f64| (a - b).abs() / b.abs().max(f64::MIN_POSITIVE);
                fine.map_err(|e| tracing::debug!("casing sweep: the check at 2N failed: {e}"))
                    .ok()
                    .map(|f| {
                        [
                            rel(p.point.first_harmonic(master), f.first_harmonic(master)),
                            rel(largest_force(&p.point), largest_force(&f)),
                        ]
                    })
            })
            .collect();
        for (&i, change) in checked.iter().zip(changes) {
            sweep.points[i].harmonic_change = change;
            sweep.points[i].harmonic_failed = change.is_none();
        }
    }

    /// The Floquet stability of every point (when asked for; the massless boundary with the
    /// moving gaps in contact, every `verify_every`-th point in contact checked by RK4), then
    /// the changes between consecutive determined points.
    fn assess(&self, solver: &ForcedSettings, sweep: &mut CasingSweep) {
        let s = self.settings;
        if !s.stability {
            return;
        }
        let mut in_contact = 0;
        let verify: Vec<bool> = (sweep.points.iter())
            .map(|p| {
                let touching = p.point.touches();
                in_contact += usize::from(touching);
                touching && s.verify_every > 0 && (in_contact - 1) % s.verify_every == 0
            })
            .collect();
        sweep
            .points
            .par_iter_mut()
            .zip(verify)
            .for_each(|(p, verify)| {
                let how = Assessment {
                    margin: s.stability_margin,
                    period_tolerance: s.period_tolerance,
                    verify,
                };
                let st = self
                    .solver(solver, p.amplitude)
                    .and_then(|sv| assess_point_with(&sv, &p.point, &how));
                p.stability = Some(st.unwrap_or_else(|e| {
                    tracing::warn!("casing sweep: no stability at {:e} m: {e}", p.amplitude);
                    PointStability::unchecked()
                }));
            });
        crate::speed_sweep::classify_changes(
            sweep.points.iter_mut().filter_map(|p| p.stability.as_mut()),
        );
    }
}

/// The largest contact force of an orbit over its samples and rows (force units).
pub fn largest_force(p: &ForcedPoint) -> f64 {
    p.contact_force.iter().fold(0.0_f64, |m, f| m.max(f.abs()))
}
