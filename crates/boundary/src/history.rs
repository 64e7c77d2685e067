//! Fig. 4 on the massless contact boundary (docs/STABILITY.md Sec. 9.3): the contact rows'
//! displacement over one period of the exact periodic orbit next to a harmonic-balance point,
//! with no harmonic truncated, so that the contact phases show with their exact durations.

use serde::{Deserialize, Serialize};

use crate::free_flow::{BoundaryFlow, FlowState};
use crate::free_shooting::ShotOrbit;
use crate::model::BoundaryModel;
use nlmodes_hb::HbError;

/// One period of the exact orbit next to a point, sampled.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct BoundaryHistory {
    /// Master amplitude of the harmonic-balance point it was shot from (m).
    pub q: f64,
    /// Its circular frequency (rad/s).
    pub omega: f64,
    /// Modes kept dynamic.
    pub modes: usize,
    /// Share of the period each contact row is closed (from the exact switch instants).
    pub contact_shares: Vec<f64>,
    /// Contact-row displacement u_c (m) at t_k = k T / samples, k = 0..=samples, one vector per
    /// row: B q - R lambda plus a penalty law's penetration lambda / kc.
    pub contact_displacement: Vec<Vec<f64>>,
}

/// The shot orbit `orbit` of `model` (next to the harmonic-balance point of master amplitude
/// `q`, m) sampled at `samples` + 1 instants over its period; `penalty` the kc of each row of a
/// penalty law (N/m), whose penetration lambda / kc is added to the stop side.
pub fn contact_history(
    model: &BoundaryModel,
    orbit: ShotOrbit,
    penalty: Option<&[f64]>,
    q: f64,
    samples: usize,
) -> Result<BoundaryHistory, HbError> {
    let r = model.omega2.len();
    let c = model.gaps.len();
    let mut flow = BoundaryFlow::new(model);
    let mut active = flow.active_set_at(&orbit.q0)?;
    let mut state = FlowState {
        q: orbit.q0.clone(),
        v: vec![0.0; r],
    };
    let mut rows = vec![Vec::with_capacity(samples + 1); c];
    let dt = orbit.period / samples as f64;
    for k in 0..=samples {
        let lambda = flow.contact_force(&state, &active)?;
        let stop_side = flow.stop_side_displacement(&state, &lambda);
        for j in 0..c {
            let penetration = penalty.map_or(0.0, |kc| lambda[j] / kc[j]);
            rows[j].push(stop_side[j] + penetration);
        }
        if k < samples {
            flow.advance(&mut state, &mut active, dt, None)?;
        }
    }
    Ok(BoundaryHistory {
        q,
        omega: 2.0 * std::f64::consts::PI / orbit.period,
        modes: r,
        contact_shares: orbit.contact_shares,
        contact_displacement: rows,
    })
}
