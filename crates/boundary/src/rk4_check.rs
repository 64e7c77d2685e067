//! The independent check of a shooting verdict on the massless boundary (docs/STABILITY.md
//! Sec. 9; `[stability] verify_every`): one period of the RK4 integration of `rk4` from the shot
//! orbit's start, compared with the exact flow's end state and monodromy. Free orbits
//! ([`check_by_rk4`]) leave their trivial pair out of the comparison; forced ones
//! ([`check_driven_by_rk4`], constant or moving gaps, Sec. 9.5) have none.

use faer::Mat;
use nlmodes_dense::eigenvalues_checked;
use serde::{Deserialize, Serialize};

use crate::driven_model::DrivenBoundary;
use crate::driven_stability::BoundaryMonodromy;
use crate::free_shooting::ShotOrbit;
use crate::model::{norm, BoundaryModel};
use crate::rk4::{integrate, rk4_steps, Rk4State};
use nlmodes_hb::HbError;

/// The independent check of a shooting verdict: one period of RK4 of the massless-boundary
/// model from the shot orbit's start, with the contact problem solved afresh at every stage and
/// the variational equation integrated alongside (docs/STABILITY.md, Sec. 9).
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
pub struct ShootingCheck {
    /// RK4 steps over the period.
    pub steps: usize,
    /// Distance of the RK4 end state from the start in the scaled state (q / |q0|,
    /// q' / (w |q0|)): 0 for an exact periodic orbit and an exact integrator.
    pub periodicity: f64,
    /// Largest distance from a non-trivial multiplier of the RK4 monodromy to the nearest
    /// non-trivial exact one (the trivial pair, the two nearest +1, left out of both: a Jordan
    /// block that any perturbation delta splits by sqrt(delta)).
    pub multiplier_distance: f64,
    /// Largest |mu| of the RK4 monodromy's non-trivial multipliers (of a free orbit: 1 if none
    /// is outside; of a forced orbit: of all its multipliers).
    pub max_multiplier_abs: f64,
    /// |max_multiplier_abs - the exact monodromy's|: the difference in the decision quantity.
    pub max_multiplier_change: f64,
}

/// Largest [`ShootingCheck::max_multiplier_change`] (and periodicity) at which the RK4 check
/// confirms a shooting verdict. The check cuts its steps at the contact switches, so RK4 keeps
/// its fourth order with h s_max = 2 pi / 200: on the default blade its largest |mu| agrees with
/// the exact monodromy's to 6e-7 and its end state with the start to 2e-7 (50 points;
/// docs/STABILITY.md, Sec. 9). A disagreement past 1e-4 means the exact flow or the shot orbit
/// is wrong, and the verdict is not given.
pub const SHOOTING_CHECK_LIMIT: f64 = 1e-4;

impl ShootingCheck {
    /// The check confirms the exact monodromy: the shot orbit is periodic for RK4 and the
    /// largest non-trivial |mu| is the same within [`SHOOTING_CHECK_LIMIT`].
    pub fn agrees(&self) -> bool {
        self.max_multiplier_change <= SHOOTING_CHECK_LIMIT
            && self.periodicity <= SHOOTING_CHECK_LIMIT
    }
}

/// The independent RK4 check of a shot orbit (`rk4`): one period from its start.
pub fn check_by_rk4(model: &BoundaryModel, orbit: &ShotOrbit) -> Result<ShootingCheck, HbError> {
    let r = orbit.q0.len();
    let start = Rk4State {
        q: orbit.q0.clone(),
        v: vec![0.0; r],
    };
    let driven = DrivenBoundary::undriven(model, orbit.period);
    let compared = Compared {
        period: orbit.period,
        multipliers: nontrivial,
        floor: 1.0,
    };
    compare(&driven, &start, &orbit.monodromy, &compared)
}

/// The independent RK4 check of a forced orbit shot on the driven boundary
/// (`driven_stability`; constant or moving gaps): one period of `b.model` from the shot orbit's
/// start, every multiplier compared (a forced orbit has no trivial pair).
pub fn check_driven_by_rk4(b: &BoundaryMonodromy) -> Result<ShootingCheck, HbError> {
    let r = b.modes;
    let start = Rk4State {
        q: b.start[..r].to_vec(),
        v: b.start[r..].to_vec(),
    };
    let compared = Compared {
        period: 2.0 * std::f64::consts::PI / b.model.omega,
        multipliers: |v| v,
        floor: 0.0,
    };
    compare(&b.model, &start, &b.monodromy.matrix, &compared)
}

/// What [`compare`] compares: over `period` (s), the multipliers `multipliers` keeps of each
/// monodromy, their largest modulus taken from `floor` up (1 for a free orbit: only growth
/// counts; 0 for a forced one).
struct Compared {
    period: f64,
    multipliers: fn(Vec<faer::c64>) -> Vec<faer::c64>,
    floor: f64,
}

/// One period of RK4 of `model` from `start` against the exact monodromy `exact`: the
/// periodicity in the scaled state (q / |q0|, q' / (w |q0|), w = 2 pi / period) and the
/// multipliers `what` says.
fn compare(
    model: &DrivenBoundary,
    start: &Rk4State,
    exact: &Mat<f64>,
    what: &Compared,
) -> Result<ShootingCheck, HbError> {
    let r = start.q.len();
    let period = what.period;
    let steps = rk4_steps(model, period)?;
    let (end, monodromy) = integrate(model, start, period, steps)?;
    let q_scale = norm(&start.q);
    let v_scale = q_scale * 2.0 * std::f64::consts::PI / period;
    let periodicity = (0..r)
        .map(|i| {
            ((end.q[i] - start.q[i]) / q_scale).powi(2)
                + ((end.v[i] - start.v[i]) / v_scale).powi(2)
        })
        .sum::<f64>()
        .sqrt();
    let eigenvalues = |m: &Mat<f64>, name: &'static str| {
        eigenvalues_checked(m.as_ref(), name)
            .map(what.multipliers)
            .map_err(HbError::dense(name))
    };
    let exact = eigenvalues(exact, "eigenvalues of the massless boundary's monodromy")?;
    let integrated = eigenvalues(&monodromy, "eigenvalues of the RK4 monodromy")?;
    let multiplier_distance = integrated
        .iter()
        .map(|mu| {
            exact
                .iter()
                .map(|nu| (mu - nu).norm())
                .fold(f64::INFINITY, f64::min)
        })
        .fold(0.0, f64::max);
    let largest = |v: &[faer::c64]| v.iter().map(|mu| mu.norm()).fold(what.floor, f64::max);
    let max_multiplier_abs = largest(&integrated);
    let max_multiplier_change = (max_multiplier_abs - largest(&exact)).abs();
    Ok(ShootingCheck {
        steps,
        periodicity,
        multiplier_distance,
        max_multiplier_abs,
        max_multiplier_change,
    })
}

/// The multipliers without the trivial pair (the two nearest +1).
fn nontrivial(mut values: Vec<faer::c64>) -> Vec<faer::c64> {
    let one = faer::c64::new(1.0, 0.0);
    values.sort_by(|a, b| (a - one).norm().total_cmp(&(b - one).norm()));
    values.split_off(2.min(values.len()))
}
