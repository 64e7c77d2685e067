//! The finite-element stages over MPI with the engines HPC users know: PETSc matrices
//! assembled in parallel over a METIS partition (or assembled on rank 0 and sent by rows: the
//! blade at speed, [`Operators`]), static solves by MUMPS, eigenproblems by the serial path's
//! shift-invert block Lanczos on MUMPS block solves or by SLEPc's Krylov-Schur
//! ([`pencil::nearest_modes`]). docs/LARGE_MODELS.md, "Over MPI", describes the path and its
//! measured scaling.
//!
//! The binary starts a [`Session`] only when an MPI launcher started it ([`launch_variable`]);
//! without one nothing here runs and the serial path is untouched. Rank 0 runs the command and
//! hands each distributed computation to the other ranks (`crew`: they wait for its tasks);
//! rank 0 gets the results (the [`nlmodes_modal::CraigBampton`] of the serial path, or the full
//! model's [`nlmodes_modal::Modes`]) and writes them; an error on any rank ends every rank
//! ([`abort_if_parallel`]).
//!
//! Without the `petsc` feature the crate is a stub: [`start`] reports
//! [`DistributedError::NotBuilt`] under an MPI launcher and does nothing otherwise.

pub mod error;
pub mod launch;

pub use error::{DistributedError, Result};
pub use launch::{launch_variable, World};

#[cfg(feature = "petsc")]
mod ffi {
    #![allow(
        non_upper_case_globals,
        non_camel_case_types,
        non_snake_case,
        dead_code,
        clippy::all
    )]
    include!(concat!(env!("OUT_DIR"), "/petsc_bindings.rs"));
}

#[cfg(feature = "petsc")]
mod assembly;
#[cfg(feature = "petsc")]
mod block_eigen;
#[cfg(feature = "petsc")]
pub mod bridge;
#[cfg(feature = "petsc")]
mod collective;
#[cfg(feature = "petsc")]
pub mod crew;
#[cfg(feature = "petsc")]
pub mod eigen;
#[cfg(feature = "petsc")]
mod finish;
#[cfg(feature = "petsc")]
pub mod layout;
#[cfg(feature = "petsc")]
mod modes;
#[cfg(feature = "petsc")]
mod operators;
#[cfg(feature = "petsc")]
pub mod pencil;
#[cfg(feature = "petsc")]
pub mod petsc;
#[cfg(feature = "petsc")]
pub mod reduction;
#[cfg(feature = "petsc")]
pub mod restricted;
#[cfg(feature = "petsc")]
mod session;
#[cfg(feature = "petsc")]
pub mod static_solve;

#[cfg(feature = "petsc")]
pub use assembly::assemble;
#[cfg(feature = "petsc")]
pub use crew::abort_if_parallel;
#[cfg(feature = "petsc")]
pub use modes::full_modes;
#[cfg(feature = "petsc")]
pub use operators::Operators;
#[cfg(feature = "petsc")]
pub use reduction::{craig_bampton, Reduction, ReductionInput};
#[cfg(feature = "petsc")]
pub use session::{start, world, Session};
#[cfg(feature = "petsc")]
pub use static_solve::solve_from_root;

#[cfg(not(feature = "petsc"))]
mod stub;
#[cfg(not(feature = "petsc"))]
pub use stub::*;
