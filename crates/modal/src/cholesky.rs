//! Sparse Cholesky factorization A = P^T L L^T P of a symmetric positive
//! definite `CsMat<f64>` with faer, after a METIS nested-dissection
//! fill-reducing ordering (AMD if METIS fails).
//!
//! The factor is solved against thousands of times inside the eigensolver, so
//! solves are sequential (`Par::Seq`; rayon slows faer's triangular solves
//! 3-5x, DESIGN 6) and reuse one workspace buffer.

use std::sync::Mutex;

use faer::dyn_stack::{MemBuffer, MemStack};
use faer::linalg::cholesky::llt::factor::{LltError, LltRegularization};
use faer::sparse::linalg::cholesky::{
    factorize_symbolic_cholesky, CholeskySymbolicParams, LltRef, SymbolicCholesky,
    SymbolicCholeskyRaw, SymmetricOrdering,
};
use faer::sparse::{SparseColMatRef, SymbolicSparseColMatRef};
use faer::{Conj, MatMut, Par, Side, Spec};
use sprs::CsMat;

use crate::error::ModalError;
use crate::memory::StepTimer;
use crate::ordering::{metis_nested_dissection, FillOrdering};
use crate::sparse_ops::{as_csc, check_symmetric_input};

pub use crate::sparse_ops::shifted;

/// Options of [`SparseCholesky::with_options`].
#[derive(Copy, Clone, Debug)]
pub struct CholeskyOptions {
    /// Fill-reducing ordering (METIS by default).
    pub ordering: FillOrdering,
    /// Parallelism of the numerical factorization (solves are always sequential). Default:
    /// rayon on every core; faer's supernodal factorization parallelizes inside the dense
    /// kernels of each supernode, and gave bitwise the same factor as the sequential one on a
    /// 102k-DOF 3-D stiffness and on the 93k-DOF blade (the default blade's reduced model files
    /// are byte-identical; docs/BENCHMARKS.md, "Industrial size"). DESIGN 6.2: about 1.6x
    /// faster on 2 idle cores.
    pub factorization_par: Par,
}

impl Default for CholeskyOptions {
    fn default() -> Self {
        Self {
            ordering: FillOrdering::Metis,
            factorization_par: Par::rayon(0),
        }
    }
}

/// A factorized operator the shift-invert eigensolvers apply, x = A^-1 b: the sparse Cholesky
/// factor of K - sigma M, or the factor of an interior block bordered by a dense Schur
/// complement ([`crate::bordered::BorderedSolve`]).
pub trait FactoredSolve {
    /// Order of A.
    fn order(&self) -> usize;
    /// Overwrites `rhs` with A^-1 rhs.
    fn solve_vector(&self, rhs: &mut [f64]) -> Result<(), ModalError>;
    /// Overwrites every column of `rhs` (n x k) with A^-1 times it, in one pass over the factor.
    fn solve_block(&self, rhs: MatMut<'_, f64>) -> Result<(), ModalError>;
}

impl FactoredSolve for SparseCholesky {
    fn order(&self) -> usize {
        self.n
    }
    fn solve_vector(&self, rhs: &mut [f64]) -> Result<(), ModalError> {
        self.solve_in_place(rhs)
    }
    fn solve_block(&self, rhs: MatMut<'_, f64>) -> Result<(), ModalError> {
        self.solve_many(rhs)
    }
}

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
    /// Factorizes the SPD matrix `a` (METIS ordering, parallel numeric factorization).
    ///
    /// Errors: not square, non-finite or asymmetric entries, empty matrix,
    /// not positive definite ([`ModalError::NotPositiveDefinite`]).
    pub fn new(a: &CsMat<f64>) -> Result<Self, ModalError> {
        Self::with_options(a, "matrix", CholeskyOptions::default())
    }

    /// Factorizes `a`; `what` names the matrix in error messages
    /// (e.g. "K - sigma M with sigma = -1.0e3"). Same as [`CholeskyAnalysis::new`] followed by
    /// [`CholeskyAnalysis::factorize`].
    pub fn with_options(
        a: &CsMat<f64>,
        what: &str,
        options: CholeskyOptions,
    ) -> Result<Self, ModalError> {
        CholeskyAnalysis::new(a, what, options)?.factorize(a)
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

    fn check_rhs_len(&self, len: usize) -> Result<(), ModalError> {
        if len != self.n {
            return Err(ModalError::DimensionMismatch {
                what: "right-hand side length of the Cholesky solve".to_string(),
                expected: self.n,
                found: len,
            });
        }
        Ok(())
    }

    /// Overwrites `rhs` with A^-1 rhs (sequential, reusing the workspace).
    pub fn solve_in_place(&self, rhs: &mut [f64]) -> Result<(), ModalError> {
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
    pub fn solve_many(&self, rhs: MatMut<'_, f64>) -> Result<(), ModalError> {
        self.check_rhs_len(rhs.nrows())?;
        let k = rhs.ncols();
        if k == 0 {
            return Ok(());
        }
        let groups = (k / MIN_COLUMNS_PER_THREAD).clamp(1, rayon::current_num_threads());
        self.solve_groups(rhs, groups)
    }

    /// [`SparseCholesky::solve_many`] on `groups` column groups (recursive halving).
    fn solve_groups(&self, rhs: MatMut<'_, f64>, groups: usize) -> Result<(), ModalError> {
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
    fn solve_sequential(&self, rhs: MatMut<'_, f64>) -> Result<(), ModalError> {
        let k = rhs.ncols();
        let mut buffer = MemBuffer::try_new(
            self.symbolic.solve_in_place_scratch::<f64>(k, Par::Seq),
        )
        .map_err(|_| ModalError::Factorization {
            what: format!("solve with {k} right-hand sides"),
            message: "out of memory for the solve workspace".to_string(),
        })?;
        self.factor()
            .solve_in_place_with_conj(Conj::No, rhs, Par::Seq, MemStack::new(&mut buffer));
        Ok(())
    }
}

/// Fewest right-hand sides a thread of [`SparseCholesky::solve_many`] takes: below, one thread
/// streaming the factor once costs less than two streaming it concurrently.
pub const MIN_COLUMNS_PER_THREAD: usize = 4;

/// The symbolic half of a sparse Cholesky factorization: the fill-reducing ordering and the
/// structure of L, known before any numeric work, so that the memory the numeric factorization
/// will take ([`CholeskyAnalysis::factorization_bytes`]) can be checked first.
pub struct CholeskyAnalysis {
    n: usize,
    what: String,
    symbolic: SymbolicCholesky<usize>,
    ordering: FillOrdering,
    par: Par,
}

impl CholeskyAnalysis {
    /// Orders `a` (METIS, AMD or none, as `options` says) and computes the structure of L.
    ///
    /// Errors: not square, non-finite or asymmetric entries, empty matrix, faer's symbolic
    /// failures (index overflow, out of memory).
    pub fn new(a: &CsMat<f64>, what: &str, options: CholeskyOptions) -> Result<Self, ModalError> {
        check_symmetric_input(a, what)?;
        Self::new_prechecked(a, what, options)
    }

    /// [`CholeskyAnalysis::new`] for a matrix already checked square, finite and symmetric
    /// (a principal submatrix of a checked matrix).
    pub(crate) fn new_prechecked(
        a: &CsMat<f64>,
        what: &str,
        options: CholeskyOptions,
    ) -> Result<Self, ModalError> {
        let n = a.rows();
        if n == 0 {
            return Err(ModalError::InvalidArgument(format!(
                "{what} is empty (0 x 0): nothing to factorize"
            )));
        }
        let a = as_csc(a);
        let col_ptr = a.proper_indptr();
        let structure = SymbolicSparseColMatRef::new_checked(n, n, &col_ptr[..], None, a.indices());
        let factorization_error = |e: faer::sparse::FaerError| ModalError::Factorization {
            what: what.to_string(),
            message: format!("{e:?}"),
        };
        let symbolic_with = |ordering: SymmetricOrdering<'_, usize>| {
            factorize_symbolic_cholesky(
                structure,
                Side::Lower,
                ordering,
                CholeskySymbolicParams::default(),
            )
            .map_err(factorization_error)
        };
        let start = StepTimer::start();
        let (symbolic, ordering) = match options.ordering {
            FillOrdering::Natural => (
                symbolic_with(SymmetricOrdering::Identity)?,
                FillOrdering::Natural,
            ),
            FillOrdering::Amd => (symbolic_with(SymmetricOrdering::Amd)?, FillOrdering::Amd),
            FillOrdering::Metis => match metis_nested_dissection(&a) {
                Ok(perm) => {
                    tracing::info!(
                        "{what}: METIS ordering of {n} unknowns in {}",
                        start.elapsed()
                    );
                    let perm_ref =
                        faer::perm::PermRef::new_checked(&perm.forward, &perm.inverse, n);
                    (
                        symbolic_with(SymmetricOrdering::Custom(perm_ref))?,
                        FillOrdering::Metis,
                    )
                }
                Err(reason) => {
                    tracing::warn!("{what}: METIS ordering failed ({reason}); falling back to AMD");
                    (symbolic_with(SymmetricOrdering::Amd)?, FillOrdering::Amd)
                }
            },
        };
        tracing::info!(
            "{what}: ordering and symbolic analysis in {}, nnz(L) = {} ({:.2} GB)",
            start.elapsed(),
            symbolic.len_val(),
            (symbolic.len_val() * std::mem::size_of::<f64>()) as f64 * 1e-9
        );
        Ok(Self {
            n,
            what: what.to_string(),
            symbolic,
            ordering,
            par: options.factorization_par,
        })
    }

    /// Order of the matrix.
    pub fn n(&self) -> usize {
        self.n
    }

    /// Number of stored entries L will have (including the explicit zeros of dense supernodal
    /// blocks).
    pub fn nnz_l(&self) -> usize {
        self.symbolic.len_val()
    }

    /// Bytes the numeric factorization allocates beyond the symbolic structure: the values of L
    /// (8 bytes each), faer's factorization workspace (the largest supernode's update matrix,
    /// freed after the factorization) and the one-column solve workspace that stays with the
    /// factor.
    pub fn factorization_bytes(&self) -> usize {
        let scratch = self
            .symbolic
            .factorize_numeric_llt_scratch::<f64>(self.par, Spec::default())
            .size_bytes();
        let solve = self
            .symbolic
            .solve_in_place_scratch::<f64>(1, Par::Seq)
            .size_bytes();
        self.nnz_l() * std::mem::size_of::<f64>() + scratch + solve
    }

    /// Bytes of the workspace of a solve with `rhs_ncols` right-hand sides.
    pub fn solve_bytes(&self, rhs_ncols: usize) -> usize {
        self.symbolic
            .solve_in_place_scratch::<f64>(rhs_ncols, Par::Seq)
            .size_bytes()
    }

    /// The numeric factorization of `a`, which must be the matrix analysed (same order and
    /// pattern). Errors: order mismatch, out of memory, not positive definite
    /// ([`ModalError::NotPositiveDefinite`], index in `a`'s numbering).
    pub fn factorize(self, a: &CsMat<f64>) -> Result<SparseCholesky, ModalError> {
        let (n, what, symbolic) = (self.n, self.what, self.symbolic);
        if a.rows() != n || a.cols() != n {
            return Err(ModalError::DimensionMismatch {
                what: format!("order of {what} compared with its symbolic analysis"),
                expected: n,
                found: a.rows(),
            });
        }
        let l_values = numeric_llt(&symbolic, a, &what, self.par, self.ordering)?;
        let workspace = MemBuffer::try_new(symbolic.solve_in_place_scratch::<f64>(1, Par::Seq))
            .map_err(|_| ModalError::Factorization {
                what: what.clone(),
                message: "out of memory for the solve workspace".to_string(),
            })?;
        Ok(SparseCholesky {
            n,
            symbolic,
            l_values,
            ordering: self.ordering,
            par: self.par,
            pattern: pattern_fingerprint(a),
            workspace: Mutex::new(workspace),
        })
    }
}

impl SparseCholesky {
    /// Factorizes `a`, a matrix of the same order and sparsity pattern as the one factorized
    /// before, reusing the ordering and the symbolic analysis (about 40 % of a factorization
    /// at 93k DOFs: the METIS ordering alone is 0.65 s of 1.7 s). For a Newton solve whose
    /// tangent keeps the mesh's pattern. Errors: a different order or pattern
    /// ([`ModalError::InvalidArgument`]), not positive definite, out of memory.
    pub fn refactorize(&mut self, a: &CsMat<f64>, what: &str) -> Result<(), ModalError> {
        if a.rows() != self.n || a.cols() != self.n || pattern_fingerprint(a) != self.pattern {
            return Err(ModalError::InvalidArgument(format!(
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

/// FNV-1a over the CSC column pointers and row indices of `a` (its sparsity pattern), one
/// 64-bit word per index (byte by byte it took 50 ms at 93k DOFs, and a Newton solve checks
/// the pattern at every refactorization).
fn pattern_fingerprint(a: &CsMat<f64>) -> u64 {
    let a = as_csc(a);
    let mut h: u64 = 0xcbf2_9ce4_8422_2325;
    let mut eat = |v: usize| {
        h ^= v as u64;
        h = h.wrapping_mul(0x0000_0100_0000_01b3);
    };
    a.proper_indptr().iter().for_each(|&v| eat(v));
    a.indices().iter().for_each(|&v| eat(v));
    h
}

/// The values of L for `a` on the symbolic analysis `symbolic` (numeric supernodal or
/// simplicial LLT on `par`).
fn numeric_llt(
    symbolic: &SymbolicCholesky<usize>,
    a: &CsMat<f64>,
    what: &str,
    par: Par,
    ordering: FillOrdering,
) -> Result<Vec<f64>, ModalError> {
    let n = a.rows();
    let start = StepTimer::start();
    let a = as_csc(a);
    let col_ptr = a.proper_indptr();
    let structure = SymbolicSparseColMatRef::new_checked(n, n, &col_ptr[..], None, a.indices());
    let out_of_memory = |part: &str| ModalError::Factorization {
        what: what.to_string(),
        message: format!("out of memory for {part}"),
    };
    let mut l_values = Vec::new();
    l_values
        .try_reserve_exact(symbolic.len_val())
        .map_err(|_| out_of_memory("the values of L"))?;
    l_values.resize(symbolic.len_val(), 0.0_f64);
    let mut factor_mem =
        MemBuffer::try_new(symbolic.factorize_numeric_llt_scratch::<f64>(par, Spec::default()))
            .map_err(|_| out_of_memory("the factorization workspace"))?;
    let result = symbolic.factorize_numeric_llt::<f64>(
        &mut l_values,
        SparseColMatRef::new(structure, a.data()),
        Side::Lower,
        LltRegularization::default(),
        par,
        MemStack::new(&mut factor_mem),
        Spec::default(),
    );
    if let Err(LltError::NonPositivePivot { index }) = result {
        return Err(ModalError::NotPositiveDefinite {
            what: what.to_string(),
            index: failing_pivot(symbolic, index, n),
            hint: String::new(),
        });
    }
    tracing::info!(
        "{what}: numeric Cholesky of order {n}, nnz(A) = {}, nnz(L) = {}, ordering {ordering:?}, \
         {}",
        a.nnz(),
        l_values.len(),
        start.elapsed()
    );
    Ok(l_values)
}

/// The failing pivot of a non-positive-definite matrix in its original numbering: faer 0.24
/// reports it 1-based in its simplicial kernel (`k + 1`) but 0-based in the supernodal one
/// (`s_start + j`), both in the permuted numbering.
fn failing_pivot(symbolic: &SymbolicCholesky<usize>, index: usize, n: usize) -> usize {
    let position = match symbolic.raw() {
        SymbolicCholeskyRaw::Simplicial(_) => index.saturating_sub(1),
        SymbolicCholeskyRaw::Supernodal(_) => index,
    }
    .min(n - 1);
    symbolic
        .perm()
        .map(|p| p.arrays().0[position])
        .unwrap_or(position)
}
