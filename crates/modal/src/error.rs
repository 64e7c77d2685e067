//! Typed errors of the modal crate. Every message names the matrix, file or
//! value concerned and what was expected.

use std::path::PathBuf;

use nlmodes_dense::{SymmetryError, SYMMETRY_TOLERANCE};
use nlmodes_sparse::SparseError;

/// Errors returned by the factorizations, eigensolvers, reduction and file I/O
/// of this crate.
#[derive(Debug, thiserror::Error)]
pub enum ModalError {
    /// A matrix that must be square is not.
    #[error("{what} must be square, but it is {nrows} x {ncols}")]
    NotSquare {
        /// Which matrix.
        what: String,
        /// Number of rows found.
        nrows: usize,
        /// Number of columns found.
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

    /// A matrix entry or a value is NaN or infinite.
    #[error("{what} has a non-finite entry {value} at ({row}, {col}) (0-based)")]
    NotFinite {
        /// Which matrix.
        what: String,
        /// Row (0-based).
        row: usize,
        /// Column (0-based).
        col: usize,
        /// The offending value.
        value: f64,
    },

    /// A matrix that must be symmetric is not (beyond the stated tolerance).
    #[error(
        "{what} is not symmetric: entry ({row}, {col}) = {a_ij:e} but ({col}, {row}) = {a_ji:e} \
         (0-based; tolerance {tolerance:e} relative to the largest entry)"
    )]
    NotSymmetric {
        /// Which matrix.
        what: String,
        /// Row (0-based).
        row: usize,
        /// Column (0-based).
        col: usize,
        /// Entry (row, col).
        a_ij: f64,
        /// Entry (col, row).
        a_ji: f64,
        /// Relative tolerance used.
        tolerance: f64,
    },

    /// A Cholesky factorization met a non-positive pivot.
    #[error(
        "{what} is not positive definite: the Cholesky factorization met a non-positive pivot \
         at row/column {index} (0-based, original numbering){hint}"
    )]
    NotPositiveDefinite {
        /// Which matrix.
        what: String,
        /// Row/column of the failing pivot in the caller's numbering.
        index: usize,
        /// Extra explanation (starts with "; " when not empty).
        hint: String,
    },

    /// faer could not build the symbolic factorization (memory or index overflow).
    #[error("sparse factorization of {what} failed: {message}")]
    Factorization {
        /// Which matrix.
        what: String,
        /// faer's diagnostic.
        message: String,
    },

    /// Invalid number of requested eigenpairs.
    #[error("cannot compute {nev} eigenpairs of a problem of size {n}: {reason}")]
    InvalidEigenCount {
        /// Number requested.
        nev: usize,
        /// Problem size.
        n: usize,
        /// Why it is invalid.
        reason: String,
    },

    /// ARPACK returned an error code.
    #[error("ARPACK {routine} failed with info = {info}: {message}")]
    Arpack {
        /// `dsaupd` or `dseupd`.
        routine: &'static str,
        /// ARPACK's info code.
        info: i32,
        /// Meaning of the code.
        message: String,
    },

    /// ARPACK reached its iteration limit before all requested eigenpairs converged.
    #[error(
        "ARPACK did not converge: {converged} of {requested} requested eigenpairs converged \
         after {iterations} Arnoldi restarts (limit {max_iterations}); increase the iteration \
         limit or ncv (currently {ncv})"
    )]
    NoConvergence {
        /// Number of converged Ritz pairs.
        converged: usize,
        /// Number requested.
        requested: usize,
        /// Restarts performed.
        iterations: usize,
        /// Restart limit.
        max_iterations: usize,
        /// Krylov subspace size used.
        ncv: usize,
    },

    /// The block Lanczos eigensolver reached its largest basis, or met a rank-deficient block,
    /// before all requested eigenpairs converged.
    #[error(
        "block Lanczos did not converge: {converged} of {requested} requested eigenpairs \
         converged after {solves} solves (largest basis {max_basis}); use the ARPACK method"
    )]
    BlockLanczosNoConvergence {
        /// Number of converged Ritz pairs.
        converged: usize,
        /// Number requested.
        requested: usize,
        /// Applications of (K - sigma M)^-1.
        solves: usize,
        /// Largest basis allowed.
        max_basis: usize,
    },

    /// An operator of a [`crate::block_lanczos::BlockProblem`] failed (for a distributed
    /// problem: the MPI, PETSc or MUMPS error it met).
    #[error("applying the operators of the eigenproblem: {0}")]
    Operator(String),

    /// A dense eigen decomposition failed.
    #[error("dense eigen decomposition of {what} did not converge")]
    DenseEigen {
        /// Which matrix.
        what: String,
    },

    /// An invalid Craig-Bampton boundary or mode count.
    #[error("invalid Craig-Bampton reduction input: {0}")]
    InvalidReduction(String),

    /// A vector argument has the wrong length or an invalid value.
    #[error("invalid argument: {0}")]
    InvalidArgument(String),

    /// A point lies on the rotor axis, so it has no radial direction.
    #[error(
        "point ({x}, {y}, {z}) m lies on the rotor axis (distance {distance:e} m): \
         its radial direction is undefined"
    )]
    PointOnAxis {
        /// x coordinate, m.
        x: f64,
        /// y coordinate, m.
        y: f64,
        /// z coordinate, m.
        z: f64,
        /// Distance to the axis, m.
        distance: f64,
    },

    /// Operating-system I/O failure.
    #[error("{action} {path}: {source}")]
    Io {
        /// What was being done ("cannot read", "cannot write", ...).
        action: &'static str,
        /// File or directory.
        path: PathBuf,
        /// Underlying error.
        source: std::io::Error,
    },

    /// A Matrix Market file is malformed or does not hold what was expected.
    #[error("{path}:{line}: {message}")]
    MatrixMarket {
        /// File.
        path: PathBuf,
        /// 1-based line number (0 when the problem concerns the whole file).
        line: usize,
        /// What is wrong and what was expected.
        message: String,
    },

    /// A reduced-model directory is inconsistent or invalid.
    #[error("invalid reduced model {path}: {message}")]
    ReducedModel {
        /// File or directory concerned.
        path: PathBuf,
        /// What is wrong and what was expected.
        message: String,
    },

    /// `model.json` could not be parsed or written.
    #[error("{path}: {source}")]
    Json {
        /// File.
        path: PathBuf,
        /// serde_json's diagnostic (with line and column).
        source: serde_json::Error,
    },

    /// A computation would need more memory than the system has available.
    #[error(
        "{what} needs about {needed} more memory ({parts}) but only {available} are available \
         (MemAvailable of /proc/meminfo): use a coarser mesh, fewer modes, or a machine with \
         more memory"
    )]
    InsufficientMemory {
        /// The computation and the size of the model.
        what: String,
        /// Bytes needed, formatted ("14.60 GB").
        needed: String,
        /// The parts of the estimate.
        parts: String,
        /// Bytes available, formatted.
        available: String,
    },
}

impl ModalError {
    /// The error of the dense matrix `what` that fails `nlmodes_dense::check_symmetric`:
    /// `map_err(ModalError::symmetry(what))`.
    pub fn symmetry(what: &str) -> impl Fn(SymmetryError) -> Self + '_ {
        move |e| match e {
            SymmetryError::NotSquare { rows, cols } => ModalError::NotSquare {
                what: what.to_string(),
                nrows: rows,
                ncols: cols,
            },
            SymmetryError::NonFinite { row, col, value } => ModalError::NotFinite {
                what: what.to_string(),
                row,
                col,
                value,
            },
            SymmetryError::NotSymmetric {
                row,
                col,
                a_ij,
                a_ji,
                ..
            } => ModalError::NotSymmetric {
                what: what.to_string(),
                row,
                col,
                a_ij,
                a_ji,
                tolerance: SYMMETRY_TOLERANCE,
            },
        }
    }
}

/// The sparse crate's errors as the variants of the same name and message (a refused matrix as
/// the dense checks' errors, [`ModalError::symmetry`]; a factor that is not positive definite
/// without a hint: the eigensolvers add theirs).
impl From<SparseError> for ModalError {
    fn from(e: SparseError) -> Self {
        match e {
            SparseError::Matrix { what, source } => Self::symmetry(&what)(source),
            SparseError::DimensionMismatch {
                what,
                expected,
                found,
            } => Self::DimensionMismatch {
                what,
                expected,
                found,
            },
            SparseError::NotPositiveDefinite { what, index } => Self::NotPositiveDefinite {
                what,
                index,
                hint: String::new(),
            },
            SparseError::Factorization { what, message } => Self::Factorization { what, message },
            SparseError::InvalidArgument(message) => Self::InvalidArgument(message),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every error of the sparse crate reads, once converted, as modal's own errors read (the
    /// messages users saw when the Cholesky lived here).
    #[test]
    fn sparse_errors_keep_their_messages() {
        let what = || "K".to_string();
        let refused = |source| SparseError::Matrix {
            what: what(),
            source,
        };
        for (sparse, modal) in [
            (
                refused(SymmetryError::NotSquare { rows: 2, cols: 3 }),
                ModalError::NotSquare {
                    what: what(),
                    nrows: 2,
                    ncols: 3,
                },
            ),
            (
                refused(SymmetryError::NonFinite {
                    row: 1,
                    col: 0,
                    value: f64::INFINITY,
                }),
                ModalError::NotFinite {
                    what: what(),
                    row: 1,
                    col: 0,
                    value: f64::INFINITY,
                },
            ),
            (
                refused(SymmetryError::NotSymmetric {
                    row: 1,
                    col: 0,
                    a_ij: 1.0,
                    a_ji: 2.0,
                    scale: 2.0,
                }),
                ModalError::NotSymmetric {
                    what: what(),
                    row: 1,
                    col: 0,
                    a_ij: 1.0,
                    a_ji: 2.0,
                    tolerance: SYMMETRY_TOLERANCE,
                },
            ),
            (
                SparseError::NotPositiveDefinite {
                    what: what(),
                    index: 7,
                },
                ModalError::NotPositiveDefinite {
                    what: what(),
                    index: 7,
                    hint: String::new(),
                },
            ),
        ] {
            assert_eq!(ModalError::from(sparse).to_string(), modal.to_string());
        }
        for e in [
            SparseError::DimensionMismatch {
                what: what(),
                expected: 4,
                found: 5,
            },
            SparseError::Factorization {
                what: what(),
                message: "out of memory".to_string(),
            },
            SparseError::InvalidArgument("sigma".to_string()),
        ] {
            assert_eq!(ModalError::from(e.clone()).to_string(), e.to_string());
        }
    }
}
