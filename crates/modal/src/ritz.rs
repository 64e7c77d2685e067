//! Rayleigh-Ritz on a fixed basis (docs/ROTATION.md, "Campbell diagram"): the Campbell diagram
//! solves (K(Omega), M) at every speed on one basis Q, M-orthonormal, spanning the lowest modes
//! at a few speeds ([`RitzBasis`]). With K_r = Q^T K Q (Q^T M Q = I), the Ritz pairs are
//! (lambda, x = Q y) with K_r y = lambda y: exact where the span holds the true modes (at the
//! basis speeds), upper bounds of the lowest eigenvalues everywhere (Poincare). Each pair's
//! residual ||K x - lambda M x|| / (lambda ||M x||) on the full model is returned with it, so the
//! accuracy is measured, not assumed. Units: K in N/m and M in kg give lambda = omega^2 in
//! rad^2/s^2.

use faer::{Mat, MatRef};
use sprs::CsMat;

use crate::error::ModalError;
use crate::m_orthonormal::{project_symmetric, MOrthonormalBasis};
use crate::sparse_ops::check_square;

/// The Ritz basis: Q (d x r), M-orthonormal, and M Q.
pub struct RitzBasis {
    q: Mat<f64>,
    m_q: Mat<f64>,
}

/// The lowest Ritz pairs of one stiffness on a [`RitzBasis`].
pub struct RitzModes {
    /// lambda = omega^2 (rad^2/s^2 for SI matrices), ascending.
    pub eigenvalues: Vec<f64>,
    /// Ritz coordinates y (r x n), orthonormal: the M-inner product of two modes is the dot
    /// product of their coordinates (their mass-weighted MAC is the plain MAC of y).
    pub coordinates: Mat<f64>,
    /// ||K x - lambda M x|| / (lambda ||M x||) of each mode x = Q y on the full model
    /// (Euclidean norms).
    pub residuals: Vec<f64>,
}

impl RitzBasis {
    /// The basis spanning the columns of `vectors` (each d x k_i, d the order of `m`, kg), taken
    /// in order and M-orthonormalized ([`MOrthonormalBasis`]: a column already in the span is
    /// dropped). Errors: `m` not square, a block with other than d rows, no column left.
    pub fn new(vectors: &[MatRef<'_, f64>], m: &CsMat<f64>) -> Result<Self, ModalError> {
        let d = check_square(m, "M of the Ritz basis")?;
        let mut basis = MOrthonormalBasis::new(m);
        for block in vectors {
            if block.nrows() != d {
                return Err(ModalError::DimensionMismatch {
                    what: "rows of a block of Ritz basis vectors against the order of M"
                        .to_string(),
                    expected: d,
                    found: block.nrows(),
                });
            }
            for j in 0..block.ncols() {
                basis.add(block.col(j).iter().copied().collect());
            }
        }
        if basis.is_empty() {
            return Err(ModalError::InvalidArgument(format!(
                "the Ritz basis has no vector: {} blocks of vectors, none with a nonzero, \
                 finite M-norm",
                vectors.len()
            )));
        }
        let (q, m_q) = basis.into_matrices();
        Ok(Self { q, m_q })
    }

    /// The number r of basis vectors.
    pub fn dimension(&self) -> usize {
        self.q.ncols()
    }

    /// The lowest `n` (at most r) Ritz pairs of (K, M) for the exactly symmetric stiffness `k`
    /// (N/m) on this basis, with their residuals on the full model (module docs).
    pub fn solve(&self, k: &CsMat<f64>, n: usize) -> Result<RitzModes, ModalError> {
        let d = check_square(k, "K of the Ritz solve")?;
        if d != self.q.nrows() {
            return Err(ModalError::DimensionMismatch {
                what: "order of K against the rows of the Ritz basis".to_string(),
                expected: self.q.nrows(),
                found: d,
            });
        }
        let projection = project_symmetric(k, self.q.as_ref());
        let (k_q, k_r) = (projection.times_basis, projection.reduced);
        let r = k_r.nrows();
        let identity = Mat::<f64>::identity(r, r);
        let (values, vectors) =
            crate::modes::dense_generalized_eigen(k_r.as_ref(), identity.as_ref())?;
        let n = n.min(r);
        let coordinates = vectors.subcols(0, n).to_owned();
        let residuals = (0..n)
            .map(|j| {
                let y = coordinates.col(j);
                let kx = &k_q * y;
                let mx = &self.m_q * y;
                let res = &kx - &mx * faer::Scale(values[j]);
                res.norm_l2() / (values[j].abs() * mx.norm_l2())
            })
            .collect();
        Ok(RitzModes {
            eigenvalues: values[..n].to_vec(),
            coordinates,
            residuals,
        })
    }

    /// The mass-normalized mode shapes X = Q Y (d x n) of the first `n` of `modes` (at most
    /// as many as they hold).
    pub fn shapes(&self, modes: &RitzModes, n: usize) -> Mat<f64> {
        let n = n.min(modes.coordinates.ncols());
        &self.q * modes.coordinates.subcols(0, n)
    }
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use sprs::TriMat;

    /// A fixed-fixed chain of `n` masses: K = k tridiag(-1, 2, -1) (k = 1000 N/m) and the
    /// consistent mass M = m tridiag(1, 4, 1) / 6 (m = 3 kg), both sparse. They share the
    /// eigenvectors s_j[i] = sin(i j pi / (n + 1)), i, j = 1..n, with
    /// lambda_j = k (2 - 2 cos t_j) / (m (4 + 2 cos t_j) / 6), t_j = j pi / (n + 1).
    pub(crate) fn chain(n: usize) -> (CsMat<f64>, CsMat<f64>, Vec<f64>, Mat<f64>) {
        let (k, m) = (1000.0, 3.0);
        let (mut kt, mut mt) = (TriMat::new((n, n)), TriMat::new((n, n)));
        for i in 0..n {
            kt.add_triplet(i, i, 2.0 * k);
            mt.add_triplet(i, i, 4.0 * m / 6.0);
            if i + 1 < n {
                for (a, b) in [(i, i + 1), (i + 1, i)] {
                    kt.add_triplet(a, b, -k);
                    mt.add_triplet(a, b, m / 6.0);
                }
            }
        }
        let theta = |j: usize| j as f64 * std::f64::consts::PI / (n + 1) as f64;
        let lambda = (1..=n)
            .map(|j| k * (2.0 - 2.0 * theta(j).cos()) / (m * (4.0 + 2.0 * theta(j).cos()) / 6.0))
            .collect();
        let s = Mat::from_fn(n, n, |i, j| ((i + 1) as f64 * theta(j + 1)).sin());
        (kt.to_csc(), mt.to_csc(), lambda, s)
    }

    /// A basis spanning the exact modes 1, 2 and 4 of the chain (mixed, and one of them given
    /// twice) gives their eigenvalues to round-off (1e-12 relative: the dense eigensolver's
    /// accuracy on a 3 x 3 problem of condition about 10) and residuals of round-off (1e-12).
    #[test]
    fn a_basis_holding_exact_modes_gives_them_to_round_off() {
        let (k, m, lambda, s) = chain(9);
        let mixed = Mat::from_fn(9, 4, |i, j| match j {
            0 => s[(i, 0)] + s[(i, 3)],
            1 => s[(i, 1)] - 2.0 * s[(i, 0)],
            2 => 0.5 * s[(i, 3)] + s[(i, 1)],
            _ => s[(i, 3)],
        });
        let basis = RitzBasis::new(&[mixed.as_ref()], &m).unwrap();
        assert_eq!(basis.dimension(), 3, "the repeated mode is dropped");
        let modes = basis.solve(&k, 5).unwrap();
        assert_eq!(modes.eigenvalues.len(), 3);
        for (got, exact) in modes
            .eigenvalues
            .iter()
            .zip([lambda[0], lambda[1], lambda[3]])
        {
            assert!((got - exact).abs() < 1e-12 * exact, "{got} vs {exact}");
        }
        for r in &modes.residuals {
            assert!(*r < 1e-12, "residual {r:e}");
        }
        // The shapes are mass-normalized and proportional to the exact modes.
        let x = basis.shapes(&modes, 3);
        let dense_m = crate::sparse_ops::csmat_to_dense(&m);
        let gram = x.transpose() * &dense_m * &x;
        for (j, exact) in [0, 1, 3].into_iter().enumerate() {
            assert!((gram[(j, j)] - 1.0).abs() < 1e-13);
            let (xs, ss) = (x.col(j), s.col(exact));
            let cos = (xs.transpose() * ss).abs() / (xs.norm_l2() * ss.norm_l2());
            assert!((cos - 1.0).abs() < 1e-13, "mode {exact}: cos {cos}");
        }
    }

    /// On a basis that holds no exact mode the Ritz values bound the lowest eigenvalues from
    /// above (lambda_j^Ritz >= lambda_j, Poincare), and the residuals say they are not exact.
    #[test]
    fn ritz_values_bound_the_eigenvalues_from_above() {
        let (k, m, lambda, _) = chain(12);
        let v = Mat::from_fn(12, 4, |i, j| ((i + 1) as f64).powi(j as i32 % 3) + j as f64);
        let modes = RitzBasis::new(&[v.as_ref()], &m)
            .unwrap()
            .solve(&k, 4)
            .unwrap();
        for (j, got) in modes.eigenvalues.iter().enumerate() {
            assert!(
                *got >= lambda[j] * (1.0 - 1e-14),
                "{j}: {got} < {}",
                lambda[j]
            );
            assert!(modes.residuals[j] > 1e-6);
        }
    }

    #[test]
    fn bad_input_is_a_typed_error() {
        let (k, m, _, _) = chain(5);
        let short = Mat::<f64>::zeros(4, 2);
        assert!(matches!(
            RitzBasis::new(&[short.as_ref()], &m),
            Err(ModalError::DimensionMismatch { .. })
        ));
        let zeros = Mat::<f64>::zeros(5, 2);
        assert!(matches!(
            RitzBasis::new(&[zeros.as_ref()], &m),
            Err(ModalError::InvalidArgument(_))
        ));
        let ones = Mat::<f64>::from_fn(5, 1, |_, _| 1.0);
        let basis = RitzBasis::new(&[ones.as_ref()], &m).unwrap();
        let (small, _, _, _) = chain(4);
        assert!(basis.solve(&k, 1).is_ok());
        assert!(matches!(
            basis.solve(&small, 1),
            Err(ModalError::DimensionMismatch { .. })
        ));
    }
}
