//! Generalized symmetric eigenproblems K x = lambda M x through SLEPc: Krylov-Schur with
//! shift-invert about sigma, the factor of K - sigma M by MUMPS (docs/LARGE_MODELS.md,
//! "Over MPI"). The pairs are post-processed as the serial solvers' ([`nlmodes_modal::Modes`]):
//! ascending, mass-normalized, each vector's largest-magnitude entry positive, relative residual
//! ||K x - lambda M x|| / (|lambda| ||M x||).
//!
//! Building block of the fixed-interface modes, the full-model modes and, later, the
//! Campbell diagram's solves at each speed ([`nearest_modes`] on the matrices at speed).
//!
//! [`nearest_modes`] chooses the method: the block Lanczos of [`crate::block_eigen`] on a
//! MUMPS factor (sigma = 0, at most [`crate::block_eigen::BLOCK_MAX_NEV`] pairs; the serial
//! path's method, with block solves), SLEPc's Krylov-Schur otherwise, when block Lanczos does
//! not converge, or when PETSC_OPTIONS holds `-nlmodes_eigensolver krylovschur`.

use crate::block_eigen::{block_modes, BLOCK_MAX_NEV};
use crate::collective::gather_to_all;
use crate::error::{DistributedError, Result};
use crate::ffi;
use crate::petsc::{check, comm, int, option_string, Matrix, Vector, PETSC_DEFAULT};
use crate::static_solve::{direct_cholesky, Factor, StaticSolver};

/// The PETSc option that chooses the eigensolver: `block_lanczos` (default) or `krylovschur`.
pub const EIGENSOLVER_OPTION: &std::ffi::CStr = c"-nlmodes_eigensolver";

/// The solver that holds the factor of K - sigma M after an eigen-solve.
pub enum ShiftInvert {
    /// Block Lanczos on the factor of K (sigma = 0).
    BlockLanczos(StaticSolver),
    /// SLEPc's Krylov-Schur, which holds the factor in its spectral transformation.
    KrylovSchur(EigenSolver),
}

impl ShiftInvert {
    /// The factor of K - sigma M, for solves with the same operator.
    pub fn factor(&self) -> Result<Factor<'_>> {
        match self {
            Self::BlockLanczos(s) => s.factor(),
            Self::KrylovSchur(e) => e.factor(),
        }
    }
}

/// The `nev` eigenpairs of K x = lambda M x nearest `sigma` (rad^2/s^2) with the solver that
/// holds the factor (module documentation for the method). `serial_index`: the serial index of
/// each local row (the block method's starting block); `what` names the problem in errors.
pub fn nearest_modes(
    k: &Matrix,
    m: &Matrix,
    nev: usize,
    sigma: f64,
    serial_index: &[usize],
    what: &str,
) -> Result<(ShiftInvert, LocalModes)> {
    let choice = option_string(EIGENSOLVER_OPTION)?;
    let block = match choice.as_deref() {
        None | Some("block_lanczos") => sigma == 0.0 && nev <= BLOCK_MAX_NEV,
        Some("krylovschur") => false,
        Some(other) => {
            return Err(DistributedError::Invalid(format!(
                "PETSc option -nlmodes_eigensolver {other}: expected block_lanczos or \
                 krylovschur"
            )))
        }
    };
    if block {
        if let Some((solver, modes)) = block_modes(k, m, nev, serial_index, what)? {
            return Ok((ShiftInvert::BlockLanczos(solver), modes));
        }
    }
    let (solver, modes) = EigenSolver::solve(k, m, nev, sigma, what)?;
    Ok((ShiftInvert::KrylovSchur(solver), modes))
}

/// Relative tolerance of SLEPc's convergence test (||r|| / |lambda|) unless PETSC_OPTIONS sets
/// `-eps_tol`: the serial block Lanczos converges its Ritz estimates to 1e-10 too.
pub const EIGEN_TOLERANCE: f64 = 1e-10;

/// Eigenpairs with the vectors' rows of this rank (the row layout of K).
pub struct LocalModes {
    /// Eigenvalues, ascending (rad^2/s^2 for SI matrices).
    pub eigenvalues: Vec<f64>,
    /// Local rows of the mass-normalized vectors, one column per pair.
    pub vectors: faer::Mat<f64>,
    /// Relative residual of each pair.
    pub residuals: Vec<f64>,
}

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

    /// The first `nev` converged pairs, post-processed (module documentation).
    fn pairs(&self, k: &Matrix, m: &Matrix, nev: usize) -> Result<LocalModes> {
        let work = Finisher::new(k, m)?;
        let mut found = Vec::with_capacity(nev);
        for i in 0..nev {
            let (mut re, mut im) = (0.0, 0.0);
            check(
                unsafe {
                    ffi::EPSGetEigenpair(
                        self.eps,
                        int(i)?,
                        &mut re,
                        &mut im,
                        work.x.0,
                        std::ptr::null_mut(),
                    )
                },
                "EPSGetEigenpair",
            )?;
            let (local, residual) = work.finish(re)?;
            found.push((re, local, residual));
        }
        Ok(sorted_modes(found))
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

/// Eigenpairs with the vectors' local rows in `vectors` (one column per value, not yet
/// normalized), post-processed as SLEPc's (module documentation).
pub fn finish_pairs(
    k: &Matrix,
    m: &Matrix,
    values: &[f64],
    vectors: &faer::Mat<f64>,
) -> Result<LocalModes> {
    let work = Finisher::new(k, m)?;
    let mut found = Vec::with_capacity(values.len());
    for (j, &lambda) in values.iter().enumerate() {
        let col: Vec<f64> = (0..vectors.nrows()).map(|r| vectors[(r, j)]).collect();
        work.x.set_local(&col)?;
        let (local, residual) = work.finish(lambda)?;
        found.push((lambda, local, residual));
    }
    Ok(sorted_modes(found))
}

/// Pairs (eigenvalue, local rows, residual) in ascending order of eigenvalue.
fn sorted_modes(mut found: Vec<(f64, Vec<f64>, f64)>) -> LocalModes {
    found.sort_by(|a, b| a.0.total_cmp(&b.0));
    let rows = found.first().map_or(0, |f| f.1.len());
    LocalModes {
        eigenvalues: found.iter().map(|f| f.0).collect(),
        vectors: faer::Mat::from_fn(rows, found.len(), |r, j| found[j].1[r]),
        residuals: found.iter().map(|f| f.2).collect(),
    }
}

/// The post-processing of one eigenvector at a time, in `x`: M-normalized, its sign fixed,
/// its relative residual.
struct Finisher<'a> {
    k: &'a Matrix,
    m: &'a Matrix,
    x: Vector,
    mx: Vector,
    kx: Vector,
}

impl<'a> Finisher<'a> {
    fn new(k: &'a Matrix, m: &'a Matrix) -> Result<Self> {
        Ok(Self {
            k,
            m,
            x: k.row_vector()?,
            mx: k.row_vector()?,
            kx: k.row_vector()?,
        })
    }

    /// The local rows of the finished vector in `x` (eigenvalue `lambda`) and its residual.
    fn finish(&self, lambda: f64) -> Result<(Vec<f64>, f64)> {
        self.m.mult(&self.x, &self.mx)?;
        let scale = 1.0 / dot(&self.x, &self.mx)?.sqrt();
        let local = self.x.local()?;
        let sign = largest_entry_sign(&local);
        let local: Vec<f64> = local.iter().map(|v| v * scale * sign).collect();
        self.x.set_local(&local)?;
        let residual = residual(self.k, self.m, &self.x, lambda, &self.mx, &self.kx)?;
        Ok((local, residual))
    }
}

/// x . y over all ranks.
fn dot(x: &Vector, y: &Vector) -> Result<f64> {
    let mut d = 0.0;
    check(unsafe { ffi::VecDot(x.0, y.0, &mut d) }, "VecDot")?;
    Ok(d)
}

/// The Euclidean norm of x over all ranks.
fn norm(x: &Vector) -> Result<f64> {
    let mut n = 0.0;
    check(
        unsafe { ffi::VecNorm(x.0, ffi::NormType_NORM_2, &mut n) },
        "VecNorm",
    )?;
    Ok(n)
}

/// +1 or -1: the sign that makes the vector's largest-magnitude entry (over all ranks; the
/// first such in rank order) positive.
fn largest_entry_sign(local: &[f64]) -> f64 {
    let best = local
        .iter()
        .copied()
        .fold(0.0f64, |b, v| if v.abs() > b.abs() { v } else { b });
    let all = gather_to_all(&[best]);
    let global = all
        .iter()
        .copied()
        .fold(0.0f64, |b, v| if v.abs() > b.abs() { v } else { b });
    if global < 0.0 {
        -1.0
    } else {
        1.0
    }
}

/// ||K x - lambda M x|| / (|lambda| ||M x||) for a normalized x (`mx`, `kx`: workspace).
fn residual(
    k: &Matrix,
    m: &Matrix,
    x: &Vector,
    lambda: f64,
    mx: &Vector,
    kx: &Vector,
) -> Result<f64> {
    m.mult(x, mx)?;
    k.mult(x, kx)?;
    let m_norm = norm(mx)?;
    check(unsafe { ffi::VecAXPY(kx.0, -lambda, mx.0) }, "VecAXPY")?;
    Ok(norm(kx)? / (lambda.abs() * m_norm))
}
