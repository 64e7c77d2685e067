//! The mechanical system: mass and stiffness matrices, contact rows and initial gaps (Eq. 17).
//!
//! `System` knows nothing of meshes: any symmetric positive definite pair (M, K) of size n, with c
//! contact rows A (c x n) and initial gaps g0 (c values), defines the gap
//! g(u) = A u - g0 (Eq. 17), admissible iff g <= 0, and the contact force on the structure
//! -A^T lambda with lambda >= 0 (Eqs. 2, 11b). Units are whatever the matrices use (SI for the
//! blade: kg, N/m, m); frequencies are circular, in rad/s when M is in kg and K in N/m.
//!
//! The matrices are dense: this crate works on reduced models (Craig-Bampton, a few hundred DOFs).

use faer::{Mat, MatRef};

use crate::error::HbError;
use nlmodes_dense::{check_symmetric, cholesky_lower, generalized_eigen, symmetrize};

/// Energy shares of an orbit by linear mode and harmonic (see [`System::modal_shares`]).
#[derive(Clone, Debug)]
pub struct ModalShares {
    /// shares[(k, n)]: share of linear mode k (0-based, ascending frequency) at harmonic n; the
    /// entries sum to 1 (all zero for a zero orbit).
    pub shares: Mat<f64>,
}

impl ModalShares {
    /// Share of linear mode `mode` at harmonic `harmonic` (0 if out of range).
    pub fn share(&self, mode: usize, harmonic: usize) -> f64 {
        if mode < self.shares.nrows() && harmonic < self.shares.ncols() {
            self.shares[(mode, harmonic)]
        } else {
            0.0
        }
    }

    /// The largest share other than (`mode`, 1): (mode k, harmonic n, share).
    pub fn largest_other(&self, mode: usize) -> (usize, usize, f64) {
        let mut best = (0, 0, 0.0);
        for h in 0..self.shares.ncols() {
            for k in 0..self.shares.nrows() {
                let v = self.shares[(k, h)];
                if (k, h) != (mode, 1) && v > best.2 {
                    best = (k, h, v);
                }
            }
        }
        best
    }
}

/// A linear elastic structure with frictionless unilateral contact rows.
#[derive(Clone)]
pub struct System {
    m: Mat<f64>,
    k: Mat<f64>,
    contact_rows: Mat<f64>,
    gaps: Vec<f64>,
    master: usize,
    eigenvalues: Vec<f64>,
    modes: Mat<f64>,
    contact_stiffness: Vec<f64>,
}

impl std::fmt::Debug for System {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("System")
            .field("dofs", &self.n_dofs())
            .field("contact_rows", &self.n_contacts())
            .field("master", &self.master)
            .finish()
    }
}

impl System {
    /// Validates and builds a system.
    ///
    /// * `m`, `k`: n x n mass and stiffness, symmetric (asymmetry up to 1e-10 x max|a| is treated as
    ///   round-off and removed by symmetrization) and positive definite (checked by Cholesky; the
    ///   error names the matrix).
    /// * `contact_rows`: c x n; row j gives the normal displacement of contact DOF j as `A_j . u`
    ///   (the radial unit vector of a contact node on its three DOFs, or any nonzero row).
    /// * `gaps`: the c initial gaps g0 > 0, same length unit as u.
    /// * `master`: index in 0..n of the master coordinate whose first-harmonic amplitude is q
    ///   (Sec. 2.6).
    pub fn new(
        m: Mat<f64>,
        k: Mat<f64>,
        contact_rows: Mat<f64>,
        gaps: Vec<f64>,
        master: usize,
    ) -> Result<Self, HbError> {
        let n = m.nrows();
        if n == 0 {
            return Err(HbError::Empty);
        }
        let m = checked_symmetric("M", &m, n)?;
        let k = checked_symmetric("K", &k, n)?;
        if contact_rows.ncols() != n {
            return Err(HbError::ContactRowsWidth {
                cols: contact_rows.ncols(),
                expected: n,
            });
        }
        let c = contact_rows.nrows();
        for j in 0..c {
            let mut norm = 0.0;
            for i in 0..n {
                let v = contact_rows[(j, i)];
                if !v.is_finite() {
                    return Err(HbError::InvalidContactRow {
                        row: j,
                        detail: format!("non-finite entry {v} in column {i}"),
                    });
                }
                norm += v * v;
            }
            if norm == 0.0 {
                return Err(HbError::InvalidContactRow {
                    row: j,
                    detail: "the row is zero".to_string(),
                });
            }
        }
        if gaps.len() != c {
            return Err(HbError::GapCount {
                gaps: gaps.len(),
                rows: c,
            });
        }
        for (index, &value) in gaps.iter().enumerate() {
            if !(value.is_finite() && value > 0.0) {
                return Err(HbError::NonPositiveGap { index, value });
            }
        }
        if master >= n {
            return Err(HbError::MasterOutOfRange { master, dofs: n });
        }
        // SPD checks with named errors (the eigen-solver would only report M).
        cholesky_lower(m.as_ref()).map_err(HbError::dense("M"))?;
        let lk = cholesky_lower(k.as_ref()).map_err(HbError::dense("K"))?;
        let eig = generalized_eigen(k.as_ref(), m.as_ref()).map_err(HbError::dense("M"))?;
        if eig.values.iter().any(|&v| v <= 0.0) {
            return Err(HbError::NotPositiveDefinite {
                name: "K",
                detail: "a generalized eigenvalue of (K, M) is not positive".to_string(),
            });
        }
        // Static stiffness seen by each contact row: 1 / (A_j K^-1 A_j^T).
        let mut contact_stiffness = Vec::with_capacity(c);
        for j in 0..c {
            let mut x = Mat::from_fn(n, 1, |i, _| contact_rows[(j, i)]);
            faer::linalg::triangular_solve::solve_lower_triangular_in_place(
                lk.as_ref(),
                x.as_mut(),
                faer::Par::Seq,
            );
            let flex: f64 = (0..n).map(|i| x[(i, 0)] * x[(i, 0)]).sum();
            contact_stiffness.push(1.0 / flex);
        }
        Ok(Self {
            m,
            k,
            contact_rows,
            gaps,
            master,
            eigenvalues: eig.values,
            modes: eig.vectors,
            contact_stiffness,
        })
    }

    /// Number of degrees of freedom n.
    pub fn n_dofs(&self) -> usize {
        self.m.nrows()
    }

    /// Number of contact rows c.
    pub fn n_contacts(&self) -> usize {
        self.contact_rows.nrows()
    }

    /// Mass matrix M (symmetrized).
    pub fn mass(&self) -> MatRef<'_, f64> {
        self.m.as_ref()
    }

    /// Stiffness matrix K (symmetrized).
    pub fn stiffness(&self) -> MatRef<'_, f64> {
        self.k.as_ref()
    }

    /// Contact rows A (c x n), Eq. (17).
    pub fn contact_rows(&self) -> MatRef<'_, f64> {
        self.contact_rows.as_ref()
    }

    /// Initial gaps g0 (c values).
    pub fn gaps(&self) -> &[f64] {
        &self.gaps
    }

    /// Index of the master coordinate.
    pub fn master(&self) -> usize {
        self.master
    }

    /// Reference gap used to scale amplitudes (q / g_ref): the mean initial gap, or 1 when the system
    /// has no contact row.
    pub fn gap_reference(&self) -> f64 {
        if self.gaps.is_empty() {
            1.0
        } else {
            self.gaps.iter().sum::<f64>() / self.gaps.len() as f64
        }
    }

    /// Circular frequencies of the linear modes of (K, M), ascending (rad/s).
    pub fn linear_frequencies(&self) -> Vec<f64> {
        self.eigenvalues.iter().map(|v| v.sqrt()).collect()
    }

    /// Eigenvalues w_k^2 of (K, M), ascending (rad^2/s^2).
    pub fn eigenvalues(&self) -> &[f64] {
        &self.eigenvalues
    }

    /// All linear modes of (K, M) as columns, mass-normalized (Phi^T M Phi = I), in the order of
    /// [`System::eigenvalues`] (signs as the eigensolver returns them).
    pub fn modes(&self) -> MatRef<'_, f64> {
        self.modes.as_ref()
    }

    /// Linear mode `mode` (0-based), mass-normalized, with a positive master component.
    pub fn linear_mode(&self, mode: usize) -> Result<Vec<f64>, HbError> {
        let n = self.n_dofs();
        if mode >= n {
            return Err(HbError::ModeOutOfRange { mode, count: n });
        }
        let mut phi: Vec<f64> = (0..n).map(|i| self.modes[(i, mode)]).collect();
        let max = phi.iter().fold(0.0_f64, |a, v| a.max(v.abs()));
        let pm = phi[self.master];
        if pm.abs() <= 1e-8 * max {
            return Err(HbError::MasterNotInMode {
                master: self.master,
                mode,
                value: pm.abs() / max,
            });
        }
        if pm < 0.0 {
            phi.iter_mut().for_each(|v| *v = -*v);
        }
        Ok(phi)
    }

    /// Master amplitude q at which linear mode `mode` first touches the obstacle:
    /// min_j g0_j phi_master / |A_j phi|; `None` if no contact row moves in that mode.
    pub fn grazing_amplitude(&self, mode: usize) -> Result<Option<f64>, HbError> {
        let phi = self.linear_mode(mode)?;
        let pm = phi[self.master];
        let mut best: Option<f64> = None;
        for j in 0..self.n_contacts() {
            let aphi: f64 = (0..self.n_dofs())
                .map(|i| self.contact_rows[(j, i)] * phi[i])
                .sum();
            if aphi.abs() > 0.0 {
                let q = self.gaps[j] * pm / aphi.abs();
                best = Some(best.map_or(q, |b: f64| b.min(q)));
            }
        }
        Ok(best)
    }

    /// Static stiffness seen by each contact row, 1 / (A_j K^-1 A_j^T) (force per length): the scale
    /// of the initial augmented-Lagrangian penalties.
    pub fn contact_stiffness(&self) -> &[f64] {
        &self.contact_stiffness
    }

    /// Where the energy of an orbit sits among the linear modes and harmonics: for the cosine
    /// coefficients u_n (n = 0..N) and each mass-normalized linear mode phi_k, the modal amplitude
    /// eta_kn = phi_k^T M u_n and the share e_kn / sum e of e_kn = w_k^2 eta_kn^2 (the potential
    /// energy of the linear mode at the amplitude of that harmonic, J for SI matrices). The
    /// backbone uses the share of (starting mode, n = 1), the "modal purity", to tell the primary
    /// branch from an internal-resonance tongue, where the energy flows into (k, n) with
    /// n w close to w_k.
    pub fn modal_shares(&self, coefficients: &[Vec<f64>]) -> ModalShares {
        let n = self.n_dofs();
        let nh = coefficients.len();
        let u = Mat::from_fn(n, nh, |i, h| coefficients[h][i]);
        let mu = &self.m * &u;
        let eta = self.modes.transpose() * &mu;
        let energy = |k: usize, h: usize| self.eigenvalues[k] * eta[(k, h)].powi(2);
        let total: f64 = (0..nh)
            .map(|h| (0..n).map(|k| energy(k, h)).sum::<f64>())
            .sum();
        let scale = if total > 0.0 { 1.0 / total } else { 0.0 };
        ModalShares {
            shares: Mat::from_fn(n, nh, |k, h| energy(k, h) * scale),
        }
    }

    /// Contact displacement A_j . u.
    pub fn contact_displacement(&self, j: usize, u: &[f64]) -> f64 {
        let n = self.n_dofs();
        (0..n).map(|i| self.contact_rows[(j, i)] * u[i]).sum()
    }
}

/// `a` checked to be n x n, finite and symmetric (`nlmodes_dense::check_symmetric`: 1e-10
/// max|a|, the modal crate's bound too), symmetrized.
fn checked_symmetric(name: &'static str, a: &Mat<f64>, n: usize) -> Result<Mat<f64>, HbError> {
    if a.nrows() != n || a.ncols() != n {
        return Err(HbError::Shape {
            name,
            rows: a.nrows(),
            cols: a.ncols(),
            expected: n,
        });
    }
    check_symmetric(a.as_ref()).map_err(HbError::symmetry(name, n))?;
    let mut symmetric = a.clone();
    symmetrize(&mut symmetric);
    Ok(symmetric)
}
