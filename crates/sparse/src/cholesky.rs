//! The sparse Cholesky factor A = P^T L L^T P of a symmetric positive definite `CsMat<f64>`
//! (faer, supernodal or simplicial as faer decides), ready for repeated solves; computed by
//! [`crate::CholeskyAnalysis`] after a METIS nested-dissection fill-reducing ordering (AMD if
//! METIS fails; [`crate::ordering`]).
//!
//! The factor is solved against thousands of times inside the eigensolvers, so solves are
//! sequential (`Par::Seq`; rayon slows faer's triangular solves 3-5x, DESIGN 6) and reuse one
//! workspace buffer.

use std::sync::Mutex;

use faer::dyn_stack::{MemBuffer, MemStack};
use faer::sparse::linalg::cholesky::{LltRef, SymbolicCholesky, SymbolicCholeskyRaw};
use faer::{Conj, MatMut, Par};
use sprs::CsMat;

use crate::error::SparseError;
use crate::numeric::{numeric_llt, pattern_fingerprint};
use crate::ordering::FillOrdering;

/// Fewest right-hand sides a thread of [`SparseCholesky::solve_many`] takes: below, one thread
/// streaming the factor once costs less than two streaming it concurrently.
pub const MIN_COLUMNS_PER_THREAD: usize = 4;

/// Cholesky factor of a sparse SPD matrix, ready for repeated solves.
pub struct SparseCholesky {
    n: usize,
    symbolic: SymbolicCholesky<usize>,
    l_values: Vec<f64>,
    ordering: FillOrdering,
    par: Par,
    /// [`pattern_fingerprint`] of the factorized matrix.
    pattern: u64,
    /// Workspace of a one-column solve, reused across calls.
    workspace: Mutex<MemBuffer>,
}

impl std::fmt::Debug for SparseCholesky {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("SparseCholesky")
            .field("n", &self.n)
            .field("nnz_l", &self.l_values.len())
            .field("ordering", &self.ordering)
            .finish_non_exhaustive()
    }
}

impl SparseCholesky {
    /// The factor of `a` made of its analysis and the values of L (the end of
    /// [`crate::CholeskyAnalysis::factorize`]).
    pub(crate) fn from_parts(
        a: &CsMat<f64>,
        symbolic: SymbolicCholesky<usize>,
        l_values: Vec<f64>,
        (ordering, par): (FillOrdering, Par),
        workspace: MemBuffer,
    ) -> Self {
        SparseCholesky {
            n: a.rows(),
            symbolic,
            l_values,
            ordering,
            par,
            pattern: pattern_fingerprint(a),
            workspace: Mutex::new(workspace),
        }
    }

    /// Order of the factorized matrix.
    pub fn n(&self) -> usize {
        self.n
    }

    /// Number of stored entries of L (including the explicit zeros of dense
    /// supernodal blocks): the memory and work measure of the factorization.
    pub fn nnz_l(&self) -> usize {
        self.l_values.len()
    }

    /// Whether faer chose its supernodal (blocked) factorization rather than
    /// the simplicial one (it decides from the flop count per nonzero).
    pub fn is_supernodal(&self) -> bool {
        matches!(self.symbolic.raw(), SymbolicCholeskyRaw::Supernodal(_))
    }

    /// The ordering actually used (AMD when METIS failed).
    pub fn ordering(&self) -> FillOrdering {
        self.ordering
    }

    fn factor(&self) -> LltRef<'_, usize, f64> {
        LltRef::new(&self.symbolic, &self.l_values)
    }

    fn check_rhs_len(&self, len: usize) -> Result<(), SparseError> {
        if len != self.n {
            return Err(SparseError::DimensionMismatch {
                what: "right-hand side length of the Cholesky solve".to_string(),
                expected: self.n,
                found: len,
            });
        }
        Ok(())
    }

    /// Overwrites `rhs` with A^-1 rhs (sequential, reusing the workspace).
    pub fn solve_in_place(&self, rhs: &mut [f64]) -> Result<(), SparseError> {
        self.check_rhs_len(rhs.len())?;
        let rhs_mat = MatMut::from_column_major_slice_mut(rhs, self.n, 1);
        match self.workspace.try_lock() {
            Ok(mut buffer) => {
                self.factor().solve_in_place_with_conj(
                    Conj::No,
                    rhs_mat,
                    Par::Seq,
                    MemStack::new(&mut buffer),
                );
            }
            // Another thread is solving with this factor: use a private buffer.
            Err(_) => {
                let mut buffer =
                    MemBuffer::new(self.symbolic.solve_in_place_scratch::<f64>(1, Par::Seq));
                self.factor().solve_in_place_with_conj(
                    Conj::No,
                    rhs_mat,
                    Par::Seq,
                    MemStack::new(&mut buffer),
                );
            }
        }
        Ok(())
    }

    /// Overwrites every column of `rhs` (n x k) with A^-1 times it. The columns are split in
    /// as many groups as rayon has threads (at least [`MIN_COLUMNS_PER_THREAD`] each), solved
    /// concurrently, each group sequentially in one pass over the factor: faer's solve
    /// parallelizes inside each supernode's dense kernels, which the many small supernodes of a
    /// 3-D factor make slower than sequential (DESIGN 6), while independent column groups
    /// keep both cores busy on the same factor. Each column's arithmetic is that of a
    /// sequential solve.
    pub fn solve_many(&self, rhs: MatMut<'_, f64>) -> Result<(), SparseError> {
        self.check_rhs_len(rhs.nrows())?;
        let k = rhs.ncols();
        if k == 0 {
            return Ok(());
        }
        let groups = (k / MIN_COLUMNS_PER_THREAD).clamp(1, rayon::current_num_threads());
        self.solve_groups(rhs, groups)
    }

    /// [`SparseCholesky::solve_many`] on `groups` column groups (recursive halving).
    fn solve_groups(&self, rhs: MatMut<'_, f64>, groups: usize) -> Result<(), SparseError> {
        if groups <= 1 {
            return self.solve_sequential(rhs);
        }
        let left_groups = groups / 2;
        let split = rhs.ncols() * left_groups / groups;
        let (left, right) = rhs.split_at_col_mut(split);
        let (a, b) = rayon::join(
            || self.solve_groups(left, left_groups),
            || self.solve_groups(right, groups - left_groups),
        );
        a.and(b)
    }

    /// One sequential solve of all columns of `rhs` in one pass over the factor.
    fn solve_sequential(&self, rhs: MatMut<'_, f64>) -> Result<(), SparseError> {
        let k = rhs.ncols();
        let mut buffer = MemBuffer::try_new(
            self.symbolic.solve_in_place_scratch::<f64>(k, Par::Seq),
        )
        .map_err(|_| SparseError::Factorization {
            what: format!("solve with {k} right-hand sides"),
            message: "out of memory for the solve workspace".to_string(),
        })?;
        self.factor()
            .solve_in_place_with_conj(Conj::No, rhs, Par::Seq, MemStack::new(&mut buffer));
        Ok(())
    }

    /// Factorizes `a`, a matrix of the same order and sparsity pattern as the one factorized
    /// before, reusing the ordering and the symbolic analysis (about 40 % of a factorization
    /// at 93k DOFs: the METIS ordering alone is 0.65 s of 1.7 s). For a Newton solve whose
    /// tangent keeps the mesh's pattern. Errors: a different order or pattern
    /// ([`SparseError::InvalidArgument`]), not positive definite, out of memory.
    pub fn refactorize(&mut self, a: &CsMat<f64>, what: &str) -> Result<(), SparseError> {
        if a.rows() != self.n || a.cols() != self.n || pattern_fingerprint(a) != self.pattern {
            return Err(SparseError::InvalidArgument(format!(
                "{what}: refactorization needs the order ({}) and sparsity pattern of the \
                 matrix analysed, got a {}x{} matrix with another pattern",
                self.n,
                a.rows(),
                a.cols()
            )));
        }
        self.l_values = numeric_llt(&self.symbolic, a, what, self.par, self.ordering)?;
        Ok(())
    }

    /// Whether `a` has the order and sparsity pattern of the factorized matrix (then
    /// [`SparseCholesky::refactorize`] applies).
    pub fn same_pattern(&self, a: &CsMat<f64>) -> bool {
        a.rows() == self.n && a.cols() == self.n && pattern_fingerprint(a) == self.pattern
    }
}
