//! The massless contact boundary of a damped, driven model (DESIGN §10.6; docs/STABILITY.md
//! Sec. 9 for the free model of `model`), and how it is built from a system, its damping and its
//! load.
//!
//! The linear modes up to a cutoff are the dynamic coordinates q (mass-normalized, K = W^2,
//! damping C_q = Phi_k^T C Phi_k); the others respond statically through the residual
//! flexibility on the contact rows, R = A Phi_d W_d^-2 Phi_d^T A^T (c x c, m/N), and to the load
//! through D(t) = A Phi_d W_d^-2 Phi_d^T f(t) (c, m). The contact displacements carry no mass:
//!
//! ```text
//! q'' + C_q q' + W^2 q = Phi_k^T f(t) - B^T lambda,   u_c = B q + D(t) - R lambda,
//! 0 <= lambda _|_ g0 - u_c >= 0                        (B = A Phi_k)
//! ```
//!
//! A penalty law kc adds 1 / kc to R's diagonal. f(t) = sum_h f_h^c cos(h W t) + f_h^s sin(h W t)
//! (N). Its exact flow is `driven_flow`.
//!
//! A moving gap (a casing distortion, DESIGN §10.11; docs/STABILITY.md Sec. 9.5),
//! g_j(t) = g0_j - c_j(t) with the intrusion c_j(t) = sum_h c_hj^c cos(h W t) + c_hj^s sin(h W t)
//! ([`GapHarmonic`]), enters every contact law only through the free penetration
//! B_j q + D_j(t) - g_j(t) = B_j q + (D_j(t) + c_j(t)) - g0_j: the multiplier of a closed row and
//! the event function of an open one see D + c where they saw D. The intrusion is therefore
//! added to the drive's contact part at its harmonic (a harmonic the load lacks gets a drive of
//! its own without a modal part), and the flow, its switches and its monodromy are the
//! constant-gap ones on that drive.

use faer::{Mat, MatRef};

use crate::model::{dynamic_modes, residual_flexibility, BoundaryModel};
use crate::structure_modes::StructureCache;
use nlmodes_hb::full_basis::FullBasis;
use nlmodes_hb::system::System;
use nlmodes_hb::HbError;

/// Modes kept dynamic: w_k <= this x (N + 1) W (the modes whose resonant harmonics the orbit
/// holds, as for the free modes).
pub const BOUNDARY_CUTOFF: f64 = 1.0;

/// One harmonic of the drive in the boundary model's terms.
#[derive(Clone, Debug)]
pub struct BoundaryDrive {
    /// Harmonic h of W.
    pub harmonic: usize,
    /// Phi_k^T f_h^c and Phi_k^T f_h^s (r each, N / sqrt(kg)).
    pub modal: [Vec<f64>; 2],
    /// D_h^c and D_h^s: the discarded modes' static response at the contact rows, plus the
    /// intrusion c_h of a moving gap (module docs; c each, m).
    pub contact: [Vec<f64>; 2],
}

/// One harmonic h of a moving gap: row j's gap is g0_j - (intrusion[0][j] cos(h W t) +
/// intrusion[1][j] sin(h W t)) (module docs).
#[derive(Clone, Debug, PartialEq)]
pub struct GapHarmonic {
    /// Harmonic h >= 1 of W.
    pub harmonic: usize,
    /// The intrusion's cosine and sine parts (c each, m): the gap's reduction.
    pub intrusion: [Vec<f64>; 2],
}

/// The damped, driven massless-boundary model at one excitation frequency (module docs).
#[derive(Clone, Debug)]
pub struct DrivenBoundary {
    /// W^2 of the kept modes (rad^2/s^2).
    pub omega2: Vec<f64>,
    /// C_q (r x r, 1/s).
    pub damping: Mat<f64>,
    /// B = A Phi_k (c x r).
    pub contact_modal: Mat<f64>,
    /// R (+ diag(1 / kc)), c x c, m/N.
    pub flexibility: Mat<f64>,
    /// g0 (m).
    pub gaps: Vec<f64>,
    /// The drive's harmonics.
    pub drive: Vec<BoundaryDrive>,
    /// Excitation frequency W (rad/s).
    pub omega: f64,
    /// The structure's decompositions by active set, shared with the model's copies at other
    /// W (`structure_modes`; `Default::default()` for a new model).
    pub structure: StructureCache,
}

impl DrivenBoundary {
    pub(crate) fn r(&self) -> usize {
        self.omega2.len()
    }

    /// Size of the augmented state: 2r + 2H + 1.
    pub(crate) fn size(&self) -> usize {
        2 * self.r() + 2 * self.drive.len() + 1
    }

    /// The augmented state at time t from (q, q').
    pub fn augmented(&self, q: &[f64], v: &[f64], t: f64) -> Vec<f64> {
        let mut x: Vec<f64> = q.iter().chain(v).copied().collect();
        for d in &self.drive {
            let (s, c) = (d.harmonic as f64 * self.omega * t).sin_cos();
            x.extend([c, s]);
        }
        x.push(1.0);
        x
    }

    /// The free model `model` as a driven one without damping or drive (for the RK4 check;
    /// `period` (s) only sets its nominal frequency).
    pub fn undriven(model: &BoundaryModel, period: f64) -> Self {
        let r = model.omega2.len();
        Self {
            omega2: model.omega2.clone(),
            damping: Mat::zeros(r, r),
            contact_modal: model.contact_modal.clone(),
            flexibility: model.flexibility.clone(),
            gaps: model.gaps.clone(),
            drive: Vec::new(),
            omega: 2.0 * std::f64::consts::PI / period,
            structure: StructureCache::default(),
        }
    }

    /// The same model at excitation frequency `omega` (rad/s).
    pub fn at(&self, omega: f64) -> Self {
        let mut m = self.clone();
        m.omega = omega;
        m
    }

    /// The model under the moving gap `motion` (module docs): each harmonic's intrusion added
    /// to the drive's contact part at that harmonic, a drive without a modal part appended for
    /// a harmonic the load lacks. Errors on a harmonic 0 or an intrusion not of one value per
    /// contact row.
    pub fn with_gap_motion(mut self, motion: &[GapHarmonic]) -> Result<Self, HbError> {
        let (r, c) = (self.r(), self.gaps.len());
        for g in motion {
            if g.harmonic == 0 || g.intrusion.iter().any(|part| part.len() != c) {
                return Err(HbError::StabilityInput {
                    detail: format!(
                        "a moving gap needs a harmonic >= 1 and one intrusion per contact row \
                         ({c}); got harmonic {} with {} and {} values",
                        g.harmonic,
                        g.intrusion[0].len(),
                        g.intrusion[1].len()
                    ),
                });
            }
            let at = match self.drive.iter().position(|d| d.harmonic == g.harmonic) {
                Some(k) => k,
                None => {
                    self.drive.push(BoundaryDrive {
                        harmonic: g.harmonic,
                        modal: [vec![0.0; r], vec![0.0; r]],
                        contact: [vec![0.0; c], vec![0.0; c]],
                    });
                    self.drive.len() - 1
                }
            };
            for (part, add) in self.drive[at].contact.iter_mut().zip(&g.intrusion) {
                part.iter_mut().zip(add).for_each(|(d, a)| *d += a);
            }
        }
        Ok(self)
    }
}

/// One harmonic h of the load f(t): f_h^c cos(h W t) + f_h^s sin(h W t) (n each, N).
#[derive(Clone, Copy, Debug)]
pub struct LoadHarmonic<'a> {
    pub harmonic: usize,
    pub cos: &'a [f64],
    pub sin: &'a [f64],
}

/// What a driven boundary model is built from.
pub struct DrivenInputs<'a> {
    pub system: &'a System,
    /// C (n x n, N s/m).
    pub damping: MatRef<'a, f64>,
    /// The load at the point's level.
    pub load: Vec<LoadHarmonic<'a>>,
    /// kc of a penalty law (N/m), `None` for exact contact.
    pub penalty: Option<f64>,
    /// Harmonics N of the orbit.
    pub harmonics: usize,
    /// Whether a penalty model whose modes are all below the cutoff is kept whole (the penalty
    /// equation itself, solved exactly); otherwise the boundary needs a discarded mode.
    pub keep_all: bool,
    /// The gaps' motion (module docs; empty: constant gaps g0).
    pub gap_motion: Vec<GapHarmonic>,
}

/// The driven boundary model at W (rad/s): the modes w_k <= [`BOUNDARY_CUTOFF`] (N + 1) W
/// dynamic, the gaps moving as `inputs.gap_motion` says; `None` when it does not apply (every
/// mode resolved under exact contact, or the residual flexibility not positive definite).
/// Errors on a gap motion that does not fit the rows ([`DrivenBoundary::with_gap_motion`]).
pub fn driven_model(
    inputs: &DrivenInputs<'_>,
    omega: f64,
) -> Result<Option<DrivenBoundary>, HbError> {
    let system = inputs.system;
    let lambda = system.eigenvalues();
    let n = lambda.len();
    let limit = BOUNDARY_CUTOFF * (inputs.harmonics as f64 + 1.0) * omega;
    let resolved = dynamic_modes(lambda.iter().map(|l| l.sqrt()), limit);
    // With every mode resolved, exact contact leaves no flexibility between the massive
    // coordinates and the obstacle (an impact, not this model); a penalty law keeps its spring
    // 1 / kc, and the model is then the penalty equation itself, solved exactly.
    if resolved >= n && !(inputs.keep_all && inputs.penalty.is_some()) {
        return Ok(None);
    }
    let r = resolved.min(n);
    let phi = system.modes();
    let b_all = system.contact_rows() * phi;
    let c = b_all.nrows();
    let penalty = inputs.penalty.map(|kc| vec![kc; c]);
    let Some(flexibility) = residual_flexibility(b_all.as_ref(), lambda, r, penalty.as_deref())
    else {
        return Ok(None);
    };
    let phi_k = phi.subcols(0, r);
    let damping = phi_k.transpose() * inputs.damping * phi_k;
    let drive = inputs
        .load
        .iter()
        .map(|h| {
            let parts = [h.cos, h.sin];
            let modal_all = parts.map(|f| {
                (0..n)
                    .map(|k| (0..n).map(|i| phi[(i, k)] * f[i]).sum::<f64>())
                    .collect::<Vec<f64>>()
            });
            BoundaryDrive {
                harmonic: h.harmonic,
                modal: modal_all.clone().map(|m| m[..r].to_vec()),
                contact: modal_all.map(|m| {
                    (0..c)
                        .map(|j| (r..n).map(|k| b_all[(j, k)] * m[k] / lambda[k]).sum())
                        .collect()
                }),
            }
        })
        .collect();
    DrivenBoundary {
        omega2: lambda[..r].to_vec(),
        damping,
        contact_modal: b_all.subcols(0, r).to_owned(),
        flexibility,
        gaps: system.gaps().to_vec(),
        drive,
        omega,
        structure: StructureCache::default(),
    }
    .with_gap_motion(&inputs.gap_motion)
    .map(Some)
}

/// (q, q') at t = 0 of the harmonic-balance orbit `coefficients` (n x (2N + 1), full Fourier
/// basis) at W = `omega` (rad/s) in the first r modes.
pub fn modal_start(system: &System, coefficients: &Mat<f64>, omega: f64, r: usize) -> Vec<f64> {
    let n = coefficients.nrows();
    let series = |i: usize| -> Vec<f64> {
        (0..coefficients.ncols())
            .map(|k| coefficients[(i, k)])
            .collect()
    };
    let u: Vec<f64> = (0..n)
        .map(|i| FullBasis::value_at(&series(i), 0.0))
        .collect();
    let v: Vec<f64> = (0..n)
        .map(|i| FullBasis::rate_at(&series(i), omega, 0.0))
        .collect();
    // Phi_k^T M on the r kept modes only (r x n: not the n x n product).
    let projection = system.modes().subcols(0, r).transpose() * system.mass();
    let project = |x: &[f64], k: usize| (0..n).map(|i| projection[(k, i)] * x[i]).sum::<f64>();
    (0..r)
        .map(|k| project(&u, k))
        .chain((0..r).map(|k| project(&v, k)))
        .collect()
}
