//! The eigenproblems of the distributed stages, K x = lambda M x on the whole model or on the
//! interior DOFs of the Craig-Bampton reduction, and the choice of method
//! ([`nearest_modes`]): the block Lanczos of [`crate::block_eigen`] on a MUMPS factor of K
//! (sigma = 0, at most [`BLOCK_MAX_NEV`] pairs: the serial path's method, with block solves),
//! else SLEPc's Krylov-Schur ([`crate::eigen`]), also when block Lanczos does not converge or
//! when PETSC_OPTIONS holds `-nlmodes_eigensolver krylovschur`.
//!
//! Memory: the block method factorizes K_ii (extracted for MUMPS, dropped once factorized) and
//! applies K_ii and M_ii through K and M ([`Restricted`]), so that neither block is held
//! during the eigen-solve; Krylov-Schur extracts both for SLEPc.

use crate::block_eigen::{block_lanczos_modes, BLOCK_MAX_NEV};
use crate::eigen::{EigenSolver, LocalModes};
use crate::error::{DistributedError, Result};
use crate::ffi;
use crate::petsc::{option_string, IndexSet, Matrix};
use crate::restricted::Restricted;
use crate::static_solve::{Factor, StaticSolver};

/// The PETSc option that chooses the eigensolver: `block_lanczos` (default) or `krylovschur`.
pub const EIGENSOLVER_OPTION: &std::ffi::CStr = c"-nlmodes_eigensolver";

/// K and M, whole or restricted to some rows and the same columns.
pub struct Pencil<'a> {
    k: Restricted<'a>,
    m: Restricted<'a>,
    full: [&'a Matrix; 2],
    /// The global rows of the restriction (`None`: the whole matrices).
    rows: Option<IndexSet>,
    /// The serial index of each local row (the block method's starting block).
    serial_index: Vec<usize>,
}

/// A matrix of the pencil: borrowed when whole, extracted when restricted.
enum Held<'a> {
    Borrowed(&'a Matrix),
    Extracted(Matrix),
}

impl std::ops::Deref for Held<'_> {
    type Target = Matrix;
    fn deref(&self) -> &Matrix {
        match self {
            Self::Borrowed(m) => m,
            Self::Extracted(m) => m,
        }
    }
}

impl<'a> Pencil<'a> {
    /// The whole (K, M); `serial_index`: the serial index of each local row.
    pub fn whole(k: &'a Matrix, m: &'a Matrix, serial_index: Vec<usize>) -> Result<Self> {
        Ok(Self {
            k: Restricted::whole(k)?,
            m: Restricted::whole(m)?,
            full: [k, m],
            rows: None,
            serial_index,
        })
    }

    /// (K, M) on the global rows `rows` (each rank's own rows among them, ascending) and the
    /// same columns; `serial_index`: the serial index of each of this rank's rows.
    pub fn restricted(
        k: &'a Matrix,
        m: &'a Matrix,
        rows: &[usize],
        serial_index: Vec<usize>,
    ) -> Result<Self> {
        let first = k.owned_rows()?.start;
        let local: Vec<usize> = rows.iter().map(|r| r - first).collect();
        Ok(Self {
            k: Restricted::new(k, local.clone())?,
            m: Restricted::new(m, local)?,
            full: [k, m],
            rows: Some(IndexSet::new(rows)?),
            serial_index,
        })
    }

    /// K of the pencil, applied through the whole matrix.
    pub fn k(&self) -> &Restricted<'a> {
        &self.k
    }

    /// M of the pencil, applied through the whole matrix.
    pub fn m(&self) -> &Restricted<'a> {
        &self.m
    }

    /// K (`which` = 0) or M (1) as a matrix, flagged symmetric.
    fn matrix(&self, which: usize) -> Result<Held<'a>> {
        let full = self.full[which];
        let Some(rows) = &self.rows else {
            return Ok(Held::Borrowed(full));
        };
        let block = full.submatrix(rows, rows)?;
        block.set_option(ffi::MatOption::MAT_SYMMETRIC)?;
        Ok(Held::Extracted(block))
    }

    /// The MUMPS factor of K (the extracted block is freed once factorized).
    pub fn factor_k(&self) -> Result<StaticSolver> {
        let k = self.matrix(0)?;
        StaticSolver::new(&k)
    }
}

/// The solver that holds the factor of K - sigma M after an eigen-solve.
pub enum ShiftInvert {
    /// Block Lanczos on the factor of K (sigma = 0), or no eigen-solve at all.
    Static(StaticSolver),
    /// SLEPc's Krylov-Schur, which holds the factor in its spectral transformation.
    KrylovSchur(EigenSolver),
}

impl ShiftInvert {
    /// The factor of K - sigma M, for solves with the same operator.
    pub fn factor(&self) -> Result<Factor<'_>> {
        match self {
            Self::Static(s) => s.factor(),
            Self::KrylovSchur(e) => e.factor(),
        }
    }
}

/// Whether the block method serves `nev` pairs at `sigma` (module documentation).
fn block_method(nev: usize, sigma: f64) -> Result<bool> {
    match option_string(EIGENSOLVER_OPTION)?.as_deref() {
        None | Some("block_lanczos") => Ok(sigma == 0.0 && nev <= BLOCK_MAX_NEV),
        Some("krylovschur") => Ok(false),
        Some(other) => Err(DistributedError::Invalid(format!(
            "PETSc option -nlmodes_eigensolver {other}: expected block_lanczos or krylovschur"
        ))),
    }
}

/// The `nev` eigenpairs of the pencil nearest `sigma` (rad^2/s^2) with the solver that holds
/// the factor (module documentation for the method); `what` names the problem in errors.
pub fn nearest_modes(
    pencil: &Pencil,
    nev: usize,
    sigma: f64,
    what: &str,
) -> Result<(ShiftInvert, LocalModes)> {
    if block_method(nev, sigma)? {
        let solver = pencil.factor_k()?;
        let found = block_lanczos_modes(
            &solver.factor()?,
            pencil.k(),
            pencil.m(),
            &pencil.serial_index,
            nev,
            what,
        )?;
        if let Some(modes) = found {
            return Ok((ShiftInvert::Static(solver), modes));
        }
    }
    let (k, m) = (pencil.matrix(0)?, pencil.matrix(1)?);
    let (solver, modes) = EigenSolver::solve(&k, &m, nev, sigma, what)?;
    Ok((ShiftInvert::KrylovSchur(solver), modes))
}
