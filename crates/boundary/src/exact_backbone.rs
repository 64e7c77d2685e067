//! The exact backbone of the massless contact boundary (docs/STABILITY.md Sec. 9.3): the family
//! of its symmetric periodic orbits continued in amplitude by shooting, with no harmonic
//! truncated, beside the harmonic-balance backbone.
//!
//! The model is the caller's: `nlmodes-nnm` gives the one its stability stage shoots on (`model`,
//! `free_flow`): the modes up to `shooting_cutoff` (N + 1) w_max dynamic (w_max the largest w of
//! the main branch), the others static on the contact rows, a penalty law's spring in series. A
//! backbone orbit is at rest at t = 0 and again at T / 2 (`free_shooting`): r equations
//! q'(T/2) = 0 in the r + 1 scaled unknowns z = (q0 / s, T / T_ref), continued by `arc_length`
//! with T as the
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

use serde::{Deserialize, Serialize};

use crate::arc_length::{trace_curve, CurveEnd, CurveSettings};
use crate::backbone_curve::{covered_ranges, BackboneEquations, BoundaryPiece, Judge};
use crate::free_flow::BoundaryFlow;
use crate::holes::{follow_holes, HoleFollow};
use crate::master_row::MasterRow;
use crate::model::{norm, BoundaryModel};
use nlmodes_hb::HbError;

/// The exact backbone of the massless contact boundary (module docs).
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct BoundaryBackbone {
    pub pieces: Vec<BoundaryPiece>,
    /// Modes kept dynamic.
    pub modes: usize,
    /// The pieces' ends next to each hole between them, followed through their tongues
    /// (`holes`): why the hole stays, or the orbits that cross it.
    #[serde(default)]
    pub hole_follows: Vec<HoleFollow>,
}

impl BoundaryBackbone {
    /// The q ranges (system length unit) its pieces cover, merged, ascending.
    pub fn covered(&self) -> Vec<(f64, f64)> {
        covered_ranges(&self.pieces)
    }
}

/// Most pieces of one exact backbone (each seeded past the internal resonance that ended the
/// last).
const MAX_PIECES: usize = 64;
/// Largest step in the scaled unknowns (q0 / max |q0|, T / T_1): about a hundred points from
/// grazing to q_max, dense enough for w(q) to be read between them to 1e-3.
const MAX_STEP: f64 = 0.01;
/// Most points of one end of a piece.
const MAX_PIECE_POINTS: usize = 600;

/// A point of the harmonic-balance main branch, where a piece of the exact backbone may start.
#[derive(Clone, Debug)]
pub struct BranchStart {
    /// Its master amplitude q (m).
    pub q: f64,
    /// Its kept modal coordinates at t = 0 (where the orbit is at rest).
    pub q0: Vec<f64>,
    /// Its period (s).
    pub period: f64,
}

/// The exact backbone of the massless contact boundary `model` along the main branch `branch`
/// (its points by increasing q, the first where the backbone starts), up to master amplitude
/// `q_end` (m), in pieces (module docs): `master` the master's row of the model, `mode` the
/// traced linear mode (0-based), `judge` each orbit's verdict. `None` when no piece is found.
pub fn exact_backbone(
    model: &BoundaryModel,
    master: MasterRow,
    branch: &[BranchStart],
    mode: usize,
    q_end: f64,
    judge: &Judge<'_>,
) -> Result<Option<BoundaryBackbone>, HbError> {
    let Some(first) = branch.first() else {
        return Ok(None);
    };
    let q_scale = branch.iter().map(|p| norm(&p.q0)).fold(0.0, f64::max);
    let t_ref = first.period;
    if !(q_scale.is_finite() && q_scale > 0.0 && t_ref.is_finite() && t_ref > 0.0) {
        return Ok(None);
    }
    let equations = BackboneEquations {
        model,
        flow: RefCell::new(BoundaryFlow::new(model)),
        master,
        q_scale,
        t_ref,
        judge,
        mode,
        growing: Cell::new(true),
        extreme: Cell::new(0.0),
        following: Cell::new(false),
        ceiling: q_end,
    };
    let main: Vec<Seed> = branch
        .iter()
        .map(|p| Seed {
            z_q0: p.q0.iter().map(|v| v / q_scale).collect(),
            period: p.period / t_ref,
            q: p.q.abs(),
        })
        .collect();
    let pieces = trace_pieces(&equations, &main, q_end)?;
    if pieces.is_empty() {
        return Ok(None);
    }
    let hole_follows = follow_holes(&equations, &pieces, main[0].q, q_end)?;
    Ok(Some(BoundaryBackbone {
        pieces,
        modes: model.modes(),
        hole_follows,
    }))
}

/// The pieces from the main branch's first point (not traced below it) up to `q_end`, each
/// seeded from the first main-branch point above the q reached so far (module docs).
fn trace_pieces(
    equations: &BackboneEquations<'_>,
    main: &[Seed],
    q_end: f64,
) -> Result<Vec<BoundaryPiece>, HbError> {
    let q_start = main[0].q;
    let mut pieces: Vec<BoundaryPiece> = Vec::new();
    let mut covered = q_start;
    let mut seed = Some(&main[0]);
    while let Some(p) = seed.filter(|_| pieces.len() < MAX_PIECES) {
        // The first piece starts at q_start; the others go down to the q reached so far.
        let range = PieceRange {
            floor_up: 0.5 * q_start,
            floor_down: covered,
            ceiling: q_end,
        };
        let piece = trace_piece(equations, p.clone(), &range)?;
        let top = piece.iter().flat_map(|x| &x.points).map(|x| x.q.abs());
        covered = top.fold(covered.max(p.q), f64::max);
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
        fill_gaps(equations, main, &mut pieces)?;
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
    main: &[Seed],
    pieces: &mut Vec<BoundaryPiece>,
) -> Result<(), HbError> {
    let q_start = main[0].q;
    let ranges = covered_ranges(pieces);
    for pair in ranges.windows(2) {
        let (lo, hi) = (pair[0].1, pair[1].0);
        let below = main
            .iter()
            .filter(|p| p.q <= lo)
            .max_by(|a, b| a.q.total_cmp(&b.q));
        let above = main
            .iter()
            .filter(|p| p.q >= hi)
            .min_by(|a, b| a.q.total_cmp(&b.q));
        let (Some(a), Some(b)) = (below, above) else {
            continue;
        };
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

/// Where one piece may run (system length unit): toward larger q not below `floor_up` and up to
/// `ceiling`, toward smaller q down to `floor_down`.
struct PieceRange {
    floor_up: f64,
    floor_down: f64,
    ceiling: f64,
}

/// The main-branch point of smallest q above `covered` (by 0.1 %), where the next piece starts.
fn next_seed(main: &[Seed], covered: f64) -> Option<&Seed> {
    main.iter()
        .filter(|p| p.q > covered * 1.001)
        .min_by(|a, b| a.q.total_cmp(&b.q))
}

/// Where a piece starts: a harmonic-balance point's scaled modal start and period, and its q.
#[derive(Clone)]
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
) -> Result<Option<BoundaryPiece>, HbError> {
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
    use super::*;
    use crate::driven_model::DrivenBoundary;
    use crate::rk4::{integrate, Rk4State};
    use crate::test_models::{bilinear, bilinear_period, judge, three_modes};

    fn equations(model: &BoundaryModel, master: MasterRow, q_scale: f64) -> BackboneEquations<'_> {
        BackboneEquations {
            model,
            flow: RefCell::new(BoundaryFlow::new(model)),
            master,
            q_scale,
            t_ref: 2.0 * std::f64::consts::PI,
            judge: &judge,
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
            let master = MasterRow::from_coefficients(vec![1.0], vec![0.0]);
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
        let master = MasterRow::from_coefficients(vec![1.0, 0.5, 0.2], vec![0.1, 0.0, 0.05]);
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
            let (end, _) = integrate(
                &DrivenBoundary::undriven(&model, period),
                &start,
                period,
                40_000,
            )
            .expect("rk4");
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
