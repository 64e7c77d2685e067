//! The massless contact boundary of nlmodes (docs/STABILITY.md Sec. 9; DESIGN §10.6): the linear
//! modes up to a cutoff stay dynamic, the others act on the contact rows through their residual
//! flexibility R, and the contact displacements carry no mass. No harmonic is truncated: the flow
//! of that model is solved exactly between contact switches, its periodic orbits are found by
//! shooting and their multipliers are the eigenvalues of their exact monodromy. It is the
//! reference the harmonic balance of `nlmodes-nnm` (free modes) and `nlmodes-forced` (forced
//! response) is checked against: their stability verdicts, their exact curves, the converged
//! orbit of each point and why holes stay between the exact backbone's pieces.
//!
//! ```text
//! q'' + C_q q' + W^2 q = Phi_k^T f(t) - B^T lambda,   u_c = B q + D(t) - R lambda,
//! 0 <= lambda _|_ g0 - u_c >= 0          (free model: C_q = 0, f = 0, D = 0)
//! ```
//!
//! Units: SI for SI models (q in m sqrt(kg), lambda in N, u_c and g0 in m, w in rad/s, t in s).
//!
//! | idea | modules |
//! |---|---|
//! | the model: kept modes, residual flexibility R, drive | `model` (free), `driven_model` (driven, built from a `System`, its damping and load) |
//! | the flow with exact switches | `free_flow` (symmetric pieces), `driven_flow` (augmented pieces), `switch_scan` (the one switch and grazing scan, the active set of a state) |
//! | shooting and the monodromy | `free_shooting` (rest at 0 and T/2), `driven_shooting` (x(T) = x(0), W free), `driven_stability` (a forced orbit's multipliers), `rk4` and `rk4_check` (the independent integration) |
//! | continuation of the exact curves | `arc_length` (the Moore-Penrose engine), `backbone_curve` and `exact_backbone` (the free backbone in pieces), `driven_curve` and `response_curve` (the forced response) |
//! | the converged orbits | `orbit_at_q` (the orbit at a point's own q), `converged` (N doubled until w and the contact shares settle) |
//! | the holes | `holes` (the pieces' edges followed through their tongues) |
//! | Fig. 4 on the boundary | `history` (the contact rows' displacement over a period) |
//!
//! The crate depends on the harmonic-balance engine `nlmodes-hb` only for its `System`, its
//! error type, the Fourier basis of forced orbits and the monodromy's verdict
//! (`floquet::multipliers_of`), and on `nlmodes-dense`; the problems on the engine
//! (`nlmodes-nnm`, `nlmodes-forced`) use it, never the other way round. A verdict on a free
//! orbit is the caller's rule ([`Judge`]): `nlmodes-nnm`'s for the shooting method.

mod arc_length;
mod backbone_curve;
mod contact_peak;
mod converged;
mod converged_cutoff;
mod driven_curve;
mod driven_flow;
mod driven_model;
mod driven_shooting;
mod driven_stability;
mod exact_backbone;
mod free_flow;
mod free_shooting;
mod history;
mod holes;
mod master_row;
mod model;
mod orbit_at_q;
mod response_curve;
pub mod rk4;
mod rk4_check;
mod structure_modes;
mod switch_scan;
#[cfg(test)]
mod test_models;

pub use arc_length::{CurveEnd, CurveSettings};
pub use backbone_curve::{BoundaryBackbonePoint, BoundaryPiece, Judge};
pub use contact_peak::{largest_contact_force, ContactPeak};
pub use converged::{converged_orbit, ConvergedOrbit, ConvergenceSettings, ConvergenceStop};
pub use converged_cutoff::{boundary_with_converged_cutoff, CutoffConvergence, CUTOFF_DOUBLINGS};
pub use driven_curve::driven_end_text;
pub use driven_model::{
    BoundaryDrive, DrivenBoundary, DrivenInputs, GapHarmonic, LoadHarmonic, BOUNDARY_CUTOFF,
};
pub use driven_stability::{boundary_monodromy, BoundaryMonodromy, BOUNDARY_SHIFT_LIMIT};
pub use exact_backbone::{exact_backbone, BoundaryBackbone, BranchStart};
pub use free_shooting::{exponents_of, shot_orbit, OrbitGuess, ShotOrbit, SHOOTING_SHIFT_LIMIT};
pub use history::{contact_history, BoundaryHistory};
pub use holes::{HoleFollow, HoleFollowEnd};
pub use master_row::MasterRow;
pub use model::{residual_sum, BoundaryModel, ModalData};
pub use orbit_at_q::ExactOrbitAtQ;
pub use response_curve::{boundary_curve, BoundaryCurve, BoundaryCurvePoint};
pub use rk4_check::{check_by_rk4, check_driven_by_rk4, ShootingCheck, SHOOTING_CHECK_LIMIT};
pub use structure_modes::StructureCache;
