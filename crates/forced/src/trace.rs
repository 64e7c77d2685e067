//! The continuation of the forced response (DESIGN §10.5): pseudo-arc-length in (orbit, p),
//! p the swept parameter (W, or the load scale s at a fixed W), along the exact tangent.
//!
//! Scaled space: y / (g_ref sqrt(c)) and p / p_ref (p_ref the first linear frequency for W,
//! the end of the range for s). The first two points are solved at fixed p; then each step
//! predicts along the unit tangent t_k of the last point, x_p = x_k + h t_k, and solves with the
//! row t_k . (x - x_p) = 0 (`ArcRow`), which moves the point forward by h along t_k. The new
//! point's own tangent (the null vector of the Jacobian [dR/dy, dR/dp], oriented along t_k;
//! `ForcedSolver::tangent`) is the next predictor. A step is accepted when its corrector
//! converged within `CORRECTOR_REACH` steps of the prediction and the tangent turned by less
//! than `MAX_TURN` (the curve of the exactly integrated penalty law is continuously
//! differentiable: any turn shrinks with the step, so a step that turns more met the curve
//! elsewhere and is halved); otherwise it is halved. A point in contact is then checked at 2N
//! (`ladder`): N doubles where the orbit needs it, and goes back to the base N out of contact.
//! Folds are where the parameter's component of the tangent changes sign (`fold`).
//!
//! The sampled augmented-Lagrangian law has corners (its Jacobian jumps when a sample enters
//! contact): there a turn is accepted at the smallest step, and below `CORNER_STEP` the step
//! gives way to a hop at fixed p or at fixed phase (`corner`).

use crate::curve::{Fold, FoldKind, FrequencyResponse, FrfSettings, FrfTermination, Sweep};
use crate::error::ForcedError;
use crate::fold::fold_between;
use crate::ladder::{resize_signals, start_at, HarmonicLadder};
use crate::newton::{ArcRow, OrbitState};
use crate::solver::{ForcedPoint, ForcedSolver, ForcedStart};
use nlmodes_hb::system::System;
use nlmodes_hb::FullBasis;

/// How far (as a multiple of the step) the corrector may land from the prediction on the
/// exactly integrated law: on a smooth curve it lands within (curvature x h^2) / 2 of it, so
/// this bounds the curvature radius seen by a step from below by half the step.
const CORRECTOR_REACH: f64 = 1.0;

/// The same bound for the sampled law, whose curve turns at corners by a finite angle a, where
/// the arc hyperplane meets it at h / cos(a) (measured on the blade: 1.88 h at every h from 1e-2
/// down to 1e-6, a = 58 degrees). Four accepts corners up to 75 degrees; a jump to another
/// branch lands at a distance that does not shrink with h and is refused once h is small.
const CORNER_REACH: f64 = 4.0;

/// Largest turn of the unit tangent over one step (rad) on the exactly integrated law; the step
/// grows while turns stay below a third of it.
const MAX_TURN: f64 = 0.35;

/// Scaled step below which a failing step on the exactly integrated law tries the grazing
/// passage by prescribed penetrations (`grazing`).
const GRAZING_STEP: f64 = 1e-4;

/// Scaled step below which a failing step on the sampled law gives way to a hop (`corner`).
pub(crate) const CORNER_STEP: f64 = 1e-3;

/// The largest turn (rad) of the first harmonic's phase between two consecutive points out of
/// contact. The phase turns by pi through a resonance within its half-power bandwidth 2 zeta w:
/// a step that turns it by more than this has jumped across a resonance narrower than itself
/// (at 0.03 % damping the blade's curve at level 2 went from W/w1 = 0.984 to past the peak in
/// one step and missed it). Along the curve the phase turns by 0.01-0.3 rad per step.
const PHASE_REACH: f64 = 1.0;

/// How close (scaled distance, on the base N's coefficients) the trace from the end of the
/// range must come to a point of the first piece to have met it: half the largest step.
pub(crate) const MEET_REACH: f64 = 0.01;

/// The scales of the continuation's space (module docs): y_s = g_ref sqrt(c) (length) and p_s,
/// w_1 for W (rad/s) or the end of the range for the load scale.
pub(crate) fn scales(system: &System, settings: &FrfSettings) -> (f64, f64) {
    let y_scale = system.gap_reference() * (system.n_contacts().max(1) as f64).sqrt();
    let p_scale = match settings.sweep {
        Sweep::Frequency => system.linear_frequencies()[0],
        Sweep::Level { .. } => settings.end,
    };
    (y_scale, p_scale)
}

/// The continuation in progress (see module docs).
pub(crate) struct FrfTrace<'l, 'a, 's> {
    pub(crate) ladder: &'l HarmonicLadder<'a, 's>,
    pub(crate) settings: &'l FrfSettings,
    /// The ladder's level the steps are taken on.
    pub(crate) level: usize,
    pub(crate) y_scale: f64,
    /// p_ref: w_ref for W, the end of the range for the load scale.
    pub(crate) p_scale: f64,
    pub(crate) step: f64,
    /// The unit tangent at the last point, at the current level's size.
    pub(crate) tangent: Vec<f64>,
    /// +1 for the trace from the start of the range, -1 for the one from its end.
    pub(crate) direction: f64,
    /// The first piece's points (base N, scaled), which the trace from the end stops on meeting.
    pub(crate) meet: Vec<Vec<f64>>,
    pub(crate) curve: FrequencyResponse,
}

impl<'l, 'a, 's> FrfTrace<'l, 'a, 's> {
    /// The first two points from the linear solution at the start of the range (`direction`
    /// +1) or at its end (-1, p falling; for a frequency sweep only), each checked in N.
    pub(crate) fn begin(
        ladder: &'l HarmonicLadder<'a, 's>,
        settings: &'l FrfSettings,
        direction: f64,
        meet: Vec<Vec<f64>>,
        progress: &mut impl FnMut(&ForcedPoint),
    ) -> Result<Self, ForcedError> {
        let base = ladder.solver(0);
        let system = base.system();
        let from = if direction > 0.0 {
            settings.start
        } else {
            settings.end
        };
        let (omega, level) = match settings.sweep {
            Sweep::Frequency => (from, 1.0),
            Sweep::Level { omega } => (omega, settings.start),
        };
        let (y_scale, p_scale) = scales(system, settings);
        let first = base.solve(base.linear_start(omega, level)?, None)?;
        let (first, first_level) = ladder.converge(first, 0, None);
        progress(&first);
        let solver = ladder.solver(first_level);
        let mut start = ForcedSolver::start_from(&first);
        let parameter = settings.sweep.parameter();
        start
            .state
            .set_parameter(parameter, from + direction * settings.step * p_scale);
        let second = solver.solve(start, None)?;
        let (second, level_now) = ladder.converge(second, first_level, None);
        progress(&second);
        let mut trace = Self {
            ladder,
            settings,
            level: level_now,
            y_scale,
            p_scale,
            step: settings.step,
            tangent: Vec::new(),
            direction,
            meet,
            curve: FrequencyResponse::starting(settings.sweep, vec![first, second]),
        };
        let secant = trace.secant();
        let along = trace.arc(&secant, 0.0);
        trace.tangent = trace.solver().tangent(&trace.curve.points[1], &along)?;
        trace.settle_level();
        Ok(trace)
    }

    /// The solver of the current level.
    pub(crate) fn solver(&self) -> &'l ForcedSolver<'s> {
        self.ladder.solver(self.level)
    }

    /// Coefficients per signal at the current level.
    fn terms(&self) -> usize {
        self.solver().basis().terms()
    }

    /// Contact rows.
    fn rows(&self) -> usize {
        self.ladder.solver(0).system().n_contacts()
    }

    /// A point in the scaled space with its coefficients at `terms` per signal.
    fn scaled_at(&self, p: &ForcedPoint, terms: usize) -> Vec<f64> {
        let rows = self.rows();
        let y = resize_signals(&p.contact, rows, p.contact.len() / rows.max(1), terms);
        let mut v: Vec<f64> = y.iter().map(|y| y / self.y_scale).collect();
        v.push(self.curve.parameter(p) / self.p_scale);
        v
    }

    /// A point in the scaled space at the current level.
    pub(crate) fn scaled(&self, p: &ForcedPoint) -> Vec<f64> {
        self.scaled_at(p, self.terms())
    }

    /// A point in the scaled space on the base N's coefficients (for meeting another piece).
    pub(crate) fn scaled_base(&self, p: &ForcedPoint) -> Vec<f64> {
        self.scaled_at(p, self.ladder.solver(0).basis().terms())
    }

    /// The distance between two points in the scaled space of the current level.
    pub(crate) fn distance(&self, a: &ForcedPoint, b: &ForcedPoint) -> f64 {
        let (a, b) = (self.scaled(a), self.scaled(b));
        norm(&a.iter().zip(&b).map(|(x, y)| x - y).collect::<Vec<_>>())
    }

    /// The unit secant of the last two points in the scaled space of the current level.
    pub(crate) fn secant(&self) -> Vec<f64> {
        let n = self.curve.points.len();
        let (a, b) = (
            self.scaled(&self.curve.points[n - 2]),
            self.scaled(&self.curve.points[n - 1]),
        );
        let d: Vec<f64> = b.iter().zip(&a).map(|(x, y)| x - y).collect();
        let length = norm(&d);
        d.iter().map(|v| v / length).collect()
    }

    /// Where a step starts: the last point at the current level.
    pub(crate) fn last_start(&self) -> ForcedStart {
        start_at(self.curve.points.last().expect("two points"), self.solver())
    }

    /// The arc row of a step `h` along `tangent` (current level) from the last point.
    pub(crate) fn arc(&self, tangent: &[f64], h: f64) -> ArcRow {
        let last = self.last_start().state;
        let l = last.y.len();
        let parameter = self.curve.sweep.parameter();
        let mut predicted = OrbitState {
            y: last
                .y
                .iter()
                .zip(tangent)
                .map(|(y, t)| y + h * t * self.y_scale)
                .collect(),
            ..last.clone()
        };
        let p = last.parameter(parameter) + h * tangent[l] * self.p_scale;
        predicted.set_parameter(parameter, p);
        ArcRow {
            parameter,
            tangent_y: tangent[..l].to_vec(),
            tangent_parameter: tangent[l],
            predicted,
            y_scale: self.y_scale,
            parameter_scale: self.p_scale,
        }
    }

    /// Back to the base N when the last point is out of contact (its orbit is exact at any N):
    /// the tangent truncated to the base's size.
    fn settle_level(&mut self) {
        let last = self.curve.points.last().expect("two points");
        if self.level > 0 && !last.touches() {
            self.level = 0;
            self.tangent = resize_tangent(&self.tangent, self.rows(), self.terms());
        }
    }

    /// One accepted step, or the reason the smallest step failed.
    pub(crate) fn advance(&mut self) -> Result<(), String> {
        let mut tangent = self.tangent.clone();
        let exact = self.solver().integrates_exactly();
        let mut reason = String::from("no step tried");
        let mut grazing_tried = false;
        loop {
            if !exact
                && self.step < CORNER_STEP
                && (self.hop(tangent[tangent.len() - 1].signum()) || self.phase_hop())
            {
                self.step = CORNER_STEP;
                return Ok(());
            }
            if exact && self.step < GRAZING_STEP && !grazing_tried {
                grazing_tried = true;
                if self.pass_grazing() {
                    self.step = GRAZING_STEP.max(self.settings.min_step);
                    return Ok(());
                }
                // A passage that stopped short may still have pushed points (and moved N):
                // the steps go on from the new last point along its tangent.
                tangent = self.tangent.clone();
            }
            if self.step < self.settings.min_step {
                return Err(reason);
            }
            let arc = self.arc(&tangent, self.step);
            let start = ForcedStart {
                state: arc.predicted.clone(),
                multipliers: self.last_start().multipliers,
            };
            let judged = self
                .solver()
                .solve(start, Some(&arc))
                .map_err(|e| e.to_string())
                .and_then(|p| self.judge(&arc, &tangent, p));
            match judged {
                Ok((p, next, turn)) => {
                    let easy = p.newton_iterations <= 6 * p.inner_solves.max(1);
                    self.accept(p, &arc, next);
                    if easy && (!exact || turn < MAX_TURN / 3.0) {
                        self.step = (self.step * 1.5).min(self.settings.max_step);
                    }
                    return Ok(());
                }
                Err(why) => {
                    tracing::debug!(step = self.step, "forced response: step halved ({why})");
                    reason = why;
                    self.step *= 0.5;
                }
            }
        }
    }

    /// Whether the corrector's point `p` on `arc` is the next point of the curve (module
    /// docs): the point, its tangent and the turn from `tangent` when it is, why not otherwise.
    fn judge(
        &self,
        arc: &ArcRow,
        tangent: &[f64],
        p: ForcedPoint,
    ) -> Result<(ForcedPoint, Vec<f64>, f64), String> {
        let exact = self.solver().integrates_exactly();
        let reach = if exact { CORRECTOR_REACH } else { CORNER_REACH };
        let distance = self.corrector_distance(arc, &p);
        if distance > reach * self.step {
            return Err(format!(
                "the corrector lands {distance:.3e} from the prediction (step {:.3e}) at {:.6e} \
                 (W in rad/s, or the load scale)",
                self.step,
                self.curve.parameter(&p)
            ));
        }
        if self.phase_leaps(&p) {
            return Err("the first harmonic's phase turned by more than PHASE_REACH".into());
        }
        let next = self
            .solver()
            .tangent(&p, arc)
            .map_err(|e| format!("no tangent at the corrector's point: {e}"))?;
        let cos: f64 = next.iter().zip(tangent).map(|(a, b)| a * b).sum();
        let turn = cos.clamp(-1.0, 1.0).acos();
        if exact && turn > MAX_TURN {
            return Err(format!("the tangent turned by {turn:.3} rad in one step"));
        }
        Ok((p, next, turn))
    }

    /// Appends an accepted point: checked in N (the level follows), its tangent, a fold when
    /// the parameter's component of the tangent changed sign since the last point.
    pub(crate) fn accept(&mut self, p: ForcedPoint, arc: &ArcRow, next: Vec<f64>) {
        let (p, level) = self.ladder.converge(p, self.level, Some(arc));
        let rows = self.rows();
        let own = self.ladder.level_of(p.harmonics);
        let next = if own == self.level {
            next
        } else {
            // The point was replaced by its solve at another N: its tangent there.
            let solver = self.ladder.solver(own);
            let row = crate::ladder::resize_arc(arc, solver);
            solver
                .tangent(&p, &row)
                .unwrap_or_else(|_| resize_tangent(&next, rows, solver.basis().terms()))
        };
        self.level = level;
        let next = resize_tangent(&next, rows, self.terms());
        self.push(p, next);
        self.settle_level();
    }

    /// Pushes a point with its tangent, and the fold between it and the last point if any.
    pub(crate) fn push(&mut self, p: ForcedPoint, next: Vec<f64>) {
        let (before, after) = (self.tangent[self.tangent.len() - 1], next[next.len() - 1]);
        let last = self.curve.points.last().expect("two points");
        let ds = self.distance(last, &p);
        let (pa, pb) = (
            self.curve.parameter(last) / self.p_scale,
            self.curve.parameter(&p) / self.p_scale,
        );
        if let Some((u, at)) = fold_between((pa, before), (pb, after), ds) {
            let n = self.curve.points.len();
            self.curve.folds.push(Fold {
                point: if u < 0.5 { n - 1 } else { n },
                at: at * self.p_scale,
                kind: if before > 0.0 {
                    FoldKind::TurnsBack
                } else {
                    FoldKind::TurnsForward
                },
            });
        }
        self.curve.points.push(p);
        self.tangent = next;
    }

    /// Distance in the scaled space from the prediction of `arc` to the solution `p`.
    fn corrector_distance(&self, arc: &ArcRow, p: &ForcedPoint) -> f64 {
        let dy: f64 = p
            .contact
            .iter()
            .zip(&arc.predicted.y)
            .map(|(a, b)| ((a - b) / self.y_scale).powi(2))
            .sum();
        let dp = self.curve.parameter(p) - arc.predicted.parameter(arc.parameter);
        (dy + (dp / self.p_scale).powi(2)).sqrt()
    }

    /// Whether `p` lies across a resonance narrower than the step from the last point: both out
    /// of contact and the first harmonic's phase turned by more than `PHASE_REACH`. In contact
    /// the phase turns quickly along the curve too (linear steps only).
    fn phase_leaps(&self, p: &ForcedPoint) -> bool {
        let last = self.curve.points.last().expect("two points");
        if last.touches() || p.touches() {
            return false;
        }
        let row = phase_row(last, self.rows());
        let turn = phase(p, row, self.rows()) - phase(last, row, self.rows());
        wrap_angle(turn).abs() > PHASE_REACH
    }
}

/// A unit tangent re-expressed with `to` coefficients per contact row (padded or truncated) and
/// normalized again.
fn resize_tangent(t: &[f64], rows: usize, to: usize) -> Vec<f64> {
    let l = t.len() - 1;
    let from = l / rows.max(1);
    if from == to {
        return t.to_vec();
    }
    let mut v = resize_signals(&t[..l], rows, from, to);
    v.push(t[l]);
    let length = norm(&v);
    v.into_iter().map(|x| x / length).collect()
}

/// Euclidean norm.
pub(crate) fn norm(v: &[f64]) -> f64 {
    v.iter().map(|x| x * x).sum::<f64>().sqrt()
}

/// `angle` wrapped into (-pi, pi].
pub(crate) fn wrap_angle(angle: f64) -> f64 {
    use std::f64::consts::{PI, TAU};
    PI - (PI - angle).rem_euclid(TAU)
}

/// The contact coordinate whose first harmonic is largest at `p` (`rows` contact rows).
pub(crate) fn phase_row(p: &ForcedPoint, rows: usize) -> usize {
    (0..rows)
        .max_by(|&a, &b| amplitude(p, a, rows).total_cmp(&amplitude(p, b, rows)))
        .unwrap_or(0)
}

/// Amplitude of the first harmonic of contact coordinate `row` at `p`.
pub(crate) fn amplitude(p: &ForcedPoint, row: usize, rows: usize) -> f64 {
    let t = p.contact.len() / rows.max(1);
    let (ic, is) = (FullBasis::cos_index(1), FullBasis::sin_index(1));
    p.contact[row * t + ic].hypot(p.contact[row * t + is])
}

/// Phase (rad) of the first harmonic of contact coordinate `row` at `p`: a cos + b sin =
/// r cos(W t - phase).
pub(crate) fn phase(p: &ForcedPoint, row: usize, rows: usize) -> f64 {
    let t = p.contact.len() / rows.max(1);
    let (ic, is) = (FullBasis::cos_index(1), FullBasis::sin_index(1));
    p.contact[row * t + is].atan2(p.contact[row * t + ic])
}

impl FrfTrace<'_, '_, '_> {
    /// Steps until the far end of the range, the point limit, a failed step, a turn back past
    /// the near end, or (the trace from the end) a point that meets the first piece.
    pub(crate) fn run(&mut self, progress: &mut impl FnMut(&ForcedPoint)) {
        let d = self.direction;
        let (near, far) = if d > 0.0 {
            (self.settings.start, self.settings.end)
        } else {
            (self.settings.end, self.settings.start)
        };
        loop {
            let last = self
                .curve
                .parameter(self.curve.points.last().expect("points"));
            if d * (last - far) >= 0.0 {
                return;
            }
            if self.curve.points.len() >= self.settings.max_points {
                self.curve.termination = FrfTermination::PointLimit;
                return;
            }
            if let Err(reason) = self.advance() {
                self.curve.termination = FrfTermination::StepTooSmall { at: last, reason };
                return;
            }
            let newest = self.curve.points.last().expect("just pushed");
            if d * (self.curve.parameter(newest) - near) < 0.0 {
                self.curve.points.pop();
                let n = self.curve.points.len();
                self.curve.hops.retain(|&h| h < n);
                self.curve.folds.retain(|f| f.point < n);
                self.curve.termination = FrfTermination::LeftRange { at: last };
                return;
            }
            progress(newest);
            let x = self.scaled_base(newest);
            let met = self.meet.iter().any(|m| {
                norm(&m.iter().zip(&x).map(|(a, b)| a - b).collect::<Vec<_>>()) <= MEET_REACH
            });
            if met {
                let at = self.curve.parameter(newest);
                self.curve.termination = FrfTermination::Joined {
                    stopped: String::new(),
                    met: at,
                };
                return;
            }
        }
    }
}
