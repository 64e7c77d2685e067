//! The forced response along the rotation speed at an engine order (issue 39, item 2;
//! docs/DESIGN.md §10.10): the excitation at W = e Omega while the structure (K(Omega), the
//! contact rows, the running gaps), its damping and its load follow the speed Omega
//! ([`SpeedFamily`]), traced by pseudo-arc-length continuation in (orbit, Omega) through folds,
//! as a run-up of a test rig crosses the Campbell diagram's crossings.
//!
//! Scaled space: the contact coordinates y / (g_ref sqrt(c)) (g_ref the gap reference at the
//! start of the sweep, c the contact rows) and Omega / Omega_ref (`speed_scale`; with
//! Omega_ref = w_mode / e at the crossing, Omega / Omega_ref moves as the frequency sweep's
//! W / w_mode). The first two points are solved at fixed speed from the linear response; each
//! step then predicts along the unit secant t of the last two points, x_p = x_k + h t, and
//! solves on the row t . (x - x_p) = 0 (`speed_step`: every accepted point is an orbit of the
//! structure at its own speed, at W = e Omega). A step is accepted when the corrector lands
//! within one step of the prediction, the secant turns by less than [`MAX_TURN`] and, out of
//! contact, the first harmonic's phase by less than [`PHASE_REACH`] (the phase turns by pi
//! across a resonance: a larger turn has jumped one); otherwise it is halved (below
//! [`CORNER_STEP`] a larger turn is accepted). Below [`CORNER_STEP`], a corrector that lands
//! beyond one step but within [`CORNER_REACH`] steps at about the same multiple of the step at
//! two steps in a row ([`CORNER_RATIO_CHANGE`]) says the predicted tangent is off by a finite
//! angle (`SpeedTrace::at_corner`): after a step [`BACKTRACK_CHORD`] times longer than the
//! current one, that step is taken back (the curve bent within it) and the trace goes on from
//! the point before at the small step; otherwise the point is taken as past a corner when it
//! goes on from the last secant with the speed moving on the same way. A fold is where
//! Omega turns (the speed components of consecutive secants change sign), located at the
//! extremum of the parabola in arc length through the three points around it. Under the
//! penalty law a step that fails below [`GRAZING_STEP`] passes grazing by prescribed
//! penetrations of the grazing row, and one that fails at the smallest step hops at a fixed
//! speed (`speed_grazing`). Every point of a trace shares one N; `speed_harmonics` checks it at
//! 2N and traces the sweep again at 2N where it has not converged (`SpeedHarmonics`).

use crate::curve::{harmonics_converged, CurveHarmonics, FoldKind, FrfTermination, RaisedSegments};
use crate::error::ForcedError;
use crate::point_stability::PointStability;

use crate::speed_curve::{SpeedPoint, SpeedSweepSettings};
use crate::speed_step::{SpeedArc, SpeedFamily, SpeedStepper};
use crate::trace::{norm, phase, phase_row, wrap_angle};
use nlmodes_hb::floquet::Verdict;
use nlmodes_hb::ContactMethod;

/// Largest turn from the tangent at the last point to the secant of a step (rad), as the
/// frequency sweep's tangent
/// (`trace::MAX_TURN`); the step grows while turns stay below a third of it.
pub const MAX_TURN: f64 = 0.35;

/// Largest turn of the first harmonic's phase between two points out of contact (rad), as the
/// frequency sweep's (`trace::PHASE_REACH`).
pub const PHASE_REACH: f64 = 1.0;

/// Scaled step below which a turn larger than [`MAX_TURN`] (but below a right angle) is
/// accepted: there the turn no longer shrinks with the step, so it is the tangent estimate that
/// is off (it is a parabola through the last three points, and the curve's curvature jumps
/// where the orbit starts to touch: on the 3-DOF system the turn stays at 0.36 rad from
/// h = 1e-3 down to 1e-6), not the step; the corrector still lands within one step of the
/// prediction, on the same branch.
const CORNER_STEP: f64 = 1e-3;

/// Scaled step below which a failing step under the penalty law tries the grazing passage by
/// prescribed penetrations (`speed_grazing`), as the frequency sweep's `trace::GRAZING_STEP`.
const GRAZING_STEP: f64 = 1e-4;

/// How far (in steps) the corrector may land from the prediction.
const CORRECTOR_REACH: f64 = 1.0;

/// How far (in steps) the corrector may land from the prediction at a corner (below
/// [`CORNER_STEP`], the distance over the step the same at two steps in a row): on the row
/// normal to the tangent, a branch leaving the last point at an angle theta lands h tan(theta)
/// from the prediction at every h, so 4 steps take corners up to 76 degrees (the frequency
/// sweep's `trace::CORNER_REACH`). At N = 20 the default blade's EO 3 sweep meets one at
/// 835.41 rad/s, where a contact row starts to touch: the corrector lands 1.2 steps away at
/// every step from 1e-3 down to 2e-6.
const CORNER_REACH: f64 = 4.0;

/// How much the distance over the step may change when the step halves for the corrector's
/// point to be on a corner's branch: constant there (h tan(theta)); a landing on another branch
/// a distance D away doubles it (D / h), a smooth bend of curvature k halves it (k h / 2).
const CORNER_RATIO_CHANGE: f64 = 0.2;

/// A landing at a constant distance over the step after a step this many times longer than
/// the current one takes that step back ([`SpeedTrace::at_corner`]): the curve may have bent
/// sharply within it, so that the tangent through its point is off.
const BACKTRACK_CHORD: f64 = 4.0;

/// A fold of a speed sweep: where the speed turns.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SpeedFold {
    /// Index of the point nearest the fold.
    pub point: usize,
    /// The speed at the fold (rad/s).
    pub speed: f64,
    /// `TurnsBack`: the speed rose and now falls (a run-up jumps there); `TurnsForward`: a
    /// run-down jumps there.
    pub kind: FoldKind,
}

/// A traced speed sweep.
#[derive(Clone, Debug)]
pub struct SpeedSweep {
    /// The points in continuation order.
    pub points: Vec<SpeedPoint>,
    /// The folds met.
    pub folds: Vec<SpeedFold>,
    /// Indices of the points reached by a hop at a fixed speed (`speed_grazing`).
    pub hops: Vec<usize>,
    /// Why it stopped (`at`: the speed of the last point, rad/s).
    pub termination: FrfTermination,
    /// N of every point (the last trace's).
    pub harmonics: usize,
    /// Every trace's N and what its check at 2N found, in order (`speed_harmonics`; empty
    /// under `SpeedHarmonics::Fixed`): the last is this sweep's.
    pub retraces: Vec<CurveHarmonics>,
    /// Under `SpeedHarmonics::Retrace`: the points raised above the last trace's N where its
    /// check found them moving (`raised_segments`; `None` when none was).
    pub raised: Option<RaisedSegments>,
}

impl SpeedSweep {
    /// Under `SpeedHarmonics::Retrace` or `Check`: whether the sweep's N is converged at every
    /// point checked (the last trace's checked points, and those of its raised segments);
    /// `None` under `Fixed`.
    pub fn harmonics_converged(&self) -> Option<bool> {
        harmonics_converged(&self.retraces, self.raised.as_ref())
    }

    /// Why the sweep ended, as a sentence (speeds in rpm).
    pub fn end_text(&self) -> String {
        let rpm = |w: f64| format!("{:.2} rpm", w * 30.0 / std::f64::consts::PI);
        match &self.termination {
            FrfTermination::Complete => "complete".into(),
            FrfTermination::StepTooSmall { at, reason } => format!(
                "stopped at {}: no step down to min_step converged ({reason})",
                rpm(*at)
            ),
            FrfTermination::PointLimit => "stopped at the point limit (max_points)".into(),
            FrfTermination::LeftRange { at } => format!(
                "the sweep turned back below the start of the range after {}",
                rpm(*at)
            ),
            other => format!("{other:?}"),
        }
    }
}

/// The sweep at the settings' N, without its stability.
pub(crate) fn trace_sweep(
    family: &dyn SpeedFamily,
    settings: &SpeedSweepSettings,
    progress: &mut impl FnMut(&SpeedPoint),
) -> Result<SpeedSweep, ForcedError> {
    let mut trace = SpeedTrace::begin(family, settings, progress)?;
    trace.run(progress);
    Ok(trace.sweep)
}

/// The changes of stability between consecutive determined points of `verdicts` (in the
/// order of a sweep), each on the later point (`PointStability::classify`).
pub(crate) fn classify_changes<'a>(verdicts: impl Iterator<Item = &'a mut PointStability>) {
    let mut previous: Option<PointStability> = None;
    for st in verdicts {
        if let Some(prev) = &previous {
            st.classify(prev);
        }
        if st.verdict != Verdict::Undetermined {
            previous = Some(*st);
        }
    }
}

/// The continuation in progress.
pub(crate) struct SpeedTrace<'a> {
    pub(crate) stepper: SpeedStepper<'a>,
    pub(crate) y_scale: f64,
    step: f64,
    pub(crate) sweep: SpeedSweep,
    /// The row of the last grazing passage that did not get across and the number of points
    /// then: the passage is not tried again on that row for `PASSAGE_RETRY` points.
    pub(crate) failed_passage: Option<(usize, usize)>,
    /// The index of the last corner's vertex (the last point before a corner was passed,
    /// [`Self::advance`]): the tangent at the point after it is the secant, not the parabola
    /// through the corner.
    corner: Option<usize>,
    /// The number of points left by the last step taken back ([`Self::at_corner`]): not taken
    /// back again from there.
    backtracked: Option<usize>,
}

/// Why a step's point was refused; the point with its distance from the prediction over the
/// step when that distance alone refused it and it is within a corner's reach
/// ([`CORNER_REACH`], below [`CORNER_STEP`]).
struct Refusal {
    why: String,
    far: Option<(f64, Box<SpeedPoint>)>,
}

impl From<String> for Refusal {
    fn from(why: String) -> Self {
        Refusal { why, far: None }
    }
}

impl<'a> SpeedTrace<'a> {
    /// The first two points, at fixed speeds, from the linear response at the start.
    fn begin(
        family: &'a dyn SpeedFamily,
        settings: &'a SpeedSweepSettings,
        progress: &mut impl FnMut(&SpeedPoint),
    ) -> Result<Self, ForcedError> {
        let stepper = SpeedStepper::new(family, settings);
        let first = stepper.at_speed(settings.start, None)?;
        progress(&first);
        let next = settings.start + settings.step * settings.speed_scale;
        let second = stepper.at_speed(next.min(settings.end), Some(&first))?;
        progress(&second);
        let rows = first.point.gaps.len() / settings.solver.harmonics.samples;
        Ok(Self {
            stepper,
            y_scale: first.gap_reference * (rows.max(1) as f64).sqrt(),
            step: settings.step,
            failed_passage: None,
            corner: None,
            backtracked: None,
            sweep: SpeedSweep {
                points: vec![first, second],
                folds: Vec::new(),
                hops: Vec::new(),
                termination: FrfTermination::Complete,
                harmonics: settings.solver.harmonics.harmonics,
                retraces: Vec::new(),
                raised: None,
            },
        })
    }

    fn settings(&self) -> &'a SpeedSweepSettings {
        self.stepper.settings
    }

    /// A point in the scaled space.
    fn scaled(&self, p: &SpeedPoint) -> Vec<f64> {
        let mut v: Vec<f64> = p.point.contact.iter().map(|y| y / self.y_scale).collect();
        v.push(p.speed / self.settings().speed_scale);
        v
    }

    /// The unit secant from `a` to `b` in the scaled space, and its length.
    pub(crate) fn secant(&self, a: &SpeedPoint, b: &SpeedPoint) -> (Vec<f64>, f64) {
        let d: Vec<f64> = (self.scaled(b).iter().zip(self.scaled(a)))
            .map(|(x, y)| x - y)
            .collect();
        let length = norm(&d);
        (d.iter().map(|v| v / length).collect(), length)
    }

    /// The unit tangent at the last point: the slope there of the parabola in arc length
    /// through the last three points (the secant of the first two), second-order accurate,
    /// so that the turn to the next secant shrinks with the step on a smooth curve.
    fn last_tangent(&self) -> Vec<f64> {
        let n = self.sweep.points.len();
        let p = &self.sweep.points;
        let (b, sb) = self.secant(&p[n - 2], &p[n - 1]);
        if n < 3 || self.corner == Some(n - 2) {
            return b;
        }
        let (a, sa) = self.secant(&p[n - 3], &p[n - 2]);
        let w = sb / (sa + sb);
        let t: Vec<f64> = a.iter().zip(&b).map(|(a, b)| b + w * (b - a)).collect();
        let length = norm(&t);
        t.into_iter().map(|v| v / length).collect()
    }

    /// The step `h` along `tangent` from the last point.
    fn arc(&self, tangent: &[f64], h: f64) -> SpeedArc {
        let last = self.sweep.points.last().expect("two points");
        let l = last.point.contact.len();
        let scale = self.settings().speed_scale;
        SpeedArc {
            tangent: tangent.to_vec(),
            y: (last.point.contact.iter().zip(tangent))
                .map(|(y, t)| y + h * t * self.y_scale)
                .collect(),
            speed: last.speed + h * tangent[l] * scale,
            step: h,
            y_scale: self.y_scale,
            speed_scale: scale,
        }
    }

    /// Steps until the end of the range, the point limit, a failed step or a turn back below
    /// the start.
    fn run(&mut self, progress: &mut impl FnMut(&SpeedPoint)) {
        let (start, end) = (self.settings().start, self.settings().end);
        loop {
            let last = self.sweep.points.last().expect("points").speed;
            if last >= end {
                return;
            }
            if self.sweep.points.len() >= self.settings().max_points {
                self.sweep.termination = FrfTermination::PointLimit;
                return;
            }
            if let Err(reason) = self.advance() {
                self.sweep.termination = FrfTermination::StepTooSmall { at: last, reason };
                return;
            }
            let newest = self.sweep.points.last().expect("just pushed");
            if newest.speed < start {
                self.sweep.points.pop();
                let n = self.sweep.points.len();
                self.sweep.folds.retain(|f| f.point < n);
                self.sweep.hops.retain(|&h| h < n);
                self.sweep.termination = FrfTermination::LeftRange { at: last };
                return;
            }
            progress(newest);
        }
    }

    /// One accepted step, or the reason the smallest step failed.
    fn advance(&mut self) -> Result<(), String> {
        let tangent = self.last_tangent();
        let exact = matches!(
            self.settings().solver.algorithm.method,
            ContactMethod::Penalty { .. }
        );
        let mut reason = String::from("no step tried");
        let mut grazing_tried = false;
        // The corrector's distance from the prediction over the step at the last refused step,
        // when within a corner's reach.
        let mut overshoot: Option<f64> = None;
        loop {
            if exact && self.step < GRAZING_STEP && !grazing_tried {
                grazing_tried = true;
                if self.pass_grazing(&tangent) {
                    self.step = GRAZING_STEP.max(self.settings().min_step);
                    return Ok(());
                }
            }
            if self.step < self.settings().min_step {
                if self.hop(tangent[tangent.len() - 1].signum()) {
                    self.step = GRAZING_STEP.max(self.settings().min_step);
                    return Ok(());
                }
                return Err(reason);
            }
            let arc = self.arc(&tangent, self.step);
            let last = self.sweep.points.last().expect("two points");
            // The last step lands on the end of the range, at that fixed speed.
            let solved = if arc.speed >= self.settings().end {
                self.stepper.at_speed(self.settings().end, Some(last))
            } else {
                self.stepper.on_arc(last, &arc)
            };
            let judged = solved
                .map_err(|e| Refusal::from(e.to_string()))
                .and_then(|p| self.judge(&arc, &tangent, p));
            match judged {
                Ok((p, turn)) => {
                    let easy = p.corrections <= 4;
                    self.push(p);
                    if easy && turn < MAX_TURN / 3.0 {
                        self.step = (self.step * 1.5).min(self.settings().max_step);
                    }
                    return Ok(());
                }
                Err(Refusal { why, far }) => {
                    if let Some((ratio, p)) = far {
                        let steady = overshoot
                            .is_some_and(|r| (ratio / r - 1.0).abs() <= CORNER_RATIO_CHANGE);
                        if steady && self.at_corner(*p, ratio) {
                            return Ok(());
                        }
                        overshoot = Some(ratio);
                    } else {
                        overshoot = None;
                    }
                    tracing::debug!(step = self.step, "speed sweep: step halved ({why})");
                    reason = why;
                    self.step *= 0.5;
                }
            }
        }
    }

    /// A corrector's point `p` that lands `ratio` steps from the prediction at this step and
    /// about as far at twice it (module docs): the curve runs through the last point along the
    /// secant d to `p`, at a finite angle from the predicted tangent, one way or the other.
    /// `p` is taken (the last point a corner's vertex) when d goes on from the last secant
    /// (positive dot product) with the speed moving on the same way. Otherwise d may lead back
    /// along the curve traced (on the default blade at N = 20, 835.41 rad/s: d at 42 degrees
    /// from the last secant but the speed falling, and the points along d went back through
    /// the last points to below the range): steps along -d are tried first (this step, half,
    /// a quarter), then `p` if d goes on. Whether one was taken.
    fn at_corner(&mut self, p: SpeedPoint, ratio: f64) -> bool {
        let n = self.sweep.points.len();
        let (last, chord) = self.secant(&self.sweep.points[n - 2], &self.sweep.points[n - 1]);
        if chord > BACKTRACK_CHORD * self.step
            && n > 3
            && self.backtracked.is_none_or(|k| k < n - 1)
        {
            tracing::debug!(
                step = self.step,
                ratio,
                chord,
                speed = self.sweep.points[n - 1].speed,
                "speed sweep: the last step taken back (the tangent is off by a finite angle)"
            );
            self.pop();
            self.backtracked = Some(n - 1);
            return true;
        }
        let (d, _) = self.secant(&self.sweep.points[n - 1], &p);
        let on: f64 = d.iter().zip(&last).map(|(a, b)| a * b).sum();
        let l = d.len() - 1;
        let onward = d[l] * last[l] > 0.0;
        tracing::debug!(
            step = self.step,
            ratio,
            on,
            onward,
            speed = p.speed,
            vertex = self.sweep.points[n - 1].speed,
            "speed sweep: the corrector lands at a constant distance over the step"
        );
        if on > 0.0 && onward {
            tracing::debug!(speed = p.speed, "speed sweep: corner passed");
            self.corner = Some(n - 1);
            self.push(p);
            return true;
        }
        false
    }

    /// Drops the last point, with the fold and hop recorded with it.
    fn pop(&mut self) {
        self.sweep.points.pop();
        let n = self.sweep.points.len();
        self.sweep.folds.retain(|f| f.point + 1 < n);
        self.sweep.hops.retain(|&h| h < n);
        if self.corner.is_some_and(|c| c + 1 >= n) {
            self.corner = None;
        }
    }

    /// Whether `p` is the next point of the curve (module docs): with the secant's turn.
    fn judge(
        &self,
        arc: &SpeedArc,
        tangent: &[f64],
        p: SpeedPoint,
    ) -> Result<(SpeedPoint, f64), Refusal> {
        let mut predicted = arc.y.iter().map(|y| y / self.y_scale).collect::<Vec<_>>();
        predicted.push(arc.speed / arc.speed_scale);
        let x = self.scaled(&p);
        let distance = norm(
            &x.iter()
                .zip(&predicted)
                .map(|(a, b)| a - b)
                .collect::<Vec<_>>(),
        );
        let shaped = self.shape(tangent, &p);
        if distance > CORRECTOR_REACH * self.step {
            let why = format!(
                "the corrector lands {distance:.3e} from the prediction (step {:.3e}) at {:.6e} \
                 rad/s",
                self.step, p.speed
            );
            let ratio = distance / self.step;
            let corner = self.step < CORNER_STEP && ratio <= CORNER_REACH && shaped.is_ok();
            return Err(Refusal {
                why,
                far: corner.then(|| (ratio, Box::new(p))),
            });
        }
        Ok((p, shaped?))
    }

    /// The turn of the secant from the last point to `p` away from `tangent` when it is
    /// acceptable (module docs), why not otherwise.
    fn shape(&self, tangent: &[f64], p: &SpeedPoint) -> Result<f64, String> {
        let last = self.sweep.points.last().expect("two points");
        let (next, _) = self.secant(last, p);
        let cos: f64 = next.iter().zip(tangent).map(|(a, b)| a * b).sum();
        let turn = cos.clamp(-1.0, 1.0).acos();
        if turn > MAX_TURN && (self.step > CORNER_STEP || turn > std::f64::consts::FRAC_PI_2) {
            return Err(format!("the secant turned by {turn:.3} rad in one step"));
        }
        if !last.point.touches() && !p.point.touches() {
            let rows = self.rows();
            let row = phase_row(&last.point, rows);
            let leap = wrap_angle(phase(&p.point, row, rows) - phase(&last.point, row, rows));
            if leap.abs() > PHASE_REACH {
                return Err("the first harmonic's phase turned by more than PHASE_REACH".into());
            }
        }
        Ok(turn)
    }

    /// Contact rows.
    fn rows(&self) -> usize {
        let p = &self.sweep.points[0].point;
        p.gaps.len() / self.settings().solver.harmonics.samples
    }

    /// Appends an accepted point, and the fold before it if the speed turned there.
    pub(crate) fn push(&mut self, p: SpeedPoint) {
        self.sweep.points.push(p);
        let n = self.sweep.points.len();
        if n < 3 {
            return;
        }
        let [a, b, c] = [n - 3, n - 2, n - 1].map(|i| &self.sweep.points[i]);
        let (before, after) = (b.speed - a.speed, c.speed - b.speed);
        if before * after >= 0.0 {
            return;
        }
        let (s1, s2) = (self.secant(a, b).1, self.secant(b, c).1);
        let scale = self.settings().speed_scale;
        let speed = parabola_extremum(
            [0.0, s1, s1 + s2],
            [a.speed / scale, b.speed / scale, c.speed / scale],
        ) * scale;
        self.sweep.folds.push(SpeedFold {
            point: n - 2,
            speed,
            kind: if before > 0.0 {
                FoldKind::TurnsBack
            } else {
                FoldKind::TurnsForward
            },
        });
    }
}

/// The folds of `sweep` after N was raised around moving points (`raised_segments`): a fold
/// whose neighbourhood (within two points of its point) holds three consecutive points raised
/// to one N where the speed turns the same way is located again on them, as the trace locates
/// a fold (the parabola in the scaled arc length through the three, `SpeedTrace::push`), so
/// that the jump speed reported is that of the N the points around it carry. Other folds keep
/// the trace's.
pub(crate) fn refold_raised(sweep: &mut SpeedSweep, speed_scale: f64) {
    let pts = &sweep.points;
    let Some(first) = pts.first() else { return };
    let y_scale = first.gap_reference * (first.running_gaps.len().max(1) as f64).sqrt();
    let length = |a: &SpeedPoint, b: &SpeedPoint| {
        let dy = (a.point.contact.iter().zip(&b.point.contact))
            .map(|(x, y)| ((x - y) / y_scale).powi(2))
            .sum::<f64>();
        (dy + ((a.speed - b.speed) / speed_scale).powi(2)).sqrt()
    };
    for fold in &mut sweep.folds {
        let (lo, hi) = (fold.point.saturating_sub(2).max(1), fold.point + 2);
        for k in lo..=hi.min(pts.len().saturating_sub(2)) {
            let [a, b, c] = [k - 1, k, k + 1].map(|i| &pts[i]);
            let n = b.point.harmonics;
            if n == sweep.harmonics || a.point.harmonics != n || c.point.harmonics != n {
                continue;
            }
            let (before, after) = (b.speed - a.speed, c.speed - b.speed);
            let back = fold.kind == FoldKind::TurnsBack;
            if before * after >= 0.0 || (before > 0.0) != back {
                continue;
            }
            let (s1, s2) = (length(a, b), length(b, c));
            let speeds = [a.speed, b.speed, c.speed].map(|v| v / speed_scale);
            fold.speed = parabola_extremum([0.0, s1, s1 + s2], speeds) * speed_scale;
            fold.point = k;
            break;
        }
    }
}

/// The extreme value of the parabola through (s_i, p_i), s increasing; the middle value when
/// the three are aligned or the extremum falls outside [s_0, s_2].
fn parabola_extremum(s: [f64; 3], p: [f64; 3]) -> f64 {
    let d1 = (p[1] - p[0]) / (s[1] - s[0]);
    let d2 = (p[2] - p[1]) / (s[2] - s[1]);
    let curvature = (d2 - d1) / (s[2] - s[0]);
    if !(curvature.is_finite() && curvature != 0.0) {
        return p[1];
    }
    // p(s) = p1 + d (s - s1) + curvature (s - s1)^2 with d the slope at s1.
    let d = d1 + curvature * (s[1] - s[0]);
    let at = s[1] - d / (2.0 * curvature);
    if !(s[0]..=s[2]).contains(&at) {
        return p[1];
    }
    p[1] + d * (at - s[1]) + curvature * (at - s[1]).powi(2)
}

#[cfg(test)]
mod tests {
    use super::{parabola_extremum, SpeedSweepSettings};
    use crate::error::ForcedError;
    use crate::solver::ForcedSettings;

    /// An engine order below 1, a speed range not above 0 or inverted: refused, naming the
    /// setting.
    #[test]
    fn bad_settings_are_named() {
        let ok = SpeedSweepSettings::new(3, 0, (10.0, 20.0), 5.0, ForcedSettings::new(4).unwrap());
        assert!(ok.validate().is_ok());
        let named = |s: SpeedSweepSettings, name: &str| match s.validate() {
            Err(ForcedError::Parameter { name: n, .. }) => assert_eq!(n, name),
            other => panic!("{other:?}"),
        };
        named(
            SpeedSweepSettings {
                engine_order: 0,
                ..ok.clone()
            },
            "engine_order",
        );
        named(
            SpeedSweepSettings {
                start: 0.0,
                ..ok.clone()
            },
            "start",
        );
        named(
            SpeedSweepSettings {
                end: 10.0,
                ..ok.clone()
            },
            "end",
        );
        named(
            SpeedSweepSettings {
                speed_scale: f64::NAN,
                ..ok
            },
            "speed_scale",
        );
    }

    #[test]
    fn the_extremum_of_a_parabola_is_found_exactly() {
        // p = 2 - (s - 0.7)^2 at uneven s.
        let f = |s: f64| 2.0 - (s - 0.7) * (s - 0.7);
        let s = [0.0, 0.5, 1.3];
        let v = parabola_extremum(s, s.map(f));
        assert!((v - 2.0).abs() < 1e-14, "{v}");
        assert_eq!(parabola_extremum([0.0, 1.0, 2.0], [0.0, 1.0, 2.0]), 1.0);
    }
}
