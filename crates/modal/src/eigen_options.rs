//! Options of the shift-invert eigensolvers and the choice [`EigenMethod::Auto`] makes between
//! the dense solver, the block Lanczos of [`crate::block_lanczos`] and ARPACK
//! ([`crate::arpack`]): both solvers read these options, and neither needs the other to know
//! them.

use crate::cholesky::CholeskyOptions;

/// Which algorithm computes the eigenpairs.
#[derive(Copy, Clone, Debug, Default, PartialEq, Eq)]
pub enum EigenMethod {
    /// Dense solver when n <= 2 ncv or nev >= n (ARPACK needs ncv < n); otherwise block
    /// Lanczos for nev <= [`AUTO_MAX_NEV`] when its basis fits in
    /// [`AUTO_MAX_BASIS_BYTES`] (ARPACK if it does not converge, logged),
    /// ARPACK otherwise.
    #[default]
    Auto,
    /// Always ARPACK (error when nev >= n).
    Arpack,
    /// Always the shift-invert block Lanczos of [`crate::block_lanczos`] (error when it does not
    /// converge).
    BlockLanczos,
    /// Always the dense solver (all n eigenpairs, then the nev nearest sigma).
    Dense,
}

/// Options of the shift-invert eigensolver.
#[derive(Clone, Copy)]
pub struct EigenOptions<'a> {
    /// Number of Lanczos vectors of ARPACK; default max(2 nev + 1, 20), capped at n (block
    /// Lanczos sizes its own basis: [`crate::block_lanczos`]).
    pub ncv: Option<usize>,
    /// Convergence tolerance (ARPACK's, and the same test in block Lanczos): the Ritz estimates of
    /// OP = (K - sigma M)^-1 M must fall below tol times the Ritz value; 0
    /// means machine precision. Default 1e-10: eigenvalues converge
    /// quadratically in it (relative errors ~1e-14 observed), mode shapes to
    /// about tol / (relative gap), and the relative residuals
    /// ||K phi - lambda M phi|| / (|lambda| ||M phi||) come out near 1e-12,
    /// while machine precision needs about twice as many solves (measured:
    /// 40 modes of a 38k-DOF 3-D problem, 124 solves at 1e-10, 145 at 1e-12,
    /// 251 at machine precision, identical eigenvalues to 7 digits).
    pub tol: f64,
    /// Maximum number of implicit restarts (ARPACK's `iparam[2]`).
    pub max_iterations: usize,
    /// Dense, block Lanczos or ARPACK.
    pub method: EigenMethod,
    /// Factorization options of K - sigma M.
    pub cholesky: CholeskyOptions,
    /// Called after every application of (K - sigma M)^-1 with the number of
    /// applications so far (for a progress bar).
    pub on_iteration: Option<&'a dyn Fn(usize)>,
}

impl Default for EigenOptions<'_> {
    fn default() -> Self {
        Self {
            ncv: None,
            tol: 1e-10,
            max_iterations: 1000,
            method: EigenMethod::Auto,
            cholesky: CholeskyOptions::default(),
            on_iteration: None,
        }
    }
}

impl std::fmt::Debug for EigenOptions<'_> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("EigenOptions")
            .field("ncv", &self.ncv)
            .field("tol", &self.tol)
            .field("max_iterations", &self.max_iterations)
            .field("method", &self.method)
            .field("cholesky", &self.cholesky)
            .field("on_iteration", &self.on_iteration.is_some())
            .finish()
    }
}

/// Largest `nev` for which [`crate::EigenMethod::Auto`] uses block Lanczos. A block Krylov space
/// of the same size has a lower polynomial degree than ARPACK's single-vector one: measured on
/// the coarse blade (8979 interior DOFs), 100 fixed-interface modes took 800 solves without
/// restart against ARPACK's 202, and with thick restarts did not converge in 9000; for 40 modes
/// of the 93k-DOF blade, 240 block solves (15 blocks of 16) against ARPACK's 145 single ones,
/// which the cheaper block solves (0.013 s against 0.085 s per vector) turn into a gain.
pub const AUTO_MAX_NEV: usize = 48;

/// Largest memory (bytes) the basis and M times it may take for [`crate::EigenMethod::Auto`] to
/// choose block Lanczos, and for block Lanczos to keep M V beside V: 1 GiB keeps the 93k-DOF
/// blade (450 MB for 40 modes) on block Lanczos and sends the 234k-DOF one (1.1 GB) to ARPACK,
/// whose basis is 3 times smaller. Above it a block Lanczos asked for explicitly stores V alone
/// and recomputes M W (half the memory, two more block products with M per step); at 234k DOFs
/// that took 82 s of CPU for 256 solves against ARPACK's 103 solves in under 40 s (shared
/// machine, docs/BENCHMARKS.md "Industrial size"), so Auto keeps ARPACK there.
pub const AUTO_MAX_BASIS_BYTES: usize = 1 << 30;

/// Bytes of one copy of the basis for `nev` pairs on an n-DOF problem.
fn one_basis_bytes(n: usize, nev: usize) -> usize {
    n * max_basis(nev, block_size(nev).min(n), n) * std::mem::size_of::<f64>()
}

/// Whether block Lanczos keeps M V beside V ([`AUTO_MAX_BASIS_BYTES`]).
pub(crate) fn keeps_m_basis(n: usize, nev: usize) -> bool {
    2 * one_basis_bytes(n, nev) <= AUTO_MAX_BASIS_BYTES
}

/// Bytes of the basis (and M times it when kept) for `nev` pairs on an n-DOF problem.
pub fn basis_bytes(n: usize, nev: usize) -> usize {
    if keeps_m_basis(n, nev) {
        2 * one_basis_bytes(n, nev)
    } else {
        one_basis_bytes(n, nev)
    }
}

/// Block size for `nev` wanted pairs: about nev / 2, between 4 and 16 (16 right-hand sides
/// already amortize the pass over the factor; larger blocks only grow the basis).
pub fn block_size(nev: usize) -> usize {
    nev.div_ceil(2).clamp(4, 16)
}

/// The largest basis for `nev` pairs with blocks of `b` on an n-DOF problem (the basis and M
/// times it are stored: 2 n max_basis values; 40 modes of the 93k-DOF blade converge within
/// 240 vectors, so 304 avoids a restart there).
pub(crate) fn max_basis(nev: usize, b: usize, n: usize) -> usize {
    (6 * nev + 4 * b).min(n)
}

/// Auto: ARPACK rather than block Lanczos for `nev` pairs on an n-DOF problem (too many pairs,
/// or a basis and M times it larger than [`AUTO_MAX_BASIS_BYTES`]).
pub(crate) fn auto_prefers_arpack(n: usize, nev: usize) -> bool {
    nev > AUTO_MAX_NEV || !keeps_m_basis(n, nev)
}

/// Auto: the dense solver when all pairs are wanted or the problem is small (ARPACK needs ncv < n).
pub(crate) fn use_dense(nev: usize, n: usize, ncv: usize, method: EigenMethod) -> bool {
    match method {
        EigenMethod::Dense => true,
        EigenMethod::Arpack | EigenMethod::BlockLanczos => false,
        EigenMethod::Auto => nev >= n || n <= 2 * ncv,
    }
}

/// Bytes the shift-invert eigensolver `EigenMethod::Auto` picks allocates for `nev` pairs of an
/// n-DOF problem (for the memory check of large reductions, [`crate::memory`]): block Lanczos's
/// basis ([`basis_bytes`]), its projected matrix, a few blocks and the Ritz vectors; ARPACK's
/// ncv Lanczos vectors, its 3 n work vector and the eigenvectors; both with the n x nev result.
pub fn eigensolver_bytes(n: usize, nev: usize) -> usize {
    let f64_bytes = std::mem::size_of::<f64>();
    let result = 2 * n * nev * f64_bytes;
    if auto_prefers_arpack(n, nev) {
        let ncv = (2 * nev + 1).max(20).min(n);
        (n * (ncv + 3) + ncv * ncv) * f64_bytes + result
    } else {
        let b = block_size(nev).min(n);
        let cap = max_basis(nev, b, n);
        // W and M W, and the row-major copies of a block product with M (2 x 2 blocks).
        basis_bytes(n, nev) + (cap * cap + 6 * n * b) * f64_bytes + result
    }
}
