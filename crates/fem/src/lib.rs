//! nlmodes-fem: the finite-element front end of nlmodes.
//!
//! - [`read_msh`]: gmsh MSH 4.1 files (ASCII or binary) into a [`Mesh`] of TET4 or TET10 with
//!   named physical groups of any dimension;
//! - [`element`]: isoparametric TET4/TET10 (curved mid-edge nodes allowed), linear isotropic
//!   elasticity ([`Isotropic`]), consistent mass and stiffness, quadrature chosen by tests;
//! - [`assemble`]: global K and M (sprs CSC, full symmetric storage), pattern built once,
//!   filled in parallel;
//! - [`DofMap`], [`fixed_dofs`], [`parse_fix_spec`]: Dirichlet conditions on named groups by
//!   DOF elimination (`root`, `bottom:z`, `root:xy`).
//!
//! - [`surface_load`]: consistent nodal forces of a uniform pressure on a surface group (TRI3 or
//!   curved TRI6 faces, oriented out of the solid), exact quadrature.
//!
//! - [`rotation`]: centrifugal load, spin softening, stress stiffness, Coriolis, the static
//!   centrifugal equilibrium (geometrically nonlinear or linearized) and the stiffness at speed.
//!
//! Units: SI throughout (m, Pa, kg/m^3; K in N/m, M in kg).

// Index loops mirror the index notation of the element formulas (J[d][k], B[i][j], ...).
#![allow(clippy::needless_range_loop)]

pub mod assembly;
pub mod dofs;
pub mod element;
pub mod error;
pub mod exact_mass;
mod gauss_jacobi;
pub mod generate;
pub mod geometry;
pub mod material;
pub mod mesh;
pub mod msh;
mod msh_sections;
pub mod quadrature;
pub mod rotation;
pub mod rule_choice;
pub mod shape;
pub mod surface_load;
mod tabulated_rule;
pub mod tet_kind;

pub use assembly::{assemble, NodeAdjacency};
pub use dofs::{fixed_dofs, parse_fix_spec, DofMap};
pub use error::FemError;
pub use material::{Isotropic, Lame};
pub use mesh::{Mesh, PhysicalGroup};
pub use msh::{parse_msh, read_msh};
pub use quadrature::TetRule;
pub use tet_kind::TetKind;
