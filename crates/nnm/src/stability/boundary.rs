//! The free modes on the massless contact boundary (docs/STABILITY.md Sec. 9; the model, its
//! flow, shooting, exact curves and converged orbits are `nlmodes_boundary`'s): which modes a
//! backbone point keeps dynamic, its contact law, its shot orbit (the stability's shooting
//! method), the exact backbone of a main branch, the converged orbit of each main-branch point
//! and Fig. 4 on the boundary.

use faer::c64;
use rayon::prelude::*;

use super::hill::stability_from_exponents;
use super::{verdict_word, FloquetAnalysis, StabilityMethod, VerdictInputs};
use crate::continuation::{Backbone, BranchKind};
use crate::point::BackbonePoint;
use crate::NnmError;
use nlmodes_boundary::{
    contact_history, converged_orbit, exact_backbone, shot_orbit, BoundaryBackbone,
    BoundaryHistory, BoundaryModel, BranchStart, ConvergedOrbit, ConvergenceSettings, MasterRow,
    OrbitGuess, ShotOrbit,
};

impl FloquetAnalysis<'_> {
    /// Modes kept dynamic on the massless boundary at circular frequency `omega` with
    /// `harmonics` harmonics: w_k <= `shooting_cutoff` (N + 1) w, at least one. (Not Hill's
    /// `min_modes` floor: a second mode far above the cutoff made dynamic would be the contact
    /// node's own stiff mode on the light-contact model, leaving no boundary at all; before the
    /// decoupled modes were left out, two decoupled pads filled that floor.)
    pub(super) fn shooting_modes(&self, omega: f64, harmonics: usize) -> usize {
        let cutoff = self.settings().shooting_cutoff;
        self.modal_data().dynamic_modes(cutoff, omega, harmonics)
    }

    /// The massless-boundary model of `point` (the modes up to `shooting_cutoff` (N + 1) w
    /// dynamic, `point`'s contact law) and its periodic orbit next to `point`, by shooting; `None`
    /// where the model does not apply (shooting off, no contact, every mode resolved, R not
    /// positive definite) or Newton does not converge.
    pub(super) fn shot_orbit(
        &self,
        point: &BackbonePoint,
        harmonics: usize,
    ) -> Result<Option<(BoundaryModel, ShotOrbit)>, NnmError> {
        if !self.settings().shooting || !in_contact(point) {
            return Ok(None);
        }
        let r = self.shooting_modes(point.omega, harmonics);
        shot_orbit(&self.modal_data(), r, &guess(point))
    }

    /// The converged orbit of `point` (traced with `harmonics`; docs/STABILITY.md Sec. 9.4,
    /// `nlmodes_boundary::converged_orbit`). `None` where the boundary model does not apply
    /// (shooting off, no contact, every mode dynamic) or no orbit is found at the point's q with
    /// the modes of N.
    pub fn converged_orbit(
        &self,
        point: &BackbonePoint,
        harmonics: usize,
        settings: &ConvergenceSettings,
    ) -> Result<Option<ConvergedOrbit>, NnmError> {
        if !self.settings().shooting || !in_contact(point) {
            return Ok(None);
        }
        // The period of the stability's shot orbit (the exact orbit nearest the point, at a
        // slightly different q), where the orbit at the point's own state is not found.
        let shot_period = point
            .stability
            .as_ref()
            .filter(|s| s.orbit_omega > 0.0)
            .map(|s| 2.0 * std::f64::consts::PI / s.orbit_omega);
        let cutoff = self.settings().shooting_cutoff;
        let modal = self.modal_data();
        converged_orbit(
            &modal,
            cutoff,
            &guess(point),
            shot_period,
            harmonics,
            settings,
        )
    }

    /// The verdict of an exact orbit of the boundary from its exponents (1/s) and period (s):
    /// the shooting method's rule ([`verdict_word`]).
    fn shooting_verdict(&self, exponents: &[c64], period: f64) -> (f64, &'static str) {
        let mut s = stability_from_exponents(exponents, period, self.settings().tolerance);
        s.method = StabilityMethod::Shooting;
        (s.max_multiplier_abs, verdict_word(&VerdictInputs::of(&s)))
    }
}

/// The converged orbit of every point `chosen` of `backbone` (main-branch points in contact;
/// [`FloquetAnalysis::converged_orbit`] with the points' own N), in parallel, stored in
/// [`BackbonePoint::converged`], and the "N too small" flag (`truncation_warning`) set from it:
/// where the harmonic-balance w is farther than `settings.omega_tolerance` (relative) from the
/// converged w, or no converged orbit was found. A point whose orbit fails is logged and keeps
/// none. `progress()` is called after each point.
pub fn converge_points(
    analysis: &FloquetAnalysis<'_>,
    backbone: &mut Backbone,
    chosen: &[usize],
    settings: &ConvergenceSettings,
    progress: impl Fn() + Sync,
) {
    let g = backbone.gap_reference;
    let found: Vec<Option<ConvergedOrbit>> = chosen
        .par_iter()
        .map(|&i| {
            let p = &backbone.points[i];
            let harmonics = p.coefficients.len() - 1;
            let out = analysis
                .converged_orbit(p, harmonics, settings)
                .unwrap_or_else(|e| {
                    tracing::warn!(q_over_g0 = p.q / g, error = %e, "converged orbit failed");
                    None
                });
            progress();
            out
        })
        .collect();
    for (&i, c) in chosen.iter().zip(found) {
        let p = &mut backbone.points[i];
        p.truncation_warning = c
            .as_ref()
            .is_none_or(|c| c.omega_error(p.omega) > settings.omega_tolerance);
        p.converged = c;
    }
}

/// The exact backbone of the massless contact boundary of `backbone`'s main branch
/// (`nlmodes_boundary::exact_backbone`; docs/STABILITY.md Sec. 9.3), from its first point up to
/// master amplitude `q_end` (system length unit), in pieces. `None` when the boundary model does
/// not apply (no point in contact, every mode resolved, or R not positive definite).
pub fn boundary_backbone(
    analysis: &FloquetAnalysis<'_>,
    backbone: &Backbone,
    q_end: f64,
) -> Result<Option<BoundaryBackbone>, NnmError> {
    let main: Vec<&BackbonePoint> = backbone
        .points
        .iter()
        .filter(|p| {
            backbone
                .branches
                .get(p.branch)
                .is_none_or(|b| matches!(b.kind, BranchKind::Main | BranchKind::Linear))
        })
        .collect();
    let Some(model) = backbone_model(analysis, &main) else {
        return Ok(None);
    };
    let r = model.modes();
    let modal = analysis.modal_data();
    let branch: Vec<BranchStart> = main
        .iter()
        .map(|p| BranchStart {
            q: p.q,
            q0: modal.coordinates(&p.displacement_at(0.0), r),
            period: p.period(),
        })
        .collect();
    let judge = |exponents: &[c64], period: f64| analysis.shooting_verdict(exponents, period);
    exact_backbone(
        &model,
        MasterRow::new(&modal, r),
        &branch,
        main[0].mode,
        q_end,
        &judge,
    )
}

/// The boundary model of the main branch `main`: the modes up to `shooting_cutoff` (N + 1)
/// w_max dynamic (w_max the largest w of the branch), the harmonic balance's contact law. `None`
/// where it does not apply.
fn backbone_model(
    analysis: &FloquetAnalysis<'_>,
    main: &[&BackbonePoint],
) -> Option<BoundaryModel> {
    let in_contact: Vec<&BackbonePoint> = main.iter().filter(|p| in_contact(p)).copied().collect();
    let deepest = in_contact
        .iter()
        .max_by(|a, b| a.q.abs().total_cmp(&b.q.abs()))?;
    let harmonics = main[0].coefficients.len().saturating_sub(1);
    let w_max = main.iter().map(|p| p.omega).fold(0.0, f64::max);
    let modal = analysis.modal_data();
    let r = analysis.shooting_modes(w_max, harmonics);
    if r == modal.omega.len() {
        return None;
    }
    // A penalty law's orbits all carry their spring and no multiplier; an augmented-Lagrangian
    // orbit that barely touches may carry none yet either, so the law is read from them all.
    let penalty = if in_contact.iter().all(|p| penalty_of(p).is_some()) {
        penalty_of(deepest)
    } else {
        None
    };
    modal.model(r, penalty.as_deref())
}

/// Fig. 4 on the boundary: the exact orbit of the massless boundary next to `point` sampled at
/// `samples` + 1 instants over its period (`nlmodes_boundary::contact_history`); `None` where
/// the stability stage would not shoot it (no contact, every mode resolved, shooting off) or the
/// shooting does not converge.
pub fn boundary_history(
    analysis: &FloquetAnalysis<'_>,
    point: &BackbonePoint,
    samples: usize,
) -> Result<Option<BoundaryHistory>, NnmError> {
    let harmonics = point.coefficients.len().saturating_sub(1);
    if harmonics == 0 || samples == 0 {
        return Ok(None);
    }
    let Some((model, orbit)) = analysis.shot_orbit(point, harmonics)? else {
        return Ok(None);
    };
    let penalty = penalty_of(point);
    contact_history(&model, orbit, penalty.as_deref(), point.q, samples).map(Some)
}

/// Whether any contact force of the point is positive.
fn in_contact(point: &BackbonePoint) -> bool {
    point.contact_force.iter().flatten().any(|&f| f > 0.0)
}

/// The point as the boundary's orbits start from it: its q, w, u(0) and contact law.
fn guess(point: &BackbonePoint) -> OrbitGuess {
    OrbitGuess {
        q: point.q,
        omega: point.omega,
        start: point.displacement_at(0.0),
        penalty: penalty_of(point),
    }
}

/// The penalty stiffness of each row of a penalty orbit (theta = 0 everywhere: the largest kappa
/// of the row's samples), `None` for an augmented-Lagrangian (rigid-contact) orbit.
fn penalty_of(point: &BackbonePoint) -> Option<Vec<f64>> {
    let mult = &point.multipliers;
    if mult.theta.iter().any(|&t| t != 0.0) || mult.samples == 0 {
        return None;
    }
    Some(
        mult.kappa
            .chunks(mult.samples)
            .map(|row| row.iter().fold(0.0_f64, |a, &k| a.max(k)))
            .collect(),
    )
}
