//! Options of the shift-invert eigensolvers and the choice [`EigenMethod::Auto`] makes between
//! the dense solver, the block Lanczos of [`crate::block_lanczos`] and ARPACK
//! ([`crate::arpack`]): both solvers read these options, and neither needs the other to know
//! them.

use nlmodes_sparse::CholeskyOptions;

/// Which algorithm computes the eigenpairs.
#[derive(Copy, Clone, Debug, Default, PartialEq, Eq)]
pub enum EigenMethod {
    /// Dense solver when n <= 2 ncv or nev >= n (ARPACK needs ncv < n); otherwise block
    /// Lanczos for nev <= [`AUTO_MAX_NEV`] (its shape, [`BlockShape::for_problem`], follows
    /// the size of the problem; ARPACK if it does not converge, logged), ARPACK otherwise.
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

/// Largest memory (bytes) of the full block-Lanczos basis V and M V (blocks of up to 16,
/// [`BlockShape::full`]): 1 GiB keeps the 93k-DOF blade (450 MB for 40 modes) on it. Larger
/// problems use the compact shape ([`BlockShape::compact`]: blocks of 8, a basis of 3 nev
/// vectors, thick restarts), whose basis and M times it take 1.9 GB for 40 modes at a million
/// DOFs against 4.9 GB for the full one.
pub const FULL_BASIS_MAX_BYTES: usize = 1 << 30;

/// Block size and largest basis of the block Lanczos for a problem.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
pub struct BlockShape {
    /// Right-hand sides per block (solved in one pass over the factor per thread).
    pub block: usize,
    /// Largest basis (columns of V); M V is stored alongside.
    pub max_basis: usize,
}

impl BlockShape {
    /// The shape for `nev` pairs of an n-DOF problem: [`BlockShape::full`] while its V and M V
    /// fit in [`FULL_BASIS_MAX_BYTES`], [`BlockShape::compact`] above.
    pub fn for_problem(n: usize, nev: usize) -> Self {
        let full = Self::full(n, nev);
        if full.basis_bytes(n) <= FULL_BASIS_MAX_BYTES {
            full
        } else {
            Self::compact(n, nev)
        }
    }

    /// Blocks of about nev / 2 (4 to 16) and a basis of 6 nev + 4 b: 40 modes of the 93k-DOF
    /// blade converge within 240 vectors without restart.
    pub fn full(n: usize, nev: usize) -> Self {
        let block = block_size(nev).min(n);
        Self {
            block,
            max_basis: (6 * nev + 4 * block).min(n),
        }
    }

    /// Blocks of about nev / 5 (4 to 8) and a basis of 3 nev (at least nev + 3 blocks), thickly
    /// restarted: for 40 modes of the 234k-DOF blade, 176 solves in 22 blocks of 8 with two
    /// restarts, against 256 solves in 16 blocks of 16 for the full shape, in 40 % of the
    /// memory (docs/LARGE_MODELS.md).
    pub fn compact(n: usize, nev: usize) -> Self {
        let block = nev.div_ceil(5).clamp(4, 8).min(n);
        Self {
            block,
            max_basis: (3 * nev).max(nev + 3 * block).min(n),
        }
    }

    /// Bytes of the basis V and M V for an n-DOF problem.
    pub fn basis_bytes(&self, n: usize) -> usize {
        2 * n * self.max_basis * std::mem::size_of::<f64>()
    }
}

/// Block size of [`BlockShape::full`] for `nev` wanted pairs: about nev / 2, between 4 and 16
/// (16 right-hand sides already amortize the pass over the factor; larger blocks only grow the
/// basis).
pub fn block_size(nev: usize) -> usize {
    nev.div_ceil(2).clamp(4, 16)
}

/// Auto: ARPACK rather than block Lanczos for `nev` pairs (too many pairs: [`AUTO_MAX_NEV`]).
pub(crate) fn auto_prefers_arpack(nev: usize) -> bool {
    nev > AUTO_MAX_NEV
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
/// basis ([`BlockShape::basis_bytes`]), its projected matrix and a few blocks, or the n x nev
/// result (twice: the Ritz vectors and the normalized modes) once the basis is freed; ARPACK's
/// ncv Lanczos vectors, its 3 n work vector and the eigenvectors with the result.
pub fn eigensolver_bytes(n: usize, nev: usize) -> usize {
    let f64_bytes = std::mem::size_of::<f64>();
    let result = 2 * n * nev * f64_bytes;
    if auto_prefers_arpack(nev) {
        let ncv = (2 * nev + 1).max(20).min(n);
        (n * (ncv + 3) + ncv * ncv) * f64_bytes + result
    } else {
        let shape = BlockShape::for_problem(n, nev);
        let (b, cap) = (shape.block, shape.max_basis);
        // While iterating: the basis, W and M W, and the row-major copies of a block product
        // with M (2 blocks); the basis is freed before the Ritz vectors are finished.
        (shape.basis_bytes(n) + (cap * cap + 4 * n * b) * f64_bytes).max(result)
    }
}
