//! The speed sweep as a [`RaiseTarget`] (DESIGN §10.10): its points are `SpeedPoint`s, its
//! levels the sweep's settings at N, 2N, 4N, ... (`at_harmonics`), its parameter the speed.
//! Every solve of a point at another N is on the row through the traced point normal to the
//! sweep (the central secant of its neighbours in the scaled space of `speed_sweep`), as the
//! trace's own steps are (`SpeedStepper::on_speed_row`: under the penalty law the structure
//! follows W = e Omega inside the Newton solve; the structure frozen at one speed and that
//! speed corrected only where that fails, or under exact contact). The row is normal to the
//! speed line's curve, not to a frozen structure's response: frozen, the default blade's check
//! failed at 5 of its 8 points (docs/ROTATION.md, session 22).

use crate::error::ForcedError;
use crate::ladder::{resize_signals, same_orbit, start_at, REFINE_REACH};
use crate::raised_segments::RaiseTarget;
use crate::solver::{ForcedPoint, ForcedStart};
use crate::speed_curve::{SpeedPoint, SpeedSweepSettings};
use crate::speed_step::{problem_at, SpeedArc, SpeedFamily, SpeedStepper};
use crate::trace::norm;

/// How far (relative to Omega_ref) the frozen speed of a solve at another N may move from the
/// point's: as far as a change that still counts as the same orbit (`ladder::REFINE_REACH`).
const CHECK_REACH: f64 = REFINE_REACH;

/// Steps along the trace within which another point may be nearer to a solve at another N
/// than its own point (next to a fold the two legs lie close; a truncation change normal to
/// the trace can end nearer a neighbour).
const ALONG_REACH: usize = 2;

/// A solve at another N is another point's orbit when a trace point beyond `ALONG_REACH`
/// steps lies nearer to it than this fraction of its own point's distance.
const NEARER: f64 = 0.5;

/// A traced speed sweep (a copy of the trace: its rows stay those of the trace at N while
/// `Raising` writes the raised points into the sweep) and the settings of its N.
pub(crate) struct SpeedTarget<'a> {
    pub family: &'a dyn SpeedFamily,
    /// The sweep's settings at the trace's N.
    pub base: &'a SpeedSweepSettings,
    /// The sweep's points as traced at N.
    pub trace: Vec<SpeedPoint>,
    /// The master coordinate (its first harmonic is the measure of the change).
    pub master: usize,
}

/// `settings` on N = `harmonics`, the time samples grown as the solver grows them
/// (`ForcedSolver::with_harmonics`).
pub(crate) fn at_harmonics(
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

impl RaiseTarget for SpeedTarget<'_> {
    type Point = SpeedPoint;
    type Level = SpeedSweepSettings;
    const WHAT: &'static str = "speed sweep";

    fn orbit(p: &SpeedPoint) -> &ForcedPoint {
        &p.point
    }

    fn orbit_mut(p: &mut SpeedPoint) -> &mut ForcedPoint {
        &mut p.point
    }

    fn harmonics(level: &SpeedSweepSettings) -> usize {
        level.solver.harmonics.harmonics
    }

    fn level(&self, harmonics: usize) -> Result<SpeedSweepSettings, ForcedError> {
        at_harmonics(self.family, self.base, harmonics)
    }

    fn change(&self, a: &SpeedPoint, b: &SpeedPoint) -> [f64; 2] {
        let (coarse, fine) = match a.point.harmonics <= b.point.harmonics {
            true => (a, b),
            false => (b, a),
        };
        let q = coarse.point.first_harmonic(self.master);
        let qf = fine.point.first_harmonic(self.master);
        [
            (q - qf).abs() / qf.abs().max(f64::MIN_POSITIVE),
            (coarse.speed - fine.speed).abs() / fine.speed,
        ]
    }

    /// On the row normal to the sweep at `i`, or at the point's own speed (first when
    /// `fixed_first`).
    fn solve_finer(
        &self,
        level: &SpeedSweepSettings,
        i: usize,
        point: &SpeedPoint,
        (neighbour, neighbour_fine): (&SpeedPoint, &SpeedPoint),
        fixed_first: bool,
    ) -> Option<(SpeedPoint, [f64; 2], bool)> {
        let stepper = SpeedStepper::new(self.family, level);
        let speed = neighbour_fine.speed + (point.speed - neighbour.speed);
        let shifted = self.shifted_start(&stepper, point, (neighbour, neighbour_fine), speed)?;
        let on_row = || {
            let fine = self.on_normal(&stepper, i, shifted.clone(), speed)?;
            self.same_orbit(i, point, fine).map(|(p, c)| (p, c, false))
        };
        let at_speed = || {
            let mut start = shifted.clone();
            start.state.omega = stepper.fundamental() * point.speed;
            let problem = problem_at(self.family, level, point.speed).ok()?;
            let solver = problem.solver(&stepper.solver).ok()?;
            let solved = solver.solve(start, None).ok()?;
            let fine = stepper.finish(point.speed, solved, &solver, 1);
            self.same_orbit(i, point, fine).map(|(p, c)| (p, c, true))
        };
        if fixed_first {
            at_speed().or_else(on_row)
        } else {
            on_row().or_else(at_speed)
        }
    }

    fn solve_again(
        &self,
        level: &SpeedSweepSettings,
        i: usize,
        point: &SpeedPoint,
    ) -> Option<(SpeedPoint, [f64; 2])> {
        self.solve_directly(level, i, point).or_else(|| {
            // From the orbit at N straight to 2N the Newton basin can be too narrow where a
            // contact phase appears at 2N (on the blade's EO 3 sweep: next to the largest
            // contact force); half way first, as a continuation in N.
            let (from, to) = (point.point.harmonics, Self::harmonics(level));
            let middle = (from + to) / 2;
            if middle <= from || middle >= to {
                return None;
            }
            let half = self.level(middle).ok()?;
            let (between, _) = self.solve_directly(&half, i, point)?;
            let (fine, _) = self.solve_directly(level, i, &between)?;
            tracing::debug!(
                point = i,
                from,
                middle,
                to,
                "speed sweep: solved through N = {middle}"
            );
            self.same_orbit(i, point, fine)
        })
    }
}

impl SpeedTarget<'_> {
    /// `point` solved at `level` from itself on the row normal to the trace at `i`, on the
    /// same orbit.
    fn solve_directly(
        &self,
        level: &SpeedSweepSettings,
        i: usize,
        point: &SpeedPoint,
    ) -> Option<(SpeedPoint, [f64; 2])> {
        let stepper = SpeedStepper::new(self.family, level);
        let problem = problem_at(self.family, level, point.speed).ok()?;
        let start = start_at(&point.point, &problem.solver(&stepper.solver).ok()?);
        let fine = self.on_normal(&stepper, i, start, point.speed)?;
        self.same_orbit(i, point, fine)
    }

    /// The orbit on the row through point `i` of the trace normal to the sweep, from `start`
    /// near `speed`, at `stepper`'s N: the trace's own way (structure following W), else the
    /// frozen speed corrected on the same row (the check has no step to halve: under the
    /// penalty law an impact a few samples long can stall the following solve's inner Newton).
    fn on_normal(
        &self,
        stepper: &SpeedStepper<'_>,
        i: usize,
        start: ForcedStart,
        speed: f64,
    ) -> Option<SpeedPoint> {
        let arc = self.normal_arc(stepper, i);
        let row = arc.row(stepper.fundamental());
        let reach = CHECK_REACH * stepper.settings.speed_scale;
        let n = stepper.solver.harmonics.harmonics;
        let solved = stepper
            .on_speed_row(start.clone(), &row, speed, reach)
            .or_else(|e| {
                tracing::debug!(
                    point = i,
                    speed,
                    n,
                    "speed sweep: solve at N = {n}: {e}; frozen"
                );
                stepper.on_row(start, speed, &|_, _| row.clone(), &|_, _| true, reach)
            });
        solved
            .map_err(|e| tracing::debug!(point = i, speed, n, "speed sweep: solve at N = {n}: {e}"))
            .ok()
    }

    /// `fine` (a solve of point `i` at another N) with its change from `point` when the two
    /// are one orbit: `ladder::same_orbit`, and no point of the trace farther than
    /// `ALONG_REACH` steps from `i` is much nearer to `fine` than point `i` is
    /// (`nearer_trace_point`).
    fn same_orbit(
        &self,
        i: usize,
        point: &SpeedPoint,
        fine: SpeedPoint,
    ) -> Option<(SpeedPoint, [f64; 2])> {
        if let Some(k) = self.nearer_trace_point(i, &fine) {
            tracing::debug!(
                point = i,
                nearer = k,
                speed = point.speed,
                speed_fine = fine.speed,
                "speed sweep: the solve at another N landed next to another point of the trace"
            );
            return None;
        }
        let change = self.change(point, &fine);
        tracing::debug!(
            speed = point.speed,
            speed_fine = fine.speed,
            harmonics = fine.point.harmonics,
            ?change,
            solves = fine.corrections,
            "speed sweep: solved at another N"
        );
        if !same_orbit(change, &point.point, &fine.point) {
            tracing::debug!(
                speed = point.speed,
                ?change,
                "speed sweep: landed elsewhere"
            );
            return None;
        }
        Some((fine, change))
    }

    /// A point of the trace, more than `ALONG_REACH` steps from `i`, nearer to `fine` than
    /// `NEARER` times point `i` is, in the scaled space of `normal_arc` (`fine`'s harmonics
    /// above the trace's N left out: the same for every point). The solve of a point at
    /// another N is on the hyperplane through it normal to the trace, which the curve at the
    /// other N can cross more than once: where the sweep winds (the default blade's EO 3 sweep
    /// at 7940-8000 rpm), Newton from the point at 8039 rpm converged at N = 40 on its
    /// crossing at 7961 rpm, a change of 1.6e-2 that is not a truncation error.
    fn nearer_trace_point(&self, i: usize, fine: &SpeedPoint) -> Option<usize> {
        let pts = &self.trace;
        let rows = pts[i].running_gaps.len().max(1);
        let y_scale = pts[0].gap_reference * (rows as f64).sqrt();
        let speed_scale = self.base.speed_scale;
        let (from, to) = (
            fine.point.contact.len() / rows,
            pts[i].point.contact.len() / rows,
        );
        let y = resize_signals(&fine.point.contact, rows, from, to);
        let distance = |p: &SpeedPoint| {
            let dy: f64 = (p.point.contact.iter().zip(&y))
                .map(|(a, b)| ((a - b) / y_scale).powi(2))
                .sum();
            (dy + ((p.speed - fine.speed) / speed_scale).powi(2)).sqrt()
        };
        let own = distance(&pts[i]);
        (0..pts.len())
            .filter(|k| k.abs_diff(i) > ALONG_REACH)
            .map(|k| (k, distance(&pts[k])))
            .filter(|&(_, d)| d < NEARER * own)
            .min_by(|a, b| a.1.total_cmp(&b.1))
            .map(|(k, _)| k)
    }

    /// The start at `stepper`'s N of `point` from a neighbour solved at the point's N and at
    /// `stepper`'s: the neighbour's finer orbit plus the difference of the two points, at
    /// `speed` (the neighbour's finer speed shifted alike).
    fn shifted_start(
        &self,
        stepper: &SpeedStepper<'_>,
        point: &SpeedPoint,
        (neighbour, neighbour_fine): (&SpeedPoint, &SpeedPoint),
        speed: f64,
    ) -> Option<ForcedStart> {
        let problem = problem_at(self.family, stepper.settings, speed).ok()?;
        let solver = problem.solver(&stepper.solver).ok()?;
        let rows = point.running_gaps.len().max(1);
        let (from, to) = (point.point.contact.len() / rows, solver.basis().terms());
        let difference: Vec<f64> = (point.point.contact.iter())
            .zip(&neighbour.point.contact)
            .map(|(a, b)| a - b)
            .collect();
        let difference = resize_signals(&difference, rows, from, to);
        let mut start = start_at(&point.point, &solver);
        start.state.y = (neighbour_fine.point.contact.iter())
            .zip(&difference)
            .map(|(y, d)| y + d)
            .collect();
        start.state.omega =
            neighbour_fine.point.omega + (point.point.omega - neighbour.point.omega);
        Some(start)
    }

    /// The row through point `i` of the trace normal to the sweep, at `stepper`'s N: the unit
    /// secant of its neighbours (the point itself at an end) in the scaled space of
    /// `speed_sweep` (contact coordinates over g_ref sqrt(c), the speed over Omega_ref), padded
    /// with zero harmonics.
    fn normal_arc(&self, stepper: &SpeedStepper<'_>, i: usize) -> SpeedArc {
        let pts = &self.trace;
        let p = &pts[i];
        let rows = p.running_gaps.len().max(1);
        let y_scale = pts[0].gap_reference * (rows as f64).sqrt();
        let speed_scale = stepper.settings.speed_scale;
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
            2 * stepper.solver.harmonics.harmonics + 1,
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
}
