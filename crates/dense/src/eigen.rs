//! The dense generalized symmetric eigenproblem K phi = lambda M phi (all eigenpairs, ascending,
//! mass-normalized), the Cholesky factor it rests on, and the deterministic sign convention of
//! eigenvectors.

use faer::linalg::triangular_solve::{
    solve_lower_triangular_in_place, solve_upper_triangular_in_place,
};
use faer::{Mat, MatRef, Par, Side};

use crate::symmetric::{max_abs, symmetrize};

/// Failures of [`generalized_eigen`] and [`cholesky_lower`].
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
    /// A general (nonsymmetric) eigen-decomposition failed or its input was not finite.
    #[error("eigen-decomposition of {what} failed ({detail})")]
    General { what: &'static str, detail: String },
    /// Every attempt at a general eigen-decomposition failed its check (`general`: the
    /// eigenvalues' power sums against the traces, or the pairs' residuals).
    #[error(
        "eigen-decomposition of {what} failed its check (relative error {error:.1e} > 1e-11 \
         on the matrix, its balanced form and their transposes or reversals)"
    )]
    Unchecked { what: &'static str, error: f64 },
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
/// checks shapes, finiteness and symmetry, e.g. by [`crate::check_symmetric`]).
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

/// The lower Cholesky factor L of a symmetric positive definite matrix, A = L L^T.
pub fn cholesky_lower(a: MatRef<'_, f64>) -> Result<Mat<f64>, DenseError> {
    let llt = a
        .llt(Side::Lower)
        .map_err(DenseError::NotPositiveDefinite)?;
    Ok(llt.L().to_owned())
}

/// Flips the vector so that its largest-magnitude component is positive (the first of equal
/// magnitudes decides); returns whether it was flipped.
pub fn fix_sign(v: &mut [f64]) -> bool {
    let mut best = 0.0_f64;
    let mut sign = 1.0;
    for &x in v.iter() {
        if x.abs() > best {
            best = x.abs();
            sign = x.signum();
        }
    }
    if sign < 0.0 {
        v.iter_mut().for_each(|x| *x = -*x);
        return true;
    }
    false
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

    #[test]
    fn generalized_eigen_of_a_two_mass_chain() {
        // M = diag(1, 2), K = [[3,-1],[-1,1]]: det(K - l M) = 2 l^2 - 7 l + 2 = 0
        // -> l = (7 -+ sqrt(33)) / 4.
        let k = Mat::from_fn(2, 2, |i, j| [[3.0, -1.0], [-1.0, 1.0]][i][j]);
        let m = Mat::from_fn(2, 2, |i, j| [[1.0, 0.0], [0.0, 2.0]][i][j]);
        let e = generalized_eigen(k.as_ref(), m.as_ref()).expect("eigen");
        // Backward-stable Cholesky + symmetric eigensolver: errors of a few eps x |lambda_max|.
        let (l0, l1) = ((7.0 - 33f64.sqrt()) / 4.0, (7.0 + 33f64.sqrt()) / 4.0);
        assert!((e.values[0] - l0).abs() < 1e-13, "{:?}", e.values);
        assert!((e.values[1] - l1).abs() < 1e-13, "{:?}", e.values);
        let phi = &e.vectors;
        let gram = phi.transpose() * &m * phi;
        for i in 0..2 {
            for j in 0..2 {
                let target = if i == j { 1.0 } else { 0.0 };
                assert!((gram[(i, j)] - target).abs() < 1e-13);
            }
        }
    }
}
