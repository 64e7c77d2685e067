//! The largest contact force of a shot orbit on the massless boundary (issue 39: how hard the
//! blade strikes the casing, docs/DESIGN.md §10.10).
//!
//! The harmonic-balance orbit's contact force converges slowly in N under a stiff penalty law:
//! a strike lasts a small fraction of the period, and its peak needs harmonics far above those
//! that settle the first harmonic (the default blade's level 2 at rest: 268 N at N = 20, 202 N
//! at 40, 175 N on the exact curve). The shot orbit has no truncation: its force is the model's
//! own, as exact as the flow. The orbit is sampled at `FORCE_SAMPLES` instants of its period,
//! then the interval around the largest sample is sampled again `FORCE_SAMPLES` times finer:
//! a strike lasting 1 % of the period spans 10 coarse and 5,000 fine samples, so the peak of a
//! half-sine pulse is missed by at most (pi / 2 / 5,000)^2 / 2, about 5e-8 relative. Two
//! strikes whose peaks differ by less than the coarse pass's error (1 - cos(pi / 20), about
//! 1 %, for that strike) may be told apart wrongly: the force is then within that of the largest.

use crate::driven_flow::DrivenFlow;
use crate::driven_model::DrivenBoundary;
use nlmodes_hb::HbError;

/// Instants per period of the first pass, and per coarse interval of the second.
const FORCE_SAMPLES: usize = 1024;

/// The largest contact force of an orbit and when it acts.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ContactPeak {
    /// The force (N, compressive positive).
    pub force: f64,
    /// Its time from the orbit's start (s).
    pub time: f64,
}

/// The largest contact force over the periodic orbit of `model` from (q, q') = `start` at t = 0
/// (module docs); `None` when the orbit never touches.
pub fn largest_contact_force(
    model: &DrivenBoundary,
    start: &[f64],
) -> Result<Option<ContactPeak>, HbError> {
    let period = 2.0 * std::f64::consts::PI / model.omega;
    let dt = period / FORCE_SAMPLES as f64;
    let Some(coarse) = scan(model, start, 0.0, dt, FORCE_SAMPLES)? else {
        return Ok(None);
    };
    // Around the coarse peak, one interval either side, from the state one interval before.
    let from = coarse.time - dt;
    let fine = scan(
        model,
        start,
        from,
        2.0 * dt / FORCE_SAMPLES as f64,
        FORCE_SAMPLES + 1,
    )?;
    Ok(fine.filter(|f| f.force > coarse.force).or(Some(coarse)))
}

/// The largest force over `count` instants `first + k step` (s) of the orbit from `start`,
/// `first` possibly negative (one period later); `None` when no row is closed at any.
fn scan(
    model: &DrivenBoundary,
    start: &[f64],
    first: f64,
    step: f64,
    count: usize,
) -> Result<Option<ContactPeak>, HbError> {
    let r = model.r();
    let period = 2.0 * std::f64::consts::PI / model.omega;
    let mut flow = DrivenFlow::new(model);
    let mut x = model.augmented(&start[..r], &start[r..], 0.0);
    let mut active = flow.active_set_at(&x)?;
    let lead = first.rem_euclid(period);
    if lead > 0.0 {
        flow.advance(&mut x, &mut active, lead, None)?;
    }
    let mut best: Option<ContactPeak> = None;
    for k in 0..count {
        if k > 0 {
            flow.advance(&mut x, &mut active, step, None)?;
        }
        let lambda = flow.contact_force(&x, &active)?;
        for &force in &lambda {
            if force > 0.0 && best.is_none_or(|b| force > b.force) {
                let time = (lead + k as f64 * step).rem_euclid(period);
                best = Some(ContactPeak { force, time });
            }
        }
    }
    Ok(best)
}
