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
//!
//! N is converged point by point (`SpeedHarmonics::Retrace`, the default; DESIGN §10.11,
//! docs/ROTATION.md "The casing study's N"): every point in contact is solved again at 2N
//! from its own orbit (same delta and W); while that moves its master's amplitude at the gap's
//! harmonic h (the first harmonic when W is the lobe-passing frequency) by more than
//! `harmonic_tolerance` (relative) and 4N is within `max_harmonics`, the 2N orbit is
//! solved again at 4N, and so on (the change of the largest contact force is recorded beside
//! it, not converged on: `CasingPoint::force_converged`). The point keeps the finer
//! orbit of its last doubling, its N (`ForcedPoint::harmonics`) and that doubling's change
//! (`harmonic_change`): converged when the change is within the tolerance. Each point is a
//! solve at fixed delta and W of its own (natural-parameter continuation: no arclength
//! couples the points), so this solves the equations a whole retrace at 2N would, at the
//! points in contact only and at the N each needs. Points out of contact are at rest (linear:
//! exact at any N). `Check`: the points worth checking (the largest response and contact
//! force, the jumps, four points spread over the contact:
//! `curve_harmonics::points_worth_checking`) are solved again at 2N and flagged, the orbits
//! kept; `Fixed`: none checked.

use faer::Mat;
use nlmodes_hb::{FullBasis, System};
use rayon::prelude::*;

use crate::curve::ExactForce;
use crate::curve_harmonics::points_worth_checking;
use crate::distortion::CasingDistortion;
use crate::error::ForcedError;
use crate::ladder::start_at;
use crate::load::Load;
use crate::orbit_origin::{advanced_orbit, most_open_sample};
use crate::point_stability::{Assessment, PointStability};
use crate::settled_stability::{casing_point_stability, SettledModel};
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
    /// How N is converged (default `SpeedHarmonics::Retrace`: every point in contact raised
    /// to the N its check at 2N asks for, module docs; `Check`: the points worth checking
    /// solved again at 2N, not kept; `Fixed`: none checked).
    pub harmonic_policy: SpeedHarmonics,
    /// The largest N a point may be solved at, its check included (0: four times the
    /// solver's N).
    pub max_harmonics: usize,
    /// A point's N is enough when doubling it moves its master's first harmonic by at most
    /// this (relative; default 1e-3); the largest contact force's change is reported against
    /// it too.
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
    /// at the point's last doubling of N (its N: `point.harmonics`; `Check`: between the
    /// point and its solve at 2N;
    /// `Retrace`: between the orbit at N / 2 and the one kept at N); `None`: not checked, or
    /// that solve failed: see `harmonic_failed`.
    pub harmonic_change: Option<[f64; 2]>,
    /// Whether the solve at 2N failed.
    pub harmonic_failed: bool,
    /// The largest contact force on the point's exact orbit (its settled boundary's, shot for
    /// its stability: `exact_force`); `None` without stability, contact or a shot orbit.
    pub exact_force: Option<ExactForce>,
}

/// A traced distortion sweep.
#[derive(Clone, Debug)]
pub struct CasingSweep {
    /// The points, delta ascending (the grid's and the halved steps').
    pub points: Vec<CasingPoint>,
    /// N of the trace (every point's, unless refined: `CasingPoint::harmonics`) and the N of
    /// every trace in order (one).
    pub harmonics: usize,
    pub traced: Vec<usize>,
    /// Whether 2N was within `max_harmonics` to check the trace.
    pub checked: bool,
    /// Where the sweep stopped before its last amplitude: delta (m) and why.
    pub stopped: Option<(f64, String)>,
}

impl CasingSweep {
    /// Points whose check at 2N moved their master's first harmonic by more than `tolerance`
    /// or failed (`CasingPoint::converged`).
    pub fn not_converged(&self, tolerance: f64) -> usize {
        (self.points.iter())
            .filter(|p| !p.converged(tolerance))
            .count()
    }
}

impl CasingPoint {
    /// Whether the point's check did not fail nor move its master's amplitude at the gap's harmonic h by more
    /// than `tolerance` (true for a point not checked). The largest contact force is not part
    /// of it: the peak sample of a stiff penalty pulse moves by tens of % per doubling up to
    /// N = 40 on the default blade (docs/ROTATION.md "The casing study's N"); see
    /// `force_converged`.
    pub fn converged(&self, tolerance: f64) -> bool {
        !self.harmonic_failed && !(self.harmonic_change).is_some_and(|c| c[0] > tolerance)
    }

    /// Whether the point's check moved its largest contact force by at most `tolerance`
    /// (true for a point not checked).
    pub fn force_converged(&self, tolerance: f64) -> bool {
        !self.harmonic_failed && !(self.harmonic_change).is_some_and(|c| c[1] > tolerance)
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
    let problem = Problem {
        system,
        damping,
        load: Load::fundamental(vec![0.0; system.n_dofs()]),
        settings,
    };
    let ladder = problem.ladder()?;
    let mut sweep = problem.trace(&ladder[0], &mut progress)?;
    sweep.traced = vec![sweep.harmonics];
    sweep.checked = ladder.len() > 1 && settings.harmonic_policy != SpeedHarmonics::Fixed;
    match settings.harmonic_policy {
        SpeedHarmonics::Fixed => {}
        _ if ladder.len() < 2 => {}
        SpeedHarmonics::Check => problem.check(&ladder[1], &mut sweep),
        SpeedHarmonics::Retrace => problem.refine(&ladder, &mut sweep),
    }
    tracing::info!(
        harmonics = sweep.harmonics,
        not_converged = sweep.not_converged(settings.harmonic_tolerance),
        "casing distortion sweep at N = {} checked at 2N{}",
        sweep.harmonics,
        if settings.harmonic_policy == SpeedHarmonics::Retrace {
            ", the points in contact raised to the N their check asks for"
        } else {
            ""
        }
    );
    problem.assess(&ladder, &mut sweep);
    Ok(sweep)
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

    /// The solver settings at N, 2N, 4N, ... up to `max_harmonics` (0: 4N), the time samples
    /// grown as `ForcedSolver::with_harmonics` grows them.
    fn ladder(&self) -> Result<Vec<ForcedSettings>, ForcedError> {
        let first = &self.settings.solver;
        let base = first.harmonics.harmonics;
        let top = match self.settings.max_harmonics {
            0 => 4 * base,
            m => m.max(base),
        };
        let mut ladder = vec![first.clone()];
        let mut n = 2 * base;
        while n <= top {
            let finer = self.solver(first, 0.0)?.with_harmonics(n)?;
            ladder.push(finer.settings().clone());
            n *= 2;
        }
        Ok(ladder)
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
            exact_force: None,
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
                self.solve_again(finer, p)
                    .ok()
                    .map(|f| change(&p.point, &f, master, self.settings.harmonic))
            })
            .collect();
        for (&i, change) in checked.iter().zip(changes) {
            sweep.points[i].harmonic_change = change;
            sweep.points[i].harmonic_failed = change.is_none();
        }
    }

    /// Every point in contact raised along `ladder` (N, 2N, ...) while its doubling moves its
    /// master's amplitude at the gap's harmonic by more than `harmonic_tolerance` (module
    /// docs); in parallel, each from its own orbit. A point whose solve at 2N fails from its
    /// own orbit (next to a row starting to touch, as in `hop`) is tried once more, in delta
    /// order, from its lower neighbour's refined orbit.
    fn refine(&self, ladder: &[ForcedSettings], sweep: &mut CasingSweep) {
        (sweep.points.par_iter_mut())
            .filter(|p| p.point.touches())
            .for_each(|p| self.raise(ladder, p, None));
        for i in 1..sweep.points.len() {
            let (before, rest) = sweep.points.split_at_mut(i);
            let (p, last) = (&mut rest[0], &before[i - 1]);
            if p.harmonic_failed && p.harmonic_change.is_none() && !last.harmonic_failed {
                p.harmonic_failed = false;
                self.raise(ladder, p, Some(&last.point));
            }
        }
    }

    /// Raises `p` along `ladder` (module docs), its first solve at 2N from `from` (its own
    /// orbit when `None`).
    fn raise(&self, ladder: &[ForcedSettings], p: &mut CasingPoint, from: Option<&ForcedPoint>) {
        let master = self.system.master();
        let mut from = from.cloned();
        for finer in &ladder[1..] {
            let start = from.take().unwrap_or_else(|| p.point.clone());
            let Ok(fine) = self.solve_from(finer, p.amplitude, &start) else {
                p.harmonic_failed = true;
                return;
            };
            let moved = change(&p.point, &fine, master, self.settings.harmonic);
            tracing::debug!(
                delta = p.amplitude,
                from = p.point.harmonics,
                to = finer.harmonics.harmonics,
                q1 = fine.first_harmonic(master),
                ?moved,
                "casing sweep: a point in contact at 2N"
            );
            p.point = fine;
            p.harmonic_change = Some(moved);
            if moved[0] <= self.settings.harmonic_tolerance {
                return;
            }
        }
    }

    /// The stability of `p` on `solver`'s N as `how` says (`settled_stability`). A point in
    /// contact is shot on the massless boundary from the time origin where it is farthest from
    /// contact (`orbit_origin::most_open_sample`): at a strike (t = 0 at phase 0, where the gap
    /// is smallest) the truncated series' velocity is off by the Gibbs error of the kink the
    /// strike puts in it, whatever N, a poor start for the shooting. The multipliers and the
    /// master's amplitude it is judged by do not depend on the origin.
    fn stability(
        &self,
        solver: &ForcedSettings,
        p: &CasingPoint,
        how: &Assessment,
    ) -> Result<(PointStability, Option<ExactForce>), ForcedError> {
        let (point, theta) = if p.point.touches() {
            advanced_orbit(&p.point, most_open_sample(&p.point))
        } else {
            (p.point.clone(), 0.0)
        };
        let distortion = self.settings.distortion(p.amplitude).advanced(theta);
        let settings = ForcedSettings {
            distortion: Some(distortion),
            ..solver.clone()
        };
        let sv = ForcedSolver::new(self.system, self.damping, &self.load, settings)?;
        let model = SettledModel {
            system: self.system,
            damping: self.damping,
            load: Load {
                harmonics: Vec::new(),
            },
            distortion: Some(distortion),
        };
        let hb_change = p.harmonic_change.map(|c| c[0]);
        casing_point_stability(&model, &sv, &point, hb_change, how)
    }

    /// The orbit of `p` solved again on `finer`'s N from its own (same delta and W).
    fn solve_again(&self, finer: &ForcedSettings, p: &CasingPoint) -> Result<ForcedPoint, ()> {
        self.solve_from(finer, p.amplitude, &p.point)
    }

    /// The orbit at `delta` (m) on `finer`'s N, Newton from `start`'s orbit.
    fn solve_from(
        &self,
        finer: &ForcedSettings,
        delta: f64,
        start: &ForcedPoint,
    ) -> Result<ForcedPoint, ()> {
        self.solver(finer, delta)
            .and_then(|s| {
                let begin: ForcedStart = start_at(start, &s);
                s.solve(begin, None)
            })
            .map_err(|e| tracing::debug!(delta, "casing sweep: the solve at 2N failed: {e}"))
    }

    /// The Floquet stability of every point (when asked for; the massless boundary with the
    /// moving gaps in contact, every `verify_every`-th point in contact checked by RK4), then
    /// the changes between consecutive determined points.
    fn assess(&self, ladder: &[ForcedSettings], sweep: &mut CasingSweep) {
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
                let solver = (ladder.iter())
                    .find(|l| l.harmonics.harmonics == p.point.harmonics)
                    .unwrap_or(&ladder[0]);
                let (st, exact) = self.stability(solver, p, &how).unwrap_or_else(|e| {
                    tracing::warn!("casing sweep: no stability at {:e} m: {e}", p.amplitude);
                    (PointStability::unchecked(), None)
                });
                (p.stability, p.exact_force) = (Some(st), exact);
            });
        crate::speed_sweep::classify_changes(
            sweep.points.iter_mut().filter_map(|p| p.stability.as_mut()),
        );
    }
}

/// [|dq_h| / q_h, |dF| / F] from `coarse` to `fine`: the master's amplitude at harmonic `h`
/// (the one the casing drives: the first when W is the lobe-passing frequency; with the gap at
/// harmonic 2 the orbit has period T / 2 and its first harmonic is round-off) and the largest
/// contact force, relative to `fine`'s.
fn change(coarse: &ForcedPoint, fine: &ForcedPoint, master: usize, h: usize) -> [f64; 2] {
    let rel = |a: f64, b: f64| (a - b).abs() / b.abs().max(f64::MIN_POSITIVE);
    let amplitude = |p: &ForcedPoint| {
        let c = &p.coefficients;
        c[(master, FullBasis::cos_index(h))].hypot(c[(master, FullBasis::sin_index(h))])
    };
    [
        rel(amplitude(coarse), amplitude(fine)),
        rel(largest_force(coarse), largest_force(fine)),
    ]
}

/// The largest contact force of an orbit over its samples and rows (force units).
pub fn largest_force(p: &ForcedPoint) -> f64 {
    p.largest_contact_force()
}
