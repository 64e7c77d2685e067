//! Rotation physics of the finite elements (issue 23; DESIGN §9): centrifugal load following
//! the deformation, spin softening, stress stiffness, total-Lagrangian St Venant-Kirchhoff
//! internal force and tangent, Coriolis; their global assembly; the static centrifugal
//! equilibrium (geometrically nonlinear or linearized); the stiffness at speed K(Omega); the
//! prestress outputs; the prestressed structure at a speed with its contact nodes' radial growth,
//! running gaps, closure speed and root stress ([`prestress_at_speed`]).
//!
//! Small vibrations about the prestressed state in the rotating frame (DESIGN §9):
//! M u'' + G u' + K(Omega) u = f, K(Omega) = K_T(u0) - Omega^2 M_spin
//! ([`RotatingModel::stiffness_at_speed`]), G the Coriolis matrix
//! ([`RotatingModel::coriolis_matrix`]). Rotation about the axis through p along the unit a,
//! P = I - a a^T ([`RotorAxis`]). Units: SI (m, Pa, kg/m^3, rad/s; loads in N, stiffness in
//! N/m, M_spin in kg, G in kg/s). Verification: `docs/ROTATION.md` and the tests
//! `crates/fem/tests/rotation_*.rs`.

pub mod at_speed;
pub mod axis;
pub mod centrifugal;
pub mod element_ref;
pub mod error;
pub mod global;
pub mod model;
pub mod newton;
pub mod points;
pub mod prestress;
pub mod speed_march;
pub mod static_solve;
pub mod stress_stiffness;
pub mod total_lagrangian;

pub use at_speed::{
    closure_speed, prestress_at_speed, prestress_at_speed_from, radial_growth, Prestress,
    SpeedProblem,
};
pub use axis::{Mat3, RotorAxis};
pub use centrifugal::{
    centrifugal_load_element, centrifugal_load_from_spin_matrix, coriolis_element,
    spin_softening_element,
};
pub use element_ref::ElementRef;
pub use error::{NewtonIteration, RotationError, StopReason};
pub use global::BlockPattern;
pub use model::{ResidualAndTangent, RotatingModel, StressField};
/// The linear solve of the Newton steps (`nlmodes-sparse`: its sparse Cholesky, LU, or the
/// caller's own).
pub use nlmodes_sparse::{LinearSolveError, LinearSolver};
pub use points::PointGeometry;
pub use prestress::{max_over_nodes, von_mises};
pub use static_solve::{Kinematics, LoadStep, NewtonOptions, StaticSolution};
pub use stress_stiffness::{linear_stress_at, stress_stiffness_element, svk_stress};
pub use total_lagrangian::{
    cauchy_stress, deformation_gradient, displacement_gradient, green_lagrange,
    internal_force_and_tangent_element,
};
