//! The sparse linear solve of the static centrifugal Newton iterations, behind a small trait so
//! that the algorithm is not tied to one factorization. Two implementations with faer's sparse
//! solvers: Cholesky (the tangent of a stable equilibrium is symmetric positive definite; a
//! failed pivot is reported, which is how loss of stability shows) and LU with partial
//! pivoting (symmetric indefinite operators, e.g. K_e - Omega^2 M_spin beyond a critical speed).
//! Both keep the symbolic analysis while the sparsity pattern stays the same (it does along a
//! Newton solve: the pattern is the mesh's).

use faer::linalg::solvers::Solve;
use faer::sparse::linalg::solvers::{Llt, Lu, SymbolicLlt, SymbolicLu};
use faer::sparse::{SparseColMatRef, SymbolicSparseColMatRef};
use faer::{MatMut, Side};
use sprs::CsMat;

/// Why a linear solve failed.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[error("{0}")]
pub struct LinearSolveError(pub String);

/// Solves A x = b for a square sparse matrix A (sprs CSC, both triangles stored).
pub trait LinearSolver {
    /// Returns x = A^-1 b. Errors when A is singular (or, for a Cholesky solver, not positive
    /// definite) or the solution is not finite.
    fn solve(&mut self, a: &CsMat<f64>, b: &[f64]) -> Result<Vec<f64>, LinearSolveError>;
}

/// The CSC arrays of `a`, checked square with `b` of matching length.
fn csc_view<'a>(
    a: &'a CsMat<f64>,
    b: &[f64],
) -> Result<SparseColMatRef<'a, usize, f64>, LinearSolveError> {
    if !a.is_csc() || a.rows() != a.cols() || b.len() != a.rows() {
        return Err(LinearSolveError(format!(
            "expected a square CSC matrix and a right-hand side of its order, got a {}x{} {} \
             matrix and {} entries",
            a.rows(),
            a.cols(),
            if a.is_csc() { "CSC" } else { "CSR" },
            b.len()
        )));
    }
    let symbolic = SymbolicSparseColMatRef::new_checked(
        a.rows(),
        a.cols(),
        a.indptr().into_raw_storage(),
        None,
        a.indices(),
    );
    Ok(SparseColMatRef::new(symbolic, a.data()))
}

/// x = b solved in place by `solve`, checked finite.
fn solve_with(
    b: &[f64],
    solve: impl FnOnce(MatMut<'_, f64>),
) -> Result<Vec<f64>, LinearSolveError> {
    let mut x = b.to_vec();
    let n = x.len();
    solve(MatMut::from_column_major_slice_mut(&mut x, n, 1));
    if x.iter().all(|v| v.is_finite()) {
        Ok(x)
    } else {
        Err(LinearSolveError(
            "the solution is not finite: the matrix is numerically singular".to_string(),
        ))
    }
}

/// The pattern a symbolic factorization was computed for.
#[derive(Debug, Default)]
struct PatternKey {
    indptr: Vec<usize>,
    indices: Vec<usize>,
}

impl PatternKey {
    fn matches(&self, a: &CsMat<f64>) -> bool {
        self.indptr == a.indptr().into_raw_storage() && self.indices == a.indices()
    }
    fn of(a: &CsMat<f64>) -> Self {
        PatternKey {
            indptr: a.indptr().into_raw_storage().to_vec(),
            indices: a.indices().to_vec(),
        }
    }
}

/// Sparse Cholesky (faer, lower triangle read), symbolic analysis reused across calls with the
/// same pattern. Fails on a non-positive pivot: the matrix is not positive definite.
#[derive(Debug, Default)]
pub struct FaerCholesky {
    symbolic: Option<(PatternKey, SymbolicLlt<usize>)>,
}

impl LinearSolver for FaerCholesky {
    fn solve(&mut self, a: &CsMat<f64>, b: &[f64]) -> Result<Vec<f64>, LinearSolveError> {
        let view = csc_view(a, b)?;
        if !self
            .symbolic
            .as_ref()
            .is_some_and(|(key, _)| key.matches(a))
        {
            let sym = SymbolicLlt::try_new(view.symbolic(), Side::Lower)
                .map_err(|e| LinearSolveError(format!("symbolic Cholesky failed: {e:?}")))?;
            self.symbolic = Some((PatternKey::of(a), sym));
        }
        let sym = self
            .symbolic
            .as_ref()
            .map(|(_, s)| s.clone())
            .ok_or_else(|| LinearSolveError("no symbolic factorization".to_string()))?;
        let llt = Llt::try_new_with_symbolic(sym, view, Side::Lower).map_err(|e| {
            LinearSolveError(format!(
                "Cholesky factorization failed, not positive definite ({e:?})"
            ))
        })?;
        solve_with(b, |x| llt.solve_in_place(x))
    }
}

/// Sparse LU with partial pivoting (faer), symbolic analysis reused across calls with the same
/// pattern. For symmetric indefinite operators.
#[derive(Debug, Default)]
pub struct FaerLu {
    symbolic: Option<(PatternKey, SymbolicLu<usize>)>,
}

impl LinearSolver for FaerLu {
    fn solve(&mut self, a: &CsMat<f64>, b: &[f64]) -> Result<Vec<f64>, LinearSolveError> {
        let view = csc_view(a, b)?;
        if !self
            .symbolic
            .as_ref()
            .is_some_and(|(key, _)| key.matches(a))
        {
            let sym = SymbolicLu::try_new(view.symbolic())
                .map_err(|e| LinearSolveError(format!("symbolic LU failed: {e:?}")))?;
            self.symbolic = Some((PatternKey::of(a), sym));
        }
        let sym = self
            .symbolic
            .as_ref()
            .map(|(_, s)| s.clone())
            .ok_or_else(|| LinearSolveError("no symbolic factorization".to_string()))?;
        let lu = Lu::try_new_with_symbolic(sym, view)
            .map_err(|e| LinearSolveError(format!("LU factorization failed, singular ({e:?})")))?;
        solve_with(b, |x| lu.solve_in_place(x))
    }
}
