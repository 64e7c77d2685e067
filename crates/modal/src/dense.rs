//! Dense helpers for validation and small matrices (reduced models, tiny full models): the
//! generalized symmetric eigenproblem K phi = lambda M phi is `nlmodes_dense::generalized_eigen`
//! (shared with the nnm crate), wrapped here with modal's input checks, errors and sign
//! convention.

use faer::{Mat, MatRef};
use sprs::CsMat;

use crate::error::ModalError;
pub use nlmodes_dense::{max_abs as max_abs_dense, symmetrize, SYMMETRY_TOLERANCE};

/// Dense copy of a sparse matrix (any storage order).
pub fn csmat_to_dense(a: &CsMat<f64>) -> Mat<f64> {
    let mut out = Mat::<f64>::zeros(a.rows(), a.cols());
    for (&v, (i, j)) in a.iter() {
        out[(i, j)] += v;
    }
    out
}

/// max |A - A^T| / max |A| (0 for a zero matrix): the relative asymmetry
/// (of the leading square block if A is not square).
pub fn relative_asymmetry(a: MatRef<'_, f64>) -> f64 {
    let scale = max_abs_dense(a);
    if scale == 0.0 {
        return 0.0;
    }
    let mut worst = 0.0_f64;
    for j in 0..a.nrows().min(a.ncols()) {
        for i in 0..j {
            worst = worst.max((a[(i, j)] - a[(j, i)]).abs());
        }
    }
    worst / scale
}

/// Checks that a dense matrix is square, finite and symmetric within
/// [`SYMMETRY_TOLERANCE`].
pub fn check_dense_symmetric(a: MatRef<'_, f64>, what: &str) -> Result<usize, ModalError> {
    if a.nrows() != a.ncols() {
        return Err(ModalError::NotSquare {
            what: what.to_string(),
            nrows: a.nrows(),
            ncols: a.ncols(),
        });
    }
    let n = a.nrows();
    for j in 0..n {
        for i in 0..n {
            let v = a[(i, j)];
            if !v.is_finite() {
                return Err(ModalError::NotFinite {
                    what: what.to_string(),
                    row: i,
                    col: j,
                    value: v,
                });
            }
        }
    }
    let bound = SYMMETRY_TOLERANCE * max_abs_dense(a);
    for j in 0..n {
        for i in 0..j {
            if (a[(i, j)] - a[(j, i)]).abs() > bound {
                return Err(ModalError::NotSymmetric {
                    what: what.to_string(),
                    row: i,
                    col: j,
                    a_ij: a[(i, j)],
                    a_ji: a[(j, i)],
                    tolerance: SYMMETRY_TOLERANCE,
                });
            }
        }
    }
    Ok(n)
}

/// All eigenpairs of K phi = lambda M phi for symmetric K and SPD M.
///
/// Returns the eigenvalues in ascending order (units of K / M, rad^2/s^2 for
/// SI matrices) and the eigenvectors as the columns of an n x n matrix,
/// mass-normalized (Phi^T M Phi = I to round-off) with the largest-magnitude
/// component of each vector made positive (a deterministic sign).
///
/// Errors: non-square, mismatched, non-finite or asymmetric inputs; M not
/// positive definite; eigen decomposition failure.
pub fn dense_generalized_eigen(
    k: MatRef<'_, f64>,
    m: MatRef<'_, f64>,
) -> Result<(Vec<f64>, Mat<f64>), ModalError> {
    let n = check_dense_symmetric(k, "K")?;
    let n_m = check_dense_symmetric(m, "M")?;
    if n != n_m {
        return Err(ModalError::DimensionMismatch {
            what: "order of M compared with K".to_string(),
            expected: n,
            found: n_m,
        });
    }
    let eig = nlmodes_dense::generalized_eigen(k, m).map_err(|e| match e.pivot() {
        Some(index) => ModalError::NotPositiveDefinite {
            what: "M (dense mass matrix)".to_string(),
            index,
            hint: String::new(),
        },
        None => ModalError::DenseEigen {
            what: "L^-1 K L^-T".to_string(),
        },
    })?;
    let mut phi = eig.vectors;
    for j in 0..n {
        fix_sign(phi.col_as_slice_mut(j));
    }
    Ok((eig.values, phi))
}

/// Flips the vector so that its largest-magnitude component is positive;
/// returns whether it was flipped.
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

#[cfg(test)]
mod tests {
    use super::*;

    /// Two masses m1 = 1, m2 = 2 kg, springs k1 = 3 (ground), k2 = 1 N/m between them:
    /// K = [[4, -1], [-1, 1]], M = diag(1, 2). det(K - l M) = 2 l^2 - 9 l + 3 = 0,
    /// l = (9 -+ sqrt(57)) / 4.
    #[test]
    fn two_dof_matches_characteristic_polynomial() {
        let k = faer::mat![[4.0, -1.0], [-1.0, 1.0]];
        let m = faer::mat![[1.0, 0.0], [0.0, 2.0]];
        let (lambda, phi) = dense_generalized_eigen(k.as_ref(), m.as_ref()).unwrap();
        let exact = [(9.0 - 57f64.sqrt()) / 4.0, (9.0 + 57f64.sqrt()) / 4.0];
        for (l, e) in lambda.iter().zip(exact) {
            // Backward-stable dense eigensolver on a well-conditioned 2x2: a few ulps.
            assert!((l - e).abs() < 1e-14 * e.abs(), "{l} vs {e}");
        }
        let g = phi.transpose() * &m * &phi;
        for i in 0..2 {
            for j in 0..2 {
                let expected = if i == j { 1.0 } else { 0.0 };
                assert!((g[(i, j)] - expected).abs() < 1e-14);
            }
        }
    }

    #[test]
    fn indefinite_mass_is_rejected() {
        let k = faer::mat![[1.0, 0.0], [0.0, 1.0]];
        let m = faer::mat![[1.0, 0.0], [0.0, -1.0]];
        let err = dense_generalized_eigen(k.as_ref(), m.as_ref()).unwrap_err();
        assert!(
            matches!(err, ModalError::NotPositiveDefinite { index: 1, .. }),
            "{err}"
        );
    }
}
