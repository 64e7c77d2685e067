//! The passage of the main branch past a tongue or a corner (docs/DESIGN.md §8.3): secant and
//! tangent predictors beyond it, fixed-q hops as the last resort, and the fill-back from the
//! landing point toward the tongue.

use super::step::LEASH;
use super::{distance, normalize, Advance, Continuation, Trace};
use crate::continuation::Passage;
use crate::point::BackbonePoint;
use crate::solver::Start;

/// Smallest base distance (scaled arc length, i.e. about g_ref in q) of the predictors and hops
/// past a tongue: a tongue's width does not scale with the continuation step, so neither may the
/// distance tried to get past it (with step = 0.05 the passes would otherwise stay inside it).
const PASS_BASE: f64 = 0.25;

/// Predictors on the local tangent past a tongue (at 2, 4, ... 2^TANGENT_PASSES x the base
/// distance).
const TANGENT_PASSES: u32 = 5;

/// Fixed-q hops past a tongue, at 1, 2, ... 2^(HOPS - 1) x the base distance ahead (capped at
/// q_max, which is tried last).
const HOPS: u32 = 8;

/// Predictors on the secant past a tongue, at 1.5^k x the base distance, k = 1 ..= SECANT_PASSES
/// (0.375 to 9.6 g_ref from the smallest base).
const SECANT_PASSES: u32 = 8;

/// Points at most traced backwards from the landing point past a tongue toward it.
const BACKFILL_POINTS: usize = 200;

/// Span of q (in g_ref) over which the main branch's direction before a tongue is taken.
const PASS_SPAN: f64 = 1.0;

impl<'s, 'c, F: FnMut(&BackbonePoint)> Continuation<'s, 'c, F> {
    /// Continues the main branch past a tongue by branch switching (docs/DESIGN.md §8.3), from
    /// its last point where q was still rising:
    /// 1. predictors on its local tangent at base 2^k ahead (k = 1..=5), each corrected on the
    ///    arc-length row there, kept when out of the tongue, ahead in q and near the predictor;
    /// 2. predictors on its secant over its last `PASS_SPAN` g_ref of q (its direction before the
    ///    interaction bent it: near a tongue the local tangent can turn toward the tongue, and
    ///    the row normal to it lets the corrector slide down the tongue to q -> 0), at base
    ///    1.5^k ahead (k = 1..=9), kept when near the predictor in (q, w) (across a tongue the
    ///    orbit's shape changes more than its amplitude and frequency);
    /// 3. as the last resort, fixed-q hops.
    ///
    /// A predictor's point is then filled back toward the tongue ([`Self::land_past`]).
    pub(super) fn step_past(&mut self, main: &mut Trace) -> Option<Passage> {
        self.roll_back_to_ascent(main);
        let base = main.last_ds.max(PASS_BASE);
        let (from, secant) = self.pass_secant(main);
        let growing = (1..=SECANT_PASSES).map(|k| base * 1.5f64.powi(k as i32));
        if self.predict_past(main, Some(from), &secant, growing) {
            return Some(Passage::Predictor);
        }
        let tangent = main.tangent.clone();
        let doubling = (1..=TANGENT_PASSES).map(|k| base * f64::from(1u32 << k));
        if self.predict_past(main, None, &tangent, doubling) {
            return Some(Passage::Predictor);
        }
        if self.hop_past(main) {
            tracing::info!(
                q_over_g0 = self.last_point(main).q / self.g_ref,
                "no predictor got past the tongue: hopped ahead at fixed q"
            );
            return Some(Passage::FixedQHop);
        }
        None
    }

    /// Predictors along `direction` at the distances `steps` beyond the main branch's last
    /// point, each corrected on the arc-length row normal to `direction`; the first acceptable
    /// one is landed on ([`Self::land_past`]). `from`: the secant's first point (the guess is
    /// extrapolated along the secant and nearness judged in (q, w)), or None for the local
    /// tangent (the guess from the last two points, nearness in the whole scaled space).
    pub(super) fn predict_past(
        &mut self,
        main: &mut Trace,
        from: Option<usize>,
        direction: &[f64],
        steps: impl Iterator<Item = f64>,
    ) -> bool {
        let xl = self.scaled(self.last_point(main));
        for step in steps {
            let pred: Vec<f64> = xl
                .iter()
                .zip(direction)
                .map(|(x, t)| x + step * t)
                .collect();
            if pred[0] >= self.cont.q_max {
                break;
            }
            let mut guesses = vec![match from {
                Some(f) => {
                    let span = distance(&xl, &self.scaled(&self.result.points[f]));
                    self.extrapolate_between(f, main, &pred, step / span)
                }
                None => self.extrapolate(main, &pred, step / main.last_ds),
            }];
            if from.is_some() {
                // Far from the branch the secant extrapolation of the orbit may be poor: the
                // last orbit scaled to the predicted amplitude is the second guess.
                guesses.push(self.scaled_guess(main, &pred));
            }
            for guess in guesses {
                let row = self.arc_row(direction, &pred);
                match self.solver.solve_with_row(row, guess, Some(LEASH * step)) {
                    Ok(p) => {
                        let xn = self.scaled(&p);
                        let ahead = xn[0] > xl[0] && xn[0] <= self.cont.q_max;
                        let dims = if from.is_some() { 2 } else { xn.len() };
                        let near = distance(&xn[..dims], &pred[..dims]) <= step;
                        if ahead && near && Self::on_the_traced_mode(&p) {
                            self.land_past(main, p, direction, &xl);
                            return true;
                        }
                        tracing::debug!(
                            q_over_g0 = p.q / self.result.gap_reference,
                            omega_ratio = p.omega_ratio,
                            ahead,
                            near,
                            step,
                            secondary_share = p.secondary_share,
                            primary_share = p.primary_share,
                            "predictor past the tongue rejected (behind, far, or not on the traced mode)"
                        );
                    }
                    Err(e) => {
                        tracing::debug!(step, error = %e, "predictor past the tongue failed")
                    }
                }
            }
        }
        false
    }

    /// Lands the main branch on `p` past a tongue, after filling the stretch between the tongue
    /// and `p`: the branch is traced backwards from `p` (against `direction`) until it comes
    /// within a step of `top` in (q, w) (the scaled last rising point before the tongue: the two
    /// pieces meet), turns in q, enters the tongue or stops, so that what the main branch is past
    /// the tongue does not depend on how far the predictor that found it reached. When the
    /// pieces do not meet, the q interval left between them and why are recorded
    /// (`self.unjoined`, then `InternalResonance::unjoined`). The filled points join the main
    /// branch in rising order.
    pub(super) fn land_past(
        &mut self,
        main: &mut Trace,
        p: BackbonePoint,
        direction: &[f64],
        top: &[f64],
    ) {
        let start = self.result.points.len();
        let q_before = self.last_point(main).q;
        self.push(p, main.id);
        let mut back = Trace {
            id: main.id,
            points: vec![start],
            tangent: direction.iter().map(|t| -t).collect(),
            ds: self.cont.step.min(self.cont.max_step),
            last_ds: self.cont.step.min(self.cont.max_step),
            dq_sign: -1.0,
            // Not the pre-fold stretch after grazing (`accept` flags that on the main branch).
            folds: 1,
            penetrate: false,
        };
        let mut stop = "the point limit";
        let mut met = false;
        for _ in 0..BACKFILL_POINTS {
            let (p, xn, step) = match self.advance(&mut back, false) {
                Advance::Retry => continue,
                Advance::Stuck(_) => {
                    stop = "no converged step";
                    break;
                }
                Advance::Converged(p, xn, step) => (p, xn, step),
            };
            let xl = self.scaled(self.last_point(&back));
            let why = if xn[0] >= xl[0] {
                Some("it turns in q")
            } else if distance(&xn[..2], &top[..2]) <= step.max(PASS_BASE) {
                met = true;
                Some("it met the branch before the tongue")
            } else if xn[0] <= 0.0 {
                Some("q <= 0")
            } else if self.cont.tongue(&p, &self.omegas).is_some() {
                // Going on through orbits the tongue test flags closes the hole on the default
                // blade but lands on another sheet of the multi-valued stretch in a step-dependent
                // way (penalty kc = 1e8: 16 % of a coarse run's points 1e-2 off the dense run);
                // see DESIGN §8.3.
                Some("it enters the tongue")
            } else {
                None
            };
            if let Some(why) = why {
                stop = why;
                break;
            }
            self.accept(&mut back, *p, &xn, step);
        }
        let q_low = self.last_point(&back).q;
        tracing::info!(
            q_over_g0 = q_low / self.g_ref,
            "fill-back toward the tongue stopped: {stop}"
        );
        self.unjoined = (!met).then(|| ([q_before, q_low], stop.to_string()));
        // Reorder [p, b1, ..., bk] into [bk, ..., b1, p] (rising q) at the end of the points.
        let mut filled = self.result.points.split_off(start);
        filled.reverse();
        for f in &mut filled {
            f.fold = false;
        }
        let count = filled.len();
        self.result.points.extend(filled);
        main.points.extend(start..start + count);
        let n = main.points.len();
        let a = self.scaled(&self.result.points[main.points[n - 2]]);
        let b = self.scaled(&self.result.points[main.points[n - 1]]);
        let mut t: Vec<f64> = b.iter().zip(&a).map(|(x, y)| x - y).collect();
        let len = normalize(&mut t);
        main.tangent = if count > 1 { t } else { direction.to_vec() };
        main.last_ds = if count > 1 {
            len.max(1e-3)
        } else {
            self.cont.step
        };
        main.dq_sign = 1.0;
        main.ds = self.cont.step.min(self.cont.max_step);
        if count > 1 {
            tracing::info!(
                points = count - 1,
                q_over_g0 = self.result.points[start].q / self.g_ref,
                "main branch past the tongue filled back toward it"
            );
        }
    }

    /// The main-branch point about `PASS_SPAN` g_ref of q below its last point (or its first
    /// point) and the unit secant from it to the last point, in the scaled space.
    pub(super) fn pass_secant(&self, main: &Trace) -> (usize, Vec<f64>) {
        let last = self.last_point(main);
        let q_from = last.q / self.g_ref - PASS_SPAN;
        let from = main.points[..main.points.len() - 1]
            .iter()
            .rev()
            .copied()
            .find(|&i| self.result.points[i].q / self.g_ref <= q_from)
            .unwrap_or(main.points[0]);
        let xl = self.scaled(last);
        let mut t: Vec<f64> = xl
            .iter()
            .zip(self.scaled(&self.result.points[from]))
            .map(|(a, b)| a - b)
            .collect();
        if normalize(&mut t) == 0.0 {
            return (from, main.tangent.clone());
        }
        (from, t)
    }

    /// Last resort past a tongue: fixed-q solves ahead of the last ascending point, at q + base
    /// 2^k g_ref (k < HOPS, the last at q_max), warm-started from it, then from the linear mode
    /// scaled to q (with the solver's penalty homotopy). The point reached is flagged as a jump
    /// (explained by the tongue recorded in `Backbone::internal_resonances`) and the branch is
    /// filled back from it toward the tongue ([`Self::land_past`]).
    pub(super) fn hop_past(&mut self, main: &mut Trace) -> bool {
        let last = self.last_point(main).clone();
        let xl = self.scaled(&last);
        let base = main.last_ds.max(PASS_BASE);
        let mut previous = last.q / self.g_ref;
        for k in 0..HOPS {
            let q = (last.q / self.g_ref + base * f64::from(1u32 << k)).min(self.cont.q_max);
            if q <= previous {
                break;
            }
            previous = q;
            for start in [Start::Point(&last), Start::LinearMode(last.mode)] {
                match self.solver.solve_point(q * self.g_ref, start) {
                    Ok(mut p) if Self::on_the_traced_mode(&p) => {
                        p.jump = true;
                        let mut along_q = vec![0.0; xl.len()];
                        along_q[0] = 1.0;
                        self.land_past(main, p, &along_q, &xl);
                        return true;
                    }
                    Ok(p) => tracing::debug!(
                        q_over_g0 = p.q / self.result.gap_reference,
                        "hop landed in a tongue or on another mode"
                    ),
                    Err(e) => tracing::debug!(
                        q_over_g0 = q / self.result.gap_reference,
                        error = %e,
                        "hop failed"
                    ),
                }
            }
        }
        false
    }

    /// A landing past a tongue continues the traced mode's branch when no other component holds
    /// more of its energy than the traced mode's fundamental: neither another mode's harmonic
    /// n >= 2 (still in a tongue, however far from resonance: a landing is a jump, and a distorted
    /// orbit is accepted only where the branch leads to it continuously) nor any component n = 0,
    /// 1 (a passage must not land on another mode's family: on the 3-DOF chain of
    /// `tests/passage_guard.rs`, a predictor converged on the second mode's backbone, 92 % of the
    /// energy in its fundamental).
    fn on_the_traced_mode(p: &BackbonePoint) -> bool {
        p.secondary_share <= p.primary_share
    }

    /// A main branch may turn back in q as it enters a tongue, before the energy shares show it:
    /// continue past the tongue from the last point where q was still rising, along the secant
    /// that reached it (the points after it stay on the output, flagged by their fold).
    pub(super) fn roll_back_to_ascent(&self, main: &mut Trace) {
        let pts = &main.points;
        let Some(top) = (1..pts.len())
            .rev()
            .find(|&i| self.result.points[pts[i]].q > self.result.points[pts[i - 1]].q)
        else {
            return;
        };
        if top + 1 == pts.len() {
            return;
        }
        let a = self.scaled(&self.result.points[pts[top - 1]]);
        let b = self.scaled(&self.result.points[pts[top]]);
        let mut t: Vec<f64> = b.iter().zip(&a).map(|(x, y)| x - y).collect();
        let len = normalize(&mut t);
        main.points.truncate(top + 1);
        main.tangent = t;
        main.last_ds = len.max(f64::MIN_POSITIVE);
        main.dq_sign = 1.0;
    }
}
