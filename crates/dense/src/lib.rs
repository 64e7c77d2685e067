//! Dense symmetric linear algebra shared by `nlmodes-modal` (reduced models, checks of the sparse
//! eigensolvers) and `nlmodes-nnm` (linear modes of a system, the condensation basis, Hill's
//! method, the RK4 step limit): one generalized symmetric eigensolver and one symmetry tolerance.
//! A leaf crate on top of faer, so that neither of the two depends on the other
//! (docs/DESIGN.md §1).

use faer::linalg::triangular_solve::{
    solve_lower_triangular_in_place, solve_upper_triangular_in_place,
};
use faer::{Mat, MatRef, Par, Side};

/// Relative tolerance of the symmetry checks of both crates: a matrix is accepted as symmetric
/// when max |a_ij - a_ji| <= 1e-10 max |a| (and then symmetrized).
///
/// The matrices checked are symmetric by construction: finite-element assembly (asymmetry of a
/// few ulps per entry, relative 1e-16 to 1e-14), Craig-Bampton products T^T K T (1.3e-12 for K_r
/// and 1.7e-16 for M_r on the default blade, 93 138 DOFs, measured), reduced-model files (written
/// symmetrized) and analytic chains (exact). 1e-10 leaves two orders of magnitude over the worst
/// measured round-off while catching any genuine asymmetry (a wrong sign, a missing triangle, a
/// mis-assembled entry). It was modal's value and, through the reduced-model reader, already the
/// bound every matrix of the `nlmodes` pipeline met before `nnm` saw it; `nnm` alone used 1e-9.
pub const SYMMETRY_TOLERANCE: f64 = 1e-10;

/// Failures of [`generalized_eigen`].
#[derive(Debug, thiserror::Error)]
pub enum DenseError {
    /// The Cholesky factorization of M failed: M is not positive definite.
    #[error("Cholesky factorization failed ({0})")]
    NotPositiveDefinite(faer::linalg::solvers::LltError),
    /// The symmetric eigendecomposition failed.
    #[error("symmetric eigen-decomposition failed ({0:?})")]
    Eigen(faer::linalg::evd::EvdError),
    /// An eigenvalue came out NaN or infinite.
    #[error("non-finite generalized eigenvalue")]
    NonFinite,
}

impl DenseError {
    /// The failing pivot of M's Cholesky factorization (0-based), if that is the failure.
    pub fn pivot(&self) -> Option<usize> {
        match self {
            Self::NotPositiveDefinite(faer::linalg::solvers::LltError::NonPositivePivot {
                index,
            }) => Some(*index),
            _ => None,
        }
    }
}

/// All eigenpairs of K phi = lambda M phi.
pub struct GeneralizedEigen {
    /// Eigenvalues lambda in ascending order (units of K / M: rad^2/s^2 for SI matrices).
    pub values: Vec<f64>,
    /// Eigenvectors, one per column, mass-normalized (Phi^T M Phi = I to round-off), signs as
    /// the decomposition leaves them.
    pub vectors: Mat<f64>,
}

/// Solves K phi = lambda M phi for square symmetric K and SPD M of the same order (the caller
/// checks shapes, finiteness and symmetry, e.g. against [`SYMMETRY_TOLERANCE`]).
///
/// Method: M = L L^T (Cholesky), C = L^-1 K L^-T symmetrized, C = Q Lambda Q^T, Phi = L^-T Q, so
/// that Phi^T M Phi = I and Phi^T K Phi = Lambda.
pub fn generalized_eigen(
    k: MatRef<'_, f64>,
    m: MatRef<'_, f64>,
) -> Result<GeneralizedEigen, DenseError> {
    let n = k.nrows();
    if n == 0 {
        return Ok(GeneralizedEigen {
            values: Vec::new(),
            vectors: Mat::zeros(0, 0),
        });
    }
    let llt = m
        .llt(Side::Lower)
        .map_err(DenseError::NotPositiveDefinite)?;
    let l = llt.L();
    // X = L^-1 K, then C = L^-1 X^T = L^-1 K L^-T (K symmetric).
    let mut x = k.to_owned();
    solve_lower_triangular_in_place(l, x.as_mut(), Par::Seq);
    let mut c = x.transpose().to_owned();
    solve_lower_triangular_in_place(l, c.as_mut(), Par::Seq);
    symmetrize(&mut c);
    // faer 0.24's divide-and-conquer path (order >= 128) does not scale the tridiagonal matrix to
    // unit norm as LAPACK's dstedc does, and its deflation test then loses accuracy in proportion
    // to max|C| (residuals of 1e-3 at max|C| ~ 1e9, measured). Scale C by a power of two (exact in
    // floating point) to max|C| ~ 1 and scale the eigenvalues back.
    let scale = power_of_two_scale(c.as_ref());
    for j in 0..n {
        for i in 0..n {
            c[(i, j)] *= scale;
        }
    }
    let evd = c
        .self_adjoint_eigen(Side::Lower)
        .map_err(DenseError::Eigen)?;
    // faer returns the eigenvalues in nondecreasing order; the stable sort makes "ascending" a
    // guarantee of this function (and orders -0 before +0).
    let s = evd.S();
    let mut order: Vec<usize> = (0..n).collect();
    order.sort_by(|&a, &b| s[a].total_cmp(&s[b]));
    let values: Vec<f64> = order.iter().map(|&i| s[i] / scale).collect();
    if values.iter().any(|v| !v.is_finite()) {
        return Err(DenseError::NonFinite);
    }
    let u = evd.U();
    let mut vectors = Mat::<f64>::from_fn(n, n, |i, j| u[(i, order[j])]);
    solve_upper_triangular_in_place(l.transpose(), vectors.as_mut(), Par::Seq);
    Ok(GeneralizedEigen { values, vectors })
}

/// Largest absolute entry of a dense matrix (0 when empty).
pub fn max_abs(a: MatRef<'_, f64>) -> f64 {
    let mut m = 0.0_f64;
    for j in 0..a.ncols() {
        for i in 0..a.nrows() {
            m = m.max(a[(i, j)].abs());
        }
    }
    m
}

/// Replaces A by (A + A^T) / 2 (its leading square block if A is not square).
pub fn symmetrize(a: &mut Mat<f64>) {
    let n = a.nrows().min(a.ncols());
    for j in 0..n {
        for i in 0..j {
            let avg = 0.5 * (a[(i, j)] + a[(j, i)]);
            a[(i, j)] = avg;
            a[(j, i)] = avg;
        }
    }
}

/// 2^-round(log2 max|C|): multiplying by it is exact and brings max|C| to [0.7, 1.4].
fn power_of_two_scale(c: MatRef<'_, f64>) -> f64 {
    let max = max_abs(c);
    if max > 0.0 && max.is_finite() {
        2f64.powi(-(max.log2().round() as i32))
    } else {
        1.0
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A stiff chain at order 150 (faer's divide-and-conquer path) with max|C| ~ 4e9, where the
    /// unscaled decomposition lost accuracy: K = 1e9 tridiag(-1, 2, -1), M = I, eigenvalues
    /// 1e9 * 4 sin^2(k pi / (2 (n + 1))), k = 1..n. A backward-stable solver errs by about
    /// n eps ||K|| = 1.3e-4; the bound is ten times that (the unscaled path erred by ~1e6).
    #[test]
    fn a_stiff_chain_keeps_backward_accuracy() {
        let n = 150;
        let k = Mat::from_fn(n, n, |i, j| match i.abs_diff(j) {
            0 => 2e9,
            1 => -1e9,
            _ => 0.0,
        });
        let m = Mat::<f64>::identity(n, n);
        let e = generalized_eigen(k.as_ref(), m.as_ref()).unwrap();
        let bound = 10.0 * n as f64 * f64::EPSILON * 4e9;
        for (i, l) in e.values.iter().enumerate() {
            let angle = (i + 1) as f64 * std::f64::consts::PI / (2.0 * (n + 1) as f64);
            let exact = 4e9 * angle.sin().powi(2);
            assert!((l - exact).abs() <= bound, "{i}: {l} vs {exact}");
        }
        let g = e.vectors.transpose() * &m * &e.vectors;
        for i in 0..n {
            for j in 0..n {
                let expected = if i == j { 1.0 } else { 0.0 };
                assert!((g[(i, j)] - expected).abs() < 1e-12, "{i} {j}");
            }
        }
    }

    #[test]
    fn indefinite_mass_is_rejected_with_its_pivot() {
        let k = faer::mat![[1.0, 0.0], [0.0, 1.0]];
        let m = faer::mat![[1.0, 0.0], [0.0, -1.0]];
        let err = generalized_eigen(k.as_ref(), m.as_ref()).err().unwrap();
        assert_eq!(err.pivot(), Some(1), "{err}");
    }
}
