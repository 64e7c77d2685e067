//! N raised where a retraced curve needs it (DESIGN §10.8), in rounds. Round 1: the checked
//! points of the last trace (at N) that moved by more than the tolerance at 2N, and their
//! neighbours along the curve, are solved again at 2N, each on the row through it normal to the
//! curve, and the segment ends on each side at `EDGE` points in a row converged at N (their 2N
//! solve within the tolerance). The points that moved carry their 2N solve; those converged at
//! N keep N with their verdict. Each segment's seed and point of largest change from N to 2N
//! are then checked at 4N, where an error is likeliest. A segment whose check still moves is
//! raised again in round 2, the same way one level up (its points at 2N solved at 4N, grown
//! from the checked point among the points round 1 raised, checked at 8N), and so on while the
//! raised N stays within `RAISE_BEYOND` x `max_harmonics` and its check within
//! `MAX_CHECK_HARMONICS`. On the default blade's level 5 (N = 20, 387 points) round 1 solves
//! about 50 points at 40 and 4 at 80 where a retrace of the whole curve at 40 would trace it
//! again and check it at 80; its level 2 needs round 2 (3 points at 80, 2 checks at 160).
//!
//! Every solve of a point, at any N, is on the same row: the one normal to the trace at N
//! through the point (`normal_row`), so the changes between rounds compare one orbit. Each
//! solve starts from its neighbour's at the same N, shifted by the two points' difference one
//! level down (a predictor along the curve: the truncation error changes slowly between
//! neighbours), and falls back on a solve at the point's own W where the row fails.

use rayon::prelude::*;

use crate::curve::{CurveHarmonics, FrequencyResponse, FrfSettings, RaisedRound, RaisedSegments};
use crate::curve_harmonics::{normal_row, record_check, MovingPoint};
use crate::error::ForcedError;
use crate::harmonic_check::HarmonicCheck;
use crate::ladder::{resize_signals, solve_same_orbit, start_at, verdict};
use crate::solver::{ForcedPoint, ForcedSolver, ForcedStart};

/// The largest N at which the raised points are checked: the solve's condensed Newton matrix is
/// dense in (2N + 1) x contact rows (0.74 GB at N = 200 on the blade's 24 rows, the CLI's
/// largest `max_harmonics`); above it the raised points are left unchecked.
pub(crate) const MAX_CHECK_HARMONICS: usize = 200;

/// A raised point may carry up to this many times `max_harmonics` (the N the check of round 1
/// already reaches): `max_harmonics` bounds the N of a whole trace, which costs every point;
/// a later round raises only the few points whose check still moves.
pub(crate) const RAISE_BEYOND: usize = 2;

/// Points in a row converged one level down (or failing) that end a segment on one side: one
/// could be a change of sign of the truncation error between two moving points.
const EDGE: usize = 2;

/// The solvers at the curve's N, 2N and 4N and the tolerance of the check.
pub(crate) struct Raising<'a, 's> {
    /// The curve's N (its points are solved there).
    pub base: &'a ForcedSolver<'s>,
    /// 2N: the N of the points raised in round 1.
    pub finer: &'a ForcedSolver<'s>,
    /// 4N: the check of round 1 (`None` above `MAX_CHECK_HARMONICS`).
    pub check: Option<ForcedSolver<'s>>,
    /// `max_harmonics` (later rounds raise up to `RAISE_BEYOND` times it).
    pub top: usize,
    pub settings: &'a FrfSettings,
}

/// One round's solvers: the points at `from` harmonics are raised to `to` and checked at
/// `check`.
struct Round<'r, 's> {
    from: usize,
    to: &'r ForcedSolver<'s>,
    check: Option<&'r ForcedSolver<'s>>,
}

/// One segment grown around a moving point: its points solved one level up with their change,
/// and those whose solve failed.
struct Segment {
    first: usize,
    last: usize,
    /// (index, solve one level up, relative change [q1, W] from the level below).
    solved: Vec<(usize, ForcedPoint, [f64; 2])>,
    failed: Vec<usize>,
    /// The moving point the segment grew from.
    seed: usize,
}

/// What a check one level above a round found at a point: its verdict and its solve there.
type Checked = (usize, HarmonicCheck, Option<ForcedPoint>);

impl Raising<'_, '_> {
    /// Raises N around every point of `moving` in rounds (module docs), writes the raised
    /// points and the verdicts into `curve`, and says what was done.
    pub(crate) fn raise(
        &self,
        curve: &mut FrequencyResponse,
        moving: Vec<MovingPoint>,
    ) -> Result<RaisedSegments, ForcedError> {
        let trace = curve.clone();
        let mut failed: Vec<usize> = Vec::new();
        let mut seeds: Vec<(usize, ForcedPoint)> = Vec::new();
        for m in moving {
            match m.finer {
                Some(finer) => seeds.push((m.index, finer)),
                None => failed.push(m.index),
            }
        }
        // Above 4N (`self.check`): 8N, 16N, ... made when a round needs them.
        let mut higher: Vec<ForcedSolver<'_>> = Vec::new();
        let mut rounds: Vec<RaisedRound> = Vec::new();
        let mut from = self.base.basis().harmonics();
        loop {
            let k = rounds.len();
            let level = |j: usize| match j {
                0 => Some(self.finer),
                1 => self.check.as_ref(),
                j => higher.get(j - 2),
            };
            let Some(to) = level(k) else { break };
            let round = Round {
                from,
                to,
                check: level(k + 1),
            };
            let (done, checked) = self.round(&trace, curve, seeds, &round);
            let n = to.basis().harmonics();
            tracing::info!(
                segments = done.segments.len(),
                raised = done.raised.len(),
                failed = done.failed.len(),
                not_converged = done.check.not_converged,
                change_q1 = done.check.largest_change[0],
                change_omega = done.check.largest_change[1],
                "forced response: N raised to {n} around the points that moved at {from}",
            );
            rounds.push(done);
            seeds = checked
                .into_iter()
                .filter(|(_, c, _)| matches!(c, HarmonicCheck::NotConverged { .. }))
                .filter_map(|(i, _, p)| p.map(|p| (i, p)))
                .collect();
            let next = 2 * n;
            let within = next <= RAISE_BEYOND * self.top && 2 * next <= MAX_CHECK_HARMONICS;
            if seeds.is_empty() || !within || self.check.is_none() {
                break;
            }
            higher.push(self.base.with_harmonics(2 * next)?);
            from = n;
        }
        Ok(summary(curve, rounds, failed))
    }

    /// One round (module docs): segments grown in parallel around `seeds` (each with its solve
    /// at `round.to`), a seed already inside an earlier segment growing none; the raised points
    /// and verdicts written into `curve`; each segment's seed and point of largest change checked at
    /// `round.check`. Returns the round and its checks (with their solves, the next round's
    /// seeds).
    fn round(
        &self,
        trace: &FrequencyResponse,
        curve: &mut FrequencyResponse,
        seeds: Vec<(usize, ForcedPoint)>,
        round: &Round<'_, '_>,
    ) -> (RaisedRound, Vec<Checked>) {
        let grown: Vec<Segment> = seeds
            .into_par_iter()
            .map(|(i, finer)| self.grow(trace, curve, round, i, finer))
            .collect();
        let mut segments: Vec<Segment> = Vec::new();
        for s in grown {
            if !segments
                .iter()
                .any(|t| (t.first..=t.last).contains(&s.seed))
            {
                segments.push(s);
            }
        }
        let checked: Vec<Checked> = match round.check {
            Some(check) => segments
                .iter()
                .flat_map(|s| representatives(s, self.settings.harmonic_tolerance))
                .collect::<Vec<_>>()
                .into_par_iter()
                .map(|(i, p)| {
                    let (c, solve) = self.check_above(trace, check, i, p);
                    (i, c, solve)
                })
                .collect(),
            None => Vec::new(),
        };
        let mut out = RaisedRound {
            harmonics: round.to.basis().harmonics(),
            segments: segments.iter().map(|s| [s.first, s.last]).collect(),
            raised: Vec::new(),
            failed: Vec::new(),
            check: CurveHarmonics {
                harmonics: round.to.basis().harmonics(),
                checked: Vec::new(),
                not_converged: 0,
                largest_change: [0.0; 2],
                checkable: round.check.is_some(),
            },
        };
        for s in segments {
            self.write_segment(curve, s, &mut out);
        }
        for (i, check, _) in &checked {
            curve.points[*i].harmonic_check = *check;
            out.check.checked.push(*i);
            record_check(&mut out.check, *check);
        }
        out.raised.sort_unstable();
        out.failed.sort_unstable();
        out.check.checked.sort_unstable();
        (out, checked)
    }

    /// Writes segment `s` into `curve`: a point that moved by more than the tolerance takes
    /// its solve one level up (listed raised), one within it keeps its N, converged; a point
    /// whose solve failed is not converged (listed failed).
    fn write_segment(&self, curve: &mut FrequencyResponse, s: Segment, out: &mut RaisedRound) {
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

    /// The segment around the moving point `seed` (its solve one level up `finer`), grown
    /// both ways (at once) within its piece over the points at `round.from` until `EDGE`
    /// points in a row are converged there or fail, or the contact ends (a point out of contact
    /// is exact at any N), or a point is at another N (converged one level down in an earlier
    /// round).
    fn grow(
        &self,
        trace: &FrequencyResponse,
        curve: &FrequencyResponse,
        round: &Round<'_, '_>,
        seed: usize,
        finer: ForcedPoint,
    ) -> Segment {
        let master = self.base.system().master();
        let change = crate::ladder::relative_change(&curve.points[seed], &finer, master);
        let side = |step| self.grow_side(trace, curve, round, (seed, &finer), step);
        let (down, up) = rayon::join(|| side(-1), || side(1));
        let mut segment = Segment {
            first: seed,
            last: seed,
            solved: vec![(seed, finer.clone(), change)],
            failed: Vec::new(),
            seed,
        };
        for side in [down, up] {
            for i in side.failed.iter().chain(side.solved.iter().map(|s| &s.0)) {
                segment.first = segment.first.min(*i);
                segment.last = segment.last.max(*i);
            }
            segment.solved.extend(side.solved);
            segment.failed.extend(side.failed);
        }
        segment
    }

    /// One side of `grow`: the points from `seed` (with its solve one level up) in the
    /// direction `step` (-1 or 1), as a segment without its seed.
    fn grow_side(
        &self,
        trace: &FrequencyResponse,
        curve: &FrequencyResponse,
        round: &Round<'_, '_>,
        (seed, finer): (usize, &ForcedPoint),
        step: isize,
    ) -> Segment {
        let mut side = Segment {
            first: seed,
            last: seed,
            solved: Vec::new(),
            failed: Vec::new(),
            seed,
        };
        let (start, end) = curve.piece_of(seed);
        let (mut prev, mut prev_fine) = (seed, finer.clone());
        let (mut quiet, mut fixed) = (0, false);
        let mut j = seed as isize + step;
        while quiet < EDGE && (start as isize..end as isize).contains(&j) {
            let i = j as usize;
            let point = &curve.points[i];
            if !point.touches() || point.harmonics != round.from {
                break;
            }
            let neighbour = (&curve.points[prev], &prev_fine);
            match self.solve_finer(trace, curve, round.to, i, neighbour, fixed) {
                Some((fine, change, at_w)) => {
                    fixed = at_w;
                    let converged = change
                        .iter()
                        .all(|&c| c <= self.settings.harmonic_tolerance);
                    quiet = if converged { quiet + 1 } else { 0 };
                    side.solved.push((i, fine.clone(), change));
                    (prev, prev_fine) = (i, fine);
                }
                None => {
                    quiet += 1;
                    side.failed.push(i);
                }
            }
            j += step;
        }
        side
    }

    /// Point `i` of `curve` solved by `finer` (one level up) from its neighbour's solve there
    /// shifted by the two points' difference one level down, on the row normal to the trace
    /// at `i` or at its W (`fixed_first`: the row failed at the neighbour, where the curve at N
    /// may turn in a way 2N does not: the stalled end of the blade's first piece at level 5);
    /// with its change from the level below and whether it took its W.
    fn solve_finer(
        &self,
        trace: &FrequencyResponse,
        curve: &FrequencyResponse,
        finer: &ForcedSolver<'_>,
        i: usize,
        (neighbour, neighbour_fine): (&ForcedPoint, &ForcedPoint),
        fixed_first: bool,
    ) -> Option<(ForcedPoint, [f64; 2], bool)> {
        let point = &curve.points[i];
        let shifted = shifted_start(point, neighbour, neighbour_fine, finer);
        let on_row = || {
            let row = normal_row(self.base, self.settings, trace, i);
            solve_same_orbit(finer, point, Some(&row), Some(shifted.clone()))
                .map(|(p, c)| (p, c, false))
        };
        let at_w = || {
            let mut start = shifted.clone();
            start.state.omega = point.omega;
            start.state.level = point.level;
            solve_same_orbit(finer, point, None, Some(start)).map(|(p, c)| (p, c, true))
        };
        if fixed_first {
            at_w().or_else(on_row)
        } else {
            on_row().or_else(at_w)
        }
    }

    /// The verdict of a raised point `fine` (point `i`) solved again by `check` (one level
    /// up) on the row normal to the trace at `i`, with that solve when it converged on the
    /// same orbit.
    fn check_above(
        &self,
        trace: &FrequencyResponse,
        check: &ForcedSolver<'_>,
        i: usize,
        fine: ForcedPoint,
    ) -> (HarmonicCheck, Option<ForcedPoint>) {
        let row = normal_row(self.base, self.settings, trace, i);
        let solved = solve_same_orbit(check, &fine, Some(&row), None);
        let verdict = verdict(
            solved.as_ref().map(|s| s.1),
            self.settings.harmonic_tolerance,
        );
        (verdict, solved.map(|s| s.0))
    }
}

/// The rounds in one account (`RaisedSegments`): the deciding checks are each round's, less
/// the points a later round's segments raised again; `failed` adds the checked points of the
/// trace that could not be raised.
fn summary(
    curve: &FrequencyResponse,
    rounds: Vec<RaisedRound>,
    mut failed: Vec<usize>,
) -> RaisedSegments {
    let mut check = CurveHarmonics {
        harmonics: rounds.last().map_or(0, |r| r.harmonics),
        checked: Vec::new(),
        not_converged: 0,
        largest_change: [0.0; 2],
        checkable: rounds.first().is_some_and(|r| r.check.checkable),
    };
    let (mut segments, mut raised) = (Vec::new(), Vec::new());
    for (k, r) in rounds.iter().enumerate() {
        let again = |i: usize| {
            rounds
                .get(k + 1)
                .is_some_and(|next| next.segments.iter().any(|[a, b]| (*a..=*b).contains(&i)))
        };
        for &i in r.check.checked.iter().filter(|&&i| !again(i)) {
            check.checked.push(i);
            record_check(&mut check, curve.points[i].harmonic_check);
        }
        segments.extend(&r.segments);
        raised.extend(&r.raised);
        failed.extend(&r.failed);
    }
    for v in [&mut raised, &mut failed, &mut check.checked] {
        v.sort_unstable();
        v.dedup();
    }
    RaisedSegments {
        segments,
        raised,
        failed,
        check,
        rounds,
    }
}

/// The points of segment `s` checked one level up: its seed and its point of largest change
/// from the level below, each when it moved by more than `tolerance` (with their solves one
/// level up). Both are needed: on the blade's level 2 the seed (W/w = 1.061) moves 1.6e-3 from
/// 40 to 80, while the segment's largest change from 20 to 40 moves 7.5e-4 from 40 to 80: the
/// truncation error is not monotone along a segment (DESIGN §10.8).
fn representatives(s: &Segment, tolerance: f64) -> Vec<(usize, ForcedPoint)> {
    let moved = |c: &[f64; 2]| c.iter().any(|&v| v > tolerance);
    let size = |c: &[f64; 2]| c[0].max(c[1]);
    let largest = s
        .solved
        .iter()
        .filter(|(_, _, c)| moved(c))
        .max_by(|a, b| size(&a.2).total_cmp(&size(&b.2)));
    let seed = s.solved.iter().find(|(i, _, c)| *i == s.seed && moved(c));
    let mut out: Vec<(usize, ForcedPoint)> = Vec::new();
    for (i, p, _) in seed.into_iter().chain(largest) {
        if !out.iter().any(|(k, _)| k == i) {
            out.push((*i, p.clone()));
        }
    }
    out
}

/// The start at `finer`'s N of `point` from a neighbour solved at the point's N and at
/// `finer`'s: the neighbour's finer orbit plus the difference of the two points.
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
