//! The stability of a forced orbit on the massless contact boundary (docs/STABILITY.md,
//! Sec. 9; DESIGN §10.6): the modes up to (N + 1) W stay dynamic, the others respond statically
//! on the contact rows, the contact displacements carry no mass, and the multipliers are those of
//! the exact monodromy of that model's periodic orbit next to the harmonic-balance orbit
//! (`driven_model`, `driven_shooting`).

use faer::Mat;

use crate::driven_model::{driven_model, modal_start, DrivenBoundary, DrivenInputs};
use crate::driven_shooting::{shoot_driven, shoot_driven_at_fixed_frequency};
use nlmodes_hb::floquet::{multipliers_of, SampledMonodromy};
use nlmodes_hb::HbError;

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
    /// The largest |mu| of the boundary's orbit at the point's own W (shot from the orbit
    /// above): where it and `monodromy` give different verdicts the verdict changes within
    /// the shift (a bifurcation nearby) and is not the point's. `None` where that shooting
    /// did not converge (a steep flank: the orbit at the nearby W is the point's neighbour).
    pub fixed_frequency_largest: Option<f64>,
}

/// The multipliers of the forced orbit `coefficients` (n x (2N + 1)) at W = `omega` on the
/// massless boundary, or `None` when the model has no mode above the cutoff (unless
/// `keep_all` under a penalty law: the boundary is then the penalty spring alone and the shot
/// orbit the exact periodic solution of the penalty equation), the residual flexibility is not
/// positive definite, or shooting does not converge.
pub fn boundary_monodromy(
    inputs: &DrivenInputs<'_>,
    coefficients: &Mat<f64>,
    omega: f64,
) -> Result<Option<BoundaryMonodromy>, HbError> {
    monodromy_on_boundary(inputs, coefficients, omega, true)
}

/// [`boundary_monodromy`], the orbit at the point's own W shot too only when
/// `at_own_frequency` (`converged_cutoff` asks for it on its last model only).
pub(crate) fn monodromy_on_boundary(
    inputs: &DrivenInputs<'_>,
    coefficients: &Mat<f64>,
    omega: f64,
    at_own_frequency: bool,
) -> Result<Option<BoundaryMonodromy>, HbError> {
    let Some(model) = driven_model(inputs, omega)? else {
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
    let mut b = BoundaryMonodromy {
        monodromy: multipliers_of(orbit.monodromy, trace, period)?,
        shift: orbit.shift,
        modes: r,
        model,
        start: orbit.start,
        fixed_frequency_largest: None,
    };
    if at_own_frequency {
        b.fixed_frequency_largest = b.largest_at_own_frequency(omega);
    }
    Ok(Some(b))
}

impl BoundaryMonodromy {
    /// The largest |mu| of the boundary's periodic orbit at W = `omega` (the point's own),
    /// shot from this orbit (found with W free): `None` where W did not move or that shooting
    /// does not converge.
    pub(crate) fn largest_at_own_frequency(&self, omega: f64) -> Option<f64> {
        if self.model.omega == omega {
            return None;
        }
        let model = self.model.at(omega);
        let trace: f64 = (0..self.modes).map(|i| model.damping[(i, i)]).sum();
        let period = 2.0 * std::f64::consts::PI / omega;
        let fixed = shoot_driven_at_fixed_frequency(&model, &self.start).ok()??;
        Some(
            multipliers_of(fixed.monodromy, trace, period)
                .ok()?
                .largest(),
        )
    }
}
