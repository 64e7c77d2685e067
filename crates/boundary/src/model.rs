//! The free massless-boundary model of a system (docs/STABILITY.md Sec. 9) and what it is built
//! from: the linear modes ([`ModalData`]), the modes kept dynamic at a frequency
//! ([`dynamic_modes`]) and the residual flexibility of the others on the contact rows
//! ([`residual_flexibility`], shared with the driven model and with Hill's static correction).
//!
//! The linear modes of the system up to a cutoff are kept as dynamic coordinates q
//! (mass-normalized: M = I, K = W^2, W in rad/s); every other mode acts quasi-statically on the
//! contact rows through its residual flexibility R = sum_{k discarded} b_k b_k^T / w_k^2
//! (c x c, m/N; b_k = A phi_k). The contact displacements carry no mass:
//!
//! ```text
//! q'' + W^2 q = -B^T lambda,   u_c = B q - R lambda,   0 <= lambda  _|_  g0 - u_c >= 0
//! ```
//!
//! (B = A Phi_kept, c x r; lambda in N, u_c and g0 in m). A penalty law kc adds 1 / kc to the
//! diagonal of R (the spring in series with the stop). The flow of this model is
//! `free_flow`, that of its damped, driven version (`driven_model`) `driven_flow`.

use faer::{Mat, MatRef, Side};

/// sum_{k >= r} b_k b_k^T / w_k^2 (c x c, m/N): the static flexibility of the modes r.. on the
/// contact rows (`contact_modal` = A Phi, c x n; `eigenvalues` = w_k^2). Zero when r = n.
pub fn residual_sum(contact_modal: MatRef<'_, f64>, eigenvalues: &[f64], r: usize) -> Mat<f64> {
    let c = contact_modal.nrows();
    let b = contact_modal;
    Mat::from_fn(c, c, |i, j| {
        (r..eigenvalues.len())
            .map(|k| b[(i, k)] * b[(j, k)] / eigenvalues[k])
            .sum::<f64>()
    })
}

/// The residual flexibility of the modes r.. on the contact rows, R = sum_{k >= r} b_k b_k^T /
/// w_k^2 (c x c, m/N; `contact_modal` = A Phi, c x n, `eigenvalues` = w_k^2 ascending), plus
/// 1 / kc on the diagonal of a penalty law's rows (`penalty`: one kc per row, N/m). `None` unless
/// it is positive definite with a margin of 1e-10 of its largest diagonal entry: a row the
/// discarded modes barely reach would make a near-rigid contact of a near-massive coordinate
/// (an impact), not a massless boundary.
pub fn residual_flexibility(
    contact_modal: MatRef<'_, f64>,
    eigenvalues: &[f64],
    r: usize,
    penalty: Option<&[f64]>,
) -> Option<Mat<f64>> {
    let c = contact_modal.nrows();
    let mut flexibility = residual_sum(contact_modal, eigenvalues, r);
    if let Some(kc) = penalty {
        for (j, k) in kc.iter().enumerate() {
            flexibility[(j, j)] += 1.0 / k;
        }
    }
    let scale = (0..c).fold(0.0_f64, |a, j| a.max(flexibility[(j, j)]));
    let shifted = Mat::from_fn(c, c, |i, j| {
        flexibility[(i, j)] - if i == j { 1e-10 * scale } else { 0.0 }
    });
    if scale.is_nan() || scale <= 0.0 || shifted.llt(Side::Lower).is_err() {
        return None;
    }
    Some(flexibility)
}

/// The modes kept dynamic below `limit` (rad/s): those of circular frequency w_k <= limit, at
/// least one (`omegas` ascending, rad/s). The caller sets limit = cutoff (N + 1) w, the modes
/// whose resonant harmonics an orbit of N harmonics holds; it caps the count at the number of
/// modes where that matters to it.
pub fn dynamic_modes(omegas: impl Iterator<Item = f64>, limit: f64) -> usize {
    omegas.filter(|&w| w <= limit).count().max(1)
}

/// The massless-boundary model of a system (module docs).
#[derive(Clone, Debug)]
pub struct BoundaryModel {
    /// W^2 of the kept modes (rad^2/s^2).
    pub omega2: Vec<f64>,
    /// B = A Phi_kept (c x r).
    pub contact_modal: Mat<f64>,
    /// R (+ diag(1 / kc) for a penalty law), c x c, m/N.
    pub flexibility: Mat<f64>,
    /// g0 (m).
    pub gaps: Vec<f64>,
}

impl BoundaryModel {
    /// The number r of modes kept dynamic.
    pub fn modes(&self) -> usize {
        self.omega2.len()
    }
}

/// The linear modes and contact data a free boundary model is built from.
#[derive(Clone, Copy)]
pub struct ModalData<'a> {
    /// w_k of every mode (rad/s), ascending.
    pub omega: &'a [f64],
    /// A Phi (c x n).
    pub contact_modal: MatRef<'a, f64>,
    /// Phi^T M (n x n).
    pub projection: MatRef<'a, f64>,
    /// The master's row of Phi (n).
    pub master: &'a [f64],
    /// g0 of every contact row (m).
    pub gaps: &'a [f64],
}

impl ModalData<'_> {
    /// Modes kept dynamic at circular frequency `omega` (rad/s) with `harmonics` harmonics:
    /// w_k <= `cutoff` (N + 1) w, at least one, at most every mode.
    pub fn dynamic_modes(&self, cutoff: f64, omega: f64, harmonics: usize) -> usize {
        let limit = cutoff * (harmonics as f64 + 1.0) * omega;
        dynamic_modes(self.omega.iter().copied(), limit).min(self.omega.len())
    }

    /// The massless-boundary model keeping the first `r` modes: R from the others, plus 1 / kc
    /// on the diagonal of a penalty orbit's rows. `None` when R is not positive definite (the
    /// discarded modes do not reach every contact row: no massless boundary to build).
    pub fn model(&self, r: usize, penalty: Option<&[f64]>) -> Option<BoundaryModel> {
        let c = self.gaps.len();
        let b = self.contact_modal;
        let eigenvalues: Vec<f64> = self.omega.iter().map(|w| w * w).collect();
        let flexibility = residual_flexibility(b, &eigenvalues, r, penalty)?;
        Some(BoundaryModel {
            omega2: self.omega[..r].iter().map(|w| w * w).collect(),
            contact_modal: Mat::from_fn(c, r, |i, k| b[(i, k)]),
            flexibility,
            gaps: self.gaps.to_vec(),
        })
    }

    /// Modal coordinates q = (Phi^T M u)_k, k < r, of a displacement u.
    pub fn coordinates(&self, u: &[f64], r: usize) -> Vec<f64> {
        let p = self.projection;
        (0..r)
            .map(|k| (0..u.len()).map(|i| p[(k, i)] * u[i]).sum())
            .collect()
    }
}

/// Euclidean norm.
pub(crate) fn norm(x: &[f64]) -> f64 {
    x.iter().map(|v| v * v).sum::<f64>().sqrt()
}
