//! The sparse linear solve of Newton iterations (the static centrifugal solve of
//! `nlmodes_fem::rotation`, DESIGN §9), behind a small trait so that an algorithm is not tied to
//! one factorization: [`CholeskySolver`] (the tangent of a stable equilibrium is symmetric
//! positive definite; a failed pivot is reported, which is how loss of stability shows),
//! [`crate::LuSolver`] (symmetric indefinite operators), or a distributed solver of the caller's.

use sprs::CsMat;

use crate::analysis::CholeskyOptions;
use crate::cholesky::SparseCholesky;
use crate::error::SparseError;

/// Why a linear solve failed (the factorization's message; a Newton solve reports it as a
/// singular tangent).
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[error("{0}")]
pub struct LinearSolveError(pub String);

/// Solves A x = b for a square sparse matrix A (sprs CSC, both triangles stored).
pub trait LinearSolver {
    /// Returns x = A^-1 b. Errors when A is singular (or, for a Cholesky solver, not positive
    /// definite) or the solution is not finite.
    fn solve(&mut self, a: &CsMat<f64>, b: &[f64]) -> Result<Vec<f64>, LinearSolveError>;

    /// x = A_last^-1 b on the factor of the last matrix this solver factorized, if it keeps one
    /// (`None` otherwise: the default). A Newton solve uses it for chord steps, which reuse an
    /// earlier tangent's factor while it still contracts the residual fast (DESIGN §9).
    fn solve_with_last_factor(&mut self, _b: &[f64]) -> Option<Result<Vec<f64>, LinearSolveError>> {
        None
    }
}

/// `x` when every entry is finite; otherwise the error of a numerically singular matrix.
pub(crate) fn finite_solution(x: Vec<f64>) -> Result<Vec<f64>, LinearSolveError> {
    if x.iter().all(|v| v.is_finite()) {
        Ok(x)
    } else {
        Err(LinearSolveError(
            "the solution is not finite: the matrix is numerically singular".to_string(),
        ))
    }
}

/// The [`SparseCholesky`] (METIS ordering, numeric factorization on every core) of the last
/// matrix solved, whose ordering and symbolic analysis are reused while the sparsity pattern
/// stays (along a Newton solve and a march over speeds: the mesh's pattern). With the same
/// ordering and analysis the factor is the one a fresh analysis would give, bit for bit
/// ([`SparseCholesky::refactorize`]). At 93k DOFs it factors several times faster than faer's
/// default ordering (docs/BENCHMARKS.md).
#[derive(Debug, Default)]
pub struct CholeskySolver {
    factor: Option<SparseCholesky>,
    /// Whether `factor` holds the factorization of the last matrix factorized (false after a
    /// failed refactorization).
    factor_valid: bool,
}

impl CholeskySolver {
    /// The factorization of `a` (`what` names it in messages), reusing the ordering and symbolic
    /// analysis of the last matrix factorized when `a` has its pattern. Errors: those of
    /// [`SparseCholesky::with_options`] (not square, not finite, not symmetric, not positive
    /// definite, out of memory).
    pub fn factorize(
        &mut self,
        a: &CsMat<f64>,
        what: &str,
    ) -> Result<&SparseCholesky, SparseError> {
        // A failed factorization leaves no usable factor: [`LinearSolver::solve_with_last_factor`]
        // must not solve on a half-refactorized one (the analysis is kept).
        self.factor_valid = false;
        match &mut self.factor {
            Some(f) if f.same_pattern(a) => f.refactorize(a, what)?,
            _ => {
                self.factor = None;
                let options = CholeskyOptions::default();
                self.factor = Some(SparseCholesky::with_options(a, what, options)?);
            }
        }
        self.factor_valid = true;
        self.factor
            .as_ref()
            .ok_or_else(|| SparseError::Factorization {
                what: what.to_string(),
                message: "no factor after the factorization".to_string(),
            })
    }
}

impl LinearSolver for CholeskySolver {
    /// x = A^-1 b on the factor of A ([`CholeskySolver::factorize`], A named "tangent"); a
    /// failed pivot is reported as an indefinite tangent, a non-finite solution as a singular
    /// one.
    fn solve(&mut self, a: &CsMat<f64>, b: &[f64]) -> Result<Vec<f64>, LinearSolveError> {
        let factor = self
            .factorize(a, "tangent")
            .map_err(|e| LinearSolveError(format!("Cholesky factorization failed: {e}")))?;
        let mut x = b.to_vec();
        factor
            .solve_in_place(&mut x)
            .map_err(|e| LinearSolveError(format!("Cholesky solve failed: {e}")))?;
        finite_solution(x)
    }

    /// x on the last factor ([`CholeskySolver::factorize`] or [`LinearSolver::solve`]).
    fn solve_with_last_factor(&mut self, b: &[f64]) -> Option<Result<Vec<f64>, LinearSolveError>> {
        let factor = self.factor.as_ref().filter(|_| self.factor_valid)?;
        let mut x = b.to_vec();
        Some(
            factor
                .solve_in_place(&mut x)
                .map_err(|e| LinearSolveError(format!("Cholesky solve failed: {e}")))
                .and_then(|()| finite_solution(x)),
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::LuSolver;
    use sprs::TriMat;

    /// The 1-D Laplacian tridiag(-1, 2 + shift, -1) of order n (SPD for shift > -2 (1 -
    /// cos(pi / (n + 1))), indefinite below), and with `skip` the coupling (0, 1) left out of
    /// the pattern.
    fn laplacian(n: usize, shift: f64, skip: bool) -> CsMat<f64> {
        let mut t = TriMat::new((n, n));
        for i in 0..n {
            t.add_triplet(i, i, 2.0 + shift);
            if i + 1 < n && !(skip && i == 0) {
                t.add_triplet(i, i + 1, -1.0);
                t.add_triplet(i + 1, i, -1.0);
            }
        }
        t.to_csc()
    }

    /// ||A x - b|| / ||b||.
    fn residual(a: &CsMat<f64>, x: &[f64], b: &[f64]) -> f64 {
        let mut ax = vec![0.0; b.len()];
        crate::ops::spmv(a, x, &mut ax).unwrap();
        let norm = |v: &[f64]| v.iter().map(|x| x * x).sum::<f64>().sqrt();
        let r: Vec<f64> = ax.iter().zip(b).map(|(p, q)| p - q).collect();
        norm(&r) / norm(b)
    }

    /// The reused analysis solves as a fresh factorization does, bit for bit (same ordering,
    /// same symbolic structure, same numeric kernel); another pattern is analysed anew and
    /// still solved (residuals below 1e-13: cond(A) <= 4 / shift = 40 here, so a backward-stable
    /// solve leaves about cond x eps x sqrt(n) ~ 1e-13 at most); an indefinite matrix is an
    /// error naming the failed pivot.
    #[test]
    fn cholesky_solver_reuses_its_analysis_while_the_pattern_stays() {
        let n = 200;
        let b: Vec<f64> = (0..n).map(|i| (i as f64 * 0.37).sin()).collect();
        let mut solver = CholeskySolver::default();
        for shift in [0.1, 0.25] {
            let a = laplacian(n, shift, false);
            let x = solver.solve(&a, &b).unwrap();
            let fresh = CholeskySolver::default().solve(&a, &b).unwrap();
            assert_eq!(x, fresh, "shift {shift}");
            assert!(residual(&a, &x, &b) < 1e-13);
        }
        let other = laplacian(n, 0.1, true);
        let x = solver.solve(&other, &b).unwrap();
        assert!(residual(&other, &x, &b) < 1e-13);
        let err = solver.solve(&laplacian(n, -1.0, true), &b).unwrap_err();
        assert!(err.0.contains("not positive definite"), "{err}");
    }

    /// The last factor's solve (chord steps of a Newton solve): none before a factorization;
    /// after one, the solution of the matrix factorized (bit for bit that of `solve`), also for
    /// another right-hand side; after a failed refactorization none (not the half-refactorized
    /// factor), and again after the next successful one.
    #[test]
    fn cholesky_solver_solves_on_its_last_factor_only_while_it_is_valid() {
        let n = 200;
        let b: Vec<f64> = (0..n).map(|i| (i as f64 * 0.37).sin()).collect();
        let c: Vec<f64> = (0..n).map(|i| (i as f64 * 0.11).cos()).collect();
        let mut solver = CholeskySolver::default();
        assert!(solver.solve_with_last_factor(&b).is_none());
        let a = laplacian(n, 0.1, false);
        let x = solver.solve(&a, &b).unwrap();
        assert_eq!(solver.solve_with_last_factor(&b).unwrap().unwrap(), x);
        let y = solver.solve_with_last_factor(&c).unwrap().unwrap();
        assert!(residual(&a, &y, &c) < 1e-13);
        assert!(solver.solve(&laplacian(n, -1.0, false), &b).is_err());
        assert!(solver.solve_with_last_factor(&b).is_none());
        let x = solver.solve(&a, &c).unwrap();
        assert_eq!(solver.solve_with_last_factor(&c).unwrap().unwrap(), x);
        assert!(LuSolver::default().solve_with_last_factor(&b).is_none());
    }

    /// The LU solves the indefinite tridiag(-1, 2 + shift, -1) for shift -1.5 and -1.6
    /// (eigenvalues 2 + shift - 2 cos(k pi / 201) of both signs, the smallest in magnitude
    /// about 0.01, so cond < 500), the second time on the analysis of the first; residuals below
    /// 1e-12 (a backward-stable solve leaves about cond x eps ~ 1e-13 at most). A matrix in CSR
    /// or a right-hand side of another length is refused.
    #[test]
    fn lu_solver_solves_an_indefinite_operator() {
        let n = 200;
        let b: Vec<f64> = (0..n).map(|i| (i as f64 * 0.37).cos()).collect();
        let mut solver = LuSolver::default();
        for shift in [-1.5, -1.6] {
            let a = laplacian(n, shift, false);
            let x = solver.solve(&a, &b).unwrap();
            assert!(residual(&a, &x, &b) < 1e-12, "{}", residual(&a, &x, &b));
        }
        let a = laplacian(n, -1.5, false);
        let err = solver.solve(&a.to_csr(), &b).unwrap_err();
        assert!(err.0.contains("CSR"), "{err}");
        assert!(solver.solve(&a, &b[1..]).is_err());
    }
}
