//! LU factorization with partial pivoting of small dense matrices, in place in a reusable buffer
//! (no allocation once the size has been seen): the linear algebra of the harmonic-balance
//! Newton steps and their condensation.

use faer::dyn_stack::{MemBuffer, MemStack};
use faer::linalg::lu::partial_pivoting::{factor, solve};
use faer::perm::PermRef;
use faer::{Conj, MatMut, MatRef, Par};

/// LU factorization with partial pivoting, in place in a reusable buffer.
#[derive(Default)]
pub struct DenseLu {
    data: Vec<f64>,
    perm: Vec<usize>,
    perm_inv: Vec<usize>,
    stack: Option<MemBuffer>,
    stack_dim: usize,
    dim: usize,
    /// Smallest |U_ii| divided by the largest |a_ij| of the factored matrix.
    pub min_pivot_ratio: f64,
}

impl DenseLu {
    /// Resets the matrix to zero with dimension `n` and returns it for assembly.
    pub fn matrix(&mut self, n: usize) -> MatMut<'_, f64> {
        self.dim = n;
        self.data.clear();
        self.data.resize(n * n, 0.0);
        MatMut::from_column_major_slice_mut(&mut self.data[..], n, n)
    }

    fn ensure_stack(&mut self, n: usize) {
        if self.stack.is_none() || self.stack_dim < n {
            let req = factor::lu_in_place_scratch::<usize, f64>(n, n, Par::Seq, Default::default())
                .or(solve::solve_in_place_scratch::<usize, f64>(n, 8, Par::Seq));
            self.stack = Some(MemBuffer::new(req));
            self.stack_dim = n;
        }
    }

    /// Factors the assembled matrix in place. Returns false if it is exactly singular or not finite.
    pub fn factor(&mut self) -> bool {
        let n = self.dim;
        self.ensure_stack(n);
        let scale = self.data.iter().fold(0.0_f64, |a, v| a.max(v.abs()));
        if !scale.is_finite() {
            self.min_pivot_ratio = 0.0;
            return false;
        }
        self.perm.resize(n, 0);
        self.perm_inv.resize(n, 0);
        let Some(buffer) = self.stack.as_mut() else {
            return false;
        };
        let stack = MemStack::new(buffer);
        let a = MatMut::from_column_major_slice_mut(&mut self.data[..n * n], n, n);
        factor::lu_in_place(
            a,
            &mut self.perm[..],
            &mut self.perm_inv[..],
            Par::Seq,
            stack,
            Default::default(),
        );
        let mut min_pivot = f64::INFINITY;
        for i in 0..n {
            min_pivot = min_pivot.min(self.data[i * n + i].abs());
        }
        self.min_pivot_ratio = if n == 0 {
            1.0
        } else {
            min_pivot / scale.max(f64::MIN_POSITIVE)
        };
        self.min_pivot_ratio > 0.0 && self.min_pivot_ratio.is_finite()
    }

    /// Solves in place for the columns of `rhs` (after [`DenseLu::factor`]).
    pub fn solve_in_place(&mut self, rhs: MatMut<'_, f64>) {
        let n = self.dim;
        let ncols = rhs.ncols();
        if self.stack_dim < n || ncols > 8 {
            let req = solve::solve_in_place_scratch::<usize, f64>(n, ncols.max(8), Par::Seq).or(
                factor::lu_in_place_scratch::<usize, f64>(n, n, Par::Seq, Default::default()),
            );
            self.stack = Some(MemBuffer::new(req));
            self.stack_dim = n;
        }
        let Some(buffer) = self.stack.as_mut() else {
            return;
        };
        let stack = MemStack::new(buffer);
        let lu = MatRef::from_column_major_slice(&self.data[..n * n], n, n);
        let perm = PermRef::new_checked(&self.perm[..n], &self.perm_inv[..n], n);
        solve::solve_in_place_with_conj(lu, lu, perm, Conj::No, rhs, Par::Seq, stack);
    }

    /// Solves in place for one right-hand side stored in a slice.
    pub fn solve_slice(&mut self, rhs: &mut [f64]) {
        let n = rhs.len();
        let m = MatMut::from_column_major_slice_mut(rhs, n, 1);
        self.solve_in_place(m);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn lu_solves_a_small_system() {
        // [[4,1,0],[1,3,1],[0,1,2]] x = [1,2,3]; solution from exact rational arithmetic.
        let mut lu = DenseLu::default();
        {
            let mut a = lu.matrix(3);
            let v = [[4.0, 1.0, 0.0], [1.0, 3.0, 1.0], [0.0, 1.0, 2.0]];
            for i in 0..3 {
                for j in 0..3 {
                    a[(i, j)] = v[i][j];
                }
            }
        }
        assert!(lu.factor());
        let mut x = [1.0, 2.0, 3.0];
        lu.solve_slice(&mut x);
        // det = 18; Cramer's rule gives x = [4, 2, 26] / 18.
        let expected = [4.0 / 18.0, 2.0 / 18.0, 26.0 / 18.0];
        for i in 0..3 {
            assert!((x[i] - expected[i]).abs() < 1e-14, "{x:?}");
        }
    }
}
