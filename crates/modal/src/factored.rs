//! The factorized operator x = A^-1 b the shift-invert eigensolvers apply: the sparse Cholesky
//! factor of K - sigma M ([`SparseCholesky`], `nlmodes-sparse`), or the factor of an interior
//! block bordered by a dense Schur complement ([`crate::bordered::BorderedSolve`]).

use faer::MatMut;
use nlmodes_sparse::SparseCholesky;

use crate::error::ModalError;

/// A factorized operator the shift-invert eigensolvers apply, x = A^-1 b (module docs).
pub trait FactoredSolve {
    /// Order of A.
    fn order(&self) -> usize;
    /// Overwrites `rhs` with A^-1 rhs.
    fn solve_vector(&self, rhs: &mut [f64]) -> Result<(), ModalError>;
    /// Overwrites every column of `rhs` (n x k) with A^-1 times it, in one pass over the factor.
    fn solve_block(&self, rhs: MatMut<'_, f64>) -> Result<(), ModalError>;
}

impl FactoredSolve for SparseCholesky {
    fn order(&self) -> usize {
        self.n()
    }
    fn solve_vector(&self, rhs: &mut [f64]) -> Result<(), ModalError> {
        Ok(self.solve_in_place(rhs)?)
    }
    fn solve_block(&self, rhs: MatMut<'_, f64>) -> Result<(), ModalError> {
        Ok(self.solve_many(rhs)?)
    }
}
