//! Why a hole between the exact backbone's pieces stays (issue 24 item 3; docs/STABILITY.md
//! Sec. 9.3). The pieces on either side of a hole end where they turn into an internal-resonance
//! tongue (`BackboneEquations::leaves` of `backbone_curve`). Each is followed on through its
//! tongue with that stop off, by the same arc-length shooting, until
//! - it comes within `MEET_DISTANCE` of the piece on the other side: the main family crosses the
//!   hole through the tongue, and the followed orbits give w(q) across it;
//! - the traced mode's fundamental holds less than `backbone_curve::OTHER_MODE_SHARE` of the
//!   kept modes' energy (or q falls below `SMALL_Q` of the hole's): the curve has become another
//!   mode's family, harmonic n of mode k holding nearly all the energy (toward q -> 0 the orbit
//!   is mode k's own motion, counted n times per period), so the main family does not come back
//!   across the hole that way;
//! - or the trace stops otherwise (point limit, no converged step, q past its ceiling).
//!
//! On the default blade both holes left are of the second kind on both sides (report.md,
//! `backbone_boundary_holes.csv`).

use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use crate::arc_length::{trace_curve, CurveEnd, CurveSettings};
use crate::backbone_curve::{
    covered_ranges, BackboneEquations, BoundaryBackbonePoint, BoundaryPiece,
};
use crate::model::norm;
use nlmodes_hb::HbError;

/// Most orbits followed from one end of a piece.
const FOLLOW_POINTS: usize = 300;
/// A follow that comes within this relative distance in (q, w) (|dq| / q + |dw| / w) of an orbit
/// of the piece on the other side of the hole has met it.
const MEET_DISTANCE: f64 = 0.01;
/// A follow whose q falls below this fraction of the hole's lower q has left for another mode's
/// family.
const SMALL_Q: f64 = 0.1;
/// Largest step of a follow, in the scaled unknowns (as the pieces').
const FOLLOW_STEP: f64 = 0.01;

/// One end of a piece next to a hole, followed on through its tongue.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct HoleFollow {
    /// The hole: the lower and upper q no piece covers between (system length unit).
    pub hole: [f64; 2],
    /// Whether the followed piece lies below the hole (its upper end is followed), or above it
    /// (its lower end).
    pub from_below: bool,
    /// The orbits from the piece's end on, along the curve.
    pub points: Vec<BoundaryBackbonePoint>,
    /// How the follow ended.
    pub end: HoleFollowEnd,
}

/// How a [`HoleFollow`] ended.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub enum HoleFollowEnd {
    /// It met the piece on the other side of the hole: the family crosses the hole through the
    /// tongue (its last orbit is the meeting one).
    MetOtherSide,
    /// The starting mode's fundamental fell below `OTHER_MODE_SHARE` of the energy, or q below
    /// `SMALL_Q` of the hole's lower q: the curve became another mode's family (the last
    /// orbit's `secondary_mode` and `secondary_harmonic` say which).
    OtherMode,
    /// The trace ended otherwise.
    Stopped(CurveEnd),
}

/// The holes between `pieces` within [q_lo, q_hi] (system length unit), each side's piece that
/// turned into a tongue followed on (module docs), the edges in parallel (each with a flow of its
/// own: the same orbits as one after the other).
pub(crate) fn follow_holes(
    equations: &BackboneEquations<'_>,
    pieces: &[BoundaryPiece],
    q_lo: f64,
    q_hi: f64,
) -> Result<Vec<HoleFollow>, HbError> {
    let mut edges = Vec::new();
    for hole in holes(pieces, q_lo, q_hi) {
        let below = pieces.iter().find(|p| {
            p.upper_end == CurveEnd::LeftFamily && p.span().1 == hole[0] && p.points.len() > 1
        });
        let above = pieces.iter().find(|p| {
            p.lower_end == CurveEnd::LeftFamily && p.span().0 == hole[1] && p.points.len() > 1
        });
        for (piece, other, from_below) in [(below, above, true), (above, below, false)] {
            if let Some(piece) = piece {
                edges.push((equations.fork(), piece, other, hole, from_below));
            }
        }
    }
    edges
        .into_par_iter()
        .map(|(eq, piece, other, hole, from_below)| follow(&eq, piece, other, hole, from_below))
        .collect()
}

/// The parts of [q_lo, q_hi] no piece covers, as [lower, upper] q.
fn holes(pieces: &[BoundaryPiece], q_lo: f64, q_hi: f64) -> Vec<[f64; 2]> {
    let mut out = Vec::new();
    let mut reached = q_lo;
    for (lo, hi) in covered_ranges(pieces) {
        if lo > reached && lo < q_hi {
            out.push([reached, lo]);
        }
        reached = reached.max(hi);
    }
    out
}

/// One end of `piece` followed through its tongue (module docs).
fn follow(
    equations: &BackboneEquations<'_>,
    piece: &BoundaryPiece,
    other: Option<&BoundaryPiece>,
    hole: [f64; 2],
    from_below: bool,
) -> Result<HoleFollow, HbError> {
    let n = piece.points.len();
    let (end, before) = if from_below {
        (&piece.points[n - 1], &piece.points[n - 2])
    } else {
        (&piece.points[0], &piece.points[1])
    };
    let z_end = equations.scaled(end);
    let mut direction: Vec<f64> = z_end
        .iter()
        .zip(equations.scaled(before))
        .map(|(a, b)| a - b)
        .collect();
    let length = norm(&direction);
    direction
        .iter_mut()
        .for_each(|v| *v /= length.max(f64::MIN_POSITIVE));
    let settings = CurveSettings {
        max_points: FOLLOW_POINTS,
        max_step: FOLLOW_STEP,
        ..CurveSettings::new(SMALL_Q * hole[0], equations.q_ceiling())
    };
    equations.following.set(true);
    let curve = trace_curve(equations, z_end, &direction, &settings);
    equations.following.set(false);
    let Some(curve) = curve? else {
        return Ok(HoleFollow {
            hole,
            from_below,
            points: Vec::new(),
            end: HoleFollowEnd::Stopped(CurveEnd::StepTooSmall { at: end.q.abs() }),
        });
    };
    let mut points = curve.points;
    let met = other.and_then(|o| points.iter().position(|p| meets(p, o)));
    let end = match (met, curve.end) {
        (Some(i), _) => {
            points.truncate(i + 1);
            HoleFollowEnd::MetOtherSide
        }
        (None, CurveEnd::LeftFamily | CurveEnd::LeftRange) => HoleFollowEnd::OtherMode,
        (None, other_end) => HoleFollowEnd::Stopped(other_end),
    };
    Ok(HoleFollow {
        hole,
        from_below,
        points,
        end,
    })
}

/// Whether `p` lies within `MEET_DISTANCE` of an orbit of `piece`.
fn meets(p: &BoundaryBackbonePoint, piece: &BoundaryPiece) -> bool {
    piece.points.iter().any(|o| {
        (p.q.abs() - o.q.abs()).abs() / o.q.abs().max(f64::MIN_POSITIVE)
            + (p.omega - o.omega).abs() / o.omega
            <= MEET_DISTANCE
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn piece(lo: f64, hi: f64) -> BoundaryPiece {
        let point = |q: f64| BoundaryBackbonePoint {
            q0: vec![q],
            q,
            master_max: q,
            omega: 1.0,
            contact_shares: Vec::new(),
            switches: 0,
            max_multiplier_abs: None,
            verdict: String::new(),
            fold: false,
            primary_share: 1.0,
            secondary_mode: 0,
            secondary_harmonic: 0,
            secondary_share: 0.0,
        };
        BoundaryPiece {
            points: vec![point(lo), point(hi)],
            seed_q: lo,
            lower_end: CurveEnd::LeftFamily,
            upper_end: CurveEnd::LeftFamily,
            gap: false,
        }
    }

    #[test]
    fn holes_are_the_uncovered_parts_of_the_range() {
        let pieces = [
            piece(1.0, 3.0),
            piece(2.5, 4.0),
            piece(5.0, 6.0),
            piece(7.0, 9.0),
        ];
        assert_eq!(
            holes(&pieces, 1.0, 8.0),
            vec![[4.0, 5.0], [6.0, 7.0]],
            "overlapping pieces merge; the part above q_hi is no hole"
        );
        assert_eq!(holes(&pieces, 0.5, 2.0), vec![[0.5, 1.0]]);
        assert!(holes(&[piece(0.0, 10.0)], 1.0, 8.0).is_empty());
    }

    #[test]
    fn a_follow_meets_the_other_side_within_one_percent_in_q_and_w() {
        let other = piece(5.0, 6.0);
        let mut p = other.points[0].clone();
        p.q = 5.0 * (1.0 + 0.004);
        p.omega = 1.0 - 0.005;
        assert!(meets(&p, &other));
        p.omega = 1.0 - 0.007;
        assert!(!meets(&p, &other));
    }
}
