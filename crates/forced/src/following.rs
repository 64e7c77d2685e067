//! A structure that moves with W in the inner Newton solve (`newton`): on a speed sweep's row
//! W = e Omega the condensed structure and the running gaps are those at the speed W / e
//! (DESIGN §10.10), linearized in W around the structure where a run starts.

use crate::dynamics::ModalDynamics;
use crate::error::ForcedError;

/// A structure that moves with W: on a speed sweep's row W = e Omega, the condensed structure
/// and the running gaps are those at the speed W / e (DESIGN §10.10).
pub trait MovingStructure: Sync {
    /// The condensed structure (on the solve's basis) and the gaps g0 (length unit) at W (rad/s).
    fn at(&self, omega: f64) -> Result<(ModalDynamics, Vec<f64>), ForcedError>;
}

/// Relative step in W of the difference that gives the structure's motion with W
/// (`Following`): the structures at W_s and (1 - `STRUCTURE_STEP`) W_s. Its O(step) error and
/// the round-off of two eigen-solves over that step (about 1e-13 / 1e-6) only enter the
/// linearization, which the next run (`ForcedSolver::solve_following`) removes.
pub(crate) const STRUCTURE_STEP: f64 = 1e-6;

/// A structure following W in an inner solve (`MovingStructure`), linearized in W around the
/// structure S_s at W_s (the first W the solve asks for):
///
///   R(y, W) = y - c - y_lin(W, Lambda; S_s) - (W - W_s) D(W, Lambda),
///   Lambda = Lambda(y; g0_s + (W - W_s) dg0/dW),
///
/// with D = d y_lin/dS dS/dW and dg0/dW the difference of the structures at W_s and W_s + h.
/// One structure per run, not one per iterate: each eigen-solve of the structure carries its
/// own round-off, and R on structures built at W and W (1 + 1e-12) differs by more than the
/// Newton tolerance near resonance under the stiff penalty law (measured on the default
/// blade: the residual stalls at 1e-10 to 6e-10 g0). R is smooth in (y, W) and exact at W_s;
/// at the converged W its error is the linearization's, O((W - W_s)^2), which a run from there
/// on the structure at that W removes (`ForcedSolver::solve_following`).
pub struct Following<'p> {
    pub(crate) structure: &'p dyn MovingStructure,
    /// S_s, S(W_s + h), W_s and h (rad/s), once built.
    pub(crate) built: Option<StructurePair>,
}

/// The structures at W_s and W_s + h of `Following`.
pub(crate) struct StructurePair {
    pub(crate) omega: f64,
    pub(crate) a: (ModalDynamics, Vec<f64>),
    pub(crate) b: (ModalDynamics, Vec<f64>),
    pub(crate) h: f64,
}

impl StructurePair {
    /// The gaps at W: g0_s + (W - W_s) dg0/dW.
    pub(crate) fn gaps_at(&self, omega: f64) -> Vec<f64> {
        let shift = (omega - self.omega) / self.h;
        (self.a.1.iter().zip(&self.b.1))
            .map(|(a, b)| a + shift * (b - a))
            .collect()
    }
}

impl<'p> Following<'p> {
    /// `structure`, not evaluated yet.
    pub fn new(structure: &'p dyn MovingStructure) -> Self {
        Self {
            structure,
            built: None,
        }
    }

    /// W_s (rad/s): where the structure was built (`None` before any evaluation).
    pub fn structure_omega(&self) -> Option<f64> {
        self.built.as_ref().map(|b| b.omega)
    }
}
