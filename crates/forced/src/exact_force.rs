//! The largest contact force of a forced point on its exact orbit (issue 39, DESIGN §10.8): the
//! point's orbit shot on the massless boundary with its cutoff settled, as its settled Floquet
//! verdict is (`settled_stability`), and that orbit's largest contact force
//! (`nlmodes_boundary::largest_contact_force`: no truncation in N). Under a penalty law whose
//! modes all lie below the cutoff the boundary is the penalty equation itself, so the force is
//! the model's own exact periodic solution's; with modes above it, theirs is the static
//! response (their resonances lie above every harmonic the cutoff keeps, doubled until the
//! master's amplitude settles). The harmonic-balance force at N is the same orbit's truncated
//! series and converges to it from above on the default blade (level 2 at rest: 268 N at
//! N = 20, 202 N at N = 40, 175 N on the exact curve).

use crate::curve::ExactForce;
use crate::error::ForcedError;
use crate::settled_stability::{exact_force_of, seen_from_most_open, settled_boundary};
use crate::solver::{ForcedPoint, ForcedSolver};

/// The largest contact force of `point` (solved on `solver`) on its exact orbit (module docs);
/// `None` when the point does not touch or its boundary does not apply or does not shoot.
pub(crate) fn exact_largest_force(
    solver: &ForcedSolver<'_>,
    point: &ForcedPoint,
) -> Result<Option<ExactForce>, ForcedError> {
    if !point.touches() {
        return Ok(None);
    }
    let clock = std::time::Instant::now();
    let (model, seen) = seen_from_most_open(solver, point);
    let Some(settled) = settled_boundary(&model, solver, &seen)? else {
        return Ok(None);
    };
    let shot = clock.elapsed().as_secs_f64();
    let exact = exact_force_of(&settled)?;
    tracing::debug!(
        omega = point.omega,
        modes = settled.boundary.modes,
        force = exact.map(|e| e.force),
        harmonic_balance = point.largest_contact_force(),
        shot_seconds = shot,
        seconds = clock.elapsed().as_secs_f64(),
        "largest contact force on the exact orbit"
    );
    Ok(exact)
}

/// The larger of the candidates' exact forces (`exact_largest_force` of each); a candidate whose
/// analysis failed is left out (with a debug trace).
pub(crate) fn larger_exact(
    forces: impl IntoIterator<Item = Result<Option<ExactForce>, ForcedError>>,
) -> Option<ExactForce> {
    forces
        .into_iter()
        .filter_map(|f| {
            f.unwrap_or_else(|e| {
                tracing::debug!(error = %e, "no exact contact force");
                None
            })
        })
        .max_by(|a, b| a.force.total_cmp(&b.force))
}
