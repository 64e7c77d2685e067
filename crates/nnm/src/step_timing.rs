//! A benchmark instrument: the cost of the linear algebra of one Newton step (the solve of
//! J step = -R in Eq. 20's semi-smooth Newton), alone, without residual evaluations, transforms
//! or line search, so that its growth with the number of non-contact modes can be measured.
//!
//! The Jacobian is that of a state in contact: every contact row active over the first
//! `contact_share` of the period with slope kappa = its contact stiffness (N/m, as at kappa^(1)),
//! at frequency `omega`, normalization on the master coordinate and a fixed-amplitude parameter
//! row. The step's values do not matter, only its cost; the solver never calls this module.

use std::time::Instant;

use crate::NnmError;
use nlmodes_hb::check::require;
use nlmodes_hb::fourier::{Aft, HarmonicSettings};
use nlmodes_hb::linear_model::{JacobianData, LinearModel};
use nlmodes_hb::solver_settings::Condensation;
use nlmodes_hb::system::System;

/// Median cost of one Newton linear solve.
#[derive(Clone, Debug)]
pub struct StepTiming {
    /// Median over the repeats (s).
    pub median_seconds: f64,
    /// Fastest repeat (s).
    pub min_seconds: f64,
    /// Unknowns of the Newton system: (N + 1) n + 2.
    pub unknowns: usize,
}

/// Times `repeats` Newton linear solves (after one warm-up) on `system` at frequency `omega`
/// (rad/s) with every contact row active over the fraction `contact_share` (in (0, 1]) of the
/// period. `condensation` picks the exact condensation or the uncondensed dense LU;
/// `resonance_window` is [`crate::NewtonSettings::resonance_window`].
pub fn newton_step_timing(
    system: &System,
    settings: HarmonicSettings,
    condensation: Condensation,
    resonance_window: f64,
    omega: f64,
    contact_share: f64,
    repeats: usize,
) -> Result<StepTiming, NnmError> {
    settings.validate()?;
    let in_period = contact_share > 0.0 && contact_share <= 1.0;
    let expected_share = "a fraction of the period in (0, 1]";
    require("contact_share", contact_share, in_period, expected_share)?;
    let finite_positive = omega.is_finite() && omega > 0.0;
    require(
        "omega",
        omega,
        finite_positive,
        "a finite frequency > 0 (rad/s)",
    )?;
    let mut model = condensation.linear_model(system, resonance_window, settings.harmonics)?;
    let layout = model.layout();
    let x = smooth_state(system, model.as_ref());
    let moments = contact_moments(system, settings, layout.moments(), contact_share);
    let c = system.n_contacts();
    let active: Vec<usize> = (0..c).collect();
    let master = system.master();
    let jac = JacobianData {
        omega,
        x: &x,
        active: &active,
        moments: &moments,
        norm_scale: system.stiffness()[(master, master)].sqrt(),
        arc_w: 0.0,
        arc_q: 1.0,
        arc_y: &[],
    };
    let rhs: Vec<f64> = (0..layout.newton_len())
        .map(|i| ((i * 7919) % 101) as f64 / 101.0 - 0.5)
        .collect();
    let mut step = rhs.clone();
    model.solve_step(&jac, &mut step)?;
    let mut times = Vec::with_capacity(repeats.max(1));
    for _ in 0..repeats.max(1) {
        step.copy_from_slice(&rhs);
        let t = Instant::now();
        model.solve_step(&jac, &mut step)?;
        times.push(t.elapsed().as_secs_f64());
    }
    if step.iter().any(|v| !v.is_finite()) {
        return Err(NnmError::NonFiniteResult {
            what: "Newton step of the timing benchmark",
        });
    }
    times.sort_by(f64::total_cmp);
    Ok(StepTiming {
        median_seconds: times[times.len() / 2],
        min_seconds: times[0],
        unknowns: layout.newton_len(),
    })
}

/// A state for the Jacobian: a smooth displacement pattern at harmonic 1, in model coordinates.
fn smooth_state(system: &System, model: &dyn LinearModel) -> Vec<f64> {
    let n = system.n_dofs();
    let layout = model.layout();
    let nh = layout.count();
    let mut u = vec![0.0; n * nh];
    for (i, v) in layout
        .with_dim(n)
        .harmonic_mut(&mut u, 1)
        .iter_mut()
        .enumerate()
    {
        *v = 1.0 + 0.1 * i as f64;
    }
    let mut x = vec![0.0; layout.len()];
    model.physical_to_model(&u, nh, &mut x);
    x
}

/// Cosine moments of the contact slopes: every row active with slope kappa = its contact
/// stiffness over the first `contact_share` of the period's samples (`np` moments per row).
fn contact_moments(
    system: &System,
    settings: HarmonicSettings,
    np: usize,
    contact_share: f64,
) -> Vec<f64> {
    let (c, m) = (system.n_contacts(), settings.samples);
    let contact_samples = ((contact_share * m as f64).ceil() as usize).clamp(1, m);
    let stiffness = system.contact_stiffness();
    let mut slopes = vec![0.0; c * m];
    for j in 0..c {
        slopes[j * m..j * m + contact_samples].fill(stiffness[j]);
    }
    let mut moments = vec![0.0; c * np];
    Aft::new(settings).cosine_moments(&slopes, c, &mut moments);
    moments
}
