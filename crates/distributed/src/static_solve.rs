//! Static solves through MUMPS: the sparse Cholesky (LDL^T) factor of a symmetric positive
//! definite matrix, distributed over the ranks, applied to one or many right-hand sides.
//!
//! Building block of the constraint modes K_ii^-1 K_ib and the static corrections of the
//! Craig-Bampton reduction, and of any other static solve of the full model (the prestress of
//! the speed stage: [`StaticSolver::new`] on K, then [`StaticSolver::solve`]).

use crate::error::Result;
use crate::ffi;
use crate::petsc::{check, comm, Matrix, Vector};

/// The options prefix of the solvers, for PETSC_OPTIONS (`-nlmodes_static_mat_mumps_icntl_4 2`).
const STATIC_PREFIX: &std::ffi::CStr = c"nlmodes_static_";

/// Sets a KSP to apply the MUMPS Cholesky factor of its operator once (preonly).
pub(crate) fn direct_cholesky(ksp: ffi::KSP) -> Result<()> {
    check(
        unsafe { ffi::KSPSetType(ksp, c"preonly".as_ptr()) },
        "KSPSetType",
    )?;
    let mut pc = std::ptr::null_mut();
    check(unsafe { ffi::KSPGetPC(ksp, &mut pc) }, "KSPGetPC")?;
    check(
        unsafe { ffi::PCSetType(pc, c"cholesky".as_ptr()) },
        "PCSetType",
    )?;
    check(
        unsafe { ffi::PCFactorSetMatSolverType(pc, c"mumps".as_ptr()) },
        "PCFactorSetMatSolverType",
    )
}

/// The MUMPS factor held by a set-up KSP.
pub struct Factor<'a> {
    f: ffi::Mat,
    _owner: std::marker::PhantomData<&'a ()>,
}

impl Factor<'_> {
    /// The factor of the operator of `ksp` (set up).
    pub(crate) fn of(ksp: ffi::KSP) -> Result<Self> {
        let mut pc = std::ptr::null_mut();
        check(unsafe { ffi::KSPGetPC(ksp, &mut pc) }, "KSPGetPC")?;
        let mut f = std::ptr::null_mut();
        check(
            unsafe { ffi::PCFactorGetMatrix(pc, &mut f) },
            "PCFactorGetMatrix",
        )?;
        Ok(Self {
            f,
            _owner: std::marker::PhantomData,
        })
    }

    /// X = A^-1 B for a dense B with the row layout of A (all columns in one MUMPS solve).
    pub fn solve_many(&self, b: &Matrix) -> Result<Matrix> {
        let (_, ncols) = b.size()?;
        let x = b.dense_like_rows(ncols)?;
        check(unsafe { ffi::MatMatSolve(self.f, b.0, x.0) }, "MatMatSolve")?;
        Ok(x)
    }
}

/// A factorized symmetric positive definite matrix (MUMPS Cholesky) for static solves.
pub struct StaticSolver {
    ksp: ffi::KSP,
}

impl Drop for StaticSolver {
    fn drop(&mut self) {
        // SAFETY: the handle is owned.
        unsafe {
            ffi::KSPDestroy(&mut self.ksp);
        }
    }
}

impl StaticSolver {
    /// Factorizes `a` (flagged SPD; its values must not change while the solver lives).
    pub fn new(a: &Matrix) -> Result<Self> {
        a.set_option(ffi::MatOption::MAT_SPD)?;
        let mut ksp = std::ptr::null_mut();
        check(unsafe { ffi::KSPCreate(comm(), &mut ksp) }, "KSPCreate")?;
        let solver = Self { ksp };
        check(
            unsafe { ffi::KSPSetOperators(ksp, a.0, a.0) },
            "KSPSetOperators",
        )?;
        direct_cholesky(ksp)?;
        check(
            unsafe { ffi::KSPSetOptionsPrefix(ksp, STATIC_PREFIX.as_ptr()) },
            "KSPSetOptionsPrefix",
        )?;
        check(unsafe { ffi::KSPSetFromOptions(ksp) }, "KSPSetFromOptions")?;
        check(
            unsafe { ffi::KSPSetUp(ksp) },
            "KSPSetUp (MUMPS factorization)",
        )?;
        Ok(solver)
    }

    /// x = A^-1 b.
    pub fn solve(&self, b: &Vector, x: &Vector) -> Result<()> {
        check(unsafe { ffi::KSPSolve(self.ksp, b.0, x.0) }, "KSPSolve")
    }

    /// The factor, for solves with many right-hand sides.
    pub fn factor(&self) -> Result<Factor<'_>> {
        Factor::of(self.ksp)
    }
}
