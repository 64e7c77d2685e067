//! The Floquet verdict of a point of the distortion sweep in contact (issue 39; docs/
//! STABILITY.md Sec. 9.6): the massless boundary with the moving gap, its dynamic modes raised
//! until its exact orbit settles (`nlmodes_boundary::boundary_with_converged_cutoff`), and that
//! orbit taken for the point's when the master's amplitude at the gap's harmonic agrees with the
//! harmonic-balance orbit's within what the harmonic balance's own truncation explains.
//!
//! Why not the state distance of `PointStability::on_boundary`: it compares (q, q') at one
//! instant scaled by |q| and W |q|, so a kept mode k carries its velocity error times w_k / W.
//! On the default blade it grows with the modes kept (0.08 at 14 modes, 0.19 at 48, at 0.84 g0)
//! while the master's first harmonic of the same two orbits agrees to 1.6e-3..3.4e-3 (N = 40), and the
//! harmonic-balance orbit's truncated series carries the Gibbs error of the strike's kink in
//! exactly those velocities. The amplitude is a property of the whole orbit, the same from any
//! time origin.
//!
//! The rule: undetermined when |a_hb / a_exact - 1| exceeds `BOUNDARY_SHIFT_LIMIT` (1e-2) or
//! twice the harmonic balance's own change at its last doubling of N, whichever is larger, plus
//! the cutoff's last change (the harmonic balance converges as N^-p, p about 2 on the blade:
//! 4-5 x per doubling, so its remaining error after a change c is c 2^p / (2^p - 1) <= 2c for
//! p >= 1); the verdict margin grows by the change of the largest |mu| at the cutoff's last
//! doubling. Under a penalty law whose model has every mode below the cutoff the boundary is
//! the penalty equation itself, shot exactly (`keep_all`), so a model and the same model with a
//! free stiff coordinate get the same verdicts. Points where the boundary does not apply
//! (exact contact, every mode resolved) or does not shoot keep `assess_point_with`.

use faer::Mat;
use nlmodes_boundary::{boundary_with_converged_cutoff, DrivenInputs};
use nlmodes_hb::{ContactMethod, FullBasis, System};

use crate::boundary::BOUNDARY_SHIFT_LIMIT;
use crate::distortion::CasingDistortion;
use crate::error::ForcedError;
use crate::point_stability::{assess_point_with, Assessment, PointStability};
use crate::solver::{ForcedPoint, ForcedSolver};

/// The cutoff's doubling stops when the master's amplitude (relative) and the largest |mu|
/// change by at most this.
pub(crate) const CUTOFF_TOLERANCE: f64 = 5e-3;

/// What the verdict of a point of the sweep is computed on.
pub(crate) struct CasingModel<'a> {
    pub system: &'a System,
    /// C (n x n, N s/m).
    pub damping: &'a Mat<f64>,
    /// The casing seen from the point's time origin.
    pub distortion: CasingDistortion,
}

/// The verdict of `point` (seen from the origin `model.distortion` is advanced to) on
/// `solver` (its N and contact law), `hb_change` the harmonic balance's relative change of the
/// master's amplitude at the point's last doubling of N (`None`: not checked) (module docs).
pub(crate) fn casing_point_stability(
    model: &CasingModel<'_>,
    solver: &ForcedSolver<'_>,
    point: &ForcedPoint,
    hb_change: Option<f64>,
    how: &Assessment,
) -> Result<PointStability, ForcedError> {
    if !point.touches() {
        return assess_point_with(solver, point, how);
    }
    let penalty = match solver.settings().algorithm.method {
        ContactMethod::Penalty { stiffness } => Some(stiffness),
        _ => None,
    };
    let inputs = DrivenInputs {
        system: model.system,
        damping: model.damping.as_ref(),
        load: Vec::new(),
        penalty,
        harmonics: point.harmonics,
        keep_all: true,
        gap_motion: vec![model.distortion.gap_harmonic(model.system.n_contacts())],
    };
    let h = model.distortion.harmonic;
    let clock = std::time::Instant::now();
    let settled = boundary_with_converged_cutoff(
        &inputs,
        &point.coefficients,
        point.omega,
        h,
        CUTOFF_TOLERANCE,
    )?;
    let Some(settled) = settled else {
        // Exact contact with every mode below (N + 1) W (an impact, not this model), or no
        // shot orbit: the massive model's monodromy behind its period check.
        return assess_point_with(solver, point, how);
    };
    let c = &point.coefficients;
    let m = model.system.master();
    let hb = c[(m, FullBasis::cos_index(h))].hypot(c[(m, FullBasis::sin_index(h))]);
    let distance = (hb / settled.master_amplitude - 1.0).abs();
    let limit = BOUNDARY_SHIFT_LIMIT.max(2.0 * hb_change.unwrap_or(0.0)) + settled.change[0];
    tracing::debug!(
        omega = point.omega,
        modes = settled.boundary.modes,
        cutoff = settled.cutoff,
        distance,
        limit,
        largest = settled.boundary.monodromy.largest(),
        cutoff_change = ?settled.change,
        seconds = clock.elapsed().as_secs_f64(),
        "casing point on the converged boundary"
    );
    let st = PointStability::on_boundary_at(
        &settled.boundary,
        how.margin + settled.change[1],
        distance,
        limit,
    );
    if !how.verify {
        return Ok(st);
    }
    let clock = std::time::Instant::now();
    let st = st.verified(&settled.boundary);
    tracing::debug!(
        seconds = clock.elapsed().as_secs_f64(),
        modes = settled.boundary.modes,
        "casing point's RK4 check"
    );
    Ok(st)
}
