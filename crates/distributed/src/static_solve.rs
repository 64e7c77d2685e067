//! Static solves through MUMPS: the sparse Cholesky (LDL^T) factor of a symmetric positive
//! definite matrix, distributed over the ranks, applied to one or many right-hand sides.
//!
//! Building block of the constraint modes K_ii^-1 K_ib and the static corrections of the
//! Craig-Bampton reduction, and of any other static solve of the full model (the prestress of
//! the speed stage: [`StaticSolver::new`] on K, then [`StaticSolver::solve`]). SLEPc's
//! Krylov-Schur factorizes through its KSP ([`direct_cholesky`]) and lends its [`Factor`].

use nlmodes_fem::{DofMap, Mesh};
use sprs::CsMat;

use crate::bridge::{gather_free, scatter_matrix, scatter_vector};
use crate::error::{DistributedError, Result};
use crate::ffi;
use crate::layout::Layout;
use crate::petsc::{check, Matrix, Vector};
use crate::session::world;

/// The options prefix of the static solver's factor, for PETSC_OPTIONS
/// (`-nlmodes_static_mat_mumps_icntl_4 2`).
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

/// A borrowed MUMPS factor: a [`StaticSolver`]'s, or the one SLEPc's spectral transformation
/// holds in its KSP.
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

/// A factorized symmetric positive definite matrix (MUMPS Cholesky) for static solves. It owns
/// the factor alone: the matrix factorized can be dropped once it is built (the factor keeps
/// MUMPS's own copy of its entries, not a reference to it).
pub struct StaticSolver {
    f: ffi::Mat,
}

impl Drop for StaticSolver {
    fn drop(&mut self) {
        // SAFETY: the handle is owned.
        unsafe {
            ffi::MatDestroy(&mut self.f);
        }
    }
}

impl StaticSolver {
    /// Factorizes `a` (flagged SPD: MUMPS's symmetric positive definite LDL^T) with MUMPS;
    /// PETSC_OPTIONS `-nlmodes_static_mat_mumps_*` set MUMPS's controls.
    pub fn new(a: &Matrix) -> Result<Self> {
        a.set_option(ffi::MatOption::MAT_SPD)?;
        let mut f = std::ptr::null_mut();
        check(
            unsafe {
                ffi::MatGetFactor(
                    a.0,
                    c"mumps".as_ptr(),
                    ffi::MatFactorType::MAT_FACTOR_CHOLESKY,
                    &mut f,
                )
            },
            "MatGetFactor (MUMPS Cholesky)",
        )?;
        let solver = Self { f };
        check(
            unsafe { ffi::MatSetOptionsPrefix(f, STATIC_PREFIX.as_ptr()) },
            "MatSetOptionsPrefix",
        )?;
        let mut info = std::mem::MaybeUninit::<ffi::MatFactorInfo>::zeroed();
        check(
            unsafe { ffi::MatFactorInfoInitialize(info.as_mut_ptr()) },
            "MatFactorInfoInitialize",
        )?;
        // SAFETY: initialized by MatFactorInfoInitialize.
        let info = unsafe { info.assume_init() };
        // MUMPS orders the matrix itself (METIS or PT-Scotch, ICNTL(7), ICNTL(28)): no IS.
        check(
            unsafe { ffi::MatCholeskyFactorSymbolic(f, a.0, std::ptr::null_mut(), &info) },
            "MatCholeskyFactorSymbolic (MUMPS analysis)",
        )?;
        check(
            unsafe { ffi::MatCholeskyFactorNumeric(f, a.0, &info) },
            "MatCholeskyFactorNumeric (MUMPS factorization)",
        )?;
        Ok(solver)
    }

    /// x = A^-1 b.
    pub fn solve(&self, b: &Vector, x: &Vector) -> Result<()> {
        check(unsafe { ffi::MatSolve(self.f, b.0, x.0) }, "MatSolve")
    }

    /// The factor, for solves with many right-hand sides.
    pub fn factor(&self) -> Result<Factor<'_>> {
        Ok(Factor {
            f: self.f,
            _owner: std::marker::PhantomData,
        })
    }
}

/// x = A^-1 b for the free-DOF matrix `a` and vector `b` held by rank 0 (`Some` there, `None`
/// on the others; collective): A sent by rows ([`scatter_matrix`]), factorized by MUMPS, x
/// gathered on rank 0 (`None` on the others). One factorization per call: the tangents of a
/// Newton solve share their pattern, but MUMPS's analysis is redone (docs/LARGE_MODELS.md).
/// The ranks share the partition of `mesh` (its free DOFs `dofs`) computed for the call.
pub fn solve_from_root(
    mesh: &Mesh,
    dofs: &DofMap,
    a: Option<&CsMat<f64>>,
    b: Option<&[f64]>,
) -> Result<Option<Vec<f64>>> {
    let world = world().ok_or_else(|| DistributedError::Invalid("no MPI session".into()))?;
    let layout = Layout::new(mesh, dofs, world)?;
    let a = scatter_matrix(a, &layout)?;
    let b = scatter_vector(&a, b, &layout)?;
    let x = a.row_vector()?;
    StaticSolver::new(&a)?.solve(&b, &x)?;
    gather_free(&x, &layout)
}
