//! The linear part of the inner problem (Eq. 20, docs/DESIGN.md §3.4) as seen by the Newton
//! solver: a [`LinearModel`] evaluates (K - (n w)^2 M) u_n + A^T lambda_n in its own coordinates
//! (physical in `full`, the exact condensation in `condensed_newton`) and solves the Newton
//! system J step = rhs, given the contact Jacobian as cosine moments ([`JacobianData`]), the
//! normalization row e . u_1 = q (Sec. 2.6) and a [`ParameterRow`] (fixed q or pseudo-arc-length).
//!
//! Contact Jacobian of one contact row (generalized derivative of lambda = kappa (g + theta)_+:
//! kappa on active samples, 0 elsewhere), projected on the cosines: with the moments
//! D_p = (1/m) sum_k kappa_k active_k cos(2 pi p k / m), p = 0..=2N,
//! J_{0,n'} = D_{n'} and J_{n,n'} = D_{n+n'} + D_{|n-n'|} for n >= 1 ([`contact_jacobian`]).

use crate::error::HbError;
use crate::layout::HarmonicLayout;

/// The parameter row a_q (q - q_p)/q_s + a_w (w - w_p)/w_s + a_y . (y - y_p)/y_s = 0.
///
/// y are the kept coordinates of every harmonic: the contact coefficients A_j u_n (layout
/// j (N+1) + n) followed by the master coefficients e . u_n (layout c (N+1) + n). Fixed q:
/// a_q = 1, everything else 0 (a_y empty). Pseudo-arc-length: (a_q, a_w, a_y) is the unit tangent
/// of the branch in the scaled space (q / g_ref, w / w_lin, y / (g_ref sqrt(c + 1))).
#[derive(Clone, Debug)]
pub struct ParameterRow {
    pub a_q: f64,
    pub a_w: f64,
    pub a_y: Vec<f64>,
    pub q_p: f64,
    pub w_p: f64,
    pub y_p: Vec<f64>,
    pub q_scale: f64,
    pub w_scale: f64,
    pub y_scale: f64,
}

impl ParameterRow {
    pub fn fixed_amplitude(q: f64, q_scale: f64, w_scale: f64) -> Self {
        Self {
            a_q: 1.0,
            a_w: 0.0,
            a_y: Vec::new(),
            q_p: q,
            w_p: 0.0,
            y_p: Vec::new(),
            q_scale,
            w_scale,
            y_scale: 1.0,
        }
    }
}

/// What a Jacobian solve needs besides the model's own data.
pub struct JacobianData<'a> {
    pub omega: f64,
    pub x: &'a [f64],
    /// Contact rows with at least one active sample.
    pub active: &'a [usize],
    /// Cosine moments D_p (p = 0..=2N) of kappa * active, one block of 2N + 1 per active row.
    pub moments: &'a [f64],
    /// d R_norm / d(e . u_1) (and minus d R_norm / dq).
    pub norm_scale: f64,
    /// d R_arc / dw.
    pub arc_w: f64,
    /// d R_arc / dq.
    pub arc_q: f64,
    /// d R_arc / dy (layout of [`ParameterRow`]; empty when the row does not involve y).
    pub arc_y: &'a [f64],
}

/// Contact Jacobian entry J_{n,n'} of one contact row from its cosine moments (see module docs).
#[inline]
pub fn contact_jacobian(moments: &[f64], n: usize, np: usize) -> f64 {
    if n == 0 {
        moments[np]
    } else {
        moments[n + np] + moments[n.abs_diff(np)]
    }
}

/// The linear part of Eq. (20) in some coordinates (physical, or the exact condensation).
pub trait LinearModel {
    /// Layout of the coefficient block of the Newton unknowns: d coordinates per harmonic,
    /// harmonics 0..=N (fixed when the model is built).
    fn layout(&self) -> HarmonicLayout;
    /// Coordinates per harmonic d.
    fn dim(&self) -> usize {
        self.layout().dim()
    }
    /// Contact coefficients A_j u_n, signal-major (`layout().signals(c)`).
    fn contact_coefficients(&self, x: &[f64], out: &mut [f64]);
    /// e_master in model coordinates (length d).
    fn master_row(&self) -> &[f64];
    /// Harmonic rows (K - (n w)^2 M) x_n + A^T lambda_n; `lambda_coef` signal-major.
    fn harmonic_residual(&mut self, omega: f64, x: &[f64], lambda_coef: &[f64], out: &mut [f64]);
    /// Merit weights of the harmonic rows (1 / sqrt(diagonal stiffness)), length d.
    fn row_weights(&self) -> &[f64];
    /// Solves J step = rhs in place (`rhs` has d (N+1) + 2 entries: harmonic rows, norm, arc).
    fn solve_step(&mut self, jac: &JacobianData<'_>, rhs: &mut [f64]) -> Result<(), HbError>;
    /// Physical coefficient vectors of `count` harmonics (n x count, column-major) from model
    /// coordinates (d x count).
    fn model_to_physical(&self, x: &[f64], count: usize, u: &mut [f64]);
    /// Model coordinates (d x count) of `count` physical coefficient vectors (n x count).
    fn physical_to_model(&self, u: &[f64], count: usize, x: &mut [f64]);
}
