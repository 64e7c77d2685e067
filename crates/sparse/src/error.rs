//! Typed errors of the sparse checks, products and factorizations. Every message names the
//! matrix concerned (the caller's `what`) and what was expected; `nlmodes_modal::ModalError`
//! converts each into its variant of the same name (a refused matrix as its dense checks'
//! errors are converted).

pub use nlmodes_dense::SymmetryError;

/// Errors of this crate.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum SparseError {
    /// A matrix is not square, has a non-finite entry, or is not symmetric to
    /// [`nlmodes_dense::SYMMETRY_TOLERANCE`] (the dense crate's reasons, one definition).
    #[error("{what}: {source}")]
    Matrix {
        /// Which matrix.
        what: String,
        /// Why it is refused.
        source: SymmetryError,
    },

    /// Two operands have incompatible sizes.
    #[error("size mismatch: {what}: expected {expected}, found {found}")]
    DimensionMismatch {
        /// Which operands.
        what: String,
        /// Expected size.
        expected: usize,
        /// Size found.
        found: usize,
    },

    /// The numeric Cholesky factorization met a non-positive pivot.
    #[error(
        "{what} is not positive definite: the Cholesky factorization met a non-positive pivot \
         at row/column {index} (0-based, original numbering)"
    )]
    NotPositiveDefinite {
        /// Which matrix.
        what: String,
        /// Row/column of the failing pivot in the caller's numbering.
        index: usize,
    },

    /// faer's symbolic or numeric factorization failed (index overflow, out of memory).
    #[error("sparse factorization of {what} failed: {message}")]
    Factorization {
        /// Which matrix.
        what: String,
        /// faer's diagnostic, or the allocation that failed.
        message: String,
    },

    /// An argument is out of range (an empty matrix, a shift that is not finite, an index out
    /// of range, another sparsity pattern than the one analysed).
    #[error("invalid argument: {0}")]
    InvalidArgument(String),
}
