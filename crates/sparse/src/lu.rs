//! Sparse LU with partial pivoting (faer) behind [`LinearSolver`], for symmetric indefinite
//! operators (K_e - Omega^2 M_spin beyond a critical speed, docs/ROTATION.md), its symbolic
//! analysis reused while the sparsity pattern stays.

use faer::linalg::solvers::Solve;
use faer::sparse::linalg::solvers::{Lu, SymbolicLu};
use faer::sparse::{SparseColMatRef, SymbolicSparseColMatRef};
use faer::MatMut;
use sprs::CsMat;

use crate::numeric::pattern_fingerprint;
use crate::solver::{finite_solution, LinearSolveError, LinearSolver};

/// Sparse LU with partial pivoting (faer's default ordering), symbolic analysis reused across
/// calls with the same pattern ([`pattern_fingerprint`]).
#[derive(Debug, Default)]
pub struct LuSolver {
    symbolic: Option<(u64, SymbolicLu<usize>)>,
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

impl LinearSolver for LuSolver {
    fn solve(&mut self, a: &CsMat<f64>, b: &[f64]) -> Result<Vec<f64>, LinearSolveError> {
        let view = csc_view(a, b)?;
        let pattern = pattern_fingerprint(a);
        let symbolic = match &self.symbolic {
            Some((key, symbolic)) if *key == pattern => symbolic.clone(),
            _ => {
                let symbolic = SymbolicLu::try_new(view.symbolic())
                    .map_err(|e| LinearSolveError(format!("symbolic LU failed: {e:?}")))?;
                self.symbolic = Some((pattern, symbolic.clone()));
                symbolic
            }
        };
        let lu = Lu::try_new_with_symbolic(symbolic, view)
            .map_err(|e| LinearSolveError(format!("LU factorization failed, singular ({e:?})")))?;
        let mut x = b.to_vec();
        let n = x.len();
        lu.solve_in_place(MatMut::from_column_major_slice_mut(&mut x, n, 1));
        finite_solution(x)
    }
}
