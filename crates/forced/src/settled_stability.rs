//! The Floquet verdict of a point in contact on the massless boundary whose dynamic modes are
//! raised until its exact orbit settles (`nlmodes_boundary::boundary_with_converged_cutoff`),
//! that orbit taken for the point's when the master's amplitude at the excitation's harmonic
//! agrees with the harmonic-balance orbit's within what the harmonic balance's own truncation
//! explains (docs/STABILITY.md Sec. 9.6). First built for the casing study (issue 39, session
//! 22: `casing_sweep`), since session 25 also the second opinion on every forced point and
//! speed-sweep point that the state distance at the (N + 1) W cutoff leaves undetermined
//! (`assess_point_settled`).
//!
//! Why not the state distance of `PointStability::on_boundary` alone: it compares (q, q') at one
//! instant scaled by |q| and W |q|, so a kept mode k carries its velocity error times w_k / W.
//! On the default blade under the casing it grows with the modes kept (0.08 at 14 modes, 0.19 at
//! 48, at 0.84 g0) while the master's first harmonic of the same two orbits agrees to
//! 1.6e-3..3.4e-3 (N = 40), and the harmonic-balance orbit's truncated series carries the Gibbs
//! error of the strike's kink in exactly those velocities. The amplitude is a property of the
//! whole orbit, the same from any time origin; the orbit is shot from the sample farthest from
//! contact (`orbit_origin::most_open_sample`), the load and the casing advanced alike.
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
use nlmodes_boundary::{
    boundary_with_converged_cutoff, largest_contact_force, CutoffConvergence, DrivenInputs,
};
use nlmodes_hb::floquet::Verdict;
use nlmodes_hb::{ContactMethod, FullBasis, System};

use crate::boundary::{BoundaryInputs, BOUNDARY_SHIFT_LIMIT};
use crate::curve::ExactForce;
use crate::distortion::CasingDistortion;
use crate::error::ForcedError;
use crate::harmonic_check::HarmonicCheck;
use crate::load::Load;
use crate::orbit_origin::{advanced_orbit, most_open_sample};
use crate::point_stability::{assess_point_with, Assessment, PointStability};
use crate::solver::{ForcedPoint, ForcedSolver};

/// The cutoff's doubling stops when the master's amplitude (relative) and the largest |mu|
/// change by at most this.
pub(crate) const CUTOFF_TOLERANCE: f64 = 5e-3;

/// What the settled boundary of a point is built from, seen from the point's time origin.
pub(crate) struct SettledModel<'a> {
    pub system: &'a System,
    /// C (n x n, N s/m).
    pub damping: &'a Mat<f64>,
    /// The load at the point's level (none under the casing study).
    pub load: Load,
    /// The casing's distortion (`None`: constant gaps).
    pub distortion: Option<CasingDistortion>,
}

impl SettledModel<'_> {
    /// The harmonic the master's amplitude is compared at: the casing's, else the load's first.
    fn harmonic(&self) -> usize {
        match (&self.distortion, self.load.harmonics.first()) {
            (Some(d), _) => d.harmonic,
            (None, Some(h)) => h.harmonic,
            (None, None) => 1,
        }
    }
}

/// The orbit of `point` (under `solver`'s law, seen from the origin `model` is advanced to) on
/// the massless boundary with its cutoff settled (module docs); `None` where the boundary does
/// not apply or does not shoot. Shared with `exact_force`.
pub(crate) fn settled_boundary(
    model: &SettledModel<'_>,
    solver: &ForcedSolver<'_>,
    point: &ForcedPoint,
) -> Result<Option<CutoffConvergence>, ForcedError> {
    let penalty = match solver.settings().algorithm.method {
        ContactMethod::Penalty { stiffness } => Some(stiffness),
        _ => None,
    };
    let boundary = BoundaryInputs {
        system: model.system,
        damping: model.damping.as_ref(),
        load: &model.load,
        penalty,
        harmonics: point.harmonics,
        keep_all: true,
    };
    let inputs = DrivenInputs {
        gap_motion: (model.distortion.iter())
            .map(|d| d.gap_harmonic(model.system.n_contacts()))
            .collect(),
        ..boundary.driven()
    };
    Ok(boundary_with_converged_cutoff(
        &inputs,
        &point.coefficients,
        point.omega,
        model.harmonic(),
        CUTOFF_TOLERANCE,
    )?)
}

/// The verdict of `point` (in contact, under `solver`'s law, seen from the origin `model` is
/// advanced to) on the settled boundary (module docs), `hb_change` the harmonic balance's
/// relative change of the master's amplitude at the point's last doubling of N (`None`: not
/// checked), with the settled boundary it was read from; `None` where the boundary does not
/// apply or does not shoot.
fn settled_verdict(
    model: &SettledModel<'_>,
    solver: &ForcedSolver<'_>,
    point: &ForcedPoint,
    hb_change: Option<f64>,
    how: &Assessment,
) -> Result<Option<(PointStability, CutoffConvergence)>, ForcedError> {
    let h = model.harmonic();
    let clock = std::time::Instant::now();
    let Some(settled) = settled_boundary(model, solver, point)? else {
        return Ok(None);
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
        "point on the converged boundary"
    );
    let st = PointStability::on_boundary_at(
        &settled.boundary,
        how.margin + settled.change[1],
        distance,
        limit,
    );
    let st = match how.verify {
        true => st.verified(&settled.boundary),
        false => st,
    };
    Ok(Some((st, settled)))
}

/// The verdict of `point` on `solver` (`assess_point_with`); where that is undetermined because
/// the boundary's shot orbit lies beyond `BOUNDARY_SHIFT_LIMIT` in state from the
/// harmonic-balance orbit, the settled boundary's (module docs), from the sample farthest from
/// contact, when it applies.
pub(crate) fn assess_point_settled(
    solver: &ForcedSolver<'_>,
    point: &ForcedPoint,
    how: &Assessment,
) -> Result<PointStability, ForcedError> {
    let st = assess_point_with(solver, point, how)?;
    let shifted = st.boundary_shift.is_some_and(|s| s > BOUNDARY_SHIFT_LIMIT);
    if st.verdict != Verdict::Undetermined || !shifted || !point.touches() {
        return Ok(st);
    }
    let (model, seen) = seen_from_most_open(solver, point);
    let hb_change = match point.harmonic_check {
        HarmonicCheck::Converged { change } => Some(change[0]),
        HarmonicCheck::NotConverged { change } => change.map(|c| c[0]),
        HarmonicCheck::Unchecked | HarmonicCheck::Linear => None,
    };
    let settled = settled_verdict(&model, solver, &seen, hb_change, how)?;
    Ok(settled.map_or(st, |(st, _)| st))
}

/// `point` seen from its sample farthest from contact (`orbit_origin::most_open_sample`), and
/// the model of `solver` at its level advanced alike: the settled boundary's start.
pub(crate) fn seen_from_most_open<'a>(
    solver: &'a ForcedSolver<'_>,
    point: &ForcedPoint,
) -> (SettledModel<'a>, ForcedPoint) {
    let (seen, theta) = advanced_orbit(point, most_open_sample(point));
    let model = SettledModel {
        system: solver.system(),
        damping: solver.damping(),
        load: solver.load().scaled(point.level).advanced(theta),
        distortion: solver.settings().distortion.map(|d| d.advanced(theta)),
    };
    (model, seen)
}

/// The verdict of `point` of the casing study (seen from the origin `model.distortion` is
/// advanced to) on `solver` (its N and contact law), `hb_change` as `settled_verdict`'s: the
/// settled boundary's in contact where it applies, else `assess_point_with`; with the largest
/// contact force of the settled boundary's exact orbit (`exact_force`) where it was shot.
pub(crate) fn casing_point_stability(
    model: &SettledModel<'_>,
    solver: &ForcedSolver<'_>,
    point: &ForcedPoint,
    hb_change: Option<f64>,
    how: &Assessment,
) -> Result<(PointStability, Option<ExactForce>), ForcedError> {
    if !point.touches() {
        return Ok((assess_point_with(solver, point, how)?, None));
    }
    match settled_verdict(model, solver, point, hb_change, how)? {
        Some((st, settled)) => Ok((st, exact_force_of(&settled)?)),
        // Exact contact with every mode below (N + 1) W (an impact, not this model), or no
        // shot orbit: the massive model's monodromy behind its period check.
        None => Ok((assess_point_with(solver, point, how)?, None)),
    }
}

/// The largest contact force of the settled boundary's shot orbit (`None`: it never touches):
/// `exact_force`'s and the casing study's.
pub(crate) fn exact_force_of(
    settled: &CutoffConvergence,
) -> Result<Option<ExactForce>, ForcedError> {
    let b = &settled.boundary;
    let peak = largest_contact_force(&b.model, &b.start)?;
    Ok(peak.map(|p| ExactForce {
        force: p.force,
        omega: b.model.omega,
    }))
}
