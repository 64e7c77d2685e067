//! The curve of the exact backbone of the massless contact boundary (docs/STABILITY.md Sec.
//! 9.3): its orbits ([`BoundaryBackbonePoint`]) and pieces ([`BoundaryPiece`]), and the shooting
//! equations continued by `arc_length` ([`BackboneEquations`]): a backbone orbit is at
//! rest at t = 0 and again at T / 2, r equations q'(T/2) = 0 in the r + 1 scaled unknowns
//! z = (q0 / s, T / T_ref); what each accepted orbit records (its master amplitude, exact
//! contact shares and verdict, energy shares), and when a trace leaves the starting mode's
//! family (`leaves`). The pieces are put together in `exact_backbone`, the holes between them
//! followed in `holes`. An orbit's verdict is the caller's ([`Judge`]: the stability analysis's
//! rule for the shooting method).
//!
//! The master's displacement is u_m(t) = sum_{k < r} phi_mk q_k(t) - sum_j c_j lambda_j(t),
//! c_j = sum_{k >= r} phi_mk b_jk / w_k^2: the kept modes and the discarded modes' static
//! response to the contact forces (`master_row`). Its first harmonic (the backbone's amplitude q, as the
//! harmonic balance's e_master . u_1) and its largest value come from `MASTER_SAMPLES` instants.

use std::cell::{Cell, RefCell};

use faer::{c64, Mat};
use serde::{Deserialize, Serialize};

use crate::arc_length::{CurveEnd, CurveEquations};
use crate::free_flow::{BoundaryFlow, FlowState};
use crate::free_shooting::{exponents_of, half_period, ShotOrbit};
use crate::master_row::{MasterRow, MASTER_SAMPLES};
use crate::model::BoundaryModel;
use nlmodes_hb::HbError;

/// One exact orbit of the boundary's backbone.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct BoundaryBackbonePoint {
    /// Kept modal coordinates at t = 0, where the orbit is at rest.
    pub q0: Vec<f64>,
    /// First-harmonic amplitude of the master (system length unit, m for SI).
    pub q: f64,
    /// Largest |u_master| over the period (m).
    pub master_max: f64,
    /// Circular frequency w = 2 pi / T (rad/s).
    pub omega: f64,
    /// Share of the period each contact row is closed (from the exact switch instants).
    pub contact_shares: Vec<f64>,
    /// Contact switches per period.
    pub switches: usize,
    /// Largest non-trivial multiplier modulus (`None` when the monodromy failed its checks).
    pub max_multiplier_abs: Option<f64>,
    /// `stable`, `unstable` or `undetermined` (the [`Judge`]'s word).
    pub verdict: String,
    /// w turned between the previous point and this one.
    pub fold: bool,
    /// Share of the kept modes' energy, sum_k,h w_k^2 c_kh^2 over the harmonics h of q_k(t),
    /// in the starting mode's fundamental (as `BackbonePoint::primary_share`).
    pub primary_share: f64,
    /// The kept mode (0-based) holding the largest other share.
    pub secondary_mode: usize,
    /// The harmonic of that share.
    pub secondary_harmonic: usize,
    /// The largest other share.
    pub secondary_share: f64,
}

/// One connected piece of the exact backbone, traced both ways from a harmonic-balance point.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct BoundaryPiece {
    /// Its orbits along the curve, by increasing arc length from its lower end.
    pub points: Vec<BoundaryBackbonePoint>,
    /// The harmonic-balance amplitude it was seeded from (m).
    pub seed_q: f64,
    /// Why its lower end (traced toward smaller q) ended.
    pub lower_end: CurveEnd,
    /// Why its upper end ended (`Complete`: q_max, or for a gap piece the piece above).
    pub upper_end: CurveEnd,
    /// Seeded inside a gap between the pieces of the first pass (between the harmonic-balance
    /// points on either side), not from a harmonic-balance point.
    #[serde(default)]
    pub gap: bool,
}

impl BoundaryPiece {
    /// The smallest and largest |q| of its orbits (system length unit).
    pub fn span(&self) -> (f64, f64) {
        let q = self.points.iter().map(|x| x.q.abs());
        (
            q.clone().fold(f64::INFINITY, f64::min),
            q.fold(0.0, f64::max),
        )
    }
}

/// The q ranges (system length unit) the pieces cover, merged, ascending.
pub fn covered_ranges(pieces: &[BoundaryPiece]) -> Vec<(f64, f64)> {
    let mut ranges: Vec<(f64, f64)> = pieces
        .iter()
        .filter(|p| !p.points.is_empty())
        .map(BoundaryPiece::span)
        .collect();
    ranges.sort_by(|a, b| a.0.total_cmp(&b.0));
    let mut merged: Vec<(f64, f64)> = Vec::new();
    for (lo, hi) in ranges {
        match merged.last_mut() {
            Some(last) if lo <= last.1 => last.1 = last.1.max(hi),
            _ => merged.push((lo, hi)),
        }
    }
    merged
}

/// How an exact orbit is judged: from the exponents s (1/s) of its monodromy and its period T
/// (s), its largest non-trivial multiplier modulus and its verdict (`stable`, `unstable` or
/// `undetermined`). The caller's rule: the stability analysis's for the shooting method.
pub type Judge<'a> = dyn Fn(&[c64], f64) -> (f64, &'static str) + Sync + 'a;

/// The backbone's shooting equations (module docs) and what each accepted point records.
pub(crate) struct BackboneEquations<'m> {
    pub(crate) model: &'m BoundaryModel,
    pub(crate) flow: RefCell<BoundaryFlow<'m>>,
    pub(crate) master: MasterRow,
    pub(crate) q_scale: f64,
    pub(crate) t_ref: f64,
    /// Each orbit's verdict.
    pub(crate) judge: &'m Judge<'m>,
    /// The starting linear mode (0-based).
    pub(crate) mode: usize,
    /// Whether the trace in progress goes toward larger q.
    pub(crate) growing: Cell<bool>,
    /// The largest (growing) or smallest q of the trace so far.
    pub(crate) extreme: Cell<f64>,
    /// Whether a piece's end is being followed through its tongue (`holes`): then
    /// the curve leaves only where the starting mode's fundamental holds less than
    /// `OTHER_MODE_SHARE` of the energy.
    pub(crate) following: Cell<bool>,
    /// The largest q traced (system length unit).
    pub(crate) ceiling: f64,
}

impl BackboneEquations<'_> {
    /// The same equations and trace state with a flow of their own (for a trace on another
    /// thread).
    pub(crate) fn fork(&self) -> Self {
        Self {
            model: self.model,
            flow: RefCell::new(BoundaryFlow::new(self.model)),
            master: self.master.clone(),
            q_scale: self.q_scale,
            t_ref: self.t_ref,
            judge: self.judge,
            mode: self.mode,
            growing: Cell::new(self.growing.get()),
            extreme: Cell::new(self.extreme.get()),
            following: Cell::new(self.following.get()),
            ceiling: self.ceiling,
        }
    }

    fn r(&self) -> usize {
        self.model.omega2.len()
    }

    /// The largest q traced (system length unit).
    pub(crate) fn q_ceiling(&self) -> f64 {
        self.ceiling
    }

    /// The scaled unknowns z = (q0 / s, T / T_ref) of an orbit of the curve.
    pub(crate) fn scaled(&self, p: &BoundaryBackbonePoint) -> Vec<f64> {
        let period = 2.0 * std::f64::consts::PI / p.omega;
        p.q0.iter()
            .map(|v| v / self.q_scale)
            .chain([period / self.t_ref])
            .collect()
    }

    fn v_scale(&self) -> f64 {
        self.q_scale * 2.0 * std::f64::consts::PI / self.t_ref
    }

    fn state(&self, z: &[f64]) -> (Vec<f64>, f64) {
        let r = self.r();
        (
            (0..r).map(|i| z[i] * self.q_scale).collect(),
            z[r] * self.t_ref,
        )
    }

    /// The orbit from rest at q0 over one period: its monodromy, switches and contact shares,
    /// and the master's displacement and the kept modal coordinates at `MASTER_SAMPLES`
    /// instants.
    fn orbit(&self, q0: &[f64], period: f64) -> Result<SampledOrbit, HbError> {
        let r = self.r();
        let mut flow = self.flow.borrow_mut();
        let mut active = flow.active_set_at(q0)?;
        let mut state = FlowState {
            q: q0.to_vec(),
            v: vec![0.0; r],
        };
        let mut monodromy = Mat::<f64>::identity(2 * r, 2 * r);
        let (switches, closed) = (flow.switches, flow.closed_time.clone());
        let mut master = Vec::with_capacity(MASTER_SAMPLES);
        let mut modal = vec![Vec::with_capacity(MASTER_SAMPLES); r];
        let dt = period / MASTER_SAMPLES as f64;
        for _ in 0..MASTER_SAMPLES {
            let lambda = flow.contact_force(&state, &active)?;
            master.push(self.master.at(&state.q, &lambda));
            modal.iter_mut().zip(&state.q).for_each(|(m, q)| m.push(*q));
            flow.advance(&mut state, &mut active, dt, Some(&mut monodromy))?;
        }
        let contact_shares = (flow.closed_time.iter().zip(&closed))
            .map(|(after, before)| (after - before) / period)
            .collect();
        let orbit = ShotOrbit {
            q0: q0.to_vec(),
            period,
            monodromy,
            switches: flow.switches - switches,
            contact_shares,
        };
        Ok(SampledOrbit {
            orbit,
            master,
            modal,
        })
    }
}

/// One period of an exact orbit, sampled at `MASTER_SAMPLES` instants from t = 0.
struct SampledOrbit {
    orbit: ShotOrbit,
    /// The master's displacement (m).
    master: Vec<f64>,
    /// The kept modal coordinates (r rows).
    modal: Vec<Vec<f64>>,
}

/// Cosine coefficient of harmonic h of samples over one period of an even function.
fn cosine_coefficient(samples: &[f64], h: usize) -> f64 {
    let m = samples.len() as f64;
    let weight = if h == 0 { 1.0 } else { 2.0 };
    let step = 2.0 * std::f64::consts::PI * h as f64 / m;
    weight / m
        * samples
            .iter()
            .enumerate()
            .map(|(i, x)| x * (step * i as f64).cos())
            .sum::<f64>()
}

/// The energy shares w_k^2 c_kh^2 / total of the kept modes' harmonics h = 0..m/2 (as the
/// harmonic balance's `primary_share` and `secondary_*`): the starting mode's at harmonic 1,
/// and the largest other as (mode, harmonic, share).
fn energy_shares(modal: &[Vec<f64>], omega2: &[f64], mode: usize) -> (f64, usize, usize, f64) {
    let harmonics = MASTER_SAMPLES / 2;
    let energy: Vec<Vec<f64>> = modal
        .iter()
        .zip(omega2)
        .map(|(q, w2)| {
            (0..harmonics)
                .map(|h| w2 * cosine_coefficient(q, h).powi(2))
                .collect()
        })
        .collect();
    let total: f64 = energy.iter().flatten().sum();
    let scale = if total > 0.0 { 1.0 / total } else { 0.0 };
    let primary = energy.get(mode).map_or(0.0, |e| e[1] * scale);
    let mut secondary = (0, 0, 0.0);
    for (k, e) in energy.iter().enumerate() {
        for (h, &x) in e.iter().enumerate() {
            if (k, h) != (mode, 1) && x * scale > secondary.2 {
                secondary = (k, h, x * scale);
            }
        }
    }
    (primary, secondary.0, secondary.1, secondary.2)
}

impl CurveEquations for &BackboneEquations<'_> {
    type Point = BoundaryBackbonePoint;

    /// q'(T/2) / v_scale, and the scaled Jacobian [dq'/dq0 s, dq'/dT T_ref] / v_scale.
    fn residual(&self, z: &[f64]) -> Result<(Vec<f64>, Mat<f64>), HbError> {
        let r = self.r();
        let (q0, period) = self.state(z);
        if period.is_nan() || period <= 0.0 {
            return Ok((vec![f64::NAN; r], Mat::zeros(r, r + 1)));
        }
        let hp = half_period(&mut self.flow.borrow_mut(), &q0, period)?;
        let v = self.v_scale();
        let jacobian = Mat::from_fn(r, r + 1, |i, k| {
            if k < r {
                hp.d_q0[(i, k)] * self.q_scale / v
            } else {
                hp.d_period[i] * self.t_ref / v
            }
        });
        Ok((hp.velocity.iter().map(|x| x / v).collect(), jacobian))
    }

    fn jacobian(&self, _: &[f64], _: &[f64], jacobian: &Mat<f64>) -> Result<Mat<f64>, HbError> {
        Ok(jacobian.clone())
    }

    fn point(&self, z: &[f64], _: &Mat<f64>, fold: bool) -> Result<BoundaryBackbonePoint, HbError> {
        let (q0, period) = self.state(z);
        let SampledOrbit {
            orbit,
            master,
            modal,
        } = self.orbit(&q0, period)?;
        let q = cosine_coefficient(&master, 1);
        let master_max = master.iter().fold(0.0_f64, |a, u| a.max(u.abs()));
        let (primary_share, secondary_mode, secondary_harmonic, secondary_share) =
            energy_shares(&modal, &self.model.omega2, self.mode);
        let (max_multiplier_abs, verdict) = match exponents_of(&orbit)? {
            Some(exponents) => {
                let (largest, verdict) = (self.judge)(&exponents, period);
                (Some(largest), verdict)
            }
            None => (None, "undetermined"),
        };
        Ok(BoundaryBackbonePoint {
            q0,
            q,
            master_max,
            omega: 2.0 * std::f64::consts::PI / period,
            contact_shares: orbit.contact_shares,
            switches: orbit.switches,
            max_multiplier_abs,
            verdict: verdict.to_string(),
            fold,
            primary_share,
            secondary_mode,
            secondary_harmonic,
            secondary_share,
        })
    }

    fn progress(point: &BoundaryBackbonePoint) -> f64 {
        point.q.abs()
    }

    /// The first point of the linear segment is on a family of any amplitude at T = 2 pi / w_k:
    /// the square system at fixed T is singular there.
    const FIRST_AT_FIXED_PARAMETER: bool = false;

    /// The orbit is no longer the starting mode's: another component (mode, harmonic) holds
    /// more of the kept modes' energy than its fundamental (the harmonic balance's passage
    /// guard, `on_the_traced_mode`), or the curve turned back in q by more than `TURN_BACK` of
    /// its extreme so far in the direction traced (an internal-resonance tongue, where q falls
    /// while the resonating mode grows; a fold of the main branch turns back by less).
    fn leaves(&self, point: &BoundaryBackbonePoint) -> bool {
        if self.following.get() {
            return point.primary_share < OTHER_MODE_SHARE;
        }
        if point.secondary_share > point.primary_share {
            return true;
        }
        let q = point.q.abs();
        let (up, extreme) = (self.growing.get(), self.extreme.get());
        if up {
            self.extreme.set(extreme.max(q));
            q < extreme * (1.0 - TURN_BACK)
        } else {
            self.extreme.set(extreme.min(q));
            q > extreme * (1.0 + TURN_BACK)
        }
    }
}

/// How far (relative) q may fall back from its largest value along a trace toward larger q
/// (or rise from its smallest toward smaller q) before the trace counts as turned into a tongue.
const TURN_BACK: f64 = 0.05;

/// While a piece's edge is followed through its tongue (`holes`), the trace leaves
/// only where the starting mode's fundamental holds less than this share of the kept modes'
/// energy: the orbit is another mode's.
pub(crate) const OTHER_MODE_SHARE: f64 = 0.02;
