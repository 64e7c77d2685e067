//! The converged orbit of a harmonic-balance point (issue 24 item 2; docs/STABILITY.md Sec.
//! 9.4): the exact periodic orbit of the massless contact boundary at the point's own master
//! amplitude q (`orbit_at_q`), with the number of dynamic modes chosen by accuracy.
//!
//! The model keeps the modes w_k <= `cutoff` (N + 1) w dynamic and the rest static; the time
//! integration is exact (switch instants by event location). The only knob left is N through
//! that cutoff. The orbit is computed with the modes of N, then 2N, 4N, ... up to
//! `max_harmonics`, until doubling N changes w by at most `omega_tolerance` (relative) and every
//! row's contact share by at most `share_tolerance` (the 2N estimate of the converged orbit
//! itself); the last orbit is the point's converged orbit.

use serde::{Deserialize, Serialize};

use crate::free_shooting::{OrbitGuess, SHOOTING_SHIFT_LIMIT};
use crate::model::ModalData;
use crate::orbit_at_q::{exact_orbit_at_q, ExactOrbitAtQ, Start};
use nlmodes_hb::HbError;

/// Why the converged orbit's refinement stopped.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum ConvergenceStop {
    /// Doubling N changed w and every share by less than the tolerances (or added no mode, so
    /// the orbit is the same).
    Converged,
    /// `max_harmonics` reached first, or 2N would keep every mode dynamic.
    MaxHarmonics,
    /// The orbit at the next N was not found (Newton did not converge).
    SolveFailed,
}

/// The converged orbit of a point and how it was reached (module docs).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ConvergedOrbit {
    /// The orbits with the modes of N, 2N, ... in order; the last is the converged one.
    pub levels: Vec<ExactOrbitAtQ>,
    /// Relative change of w between the last two levels (None with one level).
    pub omega_change: Option<f64>,
    /// Largest change of a row's contact share between the last two levels.
    pub share_change: Option<f64>,
    pub stop: ConvergenceStop,
}

impl ConvergedOrbit {
    /// The converged (finest) orbit.
    pub fn orbit(&self) -> &ExactOrbitAtQ {
        self.levels
            .last()
            .expect("a converged orbit has at least one level")
    }

    /// Whether the 2N estimate met both tolerances.
    pub fn converged(&self) -> bool {
        self.stop == ConvergenceStop::Converged
    }

    /// |w - w_converged| / w_converged of a frequency w (rad/s), such as the harmonic-balance
    /// point's: what the "N too small" flag reads.
    pub fn omega_error(&self, omega: f64) -> f64 {
        let w = self.orbit().omega;
        (omega - w).abs() / w
    }
}

/// Tolerances and the largest N of [`converged_orbit`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ConvergenceSettings {
    /// Largest relative change of w when N is doubled (`[nnm] truncation_tolerance`).
    pub omega_tolerance: f64,
    /// Largest change of a row's contact share (fraction of the period) when N is doubled
    /// (`[nnm] share_tolerance`).
    pub share_tolerance: f64,
    /// The largest N whose modes are kept dynamic (`[nnm] max_harmonics`).
    pub max_harmonics: usize,
}

/// The converged orbit of the harmonic-balance orbit `point` (traced with `harmonics`) on the
/// boundary of `modal` whose modes w_k <= `cutoff` (N + 1) w are dynamic (module docs);
/// `shot_period` (s), where the stability shot one, the period of the exact orbit nearest the
/// point. `None` where the boundary model does not apply (every mode dynamic, R not positive
/// definite) or no orbit is found at the point's q with the modes of N.
pub fn converged_orbit(
    modal: &ModalData<'_>,
    cutoff: f64,
    point: &OrbitGuess,
    shot_period: Option<f64>,
    harmonics: usize,
    settings: &ConvergenceSettings,
) -> Result<Option<ConvergedOrbit>, HbError> {
    let at_q = |n: usize, start: Option<Start<'_>>| {
        let r = modal.dynamic_modes(cutoff, point.omega, n);
        exact_orbit_at_q(modal, r, point, n, start)
    };
    // From the point's own state; failing that, at the period of the stability's shot
    // orbit (the exact orbit nearest the point, at a slightly different q).
    let mut first = at_q(harmonics, None)?;
    if let (None, Some(t)) = (&first, shot_period) {
        first = at_q(harmonics, Some(Start::Period(t)))?;
    }
    let Some(first) = first else {
        return Ok(None);
    };
    // An orbit of the same q farther in w than the stability trusts a shot orbit to be from
    // its point is another member of the family (a tongue's), not this point's.
    if (first.omega / point.omega - 1.0).abs() > SHOOTING_SHIFT_LIMIT {
        return Ok(None);
    }
    let mut out = ConvergedOrbit {
        levels: vec![first],
        omega_change: None,
        share_change: None,
        stop: ConvergenceStop::MaxHarmonics,
    };
    let mut n = harmonics;
    while 2 * n <= settings.max_harmonics {
        n *= 2;
        let below = out.orbit().clone();
        let modes = modal.dynamic_modes(cutoff, point.omega, n);
        if modes == below.modes {
            // No new mode below the cutoff of 2N: the same model, the same orbit.
            out.omega_change = Some(0.0);
            out.share_change = Some(0.0);
            out.stop = ConvergenceStop::Converged;
            return Ok(Some(out));
        }
        if modes == modal.omega.len() {
            // Every mode dynamic: no massless boundary left to refine.
            return Ok(Some(out));
        }
        let Some(next) = at_q(n, Some(Start::Level(&below)))? else {
            out.stop = ConvergenceStop::SolveFailed;
            return Ok(Some(out));
        };
        let omega_change = (next.omega - below.omega).abs() / below.omega;
        let share_change = (next.contact_shares.iter().zip(&below.contact_shares))
            .map(|(a, b)| (a - b).abs())
            .fold(0.0, f64::max);
        out.levels.push(next);
        out.omega_change = Some(omega_change);
        out.share_change = Some(share_change);
        if omega_change <= settings.omega_tolerance && share_change <= settings.share_tolerance {
            out.stop = ConvergenceStop::Converged;
            return Ok(Some(out));
        }
    }
    Ok(Some(out))
}
