//! Forced response of damped structures with frictionless unilateral contact, by harmonic
//! balance on the full Fourier basis with the exact contact of Algorithm 1 (Laxalde, Legrand &
//! Pierre 2009) or a penalty law, on the engine `nlmodes-hb` (DESIGN §10).
//!
//! The equation of motion M u'' + C u' + K u + A^T lambda = f(t), with f(t) harmonic in the
//! excitation frequency W ([`Load`]) and C from [`Damping`], is balanced on
//! u(t) = u_0 + sum_n (a_n cos nWt + b_n sin nWt) (`nlmodes_hb::FullBasis`). The structure is
//! condensed exactly onto the contact coordinates ([`ModalDynamics`], modal coordinates of the
//! whole reduced model), the contact law is sampled on m points per period (AFT), and the
//! augmented-Lagrangian multipliers are driven by the engine's Algorithm 1 through
//! `InnerSolves`: one implementation of the law, the measure and the updates for free and forced
//! motion. Units: SI for SI matrices (W in rad/s, forces in N, damping in N s/m).
//!
//! Entry points: [`ForcedSolver`] (one orbit at W, or on an arc-length row),
//! [`response_curve`] (the curve over a frequency range, or over the load at a fixed
//! frequency, through its folds), [`speed_sweep`] (the response along the rotation speed at
//! an engine order, the structure following the speed), [`synthesize`]
//! (the backbone's prediction: nonlinear modal damping and single-mode synthesis).

mod active_jacobian;
mod boundary;
mod casing_sweep;
mod compliance;
mod corner;
mod curve;
mod curve_harmonics;
mod curve_stability;
mod damping;
mod distortion;
mod dynamics;
mod error;
mod exact_force;
mod fold;
mod following;
mod frf;
mod grazing;
mod harmonic_check;
mod ladder;
mod load;
mod newton;
mod orbit_origin;
mod period_check;
mod point_stability;
mod raise_frequency;
mod raise_speed;
mod raised_segments;
mod settled_stability;
mod solver;
#[cfg(test)]
mod speed_column_check;
mod speed_curve;
mod speed_grazing;
mod speed_harmonics;
mod speed_step;
mod speed_sweep;
mod synthesis;
mod trace;

pub use boundary::boundary_curve;
pub use boundary::{
    boundary_monodromy, BoundaryInputs, BoundaryMonodromy, BOUNDARY_CUTOFF, BOUNDARY_SHIFT_LIMIT,
};
pub use casing_sweep::{
    casing_sweep, largest_force, CasingPoint, CasingSweep, CasingSweepSettings,
};
pub use compliance::ContactCompliance;
pub use curve::{
    CurveHarmonics, ExactForce, Fold, FoldKind, ForceCheck, FrequencyResponse, FrfSettings,
    FrfTermination, HarmonicPolicy, RaisedRound, RaisedSegments, Sweep,
};
pub use damping::{check_semidefinite, modal_ratios, Damping, SEMIDEFINITE_TOLERANCE};
pub use distortion::CasingDistortion;
pub use dynamics::ModalDynamics;
pub use error::ForcedError;
pub use following::MovingStructure;
pub use frf::response_curve;
pub use harmonic_check::HarmonicCheck;
pub use load::{HarmonicLoad, Load};
pub use newton::{ArcRow, OrbitState, Parameter};
pub use nlmodes_boundary::{BoundaryCurve, BoundaryCurvePoint};
pub use nlmodes_hb::floquet::Verdict;
pub use point_stability::{ForcedBifurcation, PointStability};
pub use solver::{FollowingSolve, ForcedPoint, ForcedSettings, ForcedSolver, ForcedStart};
pub use speed_curve::{LobedCasing, SpeedHarmonics, SpeedPoint, SpeedSweepSettings};
pub use speed_harmonics::speed_sweep;
pub use speed_step::{SpeedFamily, SpeedProblem};
pub use speed_sweep::{SpeedFold, SpeedSweep};
pub use synthesis::{
    check_orbits, nonlinear_damping_ratio, synthesize, synthesized_peak, FreeOrbit,
    SynthesizedPoint,
};
