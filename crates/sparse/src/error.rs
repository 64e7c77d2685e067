//! Typed errors of the sparse checks, products and factorizations. Every message names the
//! matrix concerned (the caller's `what`) and what was expected; `nlmodes_modal::ModalError`
//! converts each into its variant of the same name and message.

/// Errors of this crate.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum SparseError {
    /// A matrix that must be square is not.
    #[error("{what} must be square, but it is {nrows} x {ncols}")]
    NotSquare {
        /// Which matrix.
        what: String,
        /// Rows found.
        nrows: usize,
        /// Columns found.
        ncols: usize,
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

    /// A stored entry is NaN or infinite.
    #[error("{what} has a non-finite entry {value} at ({row}, {col}) (0-based)")]
    NotFinite {
        /// Which matrix.
        what: String,
        /// Row and column (0-based).
        row: usize,
        col: usize,
        /// The entry.
        value: f64,
    },

    /// |a_ij - a_ji| exceeds `tolerance` times the largest entry.
    #[error(
        "{what} is not symmetric: entry ({row}, {col}) = {a_ij:e} but ({col}, {row}) = {a_ji:e} \
         (0-based; tolerance {tolerance:e} relative to the largest entry)"
    )]
    NotSymmetric {
        /// Which matrix.
        what: String,
        /// Row and column of the first offending entry (0-based).
        row: usize,
        col: usize,
        /// Entries (row, col) and (col, row).
        a_ij: f64,
        a_ji: f64,
        /// Relative tolerance of the check.
        tolerance: f64,
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
