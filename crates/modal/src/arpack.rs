//! Generalized symmetric eigenproblem K phi = lambda M phi by ARPACK's
//! implicitly restarted Lanczos method in shift-invert mode (`dsaupd`/`dseupd`,
//! mode 3, bmat = "G", which = "LM"): the nev eigenvalues nearest the shift
//! sigma, from the operator OP = (K - sigma M)^-1 M and the inner product of M.
//!
//! Reverse communication (DESIGN 6): ido = -1: y = (K - sigma M)^-1 M x;
//! ido = 1: y = (K - sigma M)^-1 (M x) with M x already in
//! `workd[ipntr[2] - 1 ..]`; ido = 2: y = M x. `ipntr` is 1-based, strings are
//! NUL-terminated, integers are `a_int` = i32. ARPACK keeps state in Fortran
//! SAVE variables, so every session runs under one process-wide lock.
//!
//! The factorization of K - sigma M is an LL^T Cholesky: sigma must lie below
//! the lowest eigenvalue (sigma = 0 for a clamped structure, a negative sigma
//! for a free one).
//!
//! [`EigenMethod::Auto`] (chosen in [`crate::eigen_options`]) uses the block Lanczos of [`crate::block_lanczos`] for large problems
//! (several right-hand sides per pass over the factor) and falls back to ARPACK if it does
//! not converge.

use std::ffi::CStr;
use std::sync::Mutex;

use faer::Mat;
use sprs::CsMat;

use nlmodes_sparse::SparseCholesky;

use crate::block_lanczos::block_lanczos;
use crate::eigen_options::{auto_prefers_arpack, use_dense, EigenMethod, EigenOptions};
use crate::error::ModalError;
use crate::factored::FactoredSolve;
use crate::modes::dense_generalized_eigen;
use crate::modes::{finalize_modes, Modes};
use nlmodes_sparse::ops::csmat_to_dense;
use nlmodes_sparse::ops::{check_symmetric_input, shifted, spmv_unchecked};

/// ARPACK is not reentrant (Fortran SAVE state): one session at a time.
static ARPACK_LOCK: Mutex<()> = Mutex::new(());

/// The nev eigenpairs of K phi = lambda M phi nearest the shift `sigma`
/// (rad^2/s^2 for SI matrices), ascending and mass-normalized.
///
/// Factorizes K - sigma M (must be positive definite) then runs
/// [`eigs_shift_invert_factored`].
pub fn eigs_shift_invert(
    k: &CsMat<f64>,
    m: &CsMat<f64>,
    nev: usize,
    sigma: f64,
    opts: &EigenOptions<'_>,
) -> Result<Modes, ModalError> {
    let n = check_pair(k, m)?;
    check_sigma(sigma)?;
    let ncv = resolve_ncv(nev, n, opts)?;
    if use_dense(nev, n, ncv, opts.method) {
        return dense_nearest(k, m, nev, sigma);
    }
    let what = format!("K - sigma M (sigma = {sigma:e})");
    let a = shifted(k, m, sigma)?;
    let factor = SparseCholesky::with_options(&a, &what, opts.cholesky)
        .map_err(|e| add_shift_hint(e.into()))?;
    drop(a);
    run_iterative(k, m, sigma, &factor, nev, ncv, opts)
}

/// Same as [`eigs_shift_invert`] with an existing factorization of K - sigma M (reused, e.g.,
/// by the Craig-Bampton reduction at sigma = 0: [`SparseCholesky`], or
/// [`crate::bordered::BorderedSolve`] for the full model from the interior factor).
pub fn eigs_shift_invert_factored(
    k: &CsMat<f64>,
    m: &CsMat<f64>,
    sigma: f64,
    factor: &dyn FactoredSolve,
    nev: usize,
    opts: &EigenOptions<'_>,
) -> Result<Modes, ModalError> {
    check_pair(k, m)?;
    eigs_factored_prechecked(k, m, sigma, factor, nev, opts)
}

/// [`eigs_shift_invert_factored`] for K and M already checked square, finite, symmetric and of
/// the same order (principal submatrices of checked matrices): the check reads every entry of
/// both matrices (2.6 s at a million DOFs).
pub(crate) fn eigs_factored_prechecked(
    k: &CsMat<f64>,
    m: &CsMat<f64>,
    sigma: f64,
    factor: &dyn FactoredSolve,
    nev: usize,
    opts: &EigenOptions<'_>,
) -> Result<Modes, ModalError> {
    let n = k.rows();
    let ncv = check_factored_problem(n, sigma, factor, nev, opts)?;
    if use_dense(nev, n, ncv, opts.method) {
        return dense_nearest(k, m, nev, sigma);
    }
    run_iterative(k, m, sigma, factor, nev, ncv, opts)
}

/// The checks shared by the factored entry points (the shift, the factor's order against K's
/// order n); returns the Lanczos basis size ncv.
fn check_factored_problem(
    n: usize,
    sigma: f64,
    factor: &dyn FactoredSolve,
    nev: usize,
    opts: &EigenOptions<'_>,
) -> Result<usize, ModalError> {
    check_sigma(sigma)?;
    if factor.order() != n {
        return Err(ModalError::DimensionMismatch {
            what: "order of the factorization of K - sigma M compared with K".to_string(),
            expected: n,
            found: factor.order(),
        });
    }
    resolve_ncv(nev, n, opts)
}

/// [`eigs_factored_prechecked`] for a K needed only for the residuals of the modes: on the
/// iterative path `k` is dropped before the iteration and `rebuild_k` called once the solver's
/// basis is freed, so that K and the basis are never in memory together (K_ii of a
/// million-DOF blade is 1.2 GB; the Craig-Bampton reduction rebuilds it from K).
pub(crate) fn eigs_factored_deferred_k(
    k: CsMat<f64>,
    rebuild_k: &dyn Fn() -> CsMat<f64>,
    m: &CsMat<f64>,
    sigma: f64,
    factor: &dyn FactoredSolve,
    nev: usize,
    opts: &EigenOptions<'_>,
) -> Result<Modes, ModalError> {
    let n = k.rows();
    let ncv = check_factored_problem(n, sigma, factor, nev, opts)?;
    if use_dense(nev, n, ncv, opts.method) {
        return dense_nearest(&k, m, nev, sigma);
    }
    drop(k);
    let (values, vectors) = run_iterative_unfinished(m, sigma, factor, nev, ncv, opts)?;
    let k = rebuild_k();
    Ok(finalize_modes(&k, m, &values, &vectors))
}

/// Block Lanczos or ARPACK, as `opts.method` says (Auto: block Lanczos, ARPACK if it fails),
/// with the modes finished against K and M ([`finalize_modes`]).
fn run_iterative(
    k: &CsMat<f64>,
    m: &CsMat<f64>,
    sigma: f64,
    factor: &dyn FactoredSolve,
    nev: usize,
    ncv: usize,
    opts: &EigenOptions<'_>,
) -> Result<Modes, ModalError> {
    let (values, vectors) = run_iterative_unfinished(m, sigma, factor, nev, ncv, opts)?;
    Ok(finalize_modes(k, m, &values, &vectors))
}

/// The eigenvalues and eigenvectors (not yet normalized) of [`run_iterative`]; K is not needed.
fn run_iterative_unfinished(
    m: &CsMat<f64>,
    sigma: f64,
    factor: &dyn FactoredSolve,
    nev: usize,
    ncv: usize,
    opts: &EigenOptions<'_>,
) -> Result<(Vec<f64>, Mat<f64>), ModalError> {
    match opts.method {
        EigenMethod::Arpack => run_arpack(m, sigma, factor, nev, ncv, opts),
        EigenMethod::BlockLanczos => block_lanczos(m, sigma, factor, nev, opts),
        EigenMethod::Auto if auto_prefers_arpack(nev) => {
            run_arpack(m, sigma, factor, nev, ncv, opts)
        }
        EigenMethod::Auto | EigenMethod::Dense => {
            match block_lanczos(m, sigma, factor, nev, opts) {
                Err(e @ ModalError::BlockLanczosNoConvergence { .. }) => {
                    tracing::info!("{e}; falling back to ARPACK");
                    run_arpack(m, sigma, factor, nev, ncv, opts)
                }
                other => other,
            }
        }
    }
}

fn add_shift_hint(e: ModalError) -> ModalError {
    match e {
        ModalError::NotPositiveDefinite { what, index, .. } => ModalError::NotPositiveDefinite {
            what,
            index,
            hint: "; shift-invert factorizes K - sigma M by Cholesky, so sigma must lie below \
                   the lowest eigenvalue (sigma = 0 for a clamped structure, sigma < 0 for a free one)"
                .to_string(),
        },
        other => other,
    }
}

/// K and M square, finite, symmetric and of the same order; returns the order.
pub(crate) fn check_pair(k: &CsMat<f64>, m: &CsMat<f64>) -> Result<usize, ModalError> {
    let n = check_symmetric_input(k, "K")?;
    let n_m = check_symmetric_input(m, "M")?;
    if n != n_m {
        return Err(ModalError::DimensionMismatch {
            what: "order of M compared with K".to_string(),
            expected: n,
            found: n_m,
        });
    }
    Ok(n)
}

fn check_sigma(sigma: f64) -> Result<(), ModalError> {
    if sigma.is_finite() {
        Ok(())
    } else {
        Err(ModalError::InvalidArgument(format!(
            "the shift sigma must be finite, got {sigma}"
        )))
    }
}

/// Validates nev and returns ncv (number of Lanczos vectors).
fn resolve_ncv(nev: usize, n: usize, opts: &EigenOptions<'_>) -> Result<usize, ModalError> {
    let invalid = |reason: String| ModalError::InvalidEigenCount { nev, n, reason };
    if nev == 0 {
        return Err(invalid(
            "at least one eigenpair must be requested".to_string(),
        ));
    }
    if nev > n {
        return Err(invalid(
            "more eigenpairs than the order of the problem".to_string(),
        ));
    }
    if opts.method == EigenMethod::Arpack && nev >= n {
        return Err(invalid(
            "ARPACK needs nev < n (use the dense method for all eigenpairs)".to_string(),
        ));
    }
    if !(opts.tol >= 0.0 && opts.tol.is_finite()) {
        return Err(ModalError::InvalidArgument(format!(
            "the ARPACK tolerance must be finite and >= 0, got {}",
            opts.tol
        )));
    }
    if opts.max_iterations == 0 {
        return Err(ModalError::InvalidArgument(
            "the ARPACK iteration limit must be positive".to_string(),
        ));
    }
    let ncv = match opts.ncv {
        Some(ncv) => {
            if (ncv <= nev || ncv > n) && opts.method != EigenMethod::Dense {
                return Err(invalid(format!("ncv = {ncv} must satisfy nev < ncv <= n")));
            }
            ncv
        }
        None => (2 * nev + 1).max(20).min(n),
    };
    Ok(ncv)
}

/// Dense path: all eigenpairs, keep the nev nearest sigma.
fn dense_nearest(
    k: &CsMat<f64>,
    m: &CsMat<f64>,
    nev: usize,
    sigma: f64,
) -> Result<Modes, ModalError> {
    let kd = csmat_to_dense(k);
    let md = csmat_to_dense(m);
    let (values, vectors) = dense_generalized_eigen(kd.as_ref(), md.as_ref())?;
    let mut order: Vec<usize> = (0..values.len()).collect();
    order.sort_by(|&a, &b| {
        (values[a] - sigma)
            .abs()
            .total_cmp(&(values[b] - sigma).abs())
    });
    order.truncate(nev);
    let chosen: Vec<f64> = order.iter().map(|&i| values[i]).collect();
    let chosen_vectors = Mat::<f64>::from_fn(k.rows(), nev, |i, j| vectors[(i, order[j])]);
    Ok(finalize_modes(k, m, &chosen, &chosen_vectors))
}

/// Meaning of ARPACK's `dsaupd` / `dseupd` info codes (ARPACK documentation).
fn arpack_message(info: i32) -> &'static str {
    match info {
        1 => "maximum number of iterations taken",
        3 => "no shifts could be applied during an implicit restart; increase ncv",
        -1 => "n must be positive",
        -2 => "nev must be positive",
        -3 => "ncv must satisfy nev < ncv <= n",
        -4 => "the maximum number of iterations must be positive",
        -5 => "which must be one of LM, SM, LA, SA, BE",
        -6 => "bmat must be I or G",
        -7 => "lworkl is too small (needs ncv^2 + 8 ncv)",
        -8 => "error in the LAPACK tridiagonal eigenvalue computation (dsteqr)",
        -9 => "the starting vector is zero",
        -10 => "iparam[6] (mode) must be 1 to 5",
        -11 => "mode 1 is incompatible with bmat = G",
        -12 => "iparam[0] (ishift) must be 0 or 1",
        -13 => "nev and which = BE are incompatible",
        -14 => "dsaupd did not find any eigenvalue to sufficient accuracy",
        -15 => "howmny must be A or S when rvec is true",
        -16 => "howmny = S is not implemented",
        -17 => "dseupd found a different number of converged Ritz values than dsaupd",
        -9999 => "could not build a Lanczos factorization (the operator may be singular)",
        _ => "undocumented ARPACK error code",
    }
}

/// Deterministic starting vector (xorshift64 in [-1, 1]) so runs are reproducible.
fn starting_vector(n: usize) -> Vec<f64> {
    let mut state: u64 = 0x9E37_79B9_7F4A_7C15;
    (0..n)
        .map(|_| {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            (state >> 11) as f64 / (1u64 << 53) as f64 * 2.0 - 1.0
        })
        .collect()
}

fn to_a_int(value: usize, what: &str) -> Result<i32, ModalError> {
    i32::try_from(value).map_err(|_| {
        ModalError::InvalidArgument(format!("{what} = {value} exceeds ARPACK's 32-bit integers"))
    })
}

#[allow(clippy::too_many_arguments)]
fn run_arpack(
    m: &CsMat<f64>,
    sigma: f64,
    factor: &dyn FactoredSolve,
    nev: usize,
    ncv: usize,
    opts: &EigenOptions<'_>,
) -> Result<(Vec<f64>, Mat<f64>), ModalError> {
    let n = m.rows();
    let n_i = to_a_int(n, "n")?;
    let nev_i = to_a_int(nev, "nev")?;
    let ncv_i = to_a_int(ncv, "ncv")?;
    let lworkl = ncv * (ncv + 8);
    let lworkl_i = to_a_int(lworkl, "lworkl")?;
    let maxiter = to_a_int(opts.max_iterations, "max_iterations")?;

    const BMAT: &CStr = c"G";
    const WHICH: &CStr = c"LM";
    const HOWMNY: &CStr = c"A";

    let mut resid = starting_vector(n);
    let mut v = vec![0.0_f64; n * ncv];
    let mut workd = vec![0.0_f64; 3 * n];
    let mut workl = vec![0.0_f64; lworkl];
    let mut iparam = [0_i32; 11];
    iparam[0] = 1; // exact shifts
    iparam[2] = maxiter;
    iparam[3] = 1; // block size
    iparam[6] = 3; // shift-invert mode
    let mut ipntr = [0_i32; 14];
    let mut ido: i32 = 0;
    let mut info: i32 = 1; // resid holds the starting vector
    let mut x = vec![0.0_f64; n];
    let mut y = vec![0.0_f64; n];
    let mut op_count = 0usize;

    let _guard = ARPACK_LOCK.lock().unwrap_or_else(|e| e.into_inner());
    loop {
        // SAFETY: all arrays have the sizes ARPACK documents for dsaupd
        // (resid n, v n*ncv with ldv = n, workd 3n, workl lworkl >= ncv^2 + 8 ncv,
        // iparam 11, ipntr >= 11); strings are NUL-terminated.
        unsafe {
            arpack_ng_sys::dsaupd_c(
                &mut ido,
                BMAT.as_ptr(),
                n_i,
                WHICH.as_ptr(),
                nev_i,
                opts.tol,
                resid.as_mut_ptr(),
                ncv_i,
                v.as_mut_ptr(),
                n_i,
                iparam.as_mut_ptr(),
                ipntr.as_mut_ptr(),
                workd.as_mut_ptr(),
                workl.as_mut_ptr(),
                lworkl_i,
                &mut info,
            );
        }
        let slot = |p: i32| -> Result<usize, ModalError> {
            let start = usize::try_from(p - 1).unwrap_or(usize::MAX);
            if start.checked_add(n).is_none_or(|end| end > 3 * n) {
                return Err(ModalError::Arpack {
                    routine: "dsaupd",
                    info: p,
                    message: "returned a workd pointer out of range".to_string(),
                });
            }
            Ok(start)
        };
        match ido {
            -1 | 1 | 2 => {
                let xs = slot(ipntr[0])?;
                let ys = slot(ipntr[1])?;
                if ido == 1 {
                    // M x is already available in workd[ipntr[2] - 1 ..].
                    let bs = slot(ipntr[2])?;
                    y.copy_from_slice(&workd[bs..bs + n]);
                } else {
                    x.copy_from_slice(&workd[xs..xs + n]);
                    spmv_unchecked(m, &x, &mut y);
                }
                if ido != 2 {
                    factor.solve_vector(&mut y)?;
                    op_count += 1;
                    if let Some(callback) = opts.on_iteration {
                        callback(op_count);
                    }
                }
                workd[ys..ys + n].copy_from_slice(&y);
            }
            99 => break,
            other => {
                return Err(ModalError::Arpack {
                    routine: "dsaupd",
                    info: other,
                    message: format!("unexpected reverse-communication request ido = {other}"),
                })
            }
        }
    }
    let iterations = iparam[2].max(0) as usize;
    let converged = iparam[4].max(0) as usize;
    match info {
        0 => {}
        1 => {
            return Err(ModalError::NoConvergence {
                converged,
                requested: nev,
                iterations,
                max_iterations: opts.max_iterations,
                ncv,
            })
        }
        code => {
            return Err(ModalError::Arpack {
                routine: "dsaupd",
                info: code,
                message: arpack_message(code).to_string(),
            })
        }
    }

    let mut select = vec![0_i32; ncv];
    let mut d = vec![0.0_f64; nev];
    let mut z = vec![0.0_f64; n * nev];
    let mut info_e: i32 = 0;
    // SAFETY: same workspace as dsaupd; select has ncv entries, d nev,
    // z n*nev with ldz = n.
    unsafe {
        arpack_ng_sys::dseupd_c(
            1,
            HOWMNY.as_ptr(),
            select.as_mut_ptr(),
            d.as_mut_ptr(),
            z.as_mut_ptr(),
            n_i,
            sigma,
            BMAT.as_ptr(),
            n_i,
            WHICH.as_ptr(),
            nev_i,
            opts.tol,
            resid.as_mut_ptr(),
            ncv_i,
            v.as_mut_ptr(),
            n_i,
            iparam.as_mut_ptr(),
            ipntr.as_mut_ptr(),
            workd.as_mut_ptr(),
            workl.as_mut_ptr(),
            lworkl_i,
            &mut info_e,
        );
    }
    drop(_guard);
    if info_e != 0 {
        return Err(ModalError::Arpack {
            routine: "dseupd",
            info: info_e,
            message: arpack_message(info_e).to_string(),
        });
    }
    let nconv = iparam[4].max(0) as usize;
    if nconv < nev {
        return Err(ModalError::NoConvergence {
            converged: nconv,
            requested: nev,
            iterations,
            max_iterations: opts.max_iterations,
            ncv,
        });
    }
    if let Some((i, value)) = d.iter().enumerate().find(|(_, v)| !v.is_finite()) {
        return Err(ModalError::Arpack {
            routine: "dseupd",
            info: 0,
            message: format!("returned a non-finite eigenvalue {value} at position {i}"),
        });
    }
    tracing::debug!(
        "ARPACK: {nev} eigenpairs of order {n} near sigma = {sigma:e}: {iterations} restarts, \
         {op_count} solves, ncv = {ncv}"
    );
    let vectors = Mat::<f64>::from_fn(n, nev, |i, j| z[j * n + i]);
    Ok((d, vectors))
}
