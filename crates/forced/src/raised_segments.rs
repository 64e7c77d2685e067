//! N raised where a retraced curve needs it (DESIGN §10.8): the checked points of the last
//! trace that moved by more than the tolerance at 2N, and their neighbours along the curve, are
//! solved again at 2N, each on the row through it normal to the curve, and the segment ends on
//! each side at `EDGE` points in a row converged at N (their 2N solve within the tolerance).
//! The points that moved carry their 2N solve; those converged at N keep N with their verdict.
//! The raised points are then checked at 4N where an error is likeliest: each segment's moving
//! checked point and its point of largest change from N to 2N. On the default blade's level 5
//! (N = 20, 387 points) this solves about 50 points at 40 and 4 at 80 where a retrace of the
//! whole curve at 40 would trace it again and check it at 80.
//!
//! Each 2N solve starts from its neighbour's, shifted by the two points' difference at N (a
//! predictor along the curve: the truncation error changes slowly between neighbours), and
//! falls back on the point itself padded with zero harmonics.

use rayon::prelude::*;

use crate::curve::{CurveHarmonics, FrequencyResponse, FrfSettings, RaisedSegments};
use crate::curve_harmonics::{normal_row, record_check, MovingPoint};
use crate::error::ForcedError;
use crate::harmonic_check::HarmonicCheck;
use crate::ladder::{resize_signals, solve_same_orbit, start_at, verdict};
use crate::solver::{ForcedPoint, ForcedSolver, ForcedStart};

/// The largest N at which the raised points are checked: the solve's condensed Newton matrix is
/// dense in (2N + 1) x contact rows (0.74 GB at N = 200 on the blade's 24 rows, the CLI's
/// largest `max_harmonics`); above it the raised points are left unchecked.
pub(crate) const MAX_CHECK_HARMONICS: usize = 200;

/// Points in a row converged at N (or failing at 2N) that end a segment on one side: one
/// could be a change of sign of the truncation error between two moving points.
const EDGE: usize = 2;

/// The solvers at the curve's N, 2N and 4N and the tolerance of the check.
pub(crate) struct Raising<'a, 's> {
    /// The curve's N (its points are solved there).
    pub base: &'a ForcedSolver<'s>,
    /// 2N: the N of the raised points.
    pub finer: &'a ForcedSolver<'s>,
    /// 4N: the check of the raised points (`None` above `MAX_CHECK_HARMONICS`).
    pub check: Option<ForcedSolver<'s>>,
    pub settings: &'a FrfSettings,
}

/// One segment grown around a moving point: its points solved at 2N with their change, and
/// those whose 2N solve failed.
struct Segment {
    first: usize,
    last: usize,
    /// (index, solve at 2N, relative change [q1, W] from N).
    solved: Vec<(usize, ForcedPoint, [f64; 2])>,
    failed: Vec<usize>,
    /// The moving checked point the segment grew from.
    seed: usize,
}

impl Raising<'_, '_> {
    /// Raises N around every point of `moving` (module docs), writes the raised points and
    /// the verdicts into `curve`, and says what was done. Segments are grown in parallel (they
    /// depend on the curve at N alone); a moving point already inside an earlier segment
    /// grows none.
    pub(crate) fn raise(
        &self,
        curve: &mut FrequencyResponse,
        moving: Vec<MovingPoint>,
    ) -> Result<RaisedSegments, ForcedError> {
        let grown: Vec<Result<Segment, usize>> = moving
            .into_par_iter()
            .map(|m| match m.finer {
                Some(finer) => Ok(self.grow(curve, m.index, finer)),
                None => Err(m.index),
            })
            .collect();
        let mut out = RaisedSegments {
            segments: Vec::new(),
            raised: Vec::new(),
            failed: Vec::new(),
            check: CurveHarmonics {
                harmonics: self.finer.basis().harmonics(),
                checked: Vec::new(),
                not_converged: 0,
                largest_change: [0.0; 2],
                checkable: self.check.is_some(),
            },
        };
        let mut segments = Vec::new();
        for g in grown {
            match g {
                Err(i) => out.failed.push(i),
                Ok(s)
                    if out
                        .segments
                        .iter()
                        .any(|[a, b]| (*a..=*b).contains(&s.seed)) => {}
                Ok(s) => {
                    out.segments.push([s.first, s.last]);
                    segments.push(s);
                }
            }
        }
        let checks: Vec<(usize, ForcedPoint)> = match self.check {
            Some(_) => segments
                .iter()
                .flat_map(|s| self.representatives(s))
                .collect(),
            None => Vec::new(),
        };
        let checked: Vec<(usize, HarmonicCheck)> = checks
            .par_iter()
            .map(|(i, p)| (*i, self.check_at_4n(curve, *i, p)))
            .collect();
        for s in segments {
            out.failed.extend(&s.failed);
            for i in &s.failed {
                curve.points[*i].harmonic_check = HarmonicCheck::NotConverged { change: None };
            }
            for (i, fine, change) in s.solved {
                if change
                    .iter()
                    .all(|&c| c <= self.settings.harmonic_tolerance)
                {
                    curve.points[i].harmonic_check = HarmonicCheck::Converged { change };
                } else {
                    curve.points[i] = fine;
                    out.raised.push(i);
                }
            }
        }
        for (i, check) in checked {
            curve.points[i].harmonic_check = check;
            out.check.checked.push(i);
            record_check(&mut out.check, check);
        }
        out.raised.sort_unstable();
        out.failed.sort_unstable();
        out.check.checked.sort_unstable();
        Ok(out)
    }

    /// The segment around the moving point `seed` (its 2N solve `finer`), grown both ways
    /// within its piece until `EDGE` points in a row are converged at N or fail, or the
    /// contact ends (a point out of contact is exact at any N).
    fn grow(&self, curve: &FrequencyResponse, seed: usize, finer: ForcedPoint) -> Segment {
        let master = self.base.system().master();
        let change = crate::ladder::relative_change(&curve.points[seed], &finer, master);
        let mut segment = Segment {
            first: seed,
            last: seed,
            solved: vec![(seed, finer.clone(), change)],
            failed: Vec::new(),
            seed,
        };
        let (start, end) = curve.piece_of(seed);
        for step in [-1_isize, 1] {
            let (mut prev, mut prev_fine) = (seed, finer.clone());
            let (mut quiet, mut fixed) = (0, false);
            let mut j = seed as isize + step;
            while quiet < EDGE && (start as isize..end as isize).contains(&j) {
                let i = j as usize;
                if !curve.points[i].touches() {
                    break;
                }
                match self.solve_finer(curve, i, (&curve.points[prev], &prev_fine), fixed) {
                    Some((fine, change, at_w)) => {
                        fixed = at_w;
                        let converged = change
                            .iter()
                            .all(|&c| c <= self.settings.harmonic_tolerance);
                        quiet = if converged { quiet + 1 } else { 0 };
                        segment.solved.push((i, fine.clone(), change));
                        (prev, prev_fine) = (i, fine);
                    }
                    None => {
                        quiet += 1;
                        segment.failed.push(i);
                    }
                }
                segment.first = segment.first.min(i);
                segment.last = segment.last.max(i);
                j += step;
            }
        }
        segment
    }

    /// Point `i` solved at 2N from its neighbour's 2N solve shifted by the two points'
    /// difference at N, on its normal row or at its W (`fixed_first`: the normal row failed at
    /// the neighbour, where the curve at N may turn in a way 2N does not: the stalled end of
    /// the blade's first piece at level 5); with its change from N and whether it took its W.
    fn solve_finer(
        &self,
        curve: &FrequencyResponse,
        i: usize,
        (neighbour, neighbour_fine): (&ForcedPoint, &ForcedPoint),
        fixed_first: bool,
    ) -> Option<(ForcedPoint, [f64; 2], bool)> {
        let point = &curve.points[i];
        let shifted = shifted_start(point, neighbour, neighbour_fine, self.finer);
        let on_row = || {
            let row = normal_row(self.base, self.settings, curve, i);
            solve_same_orbit(self.finer, point, Some(&row), Some(shifted.clone()))
                .map(|(p, c)| (p, c, false))
        };
        let at_w = || {
            let mut start = shifted.clone();
            start.state.omega = point.omega;
            start.state.level = point.level;
            solve_same_orbit(self.finer, point, None, Some(start)).map(|(p, c)| (p, c, true))
        };
        if fixed_first {
            at_w().or_else(on_row)
        } else {
            on_row().or_else(at_w)
        }
    }

    /// The points of a segment checked at 4N: its seed, when it moved, and its point of
    /// largest change from N to 2N (with their 2N solves).
    fn representatives(&self, s: &Segment) -> Vec<(usize, ForcedPoint)> {
        let tolerance = self.settings.harmonic_tolerance;
        let moved = |c: &[f64; 2]| c.iter().any(|&v| v > tolerance);
        let size = |c: &[f64; 2]| c[0].max(c[1]);
        let mut out: Vec<(usize, ForcedPoint)> = Vec::new();
        let largest = s
            .solved
            .iter()
            .filter(|(_, _, c)| moved(c))
            .max_by(|a, b| size(&a.2).total_cmp(&size(&b.2)));
        for (i, p, c) in s
            .solved
            .iter()
            .filter(|(i, _, _)| *i == s.seed)
            .chain(largest)
        {
            if moved(c) && !out.iter().any(|(k, _)| k == i) {
                out.push((*i, p.clone()));
            }
        }
        out
    }

    /// The verdict of a raised point `fine` (point `i` at 2N) solved again at 4N on the row
    /// normal to the curve at `i` (computed at N).
    fn check_at_4n(
        &self,
        curve: &FrequencyResponse,
        i: usize,
        fine: &ForcedPoint,
    ) -> HarmonicCheck {
        let Some(check) = &self.check else {
            return HarmonicCheck::Unchecked;
        };
        let row = normal_row(self.base, self.settings, curve, i);
        let row = crate::ladder::resize_arc(&row, self.finer);
        let solved = solve_same_orbit(check, fine, Some(&row), None);
        verdict(solved.map(|s| s.1), self.settings.harmonic_tolerance)
    }
}

/// The start at `finer`'s N of `point` from a neighbour solved at the curve's N and at
/// `finer`'s: the neighbour's finer orbit plus the difference of the two points at N.
fn shifted_start(
    point: &ForcedPoint,
    neighbour: &ForcedPoint,
    neighbour_fine: &ForcedPoint,
    finer: &ForcedSolver<'_>,
) -> ForcedStart {
    let rows = finer.system().n_contacts().max(1);
    let (from, to) = (point.contact.len() / rows, finer.basis().terms());
    let difference: Vec<f64> = point
        .contact
        .iter()
        .zip(&neighbour.contact)
        .map(|(a, b)| a - b)
        .collect();
    let difference = resize_signals(&difference, rows, from, to);
    let mut start = start_at(point, finer);
    start.state.y = neighbour_fine
        .contact
        .iter()
        .zip(&difference)
        .map(|(y, d)| y + d)
        .collect();
    start.state.omega = neighbour_fine.omega + (point.omega - neighbour.omega);
    start.state.level = neighbour_fine.level + (point.level - neighbour.level);
    start
}
