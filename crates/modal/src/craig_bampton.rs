//! Craig-Bampton reduction (fixed-interface component mode synthesis).
//!
//! The DOFs are split into boundary DOFs b (kept physical, in the caller's
//! order) and interior DOFs i (the rest, ascending). With
//!
//! * constraint modes Psi = -K_ii^-1 K_ib (n_i x n_b): the static interior
//!   response to a unit displacement of each boundary DOF, and
//! * fixed-interface modes Phi (n_i x n_modes): the lowest eigenpairs of
//!   K_ii phi = lambda M_ii phi, mass-normalized (Phi^T M_ii Phi = I),
//!
//! the displacement is u = T q with q = [u_b; eta] and
//! T = [[I, 0], [Psi, Phi]] (rows in the b/i partition), and the reduced
//! matrices are K_r = T^T K T, M_r = T^T M T (dense). Exactly, K_r is
//! block diagonal: [[K_bb + K_bi Psi, 0], [0, Lambda]]; M_r is full.
//!
//! One sparse factorization of K_ii serves the constraint modes (one block solve with n_b
//! right-hand sides), the shift-invert eigensolver at sigma = 0 and, when asked, the full
//! model's modes for the accuracy check ([`crate::bordered`]). Its memory, and that of the
//! rest of the reduction, is checked against the memory available after the symbolic analysis,
//! before any numeric work ([`crate::memory`]).

use faer::linalg::matmul::matmul;
use faer::{Accum, Mat, Par};
use sprs::CsMat;

use crate::arpack::{check_pair, eigs_factored_deferred_k, eigs_factored_prechecked};
use crate::bordered::BorderedSolve;
use crate::eigen_options::{eigensolver_bytes, EigenOptions};
use crate::error::ModalError;
use crate::memory::{available_bytes, check_fits, MemoryEstimate, StepTimer};
use crate::modes::dense_generalized_eigen;
use crate::modes::Modes;
use nlmodes_dense::{relative_asymmetry, symmetrize};
use nlmodes_sparse::ops::{spmm_symmetric, submatrix_unchecked};
use nlmodes_sparse::{CholeskyAnalysis, SparseCholesky};

/// A Craig-Bampton reduced model and the basis that produced it.
#[derive(Clone, Debug)]
pub struct CraigBampton {
    /// Reduced stiffness T^T K T (n_b + n_modes square, symmetrized), N/m for SI input.
    pub k_r: Mat<f64>,
    /// Reduced mass T^T M T (symmetrized), kg for SI input.
    pub m_r: Mat<f64>,
    /// Constraint modes Psi = -K_ii^-1 K_ib (n_i x n_b), dimensionless.
    pub psi: Mat<f64>,
    /// Fixed-interface modes (n_i x n_modes), Phi^T M_ii Phi = I.
    pub phi: Mat<f64>,
    /// Interior DOFs (input numbering, ascending): row r of `psi`/`phi` is DOF `interior[r]`.
    pub interior: Vec<usize>,
    /// Boundary DOFs (input numbering, caller's order): reduced coordinate j < n_b is DOF `boundary[j]`.
    pub boundary: Vec<usize>,
    /// Eigenvalues of the fixed-interface modes, ascending (rad^2/s^2 for SI input).
    pub fixed_interface_eigenvalues: Vec<f64>,
    /// max |K_r - K_r^T| / max |K_r| before symmetrization.
    pub asymmetry_k: f64,
    /// max |M_r - M_r^T| / max |M_r| before symmetrization.
    pub asymmetry_m: f64,
    /// Order of the input matrices.
    pub n_full: usize,
}

impl CraigBampton {
    /// Order of the input (full) model.
    pub fn n_full(&self) -> usize {
        self.n_full
    }

    /// Order of the reduced model: n_b + n_modes.
    pub fn n_reduced(&self) -> usize {
        self.boundary.len() + self.phi.ncols()
    }

    /// Full displacement u = T q_r (input numbering) from reduced coordinates
    /// q_r = [u_b (boundary order); eta (modal amplitudes)].
    pub fn recover(&self, q_r: &[f64]) -> Result<Vec<f64>, ModalError> {
        let n_r = self.n_reduced();
        if q_r.len() != n_r {
            return Err(ModalError::DimensionMismatch {
                what: "length of the reduced coordinate vector".to_string(),
                expected: n_r,
                found: q_r.len(),
            });
        }
        let n_b = self.boundary.len();
        let mut u = vec![0.0; self.n_full];
        for (&dof, &value) in self.boundary.iter().zip(q_r) {
            u[dof] = value;
        }
        for (r, &dof) in self.interior.iter().enumerate() {
            let mut acc = 0.0;
            for (j, &q) in q_r[..n_b].iter().enumerate() {
                acc += self.psi[(r, j)] * q;
            }
            for (j, &eta) in q_r[n_b..].iter().enumerate() {
                acc += self.phi[(r, j)] * eta;
            }
            u[dof] = acc;
        }
        Ok(u)
    }

    /// The basis T as an n_full x n_reduced matrix in input numbering:
    /// column j is the full displacement for q_r = e_j.
    pub fn recovery_basis(&self) -> Mat<f64> {
        let n_b = self.boundary.len();
        let mut t = Mat::<f64>::zeros(self.n_full, self.n_reduced());
        for (j, &dof) in self.boundary.iter().enumerate() {
            t[(dof, j)] = 1.0;
        }
        for (r, &dof) in self.interior.iter().enumerate() {
            for j in 0..n_b {
                t[(dof, j)] = self.psi[(r, j)];
            }
            for j in 0..self.phi.ncols() {
                t[(dof, n_b + j)] = self.phi[(r, j)];
            }
        }
        t
    }
}

/// Craig-Bampton reduction of (K, M) onto the `boundary` DOFs plus
/// `n_modes` fixed-interface modes (see the module documentation).
///
/// Errors: empty boundary, boundary index out of range or duplicated,
/// boundary covering every DOF, more modes than interior DOFs, K or M not
/// square/finite/symmetric or of different sizes, K_ii not positive definite
/// (structure not held once the boundary is fixed), eigensolver failures, not enough memory
/// ([`ModalError::InsufficientMemory`], checked before the numeric factorization).
pub fn craig_bampton(
    k: &CsMat<f64>,
    m: &CsMat<f64>,
    boundary: &[usize],
    n_modes: usize,
    opts: &EigenOptions<'_>,
) -> Result<CraigBampton, ModalError> {
    craig_bampton_with_check(k, m, boundary, n_modes, 0, opts).map(|(cb, _)| cb)
}

/// [`craig_bampton`], and when `check_modes > 0` also the `check_modes` lowest modes of the
/// full model (K, M) at sigma = 0, the reference of the reduction's accuracy, computed from the
/// same factorization of K_ii bordered by the Schur complement of the boundary
/// ([`BorderedSolve`]): no second sparse factorization.
pub fn craig_bampton_with_check(
    k: &CsMat<f64>,
    m: &CsMat<f64>,
    boundary: &[usize],
    n_modes: usize,
    check_modes: usize,
    opts: &EigenOptions<'_>,
) -> Result<(CraigBampton, Option<Modes>), ModalError> {
    craig_bampton_with_loads(k, m, boundary, n_modes, check_modes, &[], opts)
}

/// [`craig_bampton_with_check`] with a static correction vector for each of `loads` (full
/// vectors of the input order, force units): x = K_ii^-1 f_i, the static interior response to
/// the load with the boundary held, M_ii-orthogonalized (twice) against the fixed-interface modes
/// and the corrections before it and M_ii-normalized, appended to Phi after the modes. The basis
/// then holds K^-1 f exactly (Psi u_b + K_ii^-1 f_i), so the reduced static response to T^T f is
/// the full one to round-off: what makes a load on interior DOFs exact in the static limit
/// (issue 22). K_r stays block diagonal (K_ii-orthogonal to the modes); the correction's
/// diagonal entry x^T K_ii x is appended to `fixed_interface_eigenvalues`. A load whose
/// interior part adds nothing new (on the boundary only, or in the span already) adds no
/// vector.
pub fn craig_bampton_with_loads(
    k: &CsMat<f64>,
    m: &CsMat<f64>,
    boundary: &[usize],
    n_modes: usize,
    check_modes: usize,
    loads: &[Vec<f64>],
    opts: &EigenOptions<'_>,
) -> Result<(CraigBampton, Option<Modes>), ModalError> {
    let (n, interior) = checked_partition(k, m, boundary, n_modes)?;
    if let Some(f) = loads
        .iter()
        .find(|f| f.len() != n || f.iter().any(|v| !v.is_finite()))
    {
        return Err(ModalError::InvalidReduction(format!(
            "a static-correction load of {} values (finite ones expected, the model has {n})",
            f.len()
        )));
    }
    let (n_b, n_i) = (boundary.len(), interior.len());
    let start = StepTimer::start();

    let k_ii = submatrix_unchecked(k, &interior, &interior);
    let m_ii = submatrix_unchecked(m, &interior, &interior);
    let k_ib = submatrix_unchecked(k, &interior, boundary);
    let sizes = Sizes {
        n,
        n_b,
        n_modes,
        check_modes,
    };
    let factor = factor_interior(&k_ii, &interior, &sizes, opts)?;
    tracing::info!(
        "Craig-Bampton: partition and factorization of K_ii in {}",
        start.elapsed()
    );
    // The eigensolver's basis, its largest allocation, is freed before Psi is allocated; K_ii
    // is dropped during the iteration and rebuilt for the residuals of the modes.
    let rebuild_k_ii = || submatrix_unchecked(k, &interior, &interior);
    let (mut phi, mut fixed_interface_eigenvalues) =
        fixed_interface_modes(k_ii, &rebuild_k_ii, &m_ii, &factor, n_modes, opts)?;
    for f in loads {
        let f_i: Vec<f64> = interior.iter().map(|&d| f[d]).collect();
        if let Some((x, kxx)) = static_correction(&factor, &rebuild_k_ii(), &m_ii, &phi, &f_i)? {
            phi = append_column(&phi, &x);
            fixed_interface_eigenvalues.push(kxx);
        }
    }
    drop(m_ii);
    let psi = constraint_modes(&factor, &k_ib, n_i, n_b)?;
    let full_modes = if check_modes > 0 {
        let start = StepTimer::start();
        let bordered = BorderedSolve::new(k, &interior, boundary, &factor, &k_ib, psi.as_ref())?;
        let modes = eigs_factored_prechecked(k, m, 0.0, &bordered, check_modes, opts)?;
        tracing::info!(
            "full-model check: {check_modes} modes of the {n}-DOF model from the factor of K_ii \
             and the Schur complement of the boundary, {}",
            start.elapsed()
        );
        Some(modes)
    } else {
        None
    };
    drop(factor);

    let start = StepTimer::start();
    let (mut k_r, mut m_r) = project(k, m, boundary, &interior, &psi, &phi);
    let asymmetry_k = relative_asymmetry(k_r.as_ref());
    let asymmetry_m = relative_asymmetry(m_r.as_ref());
    tracing::info!(
        "Craig-Bampton: reduced order {} ({n_b} boundary DOFs + {n_modes} modes) from {n}; \
         asymmetry before symmetrization: K_r {asymmetry_k:.1e}, M_r {asymmetry_m:.1e}; \
         projection {}",
        n_b + n_modes,
        start.elapsed()
    );
    symmetrize(&mut k_r);
    symmetrize(&mut m_r);
    let cb = CraigBampton {
        k_r,
        m_r,
        psi,
        phi,
        interior,
        boundary: boundary.to_vec(),
        fixed_interface_eigenvalues,
        asymmetry_k,
        asymmetry_m,
        n_full: n,
    };
    Ok((cb, full_modes))
}

/// Checks K and M (square, finite, symmetric, same order; once: the steps after work on their
/// principal submatrices) and the boundary list; returns the order and the interior DOFs.
fn checked_partition(
    k: &CsMat<f64>,
    m: &CsMat<f64>,
    boundary: &[usize],
    n_modes: usize,
) -> Result<(usize, Vec<usize>), ModalError> {
    let start = StepTimer::start();
    let n = check_pair(k, m)?;
    let interior = interior_dofs(n, boundary)?;
    let (n_b, n_i) = (boundary.len(), interior.len());
    if n_modes > n_i {
        return Err(ModalError::InvalidReduction(format!(
            "{n_modes} fixed-interface modes requested but there are only {n_i} interior DOFs \
             ({n} DOFs, {n_b} on the boundary)"
        )));
    }
    tracing::info!(
        "Craig-Bampton: K and M checked (square, finite, symmetric) in {}",
        start.elapsed()
    );
    Ok((n, interior))
}

/// Sizes of a reduction, for its memory estimate.
struct Sizes {
    /// Order of the full model.
    n: usize,
    /// Boundary DOFs.
    n_b: usize,
    /// Fixed-interface modes.
    n_modes: usize,
    /// Full-model modes of the check (0: none).
    check_modes: usize,
}

/// The bytes a reduction allocates after the symbolic analysis of K_ii, in its largest phase:
/// the numeric factorization (the values of L, `l_bytes`, and faer's workspace,
/// `factor_workspace`), the eigen-solve (L and the eigensolver's allocations), the constraint
/// modes and the full-model check (L, Psi and Phi, the workspace of the n_b-column solve,
/// `solve_bytes`, and the check's eigensolver), or the projection (Psi and Phi, the basis T
/// and the products K T, M T with their row-major copies, 6 n n_r). The phases follow each
/// other, so only the largest counts: summing them overstated the need at a million DOFs by
/// about 2 GB.
fn reduction_memory(
    sizes: &Sizes,
    l_bytes: usize,
    factor_workspace: usize,
    solve_bytes: usize,
) -> MemoryEstimate {
    let f64_bytes = std::mem::size_of::<f64>();
    let n_i = sizes.n - sizes.n_b;
    let n_r = sizes.n_b + sizes.n_modes;
    let eigen = if sizes.n_modes > 0 {
        eigensolver_bytes(n_i, sizes.n_modes)
    } else {
        0
    };
    let check = if sizes.check_modes > 0 {
        eigensolver_bytes(sizes.n, sizes.check_modes) + 2 * sizes.n * f64_bytes
    } else {
        0
    };
    let basis = n_i * n_r * f64_bytes;
    let l = "factor L of K_ii";
    let phases = [
        vec![(l, l_bytes), ("factorization workspace", factor_workspace)],
        vec![(l, l_bytes), ("eigensolver", eigen)],
        vec![
            (l, l_bytes),
            ("constraint-mode solve workspace", solve_bytes),
            ("reduction basis", basis),
            ("full-model check", check),
        ],
        vec![
            ("reduction basis", basis),
            ("projection", 6 * sizes.n * n_r * f64_bytes),
        ],
    ];
    let total = |phase: &Vec<(&str, usize)>| phase.iter().map(|(_, b)| b).sum::<usize>();
    let largest = phases
        .iter()
        .max_by_key(|phase| total(phase))
        .expect("four phases");
    let mut e = MemoryEstimate::default();
    for &(what, bytes) in largest.iter().filter(|(_, bytes)| *bytes > 0) {
        e.add(what, bytes);
    }
    e
}

/// The sparse Cholesky factor of K_ii, after checking that it and the rest of the reduction fit
/// in the memory available. A non-positive pivot is reported in the input numbering.
fn factor_interior(
    k_ii: &CsMat<f64>,
    interior: &[usize],
    sizes: &Sizes,
    opts: &EigenOptions<'_>,
) -> Result<SparseCholesky, ModalError> {
    let n_i = interior.len();
    let what = format!("K_ii (stiffness of the {n_i} interior DOFs with the boundary DOFs fixed)");
    let analysis = CholeskyAnalysis::new_prechecked(k_ii, &what, opts.cholesky)?;
    let solve_bytes = analysis.solve_bytes(sizes.n_b);
    let l_bytes = analysis.nnz_l() * std::mem::size_of::<f64>();
    let estimate = reduction_memory(
        sizes,
        l_bytes,
        analysis.factorization_bytes() - l_bytes,
        solve_bytes,
    );
    check_fits(
        &format!(
            "the Craig-Bampton reduction of the {}-DOF model (nnz(L) = {} for its {n_i} interior \
             DOFs)",
            sizes.n,
            analysis.nnz_l()
        ),
        &estimate,
        available_bytes(),
    )?;
    analysis
        .factorize(k_ii)
        .map_err(|e| in_input_numbering(e.into(), interior))
}

/// A non-positive pivot of K_ii named in the input numbering (`interior` maps K_ii's rows to
/// K's), with why it happens; other errors unchanged.
fn in_input_numbering(e: ModalError, interior: &[usize]) -> ModalError {
    match e {
        ModalError::NotPositiveDefinite { what, index, .. } => ModalError::NotPositiveDefinite {
            what,
            index: interior[index],
            hint: " (index in the input numbering); the structure must be held \
                   (clamped) once the boundary DOFs are fixed, and K must be \
                   positive semi-definite"
                .to_string(),
        },
        other => other,
    }
}

/// The `n_modes` lowest modes of K_ii phi = lambda M_ii phi (shift-invert at sigma = 0 with the
/// factor of K_ii), mass-normalized, and their eigenvalues (rad^2/s^2 for SI input). K_ii is
/// dropped during the iteration and rebuilt by `rebuild_k_ii` for the residuals, so that it and
/// the eigensolver's basis are never in memory together.
fn fixed_interface_modes(
    k_ii: CsMat<f64>,
    rebuild_k_ii: &dyn Fn() -> CsMat<f64>,
    m_ii: &CsMat<f64>,
    factor: &SparseCholesky,
    n_modes: usize,
    opts: &EigenOptions<'_>,
) -> Result<(Mat<f64>, Vec<f64>), ModalError> {
    let n_i = k_ii.rows();
    if n_modes == 0 {
        return Ok((Mat::<f64>::zeros(n_i, 0), Vec::new()));
    }
    let start = StepTimer::start();
    // K_ii and M_ii are principal submatrices of the checked K and M.
    let modes = eigs_factored_deferred_k(k_ii, rebuild_k_ii, m_ii, 0.0, factor, n_modes, opts)?;
    let worst = modes.residuals.iter().copied().fold(0.0, f64::max);
    tracing::info!(
        "Craig-Bampton: {n_modes} fixed-interface modes of {n_i} interior DOFs, \
         {:.4e} .. {:.4e} Hz, largest residual {worst:.1e}, {}",
        modes.frequencies_hz()[0],
        modes.frequencies_hz()[n_modes - 1],
        start.elapsed()
    );
    Ok((modes.vectors, modes.eigenvalues))
}

/// Constraint modes Psi = -K_ii^-1 K_ib: all n_b right-hand sides in one block solve (one pass
/// over the factor).
/// The static correction of one interior load `f_i` (see [`craig_bampton_with_loads`]): the
/// vector and its K_ii Rayleigh quotient, or None when nothing is left of it after the
/// orthogonalization (below 1e-10 of its M_ii-norm).
fn static_correction(
    factor: &SparseCholesky,
    k_ii: &CsMat<f64>,
    m_ii: &CsMat<f64>,
    phi: &Mat<f64>,
    f_i: &[f64],
) -> Result<Option<(Vec<f64>, f64)>, ModalError> {
    let n_i = f_i.len();
    let mut x = Mat::from_fn(n_i, 1, |r, _| f_i[r]);
    if f_i.iter().all(|&v| v == 0.0) {
        return Ok(None);
    }
    factor.solve_many(x.as_mut())?;
    let m_norm = |x: &Mat<f64>| -> f64 {
        let mut mx = Mat::<f64>::zeros(n_i, 1);
        spmm_symmetric(m_ii, x.as_ref(), mx.as_mut());
        (0..n_i).map(|r| x[(r, 0)] * mx[(r, 0)]).sum::<f64>().sqrt()
    };
    let before = m_norm(&x);
    for _ in 0..2 {
        let mut mx = Mat::<f64>::zeros(n_i, 1);
        spmm_symmetric(m_ii, x.as_ref(), mx.as_mut());
        for j in 0..phi.ncols() {
            let c: f64 = (0..n_i).map(|r| phi[(r, j)] * mx[(r, 0)]).sum();
            for r in 0..n_i {
                x[(r, 0)] -= c * phi[(r, j)];
            }
        }
    }
    let after = m_norm(&x);
    if after.is_nan() || after <= 1e-10 * before {
        return Ok(None);
    }
    let x: Vec<f64> = (0..n_i).map(|r| x[(r, 0)] / after).collect();
    let xm = Mat::from_fn(n_i, 1, |r, _| x[r]);
    let mut kx = Mat::<f64>::zeros(n_i, 1);
    spmm_symmetric(k_ii, xm.as_ref(), kx.as_mut());
    let kxx = (0..n_i).map(|r| x[r] * kx[(r, 0)]).sum();
    Ok(Some((x, kxx)))
}

/// `a` with `col` appended as its last column.
fn append_column(a: &Mat<f64>, col: &[f64]) -> Mat<f64> {
    Mat::from_fn(a.nrows(), a.ncols() + 1, |r, j| {
        if j < a.ncols() {
            a[(r, j)]
        } else {
            col[r]
        }
    })
}

fn constraint_modes(
    factor: &SparseCholesky,
    k_ib: &CsMat<f64>,
    n_i: usize,
    n_b: usize,
) -> Result<Mat<f64>, ModalError> {
    let start = StepTimer::start();
    let mut psi = Mat::<f64>::zeros(n_i, n_b);
    for (j, col) in k_ib.outer_iterator().enumerate() {
        for (r, &v) in col.iter() {
            psi[(r, j)] = -v;
        }
    }
    factor.solve_many(psi.as_mut())?;
    tracing::info!(
        "Craig-Bampton: {n_b} constraint modes in one block solve, {}",
        start.elapsed()
    );
    Ok(psi)
}

/// Dense generalized eigenpairs of the reduced model (K_r, M_r): eigenvalues
/// ascending (rad^2/s^2), vectors in reduced coordinates, Phi_r^T M_r Phi_r = I.
pub fn reduced_eigen(cb: &CraigBampton) -> Result<(Vec<f64>, Mat<f64>), ModalError> {
    dense_generalized_eigen(cb.k_r.as_ref(), cb.m_r.as_ref())
}

/// Validates the boundary list and returns the interior DOFs (ascending).
fn interior_dofs(n: usize, boundary: &[usize]) -> Result<Vec<usize>, ModalError> {
    if boundary.is_empty() {
        return Err(ModalError::InvalidReduction(
            "the boundary DOF list is empty".to_string(),
        ));
    }
    let mut position = vec![usize::MAX; n];
    for (p, &dof) in boundary.iter().enumerate() {
        if dof >= n {
            return Err(ModalError::InvalidReduction(format!(
                "boundary DOF {dof} (entry {p} of the list) is out of range: the model has {n} DOFs"
            )));
        }
        if position[dof] != usize::MAX {
            return Err(ModalError::InvalidReduction(format!(
                "boundary DOF {dof} appears twice (entries {} and {p} of the list)",
                position[dof]
            )));
        }
        position[dof] = p;
    }
    if boundary.len() == n {
        return Err(ModalError::InvalidReduction(format!(
            "all {n} DOFs are on the boundary: there is nothing to reduce"
        )));
    }
    Ok((0..n).filter(|&d| position[d] == usize::MAX).collect())
}

/// K_r = T^T K T and M_r = T^T M T without forming T: for each reduced
/// coordinate j, y = K t_j (one sparse product on the full matrix), then
/// T^T y = [y_b + Psi^T y_i; Phi^T y_i], the interior part as a dense product.
fn project(
    k: &CsMat<f64>,
    m: &CsMat<f64>,
    boundary: &[usize],
    interior: &[usize],
    psi: &Mat<f64>,
    phi: &Mat<f64>,
) -> (Mat<f64>, Mat<f64>) {
    let n = k.rows();
    let (n_b, n_i, n_modes) = (boundary.len(), interior.len(), phi.ncols());
    let n_r = n_b + n_modes;
    // The reduction basis T (n x n_r) in the input numbering, then K T and M T in one pass
    // over each matrix (symmetric inputs, checked by the caller).
    let mut t = Mat::<f64>::zeros(n, n_r);
    for j in 0..n_r {
        if j < n_b {
            t[(boundary[j], j)] = 1.0;
        }
        for (r, &dof) in interior.iter().enumerate() {
            t[(dof, j)] = if j < n_b {
                psi[(r, j)]
            } else {
                phi[(r, j - n_b)]
            };
        }
    }
    let mut yk = Mat::<f64>::zeros(n, n_r);
    let mut ym = Mat::<f64>::zeros(n, n_r);
    spmm_symmetric(k, t.as_ref(), yk.as_mut());
    spmm_symmetric(m, t.as_ref(), ym.as_mut());
    drop(t);
    let yk_i = Mat::<f64>::from_fn(n_i, n_r, |r, j| yk[(interior[r], j)]);
    let ym_i = Mat::<f64>::from_fn(n_i, n_r, |r, j| ym[(interior[r], j)]);
    let mut k_r = Mat::<f64>::from_fn(
        n_r,
        n_r,
        |p, j| if p < n_b { yk[(boundary[p], j)] } else { 0.0 },
    );
    let mut m_r = Mat::<f64>::from_fn(
        n_r,
        n_r,
        |p, j| if p < n_b { ym[(boundary[p], j)] } else { 0.0 },
    );
    drop((yk, ym));
    for (reduced, y_i) in [(&mut k_r, &yk_i), (&mut m_r, &ym_i)] {
        // Rows 0..n_b: y_b (already there) + Psi^T y_i.
        matmul(
            reduced.as_mut().subrows_mut(0, n_b),
            Accum::Add,
            psi.transpose(),
            y_i.as_ref(),
            1.0,
            Par::Seq,
        );
        // Rows n_b..: Phi^T y_i.
        matmul(
            reduced.as_mut().subrows_mut(n_b, n_modes),
            Accum::Replace,
            phi.transpose(),
            y_i.as_ref(),
            1.0,
            Par::Seq,
        );
    }
    (k_r, m_r)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The memory estimate is that of the largest phase, not the sum of all: at a million DOFs
    /// with a 7.5 GB factor, the eigen-solve (L and the eigensolver); with a negligible factor,
    /// the projection (Psi and Phi, and 6 n n_r values).
    #[test]
    fn memory_estimate_is_the_largest_phase() {
        let sizes = Sizes {
            n: 1_000_000,
            n_b: 72,
            n_modes: 40,
            check_modes: 0,
        };
        let names = |e: &MemoryEstimate| -> Vec<String> {
            e.parts.iter().map(|(what, _)| what.clone()).collect()
        };
        let large = reduction_memory(&sizes, 7_500_000_000, 600_000_000, 50_000_000);
        assert_eq!(names(&large), ["factor L of K_ii", "eigensolver"]);
        let eigen = eigensolver_bytes(1_000_000 - 72, 40);
        assert_eq!(large.total(), 7_500_000_000 + eigen);
        let small = reduction_memory(&sizes, 1_000_000, 0, 0);
        assert_eq!(names(&small), ["reduction basis", "projection"]);
        assert_eq!(
            small.total(),
            (1_000_000 - 72) * 112 * 8 + 6 * 1_000_000 * 112 * 8
        );
    }
}
