//! Generalized symmetric eigenproblems K x = lambda M x through SLEPc: Krylov-Schur with
//! shift-invert about sigma, the factor of K - sigma M by MUMPS (docs/LARGE_MODELS.md,
//! "Over MPI"), the pairs post-processed by [`crate::finish`]. [`crate::pencil::nearest_modes`]
//! uses it where the block Lanczos of [`crate::block_eigen`] does not serve (a shift other
//! than 0, more than 48 pairs, no convergence, or `-nlmodes_eigensolver krylovschur`).

use faer::Mat;

use crate::error::{DistributedError, Result};
use crate::ffi;
use crate::finish::finish_pairs;
pub use crate::finish::LocalModes;
use crate::petsc::{check, comm, int, Matrix, PETSC_DEFAULT};
use crate::restricted::Restricted;
use crate::static_solve::{direct_cholesky, Factor};

/// Relative tolerance of SLEPc's convergence test (||r|| / |lambda|) unless PETSC_OPTIONS sets
/// `-eps_tol`: the serial block Lanczos converges its Ritz estimates to 1e-10 too.
pub const EIGEN_TOLERANCE: f64 = 1e-10;

/// A solved SLEPc eigenproblem; it holds the factor of K - sigma M until dropped.
pub struct EigenSolver {
    eps: ffi::EPS,
}

impl Drop for EigenSolver {
    fn drop(&mut self) {
        // SAFETY: the handle is owned.
        unsafe {
            ffi::EPSDestroy(&mut self.eps);
        }
    }
}

impl EigenSolver {
    /// The `nev` eigenpairs of K x = lambda M x nearest `sigma` (rad^2/s^2); `what` names the
    /// problem in errors.
    pub fn solve(
        k: &Matrix,
        m: &Matrix,
        nev: usize,
        sigma: f64,
        what: &str,
    ) -> Result<(Self, LocalModes)> {
        let mut eps = std::ptr::null_mut();
        check(unsafe { ffi::EPSCreate(comm(), &mut eps) }, "EPSCreate")?;
        let solver = Self { eps };
        solver.configure(k, m, nev, sigma)?;
        check(unsafe { ffi::EPSSolve(eps) }, "EPSSolve")?;
        let (mut converged, mut iterations) = (0, 0);
        check(
            unsafe { ffi::EPSGetConverged(eps, &mut converged) },
            "EPSGetConverged",
        )?;
        check(
            unsafe { ffi::EPSGetIterationNumber(eps, &mut iterations) },
            "EPSGetIterationNumber",
        )?;
        if (converged as usize) < nev {
            return Err(DistributedError::NotConverged {
                what: what.to_string(),
                wanted: nev,
                converged: converged as usize,
                sigma,
                iterations: iterations as usize,
            });
        }
        let modes = solver.pairs(k, m, nev)?;
        tracing::info!(
            "SLEPc: {nev} eigenpairs of {what}, {iterations} Krylov-Schur restarts, largest \
             residual {:.1e}",
            modes.residuals.iter().copied().fold(0.0, f64::max)
        );
        Ok((solver, modes))
    }

    /// GHEP, Krylov-Schur, shift-invert about sigma with MUMPS; PETSC_OPTIONS last.
    fn configure(&self, k: &Matrix, m: &Matrix, nev: usize, sigma: f64) -> Result<()> {
        let eps = self.eps;
        check(
            unsafe { ffi::EPSSetOperators(eps, k.0, m.0) },
            "EPSSetOperators",
        )?;
        check(
            unsafe { ffi::EPSSetProblemType(eps, ffi::EPSProblemType::EPS_GHEP) },
            "EPSSetProblemType",
        )?;
        check(
            unsafe { ffi::EPSSetType(eps, c"krylovschur".as_ptr()) },
            "EPSSetType",
        )?;
        check(
            unsafe { ffi::EPSSetDimensions(eps, int(nev)?, PETSC_DEFAULT, PETSC_DEFAULT) },
            "EPSSetDimensions",
        )?;
        check(
            unsafe { ffi::EPSSetWhichEigenpairs(eps, ffi::EPSWhich::EPS_TARGET_MAGNITUDE) },
            "EPSSetWhichEigenpairs",
        )?;
        check(unsafe { ffi::EPSSetTarget(eps, sigma) }, "EPSSetTarget")?;
        // M is positive definite: no purification of the eigenvectors (one more solve each).
        check(
            unsafe { ffi::EPSSetPurify(eps, ffi::PetscBool::PETSC_FALSE) },
            "EPSSetPurify",
        )?;
        check(
            unsafe { ffi::EPSSetTolerances(eps, EIGEN_TOLERANCE, PETSC_DEFAULT) },
            "EPSSetTolerances",
        )?;
        let mut st = std::ptr::null_mut();
        check(unsafe { ffi::EPSGetST(eps, &mut st) }, "EPSGetST")?;
        check(
            unsafe { ffi::STSetType(st, c"sinvert".as_ptr()) },
            "STSetType",
        )?;
        let mut ksp = std::ptr::null_mut();
        check(unsafe { ffi::STGetKSP(st, &mut ksp) }, "STGetKSP")?;
        direct_cholesky(ksp)?;
        check(unsafe { ffi::EPSSetFromOptions(eps) }, "EPSSetFromOptions")
    }

    /// The first `nev` converged pairs, post-processed ([`crate::finish`]).
    fn pairs(&self, k: &Matrix, m: &Matrix, nev: usize) -> Result<LocalModes> {
        let x = k.row_vector()?;
        let mut values = Vec::with_capacity(nev);
        let mut columns = Vec::with_capacity(nev);
        for i in 0..nev {
            let (mut re, mut im) = (0.0, 0.0);
            check(
                unsafe {
                    ffi::EPSGetEigenpair(
                        self.eps,
                        int(i)?,
                        &mut re,
                        &mut im,
                        x.0,
                        std::ptr::null_mut(),
                    )
                },
                "EPSGetEigenpair",
            )?;
            values.push(re);
            columns.push(x.local()?);
        }
        let rows = columns.first().map_or(0, Vec::len);
        let vectors = Mat::from_fn(rows, nev, |r, j| columns[j][r]);
        drop(columns);
        finish_pairs(
            &Restricted::whole(k)?,
            &Restricted::whole(m)?,
            &values,
            vectors,
        )
    }

    /// The factor of K - sigma M (MUMPS), for solves with the same operator.
    pub fn factor(&self) -> Result<Factor<'_>> {
        let mut st = std::ptr::null_mut();
        check(unsafe { ffi::EPSGetST(self.eps, &mut st) }, "EPSGetST")?;
        let mut ksp = std::ptr::null_mut();
        check(unsafe { ffi::STGetKSP(st, &mut ksp) }, "STGetKSP")?;
        Factor::of(ksp)
    }
}
