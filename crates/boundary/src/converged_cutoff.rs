//! The massless boundary's dynamic modes chosen by convergence (issue 39; docs/STABILITY.md
//! Sec. 9.6).
//!
//! `boundary_monodromy` keeps the modes w_k <= (N + 1) W dynamic: the modes whose resonant
//! harmonics the orbit holds. That is the harmonic balance's resolution, not the exact orbit's:
//! a strike puts a force pulse on the contact rows whose spectrum reaches far above N W, and a
//! mode just above the cutoff responds to it dynamically, not statically. On the default blade
//! under the casing distortion (W = 266.7 Hz, N = 10) the cutoff 11 W keeps 3 modes and
//! discards the fourth at 11.8 W: that boundary's exact orbit lies 1-9 % in the master's first
//! harmonic from the same model with 14 modes (cutoff 41 W), and next to the jump at 0.84 g0
//! its largest |mu| is 1.20 where the 14-mode model's is 0.97 (a wrong "unstable"); from 14 to
//! 48 modes the orbit moves by at most 2e-3 and |mu| by 4e-3 (measured, docs/STABILITY.md
//! Sec. 9.6).
//!
//! Here the cutoff is doubled, (N + 1) W, 2 (N + 1) W, ..., until the shot orbit's master
//! amplitude (at the gap's harmonic) and its largest |mu| change by at most the tolerance at a
//! doubling, at most [`CUTOFF_DOUBLINGS`] times. A doubling that adds no mode changes nothing
//! and costs no shooting. The changes at the last doubling are returned: the caller adds them to
//! its margins (they are this model's error estimate, as the Liouville error is the monodromy's).
//! A doubling that would keep every mode (the penalty equation with the contact coordinates'
//! mass: the contact stiffness rings there at sqrt(kc / m_c)) is not taken.

use faer::Mat;

use crate::driven_model::DrivenInputs;
use crate::driven_stability::{monodromy_on_boundary, BoundaryMonodromy};
use crate::model::dynamic_modes;
use crate::response_curve::master_amplitude_at;
use nlmodes_hb::HbError;

/// The most doublings of the cutoff: 16 (N + 1) W at most.
pub const CUTOFF_DOUBLINGS: usize = 4;

/// The boundary orbit at the cutoff where it settled, and how much the last doubling moved it.
#[derive(Clone, Debug)]
pub struct CutoffConvergence {
    /// The shot orbit and its multipliers on the finest model solved.
    pub boundary: BoundaryMonodromy,
    /// The master's amplitude at the gap's harmonic on that orbit (m).
    pub master_amplitude: f64,
    /// The cutoff (rad/s): the modes w_k at or below it are dynamic.
    pub cutoff: f64,
    /// [relative change of the master's amplitude, change of the largest |mu|] at the last
    /// doubling that added a mode ([0, 0] when none did).
    pub change: [f64; 2],
    /// Whether both changes are within the tolerance (or no doubling added a mode).
    pub converged: bool,
}

/// One model of the ladder: its orbit and master amplitude.
struct Rung {
    boundary: BoundaryMonodromy,
    amplitude: f64,
}

/// The boundary orbit of the harmonic-balance orbit `coefficients` at W = `omega` (rad/s) with
/// the cutoff raised until it settles (module docs): `harmonic` is the gap's (the master's
/// amplitude is compared there), `tolerance` relative for the amplitude and absolute for the
/// largest |mu|. `None` where the first model does not apply or does not shoot (as
/// `boundary_monodromy`).
pub fn boundary_with_converged_cutoff(
    inputs: &DrivenInputs<'_>,
    coefficients: &Mat<f64>,
    omega: f64,
    harmonic: usize,
    tolerance: f64,
) -> Result<Option<CutoffConvergence>, HbError> {
    let frequencies: Vec<f64> = inputs
        .system
        .eigenvalues()
        .iter()
        .map(|l| l.sqrt())
        .collect();
    let kept = |cut: usize| {
        let limit = crate::BOUNDARY_CUTOFF * (cut as f64 + 1.0) * omega;
        (dynamic_modes(frequencies.iter().copied(), limit), limit)
    };
    let Some(mut rung) = shoot(
        inputs,
        inputs.harmonics,
        coefficients,
        omega,
        harmonic,
        false,
    )?
    else {
        return Ok(None);
    };
    let (mut cut, mut cutoff) = (inputs.harmonics, kept(inputs.harmonics).1);
    let (mut change, mut converged) = ([0.0; 2], true);
    for _ in 0..CUTOFF_DOUBLINGS {
        let next = 2 * cut + 1;
        let (modes, limit) = kept(next);
        if modes >= frequencies.len() {
            break;
        }
        cut = next;
        if modes == rung.boundary.modes {
            // The same model: the orbit does not move over this doubling.
            (cutoff, change, converged) = (limit, [0.0; 2], true);
            continue;
        }
        let clock = std::time::Instant::now();
        let Some(finer) = shoot(inputs, next, coefficients, omega, harmonic, false)? else {
            converged = false;
            break;
        };
        cutoff = limit;
        change = [
            (finer.amplitude / rung.amplitude - 1.0).abs(),
            (finer.boundary.monodromy.largest() - rung.boundary.monodromy.largest()).abs(),
        ];
        tracing::debug!(
            omega,
            modes,
            amplitude_change = change[0],
            multiplier_change = change[1],
            seconds = clock.elapsed().as_secs_f64(),
            "boundary cutoff doubled"
        );
        rung = finer;
        converged = change.iter().all(|c| *c <= tolerance);
        if converged {
            break;
        }
    }
    // The orbit at the point's own W on the last model (`BoundaryMonodromy::
    // fixed_frequency_largest`), from the last model's shot orbit.
    let clock = std::time::Instant::now();
    rung.boundary.fixed_frequency_largest = rung.boundary.largest_at_own_frequency(omega);
    tracing::debug!(
        seconds = clock.elapsed().as_secs_f64(),
        "the boundary orbit at the point's own W"
    );
    Ok(Some(CutoffConvergence {
        boundary: rung.boundary,
        master_amplitude: rung.amplitude,
        cutoff,
        change,
        converged,
    }))
}

/// The boundary orbit with the modes up to (`cut` + 1) W dynamic.
fn shoot(
    inputs: &DrivenInputs<'_>,
    cut: usize,
    coefficients: &Mat<f64>,
    omega: f64,
    harmonic: usize,
    at_own_frequency: bool,
) -> Result<Option<Rung>, HbError> {
    let at = DrivenInputs {
        system: inputs.system,
        damping: inputs.damping,
        load: inputs.load.clone(),
        penalty: inputs.penalty,
        harmonics: cut,
        keep_all: inputs.keep_all,
        gap_motion: inputs.gap_motion.clone(),
    };
    let Some(boundary) = monodromy_on_boundary(&at, coefficients, omega, at_own_frequency)? else {
        return Ok(None);
    };
    let amplitude = master_amplitude_at(&at, &boundary, harmonic)?;
    Ok(Some(Rung {
        boundary,
        amplitude,
    }))
}
