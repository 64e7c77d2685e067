//! A matrix restricted to some of its rows and the same columns, applied through the whole
//! matrix: K_ii x = (K [x; 0])_i for the interior DOFs i of the Craig-Bampton reduction. The
//! interior rows of a rank are among its own rows (`Layout`), so extending by zeros and
//! restricting are local copies, and K_ii and M_ii need not be held beside K and M during the
//! eigen-solve (0.45 GB each per rank for the 1M-DOF blade on 2 ranks, docs/LARGE_MODELS.md).

use faer::{Mat, MatRef};

use crate::collective::sum_all;
use crate::error::Result;
use crate::petsc::Matrix;

/// The rows `rows` (positions among this rank's own rows, ascending) of a distributed square
/// matrix, and the same columns.
pub struct Restricted<'a> {
    full: &'a Matrix,
    rows: Vec<usize>,
    owned: usize,
}

impl<'a> Restricted<'a> {
    /// The block of `full` on the local rows `rows` (positions among the owned rows).
    pub fn new(full: &'a Matrix, rows: Vec<usize>) -> Result<Self> {
        let owned = full.owned_rows()?.len();
        Ok(Self { full, rows, owned })
    }

    /// The whole of `full`.
    pub fn whole(full: &'a Matrix) -> Result<Self> {
        let owned = full.owned_rows()?.len();
        Ok(Self {
            full,
            rows: (0..owned).collect(),
            owned,
        })
    }

    /// Local rows of the restricted matrix.
    pub fn local_rows(&self) -> usize {
        self.rows.len()
    }

    /// The local rows of A_rr w for the local rows `w` (local rows x b).
    pub fn apply_block(&self, w: MatRef<'_, f64>) -> Result<Mat<f64>> {
        let mut extended = Mat::<f64>::zeros(self.owned, w.ncols());
        for (i, &r) in self.rows.iter().enumerate() {
            for j in 0..w.ncols() {
                extended[(r, j)] = w[(i, j)];
            }
        }
        let dense = self.full.dense_like_rows(w.ncols())?;
        dense.set_dense_local(extended.as_ref())?;
        drop(extended);
        let product = self.full.times_dense(&dense)?.dense_local()?;
        Ok(Mat::from_fn(self.rows.len(), w.ncols(), |i, j| {
            product[(self.rows[i], j)]
        }))
    }

    /// The local rows of A_rr x for the local rows `x`.
    pub fn apply(&self, x: &[f64]) -> Result<Vec<f64>> {
        let ax = self.apply_block(MatRef::from_column_major_slice(x, x.len(), 1))?;
        Ok(ax.col(0).iter().copied().collect())
    }
}

/// x^T y over all ranks (local entries).
pub fn dot_all(x: &[f64], y: &[f64]) -> f64 {
    let mut s = [x.iter().zip(y).map(|(a, b)| a * b).sum::<f64>()];
    sum_all(&mut s);
    s[0]
}
