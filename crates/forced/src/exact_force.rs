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
///
/// The shots run two at a time where they can (`ExactForces::fill`): the candidates, both
/// neighbours of the first best, and, where the climb needs a neighbour not shot yet, the point
/// after it in the climb's direction as well (the next step's neighbour). Each shot depends on
/// its point alone, so the climb and its answer are those of one shot at a time.
pub(crate) fn climbed_exact(
    count: usize,
    candidates: &[usize],
    touches: impl Fn(usize) -> bool,
    exact: impl Fn(usize) -> Result<Option<ExactForce>, ForcedError> + Sync,
) -> Option<ExactForce> {
    let mut known = ExactForces {
        known: vec![None; count],
        exact,
    };
    known.fill(candidates);
    let larger = |a: &(usize, ExactForce), b: &(usize, ExactForce)| a.1.force.total_cmp(&b.1.force);
    let mut best = (candidates.iter())
        .filter_map(|&i| known.at(i).map(|f| (i, f)))
        .max_by(larger)?;
    let mut direction: Option<bool> = None;
    for _ in 0..CLIMB_STEPS {
        let side = |up: bool, by: usize| match up {
            true => Some(best.0 + by),
            false => best.0.checked_sub(by),
        };
        let valid = |j: &usize| *j < count && touches(*j);
        let neighbours: Vec<usize> = [side(false, 1), side(true, 1)]
            .into_iter()
            .flatten()
            .filter(valid)
            .collect();
        let mut wanted = neighbours.clone();
        if let Some(up) = direction {
            let ahead = side(up, 1).filter(valid);
            if ahead.is_some_and(|a| !known.has(a)) {
                wanted.extend(side(up, 2).filter(valid));
            }
        }
        known.fill(&wanted);
        let next = (neighbours.iter())
            .filter_map(|&j| known.at(j).map(|f| (j, f)))
            .max_by(larger);
        match next {
            Some(n) if n.1.force > best.1.force => {
                direction = Some(n.0 > best.0);
                best = n;
            }
            _ => break,
        }
    }
    Some(best.1)
}

/// The exact forces of a curve's points shot so far (`None`: not shot; `Some(None)`: no force).
struct ExactForces<F> {
    known: Vec<Option<Option<ExactForce>>>,
    exact: F,
}

impl<F> ExactForces<F>
where
    F: Fn(usize) -> Result<Option<ExactForce>, ForcedError> + Sync,
{
    /// Whether point `i` was shot.
    fn has(&self, i: usize) -> bool {
        self.known[i].is_some()
    }

    /// Point `i`'s force (after [`Self::fill`] with it).
    fn at(&self, i: usize) -> Option<ExactForce> {
        self.known[i].flatten()
    }

    /// Shoots the points of `wanted` not shot yet, in parallel.
    fn fill(&mut self, wanted: &[usize]) {
        use rayon::prelude::*;
        let mut missing: Vec<usize> = wanted.iter().copied().filter(|&i| !self.has(i)).collect();
        missing.sort_unstable();
        missing.dedup();
        let exact = &self.exact;
        let shot: Vec<Option<ExactForce>> = (missing.par_iter())
            .map(|&i| {
                exact(i).unwrap_or_else(|e| {
                    tracing::debug!(error = %e, "no exact contact force");
                    None
                })
            })
            .collect();
        for (i, f) in missing.into_iter().zip(shot) {
            self.known[i] = Some(f);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::sync::atomic::{AtomicUsize, Ordering};

    /// A smooth force profile along a curve of 40 points, largest (100 N) at point 17.
    fn bump(i: usize) -> Result<Option<ExactForce>, ForcedError> {
        let x = i as f64 - 17.0;
        Ok(Some(ExactForce {
            force: 100.0 - x * x,
            omega: i as f64,
        }))
    }

    /// From the better of two candidates (30: 31 N; 3: -96 N) the climb walks down to the top
    /// at 17, shooting each point once and at most two beyond the 13 steps' neighbours.
    #[test]
    fn the_climb_reaches_the_top_from_the_best_candidate() {
        let shots = AtomicUsize::new(0);
        let top = climbed_exact(
            40,
            &[3, 30],
            |i| i >= 2,
            |i| {
                shots.fetch_add(1, Ordering::Relaxed);
                bump(i)
            },
        );
        assert_eq!(top.map(|f| (f.omega, f.force)), Some((17.0, 100.0)));
        // The candidates, 31 and 29..16 (the neighbours of each best), and one ahead.
        assert!(shots.load(Ordering::Relaxed) <= 2 + 1 + 14 + 1);
    }

    /// A neighbour whose shot fails (or that does not touch) is passed over: the climb stops at
    /// the best point before it; with no candidate shot there is no answer.
    #[test]
    fn a_failed_shot_or_an_open_point_stops_the_climb() {
        let failing = |i: usize| match i {
            22 => Err(ForcedError::NotConverged {
                omega: 22.0,
                reason: "test".into(),
            }),
            _ => bump(i),
        };
        let top = climbed_exact(40, &[30], |_| true, failing);
        assert_eq!(top.map(|f| f.omega), Some(23.0));
        let top = climbed_exact(40, &[30], |i| i != 25, bump);
        assert_eq!(top.map(|f| f.omega), Some(26.0));
        assert_eq!(climbed_exact(40, &[30], |_| true, |_| Ok(None)), None);
    }
}
