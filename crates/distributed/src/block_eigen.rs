//! Shift-invert block Lanczos over MPI: the serial block Lanczos of `nlmodes_modal`
//! (`crates/modal/src/block_lanczos.rs`, docs/LARGE_MODELS.md "The eigen-solve") run on the
//! rows of this rank, with M applied by PETSc, the blocks solved by MUMPS in one MatMatSolve
//! each, and each small matrix of inner products summed over the ranks.
//!
//! Why not SLEPc's Krylov-Schur alone: it applies the shift-invert operator to one vector at a
//! time, a pass over the MUMPS factor per vector (104 passes for 40 modes of the 234k-DOF
//! blade, 0.61 s each), where one MatMatSolve of b right-hand sides costs little more than one
//! pass (72 in 4.2 s). Same starting block as the serial path (its rows by their serial index),
//! so the Krylov spaces, and the iteration counts, are those of the serial run.

use faer::{Mat, MatMut, MatRef};
use nlmodes_modal::block_lanczos::{block_lanczos_on, starting_block, BlockProblem};
use nlmodes_modal::{EigenOptions, ModalError};

use crate::collective::{broadcast, sum_all};
use crate::eigen::EIGEN_TOLERANCE;
use crate::error::Result;
use crate::finish::{finish_pairs, LocalModes};
use crate::petsc::Matrix;
use crate::restricted::Restricted;
use crate::static_solve::Factor;

/// Largest number of pairs asked of block Lanczos: above, SLEPc's Krylov-Schur
/// (`nlmodes_modal`'s Auto uses ARPACK above the same count).
pub const BLOCK_MAX_NEV: usize = nlmodes_modal::eigen_options::AUTO_MAX_NEV;

/// The eigenproblem (K, M) at sigma = 0 as block Lanczos sees it on this rank.
struct RankBlocks<'a> {
    m: &'a Restricted<'a>,
    factor: &'a Factor<'a>,
    order: usize,
    /// The serial index (the caller's numbering of the whole problem) of each local row.
    serial_index: &'a [usize],
}

fn operator_error(e: crate::error::DistributedError) -> ModalError {
    ModalError::Operator(e.to_string())
}

impl BlockProblem for RankBlocks<'_> {
    fn order(&self) -> usize {
        self.order
    }
    fn local_rows(&self) -> usize {
        self.serial_index.len()
    }
    fn apply_m(
        &self,
        w: MatRef<'_, f64>,
        mut mw: MatMut<'_, f64>,
    ) -> std::result::Result<(), ModalError> {
        let product = self.m.apply_block(w).map_err(operator_error)?;
        mw.copy_from(&product);
        Ok(())
    }
    fn solve_block(&self, mut w: MatMut<'_, f64>) -> std::result::Result<(), ModalError> {
        let x = Matrix::dense(w.nrows(), w.ncols())
            .and_then(|b| {
                b.set_dense_local(w.as_ref())?;
                self.factor.solve_many(&b)?.dense_local()
            })
            .map_err(operator_error)?;
        w.copy_from(&x);
        Ok(())
    }
    fn sum_over_processes(&self, partial: Mat<f64>) -> Mat<f64> {
        let (rows, cols) = (partial.nrows(), partial.ncols());
        let mut flat: Vec<f64> = (0..rows * cols)
            .map(|i| partial[(i % rows, i / rows)])
            .collect();
        sum_all(&mut flat);
        // Rank 0's sums everywhere: the iteration's decisions must agree bit for bit.
        broadcast(&mut flat);
        Mat::from_fn(rows, cols, |i, j| flat[j * rows + i])
    }
    fn starting_block(&self, b: usize) -> Mat<f64> {
        let whole = starting_block(self.order, b);
        Mat::from_fn(self.serial_index.len(), b, |r, j| {
            whole[(self.serial_index[r], j)]
        })
    }
}

/// The `nev` lowest eigenpairs of K x = lambda M x (K positive definite, shift sigma = 0) by
/// block Lanczos on `factor`, the MUMPS factor of K. `serial_index`: the serial index of each
/// local row (the order of the problem is their count over the ranks). `Ok(None)` when block
/// Lanczos does not converge (the caller uses SLEPc).
pub fn block_lanczos_modes(
    factor: &Factor,
    k: &Restricted,
    m: &Restricted,
    serial_index: &[usize],
    nev: usize,
    what: &str,
) -> Result<Option<LocalModes>> {
    let mut order = [serial_index.len() as f64];
    sum_all(&mut order);
    let problem = RankBlocks {
        m,
        factor,
        order: order[0] as usize,
        serial_index,
    };
    let options = EigenOptions {
        tol: EIGEN_TOLERANCE,
        ..EigenOptions::default()
    };
    let (values, vectors) = match block_lanczos_on(&problem, 0.0, nev, &options) {
        Ok(found) => found,
        Err(e @ ModalError::BlockLanczosNoConvergence { .. }) => {
            tracing::info!("{what}: {e}; Krylov-Schur (SLEPc) instead");
            return Ok(None);
        }
        Err(e) => return Err(e.into()),
    };
    let modes = finish_pairs(k, m, &values, vectors)?;
    tracing::info!(
        "block Lanczos over MPI: {nev} eigenpairs of {what}, largest residual {:.1e}",
        modes.residuals.iter().copied().fold(0.0, f64::max)
    );
    Ok(Some(modes))
}
