//! nlmodes-modal: the ARPACK and block Lanczos shift-invert generalized eigensolvers on the
//! sparse Cholesky of `nlmodes-sparse`, Craig-Bampton reduction, the reduced-model files, the
//! parametric reduced model in the rotation speed, and the Campbell diagram's numerics:
//! Rayleigh-Ritz on a multi-speed basis and the gyroscopic (Coriolis) correction.
//!
//! This crate knows nothing of meshes: it works on sparse symmetric matrices
//! (`sprs::CsMat<f64>`, CSC with both triangles stored) and index lists.
//! Units follow the caller's: with SI matrices (K in N/m, M in kg) eigenvalues
//! are in rad^2/s^2 and frequencies in Hz.

pub mod arpack;
pub mod block_lanczos;
pub mod bordered;
pub mod contact_geometry;
pub mod craig_bampton;
/// The dense linear algebra this crate uses: `nlmodes-dense` (its old module path).
pub use nlmodes_dense as dense;
pub mod eigen_options;
pub mod enriched_basis;
pub mod error;
pub mod factored;
pub mod gyroscopic;
pub mod m_orthonormal;
pub mod matrix_market;
pub mod matrix_market_general;
mod matrix_market_io;
pub mod memory;
pub mod model_checks;
pub mod modes;
pub mod parametric;
mod recovery_codec;
pub mod reduced_model;
pub mod ritz;
/// The sparse matrix checks and products: `nlmodes_sparse::ops` (its old module path).
pub use nlmodes_sparse::ops as sparse_ops;
pub mod spline;
mod tall;

pub use arpack::{eigs_shift_invert, eigs_shift_invert_factored};
pub use bordered::BorderedSolve;
pub use contact_geometry::{radial_unit_vector, RotorAxis};
pub use craig_bampton::{
    craig_bampton, craig_bampton_with_check, craig_bampton_with_loads, reduced_eigen, CraigBampton,
};
pub use eigen_options::{EigenMethod, EigenOptions};
pub use enriched_basis::{enrich_with_modes, EnrichedBasis};
pub use error::ModalError;
pub use factored::FactoredSolve;
pub use gyroscopic::{gyroscopic_frequencies, projected_gyroscopic_frequencies};
pub use m_orthonormal::{project_symmetric, MOrthonormalBasis, Projection};
pub use modes::{dense_generalized_eigen, Modes};
/// The one sparse Cholesky (`nlmodes-sparse`), at the paths modal's users know.
pub use nlmodes_sparse::{
    csmat_to_dense, shifted, CholeskyAnalysis, CholeskyOptions, FillOrdering, SparseCholesky,
};
pub use parametric::{Accuracy, AccuracyCheck, ParametricContact, ParametricModel};
pub use reduced_model::{
    ContactNode, MasterCoordinate, MeshReference, RecoveryStorage, ReducedModel,
};
pub use ritz::{RitzBasis, RitzModes};
pub use tall::tall_gram;
