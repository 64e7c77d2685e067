//! The largest contact force of a forced point on its exact orbit (issue 39, DESIGN §10.10): the
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

/// The most steps of `climbed_exact` along a curve.
const CLIMB_STEPS: usize = 30;

/// The largest exact force along a curve of `count` points, `touches(i)` saying which touch:
/// each of `candidates` (`curve_harmonics::force_candidates`: the harmonic balance's strongest
/// point and peak) shot (`exact(i)`: `exact_largest_force`, `None` where it fails), then from
/// the largest a climb along the curve to the neighbour whose exact force is larger, until
/// neither is (at most `CLIMB_STEPS` steps). The exact force varies smoothly along the curve,
/// and the truncated series' strongest point and peak need not be where it is largest (the
/// default blade's level 5 at 8000 rpm: 162 N at the two, 165 N on the exact curve).
pub(crate) fn climbed_exact(
    count: usize,
    candidates: &[usize],
    touches: impl Fn(usize) -> bool,
    exact: impl Fn(usize) -> Result<Option<ExactForce>, ForcedError>,
) -> Option<ExactForce> {
    let mut known: Vec<Option<Option<ExactForce>>> = vec![None; count];
    let mut at = |i: usize| {
        *known[i].get_or_insert_with(|| {
            exact(i).unwrap_or_else(|e| {
                tracing::debug!(error = %e, "no exact contact force");
                None
            })
        })
    };
    let larger = |a: &(usize, ExactForce), b: &(usize, ExactForce)| a.1.force.total_cmp(&b.1.force);
    let mut best = (candidates.iter())
        .filter_map(|&i| at(i).map(|f| (i, f)))
        .max_by(larger)?;
    for _ in 0..CLIMB_STEPS {
        let next = [best.0.checked_sub(1), Some(best.0 + 1)]
            .into_iter()
            .flatten()
            .filter(|&j| j < count && touches(j))
            .filter_map(|j| at(j).map(|f| (j, f)))
            .max_by(larger);
        match next {
            Some(n) if n.1.force > best.1.force => best = n,
            _ => break,
        }
    }
    Some(best.1)
}
