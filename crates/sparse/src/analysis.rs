//! The symbolic half of the sparse Cholesky factorization: the fill-reducing ordering (METIS
//! nested dissection, AMD if METIS fails; [`crate::ordering`]) and the structure of L, known
//! before any numeric work, then the numeric factorization into a [`SparseCholesky`].

use faer::dyn_stack::MemBuffer;
use faer::sparse::linalg::cholesky::{
    factorize_symbolic_cholesky, CholeskySymbolicParams, SymbolicCholesky, SymmetricOrdering,
};
use faer::sparse::SymbolicSparseColMatRef;
use faer::{Par, Side, Spec};
use sprs::CsMat;

use crate::cholesky::SparseCholesky;
use crate::error::SparseError;
use crate::numeric::numeric_llt;
use crate::ops::{as_csc, check_symmetric_input};
use crate::ordering::{metis_nested_dissection, FillOrdering};
use crate::timer::StepTimer;

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

impl SparseCholesky {
    /// Factorizes the SPD matrix `a` (METIS ordering, parallel numeric factorization).
    ///
    /// Errors: not square, non-finite or asymmetric entries, empty matrix,
    /// not positive definite ([`SparseError::NotPositiveDefinite`]).
    pub fn new(a: &CsMat<f64>) -> Result<Self, SparseError> {
        Self::with_options(a, "matrix", CholeskyOptions::default())
    }

    /// Factorizes `a`; `what` names the matrix in error messages
    /// (e.g. "K - sigma M with sigma = -1.0e3"). Same as [`CholeskyAnalysis::new`] followed by
    /// [`CholeskyAnalysis::factorize`].
    pub fn with_options(
        a: &CsMat<f64>,
        what: &str,
        options: CholeskyOptions,
    ) -> Result<Self, SparseError> {
        CholeskyAnalysis::new(a, what, options)?.factorize(a)
    }
}

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
    pub fn new(a: &CsMat<f64>, what: &str, options: CholeskyOptions) -> Result<Self, SparseError> {
        check_symmetric_input(a, what)?;
        Self::new_prechecked(a, what, options)
    }

    /// [`CholeskyAnalysis::new`] for a matrix already checked square, finite and symmetric
    /// (a principal submatrix of a checked matrix: the interior block of a Craig-Bampton
    /// reduction). Errors: an empty matrix, faer's symbolic failures.
    pub fn new_prechecked(
        a: &CsMat<f64>,
        what: &str,
        options: CholeskyOptions,
    ) -> Result<Self, SparseError> {
        let n = a.rows();
        if n == 0 {
            return Err(SparseError::InvalidArgument(format!(
                "{what} is empty (0 x 0): nothing to factorize"
            )));
        }
        let a = as_csc(a);
        let col_ptr = a.proper_indptr();
        let structure = SymbolicSparseColMatRef::new_checked(n, n, &col_ptr[..], None, a.indices());
        let factorization_error = |e: faer::sparse::FaerError| SparseError::Factorization {
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
    /// ([`SparseError::NotPositiveDefinite`], index in `a`'s numbering).
    pub fn factorize(self, a: &CsMat<f64>) -> Result<SparseCholesky, SparseError> {
        let (n, what, symbolic) = (self.n, self.what, self.symbolic);
        if a.rows() != n || a.cols() != n {
            return Err(SparseError::DimensionMismatch {
                what: format!("order of {what} compared with its symbolic analysis"),
                expected: n,
                found: a.rows(),
            });
        }
        let l_values = numeric_llt(&symbolic, a, &what, self.par, self.ordering)?;
        let workspace = MemBuffer::try_new(symbolic.solve_in_place_scratch::<f64>(1, Par::Seq))
            .map_err(|_| SparseError::Factorization {
                what: what.clone(),
                message: "out of memory for the solve workspace".to_string(),
            })?;
        Ok(SparseCholesky::from_parts(
            a,
            symbolic,
            l_values,
            (self.ordering, self.par),
            workspace,
        ))
    }
}
