//! Exact condensation basis: the cost of a Newton step does not grow with the number of
//! non-contact DOFs except through an O(r^2 n_o) Schur product per harmonic.
//!
//! Kept coordinates are y = B u with B = [A; e_master^T] (r = c + 1 rows), or B = A (r = c) when
//! e_master already lies in the span of the contact rows. From one SVD of B: the right inverse
//! P = B^+ (n x r, B P = I) and an orthonormal basis Q of null(B) (n x n_o, n_o = n - r). Every u is
//! u = P y + Q o. The "others" block (K_oo, M_oo) = (Q^T K Q, Q^T M Q) is diagonalized once,
//! K_oo Phi = M_oo Phi Lambda with Phi^T M_oo Phi = I, and o = Phi z. In the coordinates (y, z)
//! the dynamic stiffness of harmonic n (s = (n w)^2) is
//!
//! ```text
//! [ K_kk - s M_kk      Kt - s Mt  ] [y]   [A P]^T lambda_n      A P = [I_c 0], A Q = 0,
//! [ (Kt - s Mt)^T    Lambda - s I ] [z] + [  0  ]          = 0   e . u = (P^T e) . y
//! ```
//!
//! (Kt = P^T K Q Phi, Mt = P^T M Q Phi). Contact forces act on the first c kept coordinates only
//! and the master carries no force, so eliminating z is exact: for harmonic n,
//! z = -(Lambda - s)^-1 (Kt - s Mt)^T y and the Schur complement
//! S_n(w) = K_kk - s M_kk - (Kt - s Mt) diag(1 / (Lambda - s)) (Kt - s Mt)^T costs O(r^2 n_o); its
//! w-derivative is closed-form. The Newton unknowns remain (y, z, w, q), so condensed and
//! uncondensed Newton take the same steps; z is eliminated in the linear algebra of each step only
//! (see `condensed`). Where (n w)^2 comes within `resonance_window` of a Lambda_i (D_oo nearly
//! singular) that mode is not eliminated but kept in the small per-harmonic block, so no pole is
//! ever divided by; no perturbation is introduced.

use faer::linalg::matmul::matmul;
use faer::prelude::ReborrowMut;
use faer::{Accum, Mat, MatMut, MatRef, Par};

use crate::error::HbError;
use crate::system::System;
use nlmodes_dense::generalized_eigen;

/// Relative singular-value threshold below which contact rows are treated as dependent.
const RANK_TOLERANCE: f64 = 1e-10;

/// The precomputed condensation basis of a [`System`].
pub struct CondensedBasis {
    /// Contact rows c.
    pub c: usize,
    /// Kept coordinates r.
    pub r: usize,
    /// Other coordinates n_o = n - r.
    pub n_o: usize,
    /// Right inverse of B (n x r).
    pub p: Mat<f64>,
    /// B (r x n): y = B u.
    pub b: Mat<f64>,
    /// Q Phi (n x n_o).
    pub e: Mat<f64>,
    /// (Q Phi)^T M (n_o x n): z = (Q Phi)^T M (u - P y).
    pub etm: Mat<f64>,
    /// Eigenvalues Lambda of the "others" system (rad^2/s^2), ascending.
    pub lambda: Vec<f64>,
    pub k_kk: Mat<f64>,
    pub m_kk: Mat<f64>,
    pub kt: Mat<f64>,
    pub mt: Mat<f64>,
    /// e_master in (y, z) coordinates (zero on z).
    pub master_row: Vec<f64>,
    /// Kept coordinates with a nonzero master_row entry.
    pub master_support: Vec<usize>,
}

impl CondensedBasis {
    pub fn new(system: &System) -> Result<Self, HbError> {
        let n = system.n_dofs();
        let c = system.n_contacts();
        let a = system.contact_rows();
        let master = system.master();
        // Rank of A and whether e_master lies in span(A^T).
        let mut master_in_span = false;
        if c > 0 {
            if c > n {
                return Err(HbError::DependentContactRows { rank: n, rows: c });
            }
            let svd = a.thin_svd().map_err(|e| HbError::Decomposition {
                what: "SVD of the contact rows",
                detail: format!("{e:?}"),
            })?;
            let s = svd.S().column_vector();
            let smax = s[0];
            let rank = (0..c).filter(|&i| s[i] > RANK_TOLERANCE * smax).count();
            if rank < c {
                return Err(HbError::DependentContactRows { rank, rows: c });
            }
            // residual of projecting e_master on range(A^T) = range(V)
            let v = svd.V();
            let mut proj = vec![0.0; n];
            for l in 0..c {
                let coef = v[(master, l)];
                for i in 0..n {
                    proj[i] += coef * v[(i, l)];
                }
            }
            let resid: f64 = (0..n)
                .map(|i| {
                    let ei = if i == master { 1.0 } else { 0.0 };
                    (ei - proj[i]).powi(2)
                })
                .sum::<f64>()
                .sqrt();
            master_in_span = resid < 1e-8;
        }
        let r = if master_in_span { c } else { c + 1 };
        let b = Mat::from_fn(r, n, |i, j| {
            if i < c {
                a[(i, j)]
            } else if j == master {
                1.0
            } else {
                0.0
            }
        });
        let svd = b.svd().map_err(|e| HbError::Decomposition {
            what: "SVD of the kept-coordinate rows [A; e_master]",
            detail: format!("{e:?}"),
        })?;
        let (u, s, v) = (svd.U(), svd.S().column_vector(), svd.V());
        if s[r - 1] <= RANK_TOLERANCE * s[0] {
            return Err(HbError::DependentContactRows {
                rank: r - 1,
                rows: r,
            });
        }
        // P = V_r diag(1/s) U^T
        let p = Mat::from_fn(n, r, |i, j| {
            (0..r).map(|l| v[(i, l)] / s[l] * u[(j, l)]).sum::<f64>()
        });
        let n_o = n - r;
        let q = v.get(.., r..).to_owned();
        let k = system.stiffness();
        let m = system.mass();
        let k_oo = sym(q.transpose() * k * &q);
        let m_oo = sym(q.transpose() * m * &q);
        let eig = generalized_eigen(k_oo.as_ref(), m_oo.as_ref())
            .map_err(HbError::dense("M restricted to the others"))?;
        if eig.values.iter().any(|&l| l <= 0.0) {
            return Err(HbError::NotPositiveDefinite {
                name: "K restricted to the others",
                detail: "an eigenvalue of the condensed-out system is not positive".to_string(),
            });
        }
        let e = &q * &eig.vectors;
        let etm = e.transpose() * m;
        let k_kk = sym(p.transpose() * k * &p);
        let m_kk = sym(p.transpose() * m * &p);
        let kt = p.transpose() * k * &e;
        let mt = p.transpose() * m * &e;
        let d = r + n_o;
        let mut master_row = vec![0.0; d];
        let scale = (0..r).map(|i| p[(master, i)].abs()).fold(0.0, f64::max);
        let mut master_support = Vec::new();
        for (i, mr) in master_row.iter_mut().enumerate().take(r) {
            let val = p[(master, i)];
            if val.abs() > 1e-12 * scale {
                *mr = val;
                master_support.push(i);
            }
        }
        Ok(Self {
            c,
            r,
            n_o,
            p,
            b,
            e,
            etm,
            lambda: eig.values,
            k_kk,
            m_kk,
            kt,
            mt,
            master_row,
            master_support,
        })
    }

    /// Model coordinates (y, z) of `count` physical vectors u (n x count, column-major), written
    /// to `x` (d x count): y = B u, z = (Q Phi)^T M (u - P y).
    pub fn physical_to_model(&self, u: &[f64], count: usize, x: &mut [f64]) {
        let n = self.p.nrows();
        let d = self.r + self.n_o;
        let um = MatRef::from_column_major_slice(&u[..n * count], n, count);
        let y = &self.b * um;
        let mut diff = um.to_owned();
        matmul(
            diff.as_mut(),
            Accum::Add,
            self.p.as_ref(),
            y.as_ref(),
            -1.0,
            Par::Seq,
        );
        let z = &self.etm * &diff;
        let mut xm = MatMut::from_column_major_slice_mut(&mut x[..d * count], d, count);
        xm.rb_mut().get_mut(..self.r, ..).copy_from(&y);
        xm.get_mut(self.r.., ..).copy_from(&z);
    }

    /// Physical vectors u = P y + Q Phi z of `count` model-coordinate vectors (d x count), written
    /// to `u` (n x count).
    pub fn model_to_physical(&self, x: &[f64], count: usize, u: &mut [f64]) {
        let n = self.p.nrows();
        let d = self.r + self.n_o;
        let xm = MatRef::from_column_major_slice(&x[..d * count], d, count);
        let mut um = MatMut::from_column_major_slice_mut(&mut u[..n * count], n, count);
        matmul(
            um.rb_mut(),
            Accum::Replace,
            self.p.as_ref(),
            xm.get(..self.r, ..),
            1.0,
            Par::Seq,
        );
        if self.n_o > 0 {
            matmul(
                um,
                Accum::Add,
                self.e.as_ref(),
                xm.get(self.r.., ..),
                1.0,
                Par::Seq,
            );
        }
    }
}

fn sym(a: Mat<f64>) -> Mat<f64> {
    let n = a.nrows();
    Mat::from_fn(n, n, |i, j| 0.5 * (a[(i, j)] + a[(j, i)]))
}
