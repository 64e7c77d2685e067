//! An M-orthonormal basis grown one vector at a time ([`MOrthonormalBasis`]), and the
//! projection T^T A T of a sparse symmetric matrix onto a dense basis ([`project_symmetric`]):
//! what the Rayleigh-Ritz model of the Campbell diagram ([`crate::ritz`]) and the enriched basis
//! of the parametric model ([`crate::enriched_basis`]) are built from (docs/ROTATION.md,
//! "Campbell diagram", "Parametric reduced model").
//!
//! Orthogonalizing in the full space keeps the projected matrices as accurate as the vectors:
//! forming V^T M V and inverting its square root would lose the digits of its condition number
//! (1e8 for modes barely changed between two speeds; docs/ROTATION.md measured 1e-8 errors).

use faer::{Mat, MatRef};
use sprs::CsMat;

use nlmodes_sparse::ops::spmm_symmetric;

/// A vector is dropped when less than this fraction of its M-norm is left after it is
/// orthogonalized (a mode repeated between two basis speeds, or one the basis already holds).
pub const DROP_TOLERANCE: f64 = 1e-8;

/// Columns q_i with q_i^T M q_j = delta_ij (to round-off), each kept with M q_i; M symmetric
/// positive definite (kg for a mass matrix), the vectors in its units' square root inverse
/// (mass-normalized: x^T M x = 1).
pub struct MOrthonormalBasis<'m> {
    m: &'m CsMat<f64>,
    columns: Vec<Vec<f64>>,
    m_columns: Vec<Vec<f64>>,
}

impl<'m> MOrthonormalBasis<'m> {
    /// An empty basis in the inner product of `m` (exactly symmetric, CSC or CSR).
    pub fn new(m: &'m CsMat<f64>) -> Self {
        Self {
            m,
            columns: Vec::new(),
            m_columns: Vec::new(),
        }
    }

    /// A basis that starts from `columns` (each of length `m.rows()`), taken as M-orthonormal
    /// already (not checked: e.g. mass-normalized fixed-interface modes).
    pub fn with_orthonormal(m: &'m CsMat<f64>, columns: Vec<Vec<f64>>) -> Self {
        let m_columns = columns.iter().map(|c| m_times(m, c)).collect();
        Self {
            m,
            columns,
            m_columns,
        }
    }

    /// Orthogonalizes `x` against the basis in the M-inner product (modified Gram-Schmidt,
    /// twice: "twice is enough", Parlett), normalizes it and adds it; drops it (returns `false`)
    /// when less than [`DROP_TOLERANCE`] of its M-norm is left (or its M-norm is zero or not
    /// finite).
    pub fn add(&mut self, mut x: Vec<f64>) -> bool {
        let original = dot(&x, &m_times(self.m, &x)).sqrt();
        for _pass in 0..2 {
            for (qi, mqi) in self.columns.iter().zip(&self.m_columns) {
                let c = dot(mqi, &x);
                x.iter_mut().zip(qi).for_each(|(a, b)| *a -= c * b);
            }
        }
        let mx = m_times(self.m, &x);
        let norm = dot(&x, &mx).sqrt();
        if norm > DROP_TOLERANCE * original {
            self.columns.push(x.iter().map(|a| a / norm).collect());
            self.m_columns.push(mx.iter().map(|a| a / norm).collect());
            true
        } else {
            false
        }
    }

    /// Number of columns.
    pub fn len(&self) -> usize {
        self.columns.len()
    }

    /// Whether it has no column.
    pub fn is_empty(&self) -> bool {
        self.columns.is_empty()
    }

    /// The columns Q (d x len, d the order of M) and M Q.
    pub fn into_matrices(self) -> (Mat<f64>, Mat<f64>) {
        let d = self.m.rows();
        (as_matrix(d, &self.columns), as_matrix(d, &self.m_columns))
    }

    /// The columns (each of length d), without M Q.
    pub fn into_columns(self) -> Vec<Vec<f64>> {
        self.columns
    }
}

/// Columns of length d as a d x len matrix.
pub(crate) fn as_matrix(d: usize, columns: &[Vec<f64>]) -> Mat<f64> {
    Mat::from_fn(d, columns.len(), |i, k| columns[k][i])
}

/// M x for one vector (the block product of [`spmm_symmetric`] on one column).
fn m_times(m: &CsMat<f64>, x: &[f64]) -> Vec<f64> {
    let d = x.len();
    let mut y = Mat::<f64>::zeros(m.rows(), 1);
    spmm_symmetric(m, Mat::from_fn(d, 1, |i, _| x[i]).as_ref(), y.as_mut());
    (0..m.rows()).map(|i| y[(i, 0)]).collect()
}

fn dot(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| x * y).sum()
}

/// A symmetric sparse matrix A on a dense basis T (d x r).
pub struct Projection {
    /// A T (d x r).
    pub times_basis: Mat<f64>,
    /// T^T A T (r x r), made exactly symmetric as (P + P^T) / 2.
    pub reduced: Mat<f64>,
}

/// A T and T^T A T (symmetrized) for an exactly symmetric sparse A (K(Omega), M: symmetric by
/// construction) and a dense basis T whose rows are A's columns (not checked beyond a debug
/// assertion: the callers build T on A's DOFs).
pub fn project_symmetric(a: &CsMat<f64>, basis: MatRef<'_, f64>) -> Projection {
    debug_assert_eq!(a.cols(), basis.nrows());
    let mut times_basis = Mat::<f64>::zeros(a.rows(), basis.ncols());
    spmm_symmetric(a, basis, times_basis.as_mut());
    let reduced = basis.transpose() * &times_basis;
    let reduced = (&reduced + reduced.transpose()) * faer::Scale(0.5);
    Projection {
        times_basis,
        reduced,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use sprs::TriMat;

    /// A diagonal mass diag(1, 2, ..., n), kg.
    fn diagonal_mass(n: usize) -> CsMat<f64> {
        let mut t = TriMat::new((n, n));
        for i in 0..n {
            t.add_triplet(i, i, (i + 1) as f64);
        }
        t.to_csc()
    }

    /// Q^T M Q = I to round-off; a vector in the span already (a combination of two added
    /// ones) is dropped, a vector of zeros too.
    #[test]
    fn columns_are_m_orthonormal_and_dependent_vectors_are_dropped() {
        let m = diagonal_mass(5);
        let mut basis = MOrthonormalBasis::new(&m);
        let a = vec![1.0, 1.0, 0.0, 2.0, -1.0];
        let b = vec![0.5, -1.0, 3.0, 0.0, 1.0];
        assert!(basis.add(a.clone()));
        assert!(basis.add(b.clone()));
        let combination: Vec<f64> = a.iter().zip(&b).map(|(x, y)| 2.0 * x - 3.0 * y).collect();
        assert!(!basis.add(combination));
        assert!(!basis.add(vec![0.0; 5]));
        assert!(basis.add(vec![0.0, 0.0, 0.0, 0.0, 1.0]));
        assert_eq!(basis.len(), 3);
        let (q, mq) = basis.into_matrices();
        let gram = q.transpose() * &mq;
        for i in 0..3 {
            for j in 0..3 {
                let expected = if i == j { 1.0 } else { 0.0 };
                assert!((gram[(i, j)] - expected).abs() < 1e-14, "{i} {j}");
            }
        }
    }

    /// T^T A T equals the dense product and is exactly symmetric.
    #[test]
    fn projection_is_the_dense_product_made_symmetric() {
        let m = diagonal_mass(4);
        let t = Mat::from_fn(4, 2, |i, j| (i as f64 + 1.0) * (j as f64 - 0.5));
        let p = project_symmetric(&m, t.as_ref());
        let dense = nlmodes_sparse::ops::csmat_to_dense(&m);
        let exact = t.transpose() * &dense * &t;
        for i in 0..2 {
            for j in 0..2 {
                assert!((p.reduced[(i, j)] - exact[(i, j)]).abs() < 1e-13);
                assert_eq!(p.reduced[(i, j)], p.reduced[(j, i)]);
            }
        }
    }
}
