//! The exact backbone of the massless contact boundary (docs/STABILITY.md Sec. 9.3): the family
//! of its symmetric periodic orbits continued in amplitude by shooting, with no harmonic
//! truncated, beside the harmonic-balance backbone.
//!
//! The model is the one the stability stage shoots on (`boundary_flow`): the modes up to
//! `shooting_cutoff` (N + 1) w_max dynamic (w_max the largest w of the main branch), the others
//! static on the contact rows, a penalty law's spring in series. A backbone orbit is at rest at
//! t = 0 and again at T / 2 (`boundary_shooting`): r equations q'(T/2) = 0 in the r + 1 scaled
//! unknowns z = (q0 / s, T / T_ref), continued by `nlmodes_hb::arc_length` with T as the
//! parameter (kinks hopped at fixed T, folds where T turns). Every point is exact to the
//! shooting tolerance, its contact shares come from the exact switch instants and its verdict
//! from its own exact monodromy (Liouville-checked).
//!
//! The untruncated model meets an internal resonance at every harmonic of every dynamic mode,
//! and its symmetric family turns into the strong ones, so the backbone comes in pieces. A piece
//! ends where another (mode, harmonic) holds more of the kept modes' energy than the starting
//! mode's fundamental, or where q falls back by `TURN_BACK` (`leaves`). The next piece starts
//! from the first harmonic-balance main-branch point above the q reached so far; then the gaps
//! between pieces are seeded from inside, by guesses interpolated between the harmonic-balance
//! points on either side (`fill_gaps`). Every piece is traced both ways from its seed.
//!
//! The master's displacement is u_m(t) = sum_{k < r} phi_mk q_k(t) - sum_j c_j lambda_j(t),
//! c_j = sum_{k >= r} phi_mk b_jk / w_k^2: the kept modes and the discarded modes' static
//! response to the contact forces. Its first harmonic (the backbone's amplitude q, as the
//! harmonic balance's e_master . u_1) and its largest value come from `MASTER_SAMPLES` instants.

use std::cell::{Cell, RefCell};

use faer::Mat;
use serde::{Deserialize, Serialize};

use super::boundary_flow::{BoundaryFlow, BoundaryModel, FlowState};
use super::boundary_holes::{follow_holes, HoleFollow, OTHER_MODE_SHARE};
use super::boundary_shooting::ShotOrbit;
use super::boundary_shooting::{
    boundary_model, exponents_of, half_period, modal_coordinates, norm,
};
use super::hill::{penalty_of, stability_from_exponents};
use super::{verdict_word, FloquetAnalysis, StabilityMethod, VerdictInputs};
use crate::continuation::{Backbone, BranchKind};
use crate::point::BackbonePoint;
use crate::NnmError;
use nlmodes_hb::arc_length::{trace_curve, CurveEnd, CurveEquations, CurveSettings};

/// Instants per period at which the master's displacement is sampled (its first harmonic by
/// the trapezoid rule, exact for a smooth periodic function up to aliasing from harmonics 127
/// and 129).
pub(super) const MASTER_SAMPLES: usize = 128;

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
    /// `stable`, `unstable` or `undetermined` (`verdict_word` of the shooting method).
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

/// The exact backbone of the massless contact boundary (module docs).
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct BoundaryBackbone {
    pub pieces: Vec<BoundaryPiece>,
    /// Modes kept dynamic.
    pub modes: usize,
    /// The pieces' ends next to each hole between them, followed through their tongues
    /// (`boundary_holes`): why the hole stays, or the orbits that cross it.
    #[serde(default)]
    pub hole_follows: Vec<HoleFollow>,
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

impl BoundaryBackbone {
    /// The q ranges (system length unit) its pieces cover, merged, ascending.
    pub fn covered(&self) -> Vec<(f64, f64)> {
        covered_ranges(&self.pieces)
    }
}

/// The master's displacement on the boundary from q and lambda (module docs).
pub(super) struct MasterRow {
    pub(super) kept: Vec<f64>,
    pub(super) contact: Vec<f64>,
}

impl MasterRow {
    pub(super) fn new(analysis: &FloquetAnalysis<'_>, r: usize) -> Self {
        let modal = analysis.modal_data();
        let phi_m = analysis.master_modal();
        let b = modal.contact_modal;
        let contact = (0..b.nrows())
            .map(|j| {
                (r..modal.omega.len())
                    .map(|k| phi_m[k] * b[(j, k)] / (modal.omega[k] * modal.omega[k]))
                    .sum()
            })
            .collect();
        Self {
            kept: phi_m[..r].to_vec(),
            contact,
        }
    }

    pub(super) fn at(&self, q: &[f64], lambda: &[f64]) -> f64 {
        let dot = |a: &[f64], b: &[f64]| a.iter().zip(b).map(|(x, y)| x * y).sum::<f64>();
        dot(&self.kept, q) - dot(&self.contact, lambda)
    }
}

/// The backbone's shooting equations (module docs) and what each accepted point records.
pub(super) struct BackboneEquations<'m> {
    model: &'m BoundaryModel,
    flow: RefCell<BoundaryFlow<'m>>,
    master: MasterRow,
    q_scale: f64,
    t_ref: f64,
    tolerance: f64,
    /// The starting linear mode (0-based).
    mode: usize,
    /// Whether the trace in progress goes toward larger q.
    growing: Cell<bool>,
    /// The largest (growing) or smallest q of the trace so far.
    extreme: Cell<f64>,
    /// Whether a piece's end is being followed through its tongue (`boundary_holes`): then
    /// the curve leaves only where the starting mode's fundamental holds less than
    /// `OTHER_MODE_SHARE` of the energy.
    pub(super) following: Cell<bool>,
    /// The largest q traced (system length unit).
    ceiling: f64,
}

impl BackboneEquations<'_> {
    fn r(&self) -> usize {
        self.model.omega2.len()
    }

    /// The largest q traced (system length unit).
    pub(super) fn q_ceiling(&self) -> f64 {
        self.ceiling
    }

    /// The scaled unknowns z = (q0 / s, T / T_ref) of an orbit of the curve.
    pub(super) fn scaled(&self, p: &BoundaryBackbonePoint) -> Vec<f64> {
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
    fn orbit(&self, q0: &[f64], period: f64) -> Result<SampledOrbit, NnmError> {
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
    fn residual(&self, z: &[f64]) -> Result<(Vec<f64>, Mat<f64>), NnmError> {
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

    fn jacobian(&self, _: &[f64], _: &[f64], jacobian: &Mat<f64>) -> Result<Mat<f64>, NnmError> {
        Ok(jacobian.clone())
    }

    fn point(
        &self,
        z: &[f64],
        _: &Mat<f64>,
        fold: bool,
    ) -> Result<BoundaryBackbonePoint, NnmError> {
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
                let mut s = stability_from_exponents(&exponents, period, self.tolerance);
                s.method = StabilityMethod::Shooting;
                (
                    Some(s.max_multiplier_abs),
                    verdict_word(&VerdictInputs::of(&s)),
                )
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

/// Most pieces of one exact backbone (each seeded past the internal resonance that ended the
/// last).
const MAX_PIECES: usize = 64;
/// How far (relative) q may fall back from its largest value along a trace toward larger q
/// (or rise from its smallest toward smaller q) before the trace counts as turned into a tongue.
const TURN_BACK: f64 = 0.05;
/// Largest step in the scaled unknowns (q0 / max |q0|, T / T_1): about a hundred points from
/// grazing to q_max, dense enough for w(q) to be read between them to 1e-3.
const MAX_STEP: f64 = 0.01;
/// Most points of one end of a piece.
const MAX_PIECE_POINTS: usize = 600;

/// The exact backbone of the massless contact boundary of `backbone`'s main branch, from its
/// first point up to master amplitude `q_end` (system length unit), in pieces (module docs).
/// `None` when the boundary model does not apply (no point in contact, every mode resolved, or
/// R not positive definite).
pub fn boundary_backbone(
    analysis: &FloquetAnalysis<'_>,
    backbone: &Backbone,
    q_end: f64,
) -> Result<Option<BoundaryBackbone>, NnmError> {
    let main: Vec<&BackbonePoint> = backbone
        .points
        .iter()
        .filter(|p| {
            backbone
                .branches
                .get(p.branch)
                .is_none_or(|b| matches!(b.kind, BranchKind::Main | BranchKind::Linear))
        })
        .collect();
    let Some(model) = backbone_model(analysis, &main) else {
        return Ok(None);
    };
    let r = model.omega2.len();
    let modal = analysis.modal_data();
    let start = |p: &BackbonePoint| modal_coordinates(&modal, &p.displacement_at(0.0), r);
    let q_scale = main.iter().map(|p| norm(&start(p))).fold(0.0, f64::max);
    let t_ref = main[0].period();
    if !(q_scale.is_finite() && q_scale > 0.0 && t_ref.is_finite() && t_ref > 0.0) {
        return Ok(None);
    }
    let equations = BackboneEquations {
        model: &model,
        flow: RefCell::new(BoundaryFlow::new(&model)),
        master: MasterRow::new(analysis, r),
        q_scale,
        t_ref,
        tolerance: analysis.settings().tolerance,
        mode: main[0].mode,
        growing: Cell::new(true),
        extreme: Cell::new(0.0),
        following: Cell::new(false),
        ceiling: q_end,
    };
    let seed_of = |p: &BackbonePoint| Seed {
        z_q0: start(p).iter().map(|v| v / q_scale).collect(),
        period: p.period() / t_ref,
        q: p.q.abs(),
    };
    let pieces = trace_pieces(&equations, &main, &seed_of, q_end)?;
    if pieces.is_empty() {
        return Ok(None);
    }
    let hole_follows = follow_holes(&equations, &pieces, main[0].q.abs(), q_end)?;
    Ok(Some(BoundaryBackbone {
        pieces,
        modes: r,
        hole_follows,
    }))
}

/// The boundary model of the main branch `main` (module docs): the modes up to
/// `shooting_cutoff` (N + 1) w_max dynamic, the harmonic balance's contact law. `None` where it
/// does not apply.
fn backbone_model(
    analysis: &FloquetAnalysis<'_>,
    main: &[&BackbonePoint],
) -> Option<BoundaryModel> {
    let in_contact: Vec<&BackbonePoint> = main
        .iter()
        .filter(|p| p.contact_force.iter().flatten().any(|&f| f > 0.0))
        .copied()
        .collect();
    let deepest = in_contact
        .iter()
        .max_by(|a, b| a.q.abs().total_cmp(&b.q.abs()))?;
    let harmonics = main[0].coefficients.len().saturating_sub(1);
    let w_max = main.iter().map(|p| p.omega).fold(0.0, f64::max);
    let modal = analysis.modal_data();
    let r = analysis.shooting_modes(w_max, harmonics);
    if r == modal.omega.len() {
        return None;
    }
    // A penalty law's orbits all carry their spring and no multiplier; an augmented-Lagrangian
    // orbit that barely touches may carry none yet either, so the law is read from them all.
    let penalty = if in_contact.iter().all(|p| penalty_of(p).is_some()) {
        penalty_of(deepest)
    } else {
        None
    };
    boundary_model(&modal, analysis.system().gaps(), r, penalty.as_deref())
}

/// The pieces from the main branch's first point (not traced below it) up to `q_end`, each
/// seeded from the first main-branch point above the q reached so far (module docs).
fn trace_pieces(
    equations: &BackboneEquations<'_>,
    main: &[&BackbonePoint],
    seed_of: &dyn Fn(&BackbonePoint) -> Seed,
    q_end: f64,
) -> Result<Vec<BoundaryPiece>, NnmError> {
    let q_start = main[0].q.abs();
    let mut pieces: Vec<BoundaryPiece> = Vec::new();
    let mut covered = q_start;
    let mut seed = Some(main[0]);
    while let Some(p) = seed.filter(|_| pieces.len() < MAX_PIECES) {
        // The first piece starts at q_start; the others go down to the q reached so far.
        let range = PieceRange {
            floor_up: 0.5 * q_start,
            floor_down: covered,
            ceiling: q_end,
        };
        let piece = trace_piece(equations, seed_of(p), &range)?;
        let top = piece.iter().flat_map(|x| &x.points).map(|x| x.q.abs());
        covered = top.fold(covered.max(p.q.abs()), f64::max);
        // A seed whose orbit is already in a tongue gives one orbit and no curve.
        pieces.extend(piece.filter(|x| x.points.len() > 1));
        if covered >= q_end {
            break;
        }
        seed = next_seed(main, covered);
    }
    // Each pass may leave smaller gaps between its pieces and the others: a few more passes.
    for _ in 0..GAP_PASSES {
        let before = pieces.len();
        fill_gaps(equations, main, seed_of, &mut pieces)?;
        if pieces.len() == before {
            break;
        }
    }
    Ok(pieces)
}

/// Seeds per gap between pieces, at these fractions of the way from the harmonic-balance point
/// below the gap to the one above it.
const GAP_SEEDS: [f64; 5] = [1.0 / 6.0, 2.0 / 6.0, 3.0 / 6.0, 4.0 / 6.0, 5.0 / 6.0];
/// Passes over the gaps (each may leave smaller ones).
const GAP_PASSES: usize = 3;

/// Pieces inside the gaps the first pass left (module docs): seeds interpolated in (q0, T)
/// between the main-branch points on either side, each traced down to the piece below and up to
/// the piece above unless it turns into a tongue first. The main branch of the untruncated
/// model can lie between tongues there, out of reach of a continuation from either side.
fn fill_gaps(
    equations: &BackboneEquations<'_>,
    main: &[&BackbonePoint],
    seed_of: &dyn Fn(&BackbonePoint) -> Seed,
    pieces: &mut Vec<BoundaryPiece>,
) -> Result<(), NnmError> {
    let q_start = main[0].q.abs();
    let ranges = covered_ranges(pieces);
    for pair in ranges.windows(2) {
        let (lo, hi) = (pair[0].1, pair[1].0);
        let below = main
            .iter()
            .filter(|p| p.q.abs() <= lo)
            .max_by(|a, b| a.q.abs().total_cmp(&b.q.abs()));
        let above = main
            .iter()
            .filter(|p| p.q.abs() >= hi)
            .min_by(|a, b| a.q.abs().total_cmp(&b.q.abs()));
        let (Some(below), Some(above)) = (below, above) else {
            continue;
        };
        let (a, b) = (seed_of(below), seed_of(above));
        for s in GAP_SEEDS {
            let q = a.q + s * (b.q - a.q);
            let filled = covered_ranges(pieces).iter().any(|r| r.0 <= q && q <= r.1);
            if filled || pieces.len() >= MAX_PIECES {
                continue;
            }
            let seed = Seed {
                z_q0: a
                    .z_q0
                    .iter()
                    .zip(&b.z_q0)
                    .map(|(x, y)| x + s * (y - x))
                    .collect(),
                period: a.period + s * (b.period - a.period),
                q,
            };
            let range = PieceRange {
                floor_up: 0.5 * q_start,
                floor_down: lo,
                ceiling: hi,
            };
            let piece = trace_piece(equations, seed, &range)?;
            // Two seeds (or passes) may land on the same piece: kept once.
            let new = |x: &BoundaryPiece| !pieces.iter().any(|y| same_piece(x, y));
            if let Some(mut x) = piece.filter(|x| x.points.len() > 1 && new(x)) {
                x.gap = true;
                pieces.push(x);
            }
        }
    }
    pieces.sort_by(|x, y| x.span().0.total_cmp(&y.span().0));
    Ok(())
}

/// Whether two pieces span the same q range to 1e-6 (relative): the same curve.
fn same_piece(a: &BoundaryPiece, b: &BoundaryPiece) -> bool {
    let ((a0, a1), (b0, b1)) = (a.span(), b.span());
    (a0 - b0).abs() <= 1e-6 * a1 && (a1 - b1).abs() <= 1e-6 * a1
}

/// The q ranges (system length unit) the pieces cover, merged, ascending.
fn covered_ranges(pieces: &[BoundaryPiece]) -> Vec<(f64, f64)> {
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

/// Where one piece may run (system length unit): toward larger q not below `floor_up` and up to
/// `ceiling`, toward smaller q down to `floor_down`.
struct PieceRange {
    floor_up: f64,
    floor_down: f64,
    ceiling: f64,
}

/// The main-branch point of smallest q above `covered` (by 0.1 %), where the next piece starts.
fn next_seed<'b>(main: &[&'b BackbonePoint], covered: f64) -> Option<&'b BackbonePoint> {
    main.iter()
        .filter(|p| p.q.abs() > covered * 1.001)
        .min_by(|a, b| a.q.abs().total_cmp(&b.q.abs()))
        .copied()
}

/// Where a piece starts: a harmonic-balance point's scaled modal start and period, and its q.
struct Seed {
    /// q0 / s of the point's displacement at t = 0 (kept modes).
    z_q0: Vec<f64>,
    /// T / T_ref.
    period: f64,
    /// Its master amplitude |q| (m).
    q: f64,
}

/// One piece from `seed`, both ways within `range`. `None` when the seed has no orbit of the
/// boundary nearby.
fn trace_piece(
    equations: &BackboneEquations<'_>,
    Seed {
        z_q0,
        period,
        q: seed_q,
    }: Seed,
    range: &PieceRange,
) -> Result<Option<BoundaryPiece>, NnmError> {
    let n = norm(&z_q0);
    let growing: Vec<f64> = z_q0.iter().map(|v| v / n).chain([0.0]).collect();
    let shrinking: Vec<f64> = growing.iter().map(|v| -v).collect();
    let z0: Vec<f64> = z_q0.iter().copied().chain([period]).collect();
    let settings = |floor| CurveSettings {
        max_points: MAX_PIECE_POINTS,
        max_step: MAX_STEP,
        ..CurveSettings::new(floor, range.ceiling)
    };
    equations.growing.set(true);
    equations.extreme.set(seed_q);
    let Some(up) = trace_curve(equations, z0.clone(), &growing, &settings(range.floor_up))? else {
        tracing::debug!(
            q = seed_q,
            "exact backbone: no orbit of the boundary at this seed"
        );
        return Ok(None);
    };
    equations.growing.set(false);
    equations.extreme.set(seed_q);
    let down = trace_curve(equations, z0, &shrinking, &settings(range.floor_down))?;
    let (mut points, lower_end) = match down {
        Some(d) => (d.points.into_iter().skip(1).rev().collect(), d.end),
        None => (Vec::new(), CurveEnd::StepTooSmall { at: seed_q }),
    };
    points.extend(up.points);
    Ok(Some(BoundaryPiece {
        points,
        seed_q,
        lower_end,
        upper_end: up.end,
        gap: false,
    }))
}

#[cfg(test)]
mod tests {
    use super::super::test_models::{bilinear, bilinear_period, three_modes};
    use super::*;
    use nlmodes_hb::boundary_rk4::{integrate, Rk4State};

    fn equations(model: &BoundaryModel, master: MasterRow, q_scale: f64) -> BackboneEquations<'_> {
        BackboneEquations {
            model,
            flow: RefCell::new(BoundaryFlow::new(model)),
            master,
            q_scale,
            t_ref: 2.0 * std::f64::consts::PI,
            tolerance: 1e-3,
            mode: 0,
            growing: Cell::new(true),
            extreme: Cell::new(0.0),
            following: Cell::new(false),
            ceiling: f64::INFINITY,
        }
    }

    #[test]
    fn the_bilinear_backbone_has_the_exact_period_from_the_linear_mode_through_contact() {
        for flex in [0.1, 1.0, 10.0] {
            let model = bilinear(flex);
            let master = MasterRow {
                kept: vec![1.0],
                contact: vec![0.0],
            };
            let z0 = vec![0.5 / 3.0, 1.0];
            let curve = trace_curve(
                &equations(&model, master, 3.0),
                z0,
                &[1.0, 0.0],
                &CurveSettings::new(0.25, 3.0),
            )
            .expect("trace")
            .expect("first orbit");
            assert_eq!(curve.end, CurveEnd::Complete, "R = {flex}");
            let worst = curve
                .points
                .iter()
                .map(|p| {
                    (2.0 * std::f64::consts::PI / p.omega / bilinear_period(flex, p.q0[0]) - 1.0)
                        .abs()
                })
                .fold(0.0, f64::max);
            let contact = curve.points.iter().filter(|p| p.switches == 2).count();
            println!(
                "R = {flex}: {} points, {contact} in contact, worst period error {worst:.1e}",
                curve.points.len()
            );
            // The shooting tolerance 1e-10 on the scaled velocity; measured below 1e-12.
            assert!(worst < 1e-9, "R = {flex}: {worst}");
            assert!(contact > 10, "R = {flex}: the curve must run in contact");
            // A hardening backbone: w never turns, every orbit of a one-mode model is stable.
            assert!(curve
                .points
                .iter()
                .all(|p| !p.fold && p.verdict == "stable"));
            assert!(curve
                .points
                .windows(2)
                .all(|w| w[1].omega >= w[0].omega - 1e-12));
            // Out of contact the master's first harmonic is q0 (a pure cosine).
            let p = &curve.points[0];
            assert!((p.q - p.q0[0]).abs() < 1e-12 && (p.master_max - p.q0[0]).abs() < 1e-12);
        }
    }

    #[test]
    fn a_three_mode_backbone_returns_to_its_start_under_rk4_and_ends_at_its_4_to_1_tongue() {
        let model = three_modes();
        let master = MasterRow {
            kept: vec![1.0, 0.5, 0.2],
            contact: vec![0.1, 0.0, 0.05],
        };
        let curve = trace_curve(
            &equations(&model, master, 4.0),
            vec![0.1, 0.0, 0.0, 1.0],
            &[1.0, 0.0, 0.0, 0.0],
            &CurveSettings::new(0.2, 4.0),
        )
        .expect("trace")
        .expect("first orbit");
        let last = curve.points.last().expect("points");
        println!(
            "{} points, end {:?} at q = {:.3}, w = {:.4}: mode {} harmonic {} holds {:.2} \
             against the fundamental's {:.2}",
            curve.points.len(),
            curve.end,
            last.q,
            last.omega,
            last.secondary_mode,
            last.secondary_harmonic,
            last.secondary_share,
            last.primary_share
        );
        // The third mode (w3 = sqrt(20) = 4.47) meets harmonic 4 of w = 1.12: the curve turns
        // into that 4:1 tongue (traced on, mode 3 grows without bound while q falls to 0) and
        // the piece ends where that harmonic holds more energy than the fundamental.
        assert_eq!(curve.end, CurveEnd::LeftFamily);
        assert_eq!((last.secondary_mode, last.secondary_harmonic), (2, 4));
        assert!((last.omega - 1.12).abs() < 0.01, "{last:?}");
        let mut worst = 0.0_f64;
        let mut checked = 0;
        for p in &curve.points {
            let period = 2.0 * std::f64::consts::PI / p.omega;
            let start = Rk4State {
                q: p.q0.clone(),
                v: vec![0.0; 3],
            };
            let (end, _) = integrate(&model.undriven(period), &start, period, 40_000).expect("rk4");
            let gap = (0..3)
                .map(|i| (end.q[i] - start.q[i]).abs() + (end.v[i] * period).abs())
                .fold(0.0, f64::max);
            worst = worst.max(gap);
            checked += 1;
        }
        println!("{checked} orbits: RK4 return gap {worst:.1e}");
        assert!(
            curve.points.iter().any(|p| p.switches >= 4),
            "several rows must switch"
        );
        // RK4 at 40 000 steps per period across the switches (its error O(h) at each kink,
        // about 1e-7 here); the orbits themselves are exact to 1e-10.
        assert!(worst < 1e-6, "{worst}");
    }
}
