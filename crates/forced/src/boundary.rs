//! The stability of a forced orbit on the massless contact boundary (docs/STABILITY.md,
//! Sec. 9; DESIGN §10.6): the modes up to (N + 1) W stay dynamic, the others respond statically
//! on the contact rows, the contact displacements carry no mass, and the multipliers are those of
//! the exact monodromy of that model's periodic orbit next to the harmonic-balance orbit
//! (`nlmodes_hb::driven_boundary`).

use faer::{Mat, MatRef};

use crate::load::Load;
use nlmodes_hb::driven_boundary::{
    residual_flexibility, shoot_driven, BoundaryDrive, DrivenBoundary,
};
use nlmodes_hb::floquet::{multipliers_of, SampledMonodromy};
use nlmodes_hb::full_basis::FullBasis;
use nlmodes_hb::system::System;
use nlmodes_hb::HbError;

/// Modes kept dynamic: w_k <= this x (N + 1) W (the modes whose resonant harmonics the orbit
/// holds, as for the free modes).
pub const BOUNDARY_CUTOFF: f64 = 1.0;

/// Largest scaled distance between the harmonic-balance orbit's start and the shot orbit's at
/// which the shot orbit's verdict is the point's (as `SHOOTING_SHIFT_LIMIT` of the free modes).
pub const BOUNDARY_SHIFT_LIMIT: f64 = 1e-2;

/// The monodromy of the shot orbit, how far that orbit lies from the harmonic-balance one, and
/// the modes kept.
#[derive(Clone, Debug)]
pub struct BoundaryMonodromy {
    pub monodromy: SampledMonodromy,
    pub shift: f64,
    pub modes: usize,
    /// The model at the shot orbit's W (for an independent check).
    pub model: DrivenBoundary,
    /// (q, q') of the shot orbit at t = 0.
    pub start: Vec<f64>,
}

/// What the boundary model is built from.
pub struct BoundaryInputs<'a> {
    pub system: &'a System,
    /// C (n x n).
    pub damping: MatRef<'a, f64>,
    /// The load at the point's level.
    pub load: &'a Load,
    /// kc of a penalty law (N/m), `None` for exact contact.
    pub penalty: Option<f64>,
    /// Harmonics N of the orbit.
    pub harmonics: usize,
    /// Whether a penalty model whose modes are all below the cutoff is kept whole (the penalty
    /// equation itself, solved exactly); otherwise the boundary needs a discarded mode.
    pub keep_all: bool,
}

/// The multipliers of the forced orbit `coefficients` (n x (2N + 1)) at W = `omega` on the
/// massless boundary, or `None` when the model has no mode above the cutoff (unless
/// `keep_all` under a penalty law: the boundary is then the penalty spring alone and the shot
/// orbit the exact periodic solution of the penalty equation), the residual flexibility is not
/// positive definite, or shooting does not converge.
pub fn boundary_monodromy(
    inputs: &BoundaryInputs<'_>,
    coefficients: &Mat<f64>,
    omega: f64,
) -> Result<Option<BoundaryMonodromy>, HbError> {
    let Some(model) = driven_model(inputs, omega) else {
        return Ok(None);
    };
    let r = model.omega2.len();
    let guess = modal_start(inputs.system, coefficients, omega, r);
    // A failure of the boundary model (a chattering contact set, a singular piece) leaves the
    // point to the massive model's monodromy and its period check.
    let orbit = match shoot_driven(&model, &guess) {
        Ok(Some(orbit)) => orbit,
        Ok(None) => {
            tracing::debug!(omega, "massless-boundary shooting did not converge");
            return Ok(None);
        }
        Err(e) => {
            tracing::debug!(omega, error = %e, "massless-boundary shooting failed");
            return Ok(None);
        }
    };
    tracing::debug!(
        omega,
        shift = orbit.shift,
        iterations = orbit.iterations,
        "massless-boundary orbit"
    );
    let trace: f64 = (0..r).map(|i| model.damping[(i, i)]).sum();
    let period = 2.0 * std::f64::consts::PI / orbit.omega;
    let mut model = model;
    model.omega = orbit.omega;
    Ok(Some(BoundaryMonodromy {
        monodromy: multipliers_of(orbit.monodromy, trace, period)?,
        shift: orbit.shift,
        modes: r,
        model,
        start: orbit.start,
    }))
}

/// (q, q') at t = 0 of the harmonic-balance orbit in the first r modes.
pub(crate) fn modal_start(
    system: &System,
    coefficients: &Mat<f64>,
    omega: f64,
    r: usize,
) -> Vec<f64> {
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

/// The driven boundary model at W, `None` when it does not apply (module docs).
pub(crate) fn driven_model(inputs: &BoundaryInputs<'_>, omega: f64) -> Option<DrivenBoundary> {
    let system = inputs.system;
    let lambda = system.eigenvalues();
    let n = lambda.len();
    let limit = BOUNDARY_CUTOFF * (inputs.harmonics as f64 + 1.0) * omega;
    let resolved = lambda.iter().filter(|l| l.sqrt() <= limit).count().max(1);
    // With every mode resolved, exact contact leaves no flexibility between the massive
    // coordinates and the obstacle (an impact, not this model); a penalty law keeps its spring
    // 1 / kc, and the model is then the penalty equation itself, solved exactly.
    if resolved >= n && !(inputs.keep_all && inputs.penalty.is_some()) {
        return None;
    }
    let r = resolved.min(n);
    let phi = system.modes();
    let b_all = system.contact_rows() * phi;
    let c = b_all.nrows();
    let penalty = inputs.penalty.map(|kc| vec![kc; c]);
    let flexibility = residual_flexibility(b_all.as_ref(), lambda, r, penalty.as_deref())?;
    let phi_k = phi.subcols(0, r);
    let damping = phi_k.transpose() * inputs.damping * phi_k;
    let drive = inputs
        .load
        .harmonics
        .iter()
        .map(|h| {
            let parts = [&h.cos, &h.sin];
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
    Some(DrivenBoundary {
        omega2: lambda[..r].to_vec(),
        damping,
        contact_modal: b_all.subcols(0, r).to_owned(),
        flexibility,
        gaps: system.gaps().to_vec(),
        drive,
        omega,
    })
}
