//! Linear modes of K phi = lambda M phi: eigenvalues, mass-normalized shapes
//! and residuals, as returned by the eigensolvers.

use faer::prelude::ReborrowMut;
use faer::{Mat, MatRef};
use rayon::prelude::*;
use sprs::CsMat;

use crate::error::ModalError;
use nlmodes_dense::{check_symmetric, fix_sign};
use nlmodes_sparse::ops::{norm_one, spmv_unchecked};

/// Below this value of |lambda| ||M phi|| / (||K||_1 ||phi||) a mode is
/// treated as a rigid-body (zero-frequency) mode by [`Modes::residuals`]:
/// a computed zero eigenvalue is of order machine epsilon (1e-16) relative to
/// the largest eigenvalue, while the lowest elastic eigenvalue of a fine 3-D
/// mesh is still around 1e-10 of the largest; 1e-13 separates the two.
pub const RIGID_MODE_THRESHOLD: f64 = 1e-13;

/// Eigenpairs of K phi = lambda M phi.
#[derive(Clone, Debug)]
pub struct Modes {
    /// Eigenvalues lambda = omega^2 in ascending order (rad^2/s^2 for SI matrices).
    pub eigenvalues: Vec<f64>,
    /// Mode shapes as columns (n x nev), mass-normalized: Phi^T M Phi = I.
    /// Each column's largest-magnitude component is positive.
    pub vectors: Mat<f64>,
    /// Relative residual of each pair:
    /// ||K phi - lambda M phi|| / (|lambda| ||M phi||) (Euclidean norms); for
    /// a rigid-body mode (see [`RIGID_MODE_THRESHOLD`]), where that quotient is
    /// 0/0, the backward error ||K phi - lambda M phi|| / (||K||_1 ||phi||) instead.
    pub residuals: Vec<f64>,
}

impl Modes {
    /// Natural frequencies f = sqrt(lambda) / (2 pi) in Hz (SI matrices).
    /// A negative eigenvalue (round-off on a rigid-body mode, or an unstable
    /// system) gives a negative frequency -sqrt(-lambda) / (2 pi), never NaN.
    pub fn frequencies_hz(&self) -> Vec<f64> {
        self.eigenvalues
            .iter()
            .map(|&l| l.signum() * l.abs().sqrt() / (2.0 * std::f64::consts::PI))
            .collect()
    }

    /// Number of modes.
    pub fn len(&self) -> usize {
        self.eigenvalues.len()
    }

    /// True when no mode is held.
    pub fn is_empty(&self) -> bool {
        self.eigenvalues.is_empty()
    }
}

/// Builds [`Modes`] from raw eigenpairs: sorts ascending, mass-normalizes,
/// fixes signs and computes residuals against the sparse K and M (the modes in parallel, each
/// with its own two sparse products).
pub(crate) fn finalize_modes(
    k: &CsMat<f64>,
    m: &CsMat<f64>,
    eigenvalues: &[f64],
    vectors: &Mat<f64>,
) -> Modes {
    let n = vectors.nrows();
    let count = eigenvalues.len();
    let mut order: Vec<usize> = (0..count).collect();
    order.sort_by(|&a, &b| eigenvalues[a].total_cmp(&eigenvalues[b]));
    let k_norm = norm_one(k);
    let sorted_values: Vec<f64> = order.iter().map(|&src| eigenvalues[src]).collect();
    let mut out_vectors = Mat::<f64>::zeros(n, count);
    let residuals: Vec<f64> = out_vectors
        .as_mut()
        .par_col_chunks_mut(1)
        .zip(order.par_iter())
        .map(|(mut column, &src)| {
            let phi = column
                .rb_mut()
                .col_mut(0)
                .try_as_col_major_mut()
                .map(|c| c.as_slice_mut());
            let phi = phi.expect("a column of a column-major matrix is contiguous");
            phi.copy_from_slice(vectors.col_as_slice(src));
            normalized_residual(k, m, k_norm, eigenvalues[src], phi)
        })
        .collect();
    Modes {
        eigenvalues: sorted_values,
        vectors: out_vectors,
        residuals,
    }
}

/// Mass-normalizes `phi` in place (sign fixed: largest component positive) and returns the
/// relative residual of (lambda, phi) as [`Modes::residuals`] defines it.
fn normalized_residual(
    k: &CsMat<f64>,
    m: &CsMat<f64>,
    k_norm: f64,
    lambda: f64,
    phi: &mut [f64],
) -> f64 {
    let n = phi.len();
    let mut m_phi = vec![0.0; n];
    let mut k_phi = vec![0.0; n];
    spmv_unchecked(m, phi, &mut m_phi);
    let mass = dot(phi, &m_phi);
    if mass > 0.0 {
        let scale = 1.0 / mass.sqrt();
        phi.iter_mut().for_each(|x| *x *= scale);
        m_phi.iter_mut().for_each(|x| *x *= scale);
    }
    if fix_sign(phi) {
        m_phi.iter_mut().for_each(|x| *x = -*x);
    }
    spmv_unchecked(k, phi, &mut k_phi);
    let r = k_phi
        .iter()
        .zip(&m_phi)
        .map(|(kp, mp)| (kp - lambda * mp).powi(2))
        .sum::<f64>()
        .sqrt();
    let m_phi_norm = norm2(&m_phi);
    let phi_norm = norm2(phi);
    let elastic_scale = lambda.abs() * m_phi_norm;
    if elastic_scale > RIGID_MODE_THRESHOLD * k_norm * phi_norm {
        r / elastic_scale
    } else if k_norm * phi_norm > 0.0 {
        r / (k_norm * phi_norm)
    } else {
        r
    }
}

pub(crate) fn dot(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| x * y).sum()
}

pub(crate) fn norm2(a: &[f64]) -> f64 {
    dot(a, a).sqrt()
}

/// All eigenpairs of K phi = lambda M phi for symmetric K and SPD M (`nlmodes_dense`, with this
/// crate's input checks, errors and sign convention).
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
    let n = check_symmetric(k).map_err(ModalError::symmetry("K"))?;
    let n_m = check_symmetric(m).map_err(ModalError::symmetry("M"))?;
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

#[cfg(test)]
mod dense_tests {
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
