//! nlmodes-sparse: sparse symmetric matrices and their one sparse Cholesky, below the
//! finite-element (`nlmodes-fem`) and modal (`nlmodes-modal`) crates (docs/DESIGN.md §1).
//!
//! - [`ops`]: input checks (square, finite, symmetric to [`ops::SYMMETRY_TOLERANCE`]), products,
//!   the shifted matrix K - sigma M, principal submatrices;
//! - [`SparseCholesky`]: A = P^T L L^T P with faer after a METIS nested-dissection ordering
//!   ([`ordering`]; AMD if METIS fails), its symbolic half [`CholeskyAnalysis`] (the memory a
//!   factorization will take, known first), refactorization on the same pattern, block solves
//!   over rayon's threads (DESIGN 6);
//! - [`LinearSolver`]: the linear solve of a Newton iteration, by [`CholeskySolver`] (one
//!   [`SparseCholesky`] whose analysis is reused while the pattern stays) or [`LuSolver`]
//!   (indefinite operators);
//! - [`timer`]: wall-clock, CPU time and resident memory of a step, for log lines.
//!
//! Matrices are `sprs::CsMat<f64>`, CSC with both triangles stored (CSR accepted where said).
//! Units follow the caller's.

mod analysis;
mod cholesky;
pub mod error;
mod lu;
mod numeric;
pub mod ops;
pub mod ordering;
mod solver;
pub mod timer;

pub use analysis::{CholeskyAnalysis, CholeskyOptions};
pub use cholesky::{SparseCholesky, MIN_COLUMNS_PER_THREAD};
pub use error::SparseError;
pub use lu::LuSolver;
pub use ops::{csmat_to_dense, shifted};
pub use ordering::FillOrdering;
pub use solver::{CholeskySolver, LinearSolveError, LinearSolver};
