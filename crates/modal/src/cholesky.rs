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
use crate::ordering::{metis_nested_dissection, FillOrdering};
use crate::sparse_ops::{as_csc, check_symmetric_input};

pub use crate::sparse_ops::shifted;

/// Options of [`SparseCholesky::with_options`].
#[derive(Copy, Clone, Debug)]
pub struct CholeskyOptions {
    /// Fill-reducing ordering (METIS by default).
    pub ordering: FillOrdering,
    /// Parallelism of the numerical factorization (solves are always sequential).
    pub factorization_par: Par,
}

impl Default for CholeskyOptions {
    fn default() -> Self {
        Self {
            ordering: FillOrdering::Metis,
            factorization_par: Par::Seq,
        }
    }
}

/// Cholesky factor of a sparse SPD matrix, ready for repeated solves.
pub struct SparseCholesky {
    n: usize,
    symbolic: SymbolicCholesky<usize>,
    l_values: Vec<f64>,
    ordering: FillOrdering,
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
    /// Factorizes the SPD matrix `a` (METIS ordering, sequential).
    ///
    /// Errors: not square, non-finite or asymmetric entries, empty matrix,
    /// not positive definite ([`ModalError::NotPositiveDefinite`]).
    pub fn new(a: &CsMat<f64>) -> Result<Self, ModalError> {
        Self::with_options(a, "matrix", CholeskyOptions::default())
    }

    /// Factorizes `a`; `what` names the matrix in error messages
    /// (e.g. "K - sigma M with sigma = -1.0e3").
    pub fn with_options(
        a: &CsMat<f64>,
        what: &str,
        options: CholeskyOptions,
    ) -> Result<Self, ModalError> {
        let n = check_symmetric_input(a, what)?;
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
        let params = CholeskySymbolicParams::default();
        let (symbolic, ordering) = match options.ordering {
            FillOrdering::Natural => (
                factorize_symbolic_cholesky(
                    structure,
                    Side::Lower,
                    SymmetricOrdering::Identity,
                    params,
                )
                .map_err(factorization_error)?,
                FillOrdering::Natural,
            ),
            FillOrdering::Amd => (
                factorize_symbolic_cholesky(structure, Side::Lower, SymmetricOrdering::Amd, params)
                    .map_err(factorization_error)?,
                FillOrdering::Amd,
            ),
            FillOrdering::Metis => match metis_nested_dissection(&a) {
                Ok(perm) => {
                    let perm_ref =
                        faer::perm::PermRef::new_checked(&perm.forward, &perm.inverse, n);
                    (
                        factorize_symbolic_cholesky(
                            structure,
                            Side::Lower,
                            SymmetricOrdering::Custom(perm_ref),
                            params,
                        )
                        .map_err(factorization_error)?,
                        FillOrdering::Metis,
                    )
                }
                Err(reason) => {
                    tracing::warn!("{what}: METIS ordering failed ({reason}); falling back to AMD");
                    (
                        factorize_symbolic_cholesky(
                            structure,
                            Side::Lower,
                            SymmetricOrdering::Amd,
                            params,
                        )
                        .map_err(factorization_error)?,
                        FillOrdering::Amd,
                    )
                }
            },
        };

        let mut l_values = vec![0.0_f64; symbolic.len_val()];
        let par = options.factorization_par;
        let mut factor_mem =
            MemBuffer::try_new(symbolic.factorize_numeric_llt_scratch::<f64>(par, Spec::default()))
                .map_err(|_| ModalError::Factorization {
                    what: what.to_string(),
                    message: "out of memory for the factorization workspace".to_string(),
                })?;
        let matrix = SparseColMatRef::new(structure, a.data());
        let result = symbolic.factorize_numeric_llt::<f64>(
            &mut l_values,
            matrix,
            Side::Lower,
            LltRegularization::default(),
            par,
            MemStack::new(&mut factor_mem),
            Spec::default(),
        );
        match result {
            Ok(_) => {}
            Err(LltError::NonPositivePivot { index }) => {
                // faer 0.24 reports the failing pivot 1-based in its simplicial
                // kernel (`k + 1`) but 0-based in the supernodal one
                // (`s_start + j`), both in the permuted numbering.
                let position = match symbolic.raw() {
                    SymbolicCholeskyRaw::Simplicial(_) => index.saturating_sub(1),
                    SymbolicCholeskyRaw::Supernodal(_) => index,
                }
                .min(n - 1);
                let original = symbolic
                    .perm()
                    .map(|p| p.arrays().0[position])
                    .unwrap_or(position);
                return Err(ModalError::NotPositiveDefinite {
                    what: what.to_string(),
                    index: original,
                    hint: String::new(),
                });
            }
        }
        drop(factor_mem);

        let workspace = MemBuffer::try_new(symbolic.solve_in_place_scratch::<f64>(1, Par::Seq))
            .map_err(|_| ModalError::Factorization {
                what: what.to_string(),
                message: "out of memory for the solve workspace".to_string(),
            })?;
        tracing::debug!(
            "{what}: Cholesky of order {n}, nnz(A) = {}, nnz(L) = {}, ordering {:?}",
            a.nnz(),
            l_values.len(),
            ordering
        );
        Ok(Self {
            n,
            symbolic,
            l_values,
            ordering,
            workspace: Mutex::new(workspace),
        })
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

    /// Overwrites every column of `rhs` (n x k) with A^-1 times it.
    pub fn solve_many(&self, rhs: MatMut<'_, f64>) -> Result<(), ModalError> {
        self.check_rhs_len(rhs.nrows())?;
        let k = rhs.ncols();
        if k == 0 {
            return Ok(());
        }
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
