//! Dense linear algebra of the workspace on top of faer, one implementation of each piece: the
//! symmetry check and tolerance every symmetric input passes (`symmetric`), the balancing of a general matrix before its eigenvectors (`balance`), the generalized
//! symmetric eigenproblem K phi = lambda M phi with its Cholesky factor and the sign convention
//! of eigenvectors (`eigen`), and the reusable in-place LU of the harmonic-balance Newton steps
//! (`lu`). A leaf crate: `nlmodes-modal`, `nlmodes-hb` and the crates above use it, each mapping
//! its errors ([`DenseError`], [`SymmetryError`]) onto its own (docs/DESIGN.md §1).

mod balance;
mod eigen;
mod general;
mod lu;
mod symmetric;

pub use balance::{balance, Balanced};
pub use eigen::{cholesky_lower, fix_sign, generalized_eigen, DenseError, GeneralizedEigen};
pub use general::{eigen_checked, eigenvalues_checked, CHECK};
pub use lu::DenseLu;
pub use symmetric::{
    check_symmetric, max_abs, relative_asymmetry, symmetrize, SymmetryError, SYMMETRY_TOLERANCE,
};
