//! The numeric half of the sparse Cholesky factorization (faer's supernodal or simplicial LLT on
//! a symbolic analysis), the failing pivot in the caller's numbering, and the fingerprint of a
//! sparsity pattern that decides whether an analysis can be reused.

use faer::dyn_stack::{MemBuffer, MemStack};
use faer::linalg::cholesky::llt::factor::{LltError, LltRegularization};
use faer::sparse::linalg::cholesky::{SymbolicCholesky, SymbolicCholeskyRaw};
use faer::sparse::{SparseColMatRef, SymbolicSparseColMatRef};
use faer::{Par, Side, Spec};
use sprs::CsMat;

use crate::error::SparseError;
use crate::ops::as_csc;
use crate::ordering::FillOrdering;
use crate::timer::StepTimer;

/// FNV-1a over the CSC column pointers and row indices of `a` (its sparsity pattern), one
/// 64-bit word per index (byte by byte it took 50 ms at 93k DOFs, and a Newton solve checks
/// the pattern at every refactorization).
pub(crate) fn pattern_fingerprint(a: &CsMat<f64>) -> u64 {
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
pub(crate) fn numeric_llt(
    symbolic: &SymbolicCholesky<usize>,
    a: &CsMat<f64>,
    what: &str,
    par: Par,
    ordering: FillOrdering,
) -> Result<Vec<f64>, SparseError> {
    let n = a.rows();
    let start = StepTimer::start();
    let a = as_csc(a);
    let col_ptr = a.proper_indptr();
    let structure = SymbolicSparseColMatRef::new_checked(n, n, &col_ptr[..], None, a.indices());
    let out_of_memory = |part: &str| SparseError::Factorization {
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
        return Err(SparseError::NotPositiveDefinite {
            what: what.to_string(),
            index: failing_pivot(symbolic, index, n),
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
