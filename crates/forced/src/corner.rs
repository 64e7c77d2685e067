//! Passing the corners of the sampled augmented-Lagrangian law (DESIGN §10.5): where a sample
//! enters contact on a coordinate with mass the curve turns by a finite angle, and next to a
//! lightly damped resonance tip the rising and returning branches meet at nearly 180 degrees.
//! Below `CORNER_STEP` the continuation hops: at a fixed parameter a little further on, or at a
//! fixed phase lag a little larger. The exactly integrated penalty law has no corners and never
//! hops.

use crate::curve::Sweep;
use crate::ladder::start_at;
use crate::newton::{ArcRow, OrbitState, Parameter};
use crate::solver::{ForcedPoint, ForcedStart};
use crate::trace::{amplitude, norm, phase, phase_row, wrap_angle, FrfTrace};
use nlmodes_hb::FullBasis;

/// How far (scaled distance) a hop at fixed phase may land from the last orbit: past a corner
/// of the resonance tip the returning branch is that close; farther, the hop has skipped along
/// a branch on which the phase hardly turns (the middle branch of a stiff resonance, which
/// hugs the backbone at a lag near pi/2: on the light 2-DOF chain a lag 0.01 rad larger than
/// the tip's lies at W / w1 = 1.008, against 1.131 at the tip).
const PHASE_HOP_REACH: f64 = 0.02;

/// How far (in scaled distance, as a multiple of the hop's dW) a hop may land from the last
/// orbit: a corner turns the curve, it does not displace it.
const HOP_REACH: f64 = 20.0;

impl FrfTrace<'_, '_, '_> {
    /// Solves at a fixed parameter p_k + `direction` dp from the last orbit for growing dp
    /// (1e-4, 1e-3, 5e-3 p_ref) and keeps the first that converges within `HOP_REACH` dp,
    /// flagged as a hop (`FrequencyResponse::hops`). Returns whether one did.
    pub(crate) fn hop(&mut self, direction: f64) -> bool {
        let last = self.curve.points.last().expect("two points").clone();
        for dw in [1e-4, 1e-3, 5e-3] {
            let mut start = self.last_start();
            let p = self.curve.parameter(&last) + direction * dw * self.p_scale;
            start.state.set_parameter(self.curve.sweep.parameter(), p);
            let landed = self.solver().solve(start, None).ok().filter(|p| {
                // A hop stays on the curve: within a few dW of the last orbit, never on another
                // branch (the small orbit out of contact, say).
                self.distance(p, &last) <= HOP_REACH * dw
            });
            if let Some(p) = landed {
                tracing::debug!(
                    omega = p.omega,
                    "forced response: hop at fixed W past a corner"
                );
                if self.push_hop(p) {
                    return true;
                }
            }
        }
        false
    }

    /// A corner at the resonance tip: solves with the phase lag of the first harmonic of the
    /// contact coordinate that moves most fixed a little further than the last orbit's, W free,
    /// for growing steps (1e-4 .. 1e-2 rad), the first that lands within `PHASE_HOP_REACH` of
    /// the last orbit with the lag grown kept. The direction is physical, not read from the
    /// last steps: driven at W, the response lags the force by a phase that grows along a
    /// resonance through both of its folds (0 below it, pi/2 at phase resonance, towards pi
    /// past it), so a larger lag is always forward on the curve. Only for a frequency sweep
    /// under a force at the first harmonic. The point is flagged as a hop.
    pub(crate) fn phase_hop(&mut self) -> bool {
        let first_harmonic_force = self
            .solver()
            .load()
            .harmonics
            .iter()
            .all(|h| h.harmonic == 1);
        if self.curve.sweep != Sweep::Frequency || !first_harmonic_force {
            return false;
        }
        let last = self.curve.points.last().expect("two points").clone();
        let rows = self.solver().system().n_contacts();
        let row = phase_row(&last, rows);
        let (lag, size) = (phase(&last, row, rows), amplitude(&last, row, rows));
        for dphi in [1e-4, 3e-4, 1e-3, 3e-3, 1e-2] {
            let arc = self.phase_row_arc(row, lag + self.direction * dphi, size);
            let start = ForcedStart {
                state: arc.predicted.clone(),
                multipliers: self.last_start().multipliers,
            };
            let landed = self.solver().solve(start, Some(&arc)).ok().filter(|p| {
                let turn = wrap_angle(phase(p, row, rows) - lag);
                let distance = self.distance(p, &last);
                tracing::debug!(omega = p.omega, dphi, turn, distance, "phase hop landed");
                turn * self.direction > 0.0 && distance <= PHASE_HOP_REACH
            });
            if let Some(p) = landed {
                tracing::debug!(omega = p.omega, dphi, "forced response: hop at fixed phase");
                if self.push_hop(p) {
                    return true;
                }
            }
        }
        false
    }

    /// Pushes a hop's point with its tangent oriented along the hop; false when the tangent
    /// cannot be solved for (the hop is then not taken).
    fn push_hop(&mut self, p: ForcedPoint) -> bool {
        let last = self.curve.points.last().expect("two points");
        let (a, b) = (self.scaled(last), self.scaled(&p));
        let d: Vec<f64> = b.iter().zip(&a).map(|(x, y)| x - y).collect();
        let length = norm(&d);
        if length.is_nan() || length <= 0.0 {
            return false;
        }
        let along = self.arc(&d.iter().map(|v| v / length).collect::<Vec<_>>(), 0.0);
        let Ok(next) = self.solver().tangent(&p, &along) else {
            return false;
        };
        self.push(p, next);
        self.curve.hops.push(self.curve.points.len() - 1);
        true
    }

    /// The row "phase lag of contact coordinate `row`'s first harmonic = `lag`" (the first
    /// harmonic a cos + b sin held on the line -sin(lag) a + cos(lag) b = 0, W free), with the
    /// last orbit rotated to that lag as its prediction.
    fn phase_row_arc(&self, row: usize, lag: f64, size: f64) -> ArcRow {
        let last = start_at(self.curve.points.last().expect("two points"), self.solver());
        let t = self.solver().basis().terms();
        let (ic, is) = (FullBasis::cos_index(1), FullBasis::sin_index(1));
        let mut tangent_y = vec![0.0; last.state.y.len()];
        tangent_y[row * t + ic] = -lag.sin();
        tangent_y[row * t + is] = lag.cos();
        let mut predicted = OrbitState { ..last.state };
        predicted.y[row * t + ic] = size * lag.cos();
        predicted.y[row * t + is] = size * lag.sin();
        ArcRow {
            parameter: Parameter::Frequency,
            tangent_y,
            tangent_parameter: 0.0,
            predicted,
            y_scale: self.y_scale,
            parameter_scale: self.p_scale,
        }
    }
}
