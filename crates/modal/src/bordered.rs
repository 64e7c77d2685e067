//! Solves with the whole stiffness K from the Cholesky factor of its interior block K_ii and
//! the dense Schur complement of the boundary block, so that the full model's modes (the check
//! of a Craig-Bampton reduction) need no second sparse factorization.
//!
//! With the DOFs split into interior i and boundary b and the constraint modes
//! Psi = -K_ii^-1 K_ib (see [`crate::craig_bampton`]), block elimination of K x = f gives
//!
//! * S = K_bb + K_bi Psi (the Schur complement K_bb - K_bi K_ii^-1 K_ib, n_b x n_b, SPD when K is),
//! * x_b = S^-1 (f_b + Psi^T f_i), since K_bi K_ii^-1 f_i = -Psi^T f_i,
//! * x_i = K_ii^-1 f_i + Psi x_b, since K_ii^-1 (f_i - K_ib x_b) = K_ii^-1 f_i + Psi x_b.
//!
//! One sparse solve with K_ii per right-hand side plus two dense products with Psi
//! (4 n_i n_b flops per column, against 4 nnz(L) for the triangular solves).

use faer::linalg::matmul::matmul;
use faer::linalg::solvers::{Llt, Solve};
use faer::{Accum, Mat, MatMut, MatRef, Par, Side};
use sprs::CsMat;

use crate::error::ModalError;
use crate::factored::FactoredSolve;
use nlmodes_sparse::SparseCholesky;

/// x = K^-1 f for the whole K (shift sigma = 0) from the factor of K_ii and the Schur complement.
pub struct BorderedSolve<'a> {
    interior_factor: &'a SparseCholesky,
    interior: &'a [usize],
    boundary: &'a [usize],
    psi: MatRef<'a, f64>,
    schur: Llt<f64>,
    n: usize,
}

impl<'a> BorderedSolve<'a> {
    /// From K (n x n, symmetric), the partition, the factor of K_ii, K_ib (n_i x n_b, CSC) and
    /// Psi. Errors: inconsistent sizes, S not positive definite (K singular once the interior
    /// is held by the boundary: a free structure needs a negative shift instead).
    pub fn new(
        k: &CsMat<f64>,
        interior: &'a [usize],
        boundary: &'a [usize],
        interior_factor: &'a SparseCholesky,
        k_ib: &CsMat<f64>,
        psi: MatRef<'a, f64>,
    ) -> Result<Self, ModalError> {
        let (n_i, n_b) = (interior.len(), boundary.len());
        let n = k.rows();
        if n_i + n_b != n || interior_factor.n() != n_i || psi.nrows() != n_i || psi.ncols() != n_b
        {
            return Err(ModalError::DimensionMismatch {
                what: "interior + boundary DOFs of the bordered solve compared with K".to_string(),
                expected: n,
                found: n_i + n_b,
            });
        }
        let k_bb = nlmodes_sparse::ops::submatrix_unchecked(k, boundary, boundary);
        let mut s = Mat::<f64>::zeros(n_b, n_b);
        for (&v, (p, j)) in k_bb.iter() {
            s[(p, j)] += v;
        }
        // (K_bi Psi)[p, j] = sum_r K_ib[r, p] Psi[r, j]; column p of K_ib (CSC) holds K_ib[., p].
        let k_ib = nlmodes_sparse::ops::as_csc(k_ib);
        for (p, col) in k_ib.outer_iterator().enumerate() {
            for (r, &v) in col.iter() {
                for j in 0..n_b {
                    s[(p, j)] += v * psi[(r, j)];
                }
            }
        }
        nlmodes_dense::symmetrize(&mut s);
        let schur = s
            .llt(Side::Lower)
            .map_err(|_| ModalError::NotPositiveDefinite {
                what: "the Schur complement K_bb + K_bi Psi of the boundary DOFs".to_string(),
                index: 0,
                hint: "; K must be positive definite (a clamped structure) for the full-model \
                       check at sigma = 0"
                    .to_string(),
            })?;
        Ok(Self {
            interior_factor,
            interior,
            boundary,
            psi,
            schur,
            n,
        })
    }
}

impl FactoredSolve for BorderedSolve<'_> {
    fn order(&self) -> usize {
        self.n
    }

    fn solve_vector(&self, rhs: &mut [f64]) -> Result<(), ModalError> {
        let n = rhs.len();
        self.solve_block(MatMut::from_column_major_slice_mut(rhs, n, 1))
    }

    fn solve_block(&self, mut rhs: MatMut<'_, f64>) -> Result<(), ModalError> {
        if rhs.nrows() != self.n {
            return Err(ModalError::DimensionMismatch {
                what: "right-hand side length of the bordered solve".to_string(),
                expected: self.n,
                found: rhs.nrows(),
            });
        }
        let c = rhs.ncols();
        let mut f_i = Mat::from_fn(self.interior.len(), c, |r, j| rhs[(self.interior[r], j)]);
        // g = f_b + Psi^T f_i, then x_b = S^-1 g.
        let mut x_b = Mat::from_fn(self.boundary.len(), c, |p, j| rhs[(self.boundary[p], j)]);
        matmul(
            x_b.as_mut(),
            Accum::Add,
            self.psi.transpose(),
            f_i.as_ref(),
            1.0,
            Par::Seq,
        );
        self.schur.solve_in_place(x_b.as_mut());
        // x_i = K_ii^-1 f_i + Psi x_b.
        self.interior_factor.solve_many(f_i.as_mut())?;
        matmul(
            f_i.as_mut(),
            Accum::Add,
            self.psi,
            x_b.as_ref(),
            1.0,
            Par::Seq,
        );
        for j in 0..c {
            for (r, &dof) in self.interior.iter().enumerate() {
                rhs[(dof, j)] = f_i[(r, j)];
            }
            for (p, &dof) in self.boundary.iter().enumerate() {
                rhs[(dof, j)] = x_b[(p, j)];
            }
        }
        Ok(())
    }
}
