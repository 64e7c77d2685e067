//! One continuation step of a [`Trace`] (docs/DESIGN.md §8.2): the predictor along the tangent,
//! the corrector on the pseudo-arc-length row, step control and acceptance, the scaled branch
//! coordinates and the initial guesses extrapolated from the last points.

use super::{distance, normalize, Advance, Continuation, Trace};
use crate::point::BackbonePoint;
use crate::solver::Guess;
use nlmodes_hb::linear_model::ParameterRow;

/// A corrector is abandoned once an iterate of Algorithm 1 is more than `LEASH` times the
/// acceptance distance from its predictor in (q, w) (scaled): such a corrector is headed for a
/// point that would be rejected as far from the predictor (or behind it), and converging there
/// cost the default blade's passages 150-300 Newton iterations a time, for nothing.
pub(super) const LEASH: f64 = 3.0;

impl<'s, 'c, F: FnMut(&BackbonePoint)> Continuation<'s, 'c, F> {
    /// Predictor along the tangent, corrector on the arc-length row (a fixed-q row for the step
    /// that lands on q_max when `to_q_max`), step control.
    pub(super) fn advance(&mut self, trace: &mut Trace, to_q_max: bool) -> Advance {
        let xl = self.scaled(self.last_point(trace));
        let mut step = trace.ds;
        let final_step = to_q_max
            && trace.tangent[0] > 0.0
            && xl[0] + step * trace.tangent[0] >= self.cont.q_max;
        if final_step {
            step = (self.cont.q_max - xl[0]) / trace.tangent[0];
        }
        let pred: Vec<f64> = xl
            .iter()
            .zip(&trace.tangent)
            .map(|(x, t)| x + step * t)
            .collect();
        let mut guess = self.extrapolate(trace, &pred, step / trace.last_ds);
        if trace.penetrate && trace.points.len() == 1 {
            let s = 1.0 + step;
            guess
                .coefficients
                .iter_mut()
                .for_each(|c| c.iter_mut().for_each(|v| *v *= s));
        }
        let row = if final_step {
            ParameterRow::fixed_amplitude(self.cont.q_max * self.g_ref, self.g_ref, self.w_lin)
        } else {
            self.arc_row(&trace.tangent, &pred)
        };
        let shrunk = trace.ds * self.cont.shrink;
        // At the smallest step a far point is accepted as a jump, so it must be reached; the
        // first step from grazing may land O(step) away (below).
        let first_from_grazing = trace.penetrate && trace.points.len() == 1;
        let leash = (!final_step && !first_from_grazing && shrunk >= self.cont.min_step)
            .then_some(LEASH * self.cont.jump_factor * step);
        match self.solver.solve_with_row(row, guess, leash) {
            Err(e) => {
                tracing::debug!(step = trace.ds, error = %e, "continuation step failed");
                trace.ds = shrunk;
                if trace.ds < self.cont.min_step {
                    Advance::Stuck(e.to_string())
                } else {
                    Advance::Retry
                }
            }
            Ok(mut p) => {
                let xn = self.scaled(&p);
                if first_from_grazing {
                    // The row w = w_pred crosses the branch transversally (its tangent is not yet
                    // known), so the corrector may land O(step) away; only the trivial orbit
                    // (q -> 0, also a solution at any w) is refused.
                    if xn[0] < 0.5 * xl[0] {
                        trace.ds = shrunk;
                        return if trace.ds < self.cont.min_step {
                            Advance::Stuck("the first step from grazing found only u = 0".into())
                        } else {
                            Advance::Retry
                        };
                    }
                    return Advance::Converged(Box::new(p), xn, step);
                }
                let far = !final_step && distance(&xn, &pred) > self.cont.jump_factor * step;
                if far && shrunk >= self.cont.min_step {
                    tracing::debug!(step, "corrector far from the predictor: step shrunk");
                    trace.ds = shrunk;
                    return Advance::Retry;
                }
                p.jump = far;
                Advance::Converged(Box::new(p), xn, step)
            }
        }
    }

    /// Accepts a converged point on `trace`: fold flag, tangent = secant, step growth.
    pub(super) fn accept(
        &mut self,
        trace: &mut Trace,
        mut p: BackbonePoint,
        xn: &[f64],
        step: f64,
    ) {
        let xl = self.scaled(self.last_point(trace));
        let mut delta: Vec<f64> = xn.iter().zip(&xl).map(|(a, b)| a - b).collect();
        let len = normalize(&mut delta);
        if xn[0] != xl[0] {
            let sign = (xn[0] - xl[0]).signum();
            p.fold = trace.points.len() > 1 && sign != trace.dq_sign;
            if trace.points.len() == 1 {
                trace.dq_sign = sign;
            }
            if p.fold {
                trace.folds += 1;
                tracing::info!(
                    q_over_g0 = p.q / self.result.gap_reference,
                    omega_ratio = p.omega_ratio,
                    "turning point of q (fold) passed"
                );
            }
            trace.dq_sign = sign;
        }
        // Main-branch points that leave grazing toward smaller q, up to the first fold.
        p.pre_fold = trace.id == 1 && trace.folds == 0 && trace.dq_sign < 0.0 && !p.fold;
        if p.jump {
            tracing::debug!(
                q_over_g0 = p.q / self.result.gap_reference,
                omega_ratio = p.omega_ratio,
                "step at its minimum: accepted a jump"
            );
        }
        if len > 0.0 {
            trace.tangent = delta;
        }
        trace.last_ds = len.max(f64::MIN_POSITIVE).max(1e-3 * step);
        if p.jump {
            // Accepted at the smallest step (a corner of the sampled branch): restart the step.
            trace.ds = self.cont.step.min(self.cont.max_step);
        } else if p.newton_iterations <= self.cont.easy_iterations {
            trace.ds = (trace.ds * self.cont.growth).min(self.cont.max_step);
        }
        let index = self.push(p, trace.id);
        trace.points.push(index);
    }

    /// Scaled branch coordinates X = (q / g_ref, w / w_lin, y / (g_ref sqrt(c + 1))).
    pub(super) fn scaled(&self, p: &BackbonePoint) -> Vec<f64> {
        let mut x = vec![p.q / self.g_ref, p.omega / self.w_lin];
        let scale = self.g_ref * self.y_norm;
        x.extend(self.kept_coordinates(p).iter().map(|y| y / scale));
        x
    }

    /// Kept coordinates of a point: A_j u_n (signal-major, j (N+1) + n) then e_master . u_n.
    pub(super) fn kept_coordinates(&self, p: &BackbonePoint) -> Vec<f64> {
        let system = self.solver.system();
        let (c, nh) = (system.n_contacts(), self.solver.settings().terms());
        let mut y = vec![0.0; (c + 1) * nh];
        for (h, u) in p.coefficients.iter().enumerate().take(nh) {
            for j in 0..c {
                y[j * nh + h] = system.contact_displacement(j, u);
            }
            y[c * nh + h] = u[system.master()];
        }
        y
    }

    /// The pseudo-arc-length row t . (X - X_pred) = 0 in the solver's units.
    pub(super) fn arc_row(&self, tangent: &[f64], pred: &[f64]) -> ParameterRow {
        let (g, y) = (self.g_ref, self.y_norm);
        ParameterRow {
            a_q: tangent[0],
            a_w: tangent[1],
            a_y: tangent[2..].iter().map(|t| t / y).collect(),
            q_p: pred[0] * g,
            w_p: pred[1] * self.w_lin,
            y_p: pred[2..].iter().map(|v| v * g * y).collect(),
            q_scale: g,
            w_scale: self.w_lin,
            y_scale: g,
        }
    }

    /// Warm start at a predictor: the branch's last orbit scaled to the predicted amplitude, at
    /// the predicted frequency.
    pub(super) fn scaled_guess(&self, trace: &Trace, pred: &[f64]) -> Guess {
        let last = self.last_point(trace);
        let s = pred[0] * self.g_ref / last.q;
        let coefficients = last
            .coefficients
            .iter()
            .map(|c| c.iter().map(|v| v * s).collect())
            .collect();
        self.guess_at(last, coefficients, pred)
    }

    /// Warm start at a predictor: coefficients extrapolated along the secant from point `from`
    /// to the branch's last point (ratio = predicted step / secant length).
    pub(super) fn extrapolate_between(
        &self,
        from: usize,
        trace: &Trace,
        pred: &[f64],
        ratio: f64,
    ) -> Guess {
        let last = self.last_point(trace);
        let prev = &self.result.points[from];
        let coefficients = last
            .coefficients
            .iter()
            .zip(&prev.coefficients)
            .map(|(a, b)| a.iter().zip(b).map(|(x, y)| x + ratio * (x - y)).collect())
            .collect();
        self.guess_at(last, coefficients, pred)
    }

    /// Warm start at the predictor: coefficients extrapolated along the secant of the branch's
    /// last two points (ratio = predicted step / last step), or the last orbit scaled to the
    /// predicted amplitude on a one-point branch; theta and kappa of the last point.
    pub(super) fn extrapolate(&self, trace: &Trace, pred: &[f64], ratio: f64) -> Guess {
        let pts = &trace.points;
        if pts.len() >= 2 {
            self.extrapolate_between(pts[pts.len() - 2], trace, pred, ratio)
        } else {
            self.scaled_guess(trace, pred)
        }
    }

    /// The guess at predictor `pred` with `coefficients`, the mode and multipliers of `last`.
    pub(super) fn guess_at(
        &self,
        last: &BackbonePoint,
        coefficients: Vec<Vec<f64>>,
        pred: &[f64],
    ) -> Guess {
        Guess {
            mode: last.mode,
            coefficients,
            omega: pred[1] * self.w_lin,
            q: pred[0] * self.g_ref,
            multipliers: last.multipliers.clone(),
        }
    }
}
