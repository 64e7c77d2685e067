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
//! through the point, so the changes between rounds compare one orbit. Each solve starts from
//! its neighbour's at the same N, shifted by the two points' difference one level down (a
//! predictor along the curve: the truncation error changes slowly between neighbours), and
//! falls back on a solve at the point's own parameter where the row fails.
//!
//! The algorithm is the curve's, not its solver's: it runs on any [`RaiseTarget`], the
//! frequency response (`raise_frequency`, parameter W) and the speed sweep (`raise_speed`,
//! parameter the speed, DESIGN §10.10).

use rayon::prelude::*;

use crate::curve::{piece_bounds, CurveHarmonics, RaisedRound, RaisedSegments};
use crate::curve_harmonics::{record_check, MovingPoint};
use crate::error::ForcedError;
use crate::harmonic_check::HarmonicCheck;
use crate::ladder::verdict;
use crate::solver::ForcedPoint;

/// The largest N at which the raised points are checked: the solve's condensed Newton matrix is
/// dense in (2N + 1) x contact rows (0.74 GB at N = 200 on the blade's 24 rows, the CLI's
/// largest `max_harmonics`); above it the raised points are left unchecked.
const MAX_CHECK_HARMONICS: usize = 200;

/// A raised point may carry up to this many times `max_harmonics` (the N the check of round 1
/// already reaches): `max_harmonics` bounds the N of a whole trace, which costs every point;
/// a later round raises only the few points whose check still moves.
pub(crate) const RAISE_BEYOND: usize = 2;

/// Points in a row converged one level down (or failing) that end a segment on one side: one
/// could be a change of sign of the truncation error between two moving points.
const EDGE: usize = 2;

/// A curve whose points `Raising` solves again at other N, with the trace they were traced on
/// (its rows normal to the curve): the frequency response (`raise_frequency`) and the speed
/// sweep (`raise_speed`).
pub(crate) trait RaiseTarget: Sync {
    /// A point of the curve.
    type Point: Clone + Send + Sync;
    /// What solves points at one N.
    type Level: Send + Sync;
    /// What the curve is, for the log ("forced response", "speed sweep").
    const WHAT: &'static str;
    /// The orbit of a point (its N, contact, harmonic check).
    fn orbit(p: &Self::Point) -> &ForcedPoint;
    /// The orbit of a point, to mark its harmonic check.
    fn orbit_mut(p: &mut Self::Point) -> &mut ForcedPoint;
    /// N of a level.
    fn harmonics(level: &Self::Level) -> usize;
    /// The level at N = `harmonics`.
    fn level(&self, harmonics: usize) -> Result<Self::Level, ForcedError>;
    /// The relative change [q1, parameter] between two solves of one orbit (relative to the
    /// one at the larger N).
    fn change(&self, a: &Self::Point, b: &Self::Point) -> [f64; 2];
    /// `point` (point `i` of the curve, one level down) solved at `level` from its neighbour's
    /// solve there (`neighbour`: the neighbour one level down and at `level`) shifted by the
    /// two points' difference one level down, on the row normal to the trace at `i`, or at the
    /// point's own parameter (first when `fixed_first`); with its change from `point` and
    /// whether it took its own parameter. `None` when both fail or land on another orbit.
    fn solve_finer(
        &self,
        level: &Self::Level,
        i: usize,
        point: &Self::Point,
        neighbour: (&Self::Point, &Self::Point),
        fixed_first: bool,
    ) -> Option<(Self::Point, [f64; 2], bool)>;
    /// `point` (point `i` of the curve or its solve at some N) solved at `level` from itself
    /// on the row normal to the trace at `i`, with its change from `point`, when it converged
    /// on the same orbit.
    fn solve_again(
        &self,
        level: &Self::Level,
        i: usize,
        point: &Self::Point,
    ) -> Option<(Self::Point, [f64; 2])>;
}

/// The levels at the curve's N, 2N and 4N and the tolerance of the check.
pub(crate) struct Raising<'a, T: RaiseTarget> {
    /// The curve and its solves.
    target: &'a T,
    /// The curve's N (its points are solved there).
    base: usize,
    /// 2N: the level of the points raised in round 1.
    finer: &'a T::Level,
    /// 4N: the check of round 1 (`None` above `MAX_CHECK_HARMONICS`).
    check: Option<T::Level>,
    /// `max_harmonics` (later rounds raise up to `RAISE_BEYOND` times it).
    top: usize,
    /// `harmonic_tolerance`: the largest relative change of q1 or the parameter of a
    /// converged point.
    tolerance: f64,
}

/// One round's levels: the points at `from` harmonics are raised to `to` and checked at
/// `check`.
struct Round<'r, L> {
    from: usize,
    to: &'r L,
    check: Option<&'r L>,
}

/// One segment grown around a moving point: its points solved one level up with their change,
/// and those whose solve failed.
struct Segment<P> {
    first: usize,
    last: usize,
    /// (index, solve one level up, relative change [q1, parameter] from the level below).
    solved: Vec<(usize, P, [f64; 2])>,
    failed: Vec<usize>,
    /// The moving point the segment grew from.
    seed: usize,
}

impl<P> Segment<P> {
    fn at(seed: usize) -> Self {
        Segment {
            first: seed,
            last: seed,
            solved: Vec::new(),
            failed: Vec::new(),
            seed,
        }
    }
}

/// What a check one level above a round found at a point: its verdict and its solve there.
type Checked<P> = (usize, HarmonicCheck, Option<P>);

impl<'a, T: RaiseTarget> Raising<'a, T> {
    /// The raising of `target`'s curve traced at N = `base`, its round 1 at `finer` (2N),
    /// checked at 4N when that is within `MAX_CHECK_HARMONICS`.
    pub(crate) fn new(
        target: &'a T,
        base: usize,
        finer: &'a T::Level,
        top: usize,
        tolerance: f64,
    ) -> Result<Self, ForcedError> {
        let check = match 4 * base <= MAX_CHECK_HARMONICS {
            true => Some(target.level(4 * base)?),
            false => None,
        };
        Ok(Raising {
            target,
            base,
            finer,
            check,
            top,
            tolerance,
        })
    }

    /// Raises N around every point of `moving` in rounds (module docs) over `points` (the
    /// curve's, in pieces starting at `pieces`), writes the raised points and the verdicts
    /// into them, and says what was done.
    pub(crate) fn raise(
        &self,
        points: &mut [T::Point],
        pieces: &[usize],
        moving: Vec<MovingPoint<T::Point>>,
    ) -> Result<RaisedSegments, ForcedError> {
        let (mut seeds, failed) = Self::seeds(moving);
        // Above 4N (`self.check`): 8N, 16N, ... made when a round needs them.
        let mut higher: Vec<T::Level> = Vec::new();
        let mut rounds: Vec<RaisedRound> = Vec::new();
        let mut from = self.base;
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
            let (done, checked) = self.round(points, pieces, seeds, &round);
            let n = T::harmonics(to);
            tracing::info!(
                segments = done.segments.len(),
                raised = done.raised.len(),
                failed = done.failed.len(),
                not_converged = done.check.not_converged,
                change_q1 = done.check.largest_change[0],
                change_parameter = done.check.largest_change[1],
                "{}: N raised to {n} around the points that moved at {from}",
                T::WHAT
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
            higher.push(self.target.level(2 * next)?);
            from = n;
        }
        let raised = summary::<T>(points, rounds, failed);
        tracing::info!(
            segments = raised.segments.len(),
            raised = raised.raised.len(),
            failed = raised.failed.len(),
            not_converged = raised.check.not_converged,
            change_q1 = raised.check.largest_change[0],
            change_parameter = raised.check.largest_change[1],
            "{}: N raised up to {} around the points that moved, in {} round(s); the deciding \
             checks",
            T::WHAT,
            raised.check.harmonics,
            raised.rounds.len()
        );
        Ok(raised)
    }

    /// The seeds of round 1: the moving points with their solve at 2N; those whose solve
    /// failed are listed.
    fn seeds(moving: Vec<MovingPoint<T::Point>>) -> (Vec<(usize, T::Point)>, Vec<usize>) {
        let mut seeds = Vec::new();
        let mut failed = Vec::new();
        for m in moving {
            match m.finer {
                Some(p) => seeds.push((m.index, p)),
                None => failed.push(m.index),
            }
        }
        (seeds, failed)
    }

    /// One round (module docs): segments grown in parallel around `seeds` (each with its solve
    /// at `round.to`), a seed already inside an earlier segment growing none; the raised points
    /// and verdicts written into `points`; each segment's seed and point of largest change
    /// checked at `round.check`. Returns the round and its checks (with their solves, the next
    /// round's seeds).
    fn round(
        &self,
        points: &mut [T::Point],
        pieces: &[usize],
        seeds: Vec<(usize, T::Point)>,
        round: &Round<'_, T::Level>,
    ) -> (RaisedRound, Vec<Checked<T::Point>>) {
        let view: &[T::Point] = points;
        let grown: Vec<Segment<T::Point>> = seeds
            .into_par_iter()
            .map(|(i, finer)| self.grow(view, pieces, round, i, finer))
            .collect();
        let mut segments: Vec<Segment<T::Point>> = Vec::new();
        for s in grown {
            if !segments
                .iter()
                .any(|t| (t.first..=t.last).contains(&s.seed))
            {
                segments.push(s);
            }
        }
        let checked: Vec<Checked<T::Point>> = match round.check {
            Some(check) => segments
                .iter()
                .flat_map(|s| representatives(s, self.tolerance))
                .collect::<Vec<_>>()
                .into_par_iter()
                .map(|(i, p)| {
                    let (c, solve) = self.check_above(check, i, p);
                    (i, c, solve)
                })
                .collect(),
            None => Vec::new(),
        };
        let harmonics = T::harmonics(round.to);
        let mut out = RaisedRound {
            harmonics,
            segments: segments.iter().map(|s| [s.first, s.last]).collect(),
            raised: Vec::new(),
            failed: Vec::new(),
            check: CurveHarmonics {
                harmonics,
                checked: Vec::new(),
                not_converged: 0,
                largest_change: [0.0; 2],
                checkable: round.check.is_some(),
                force: None,
            },
        };
        for s in segments {
            self.write_segment(points, s, &mut out);
        }
        for (i, check, _) in &checked {
            T::orbit_mut(&mut points[*i]).harmonic_check = *check;
            out.check.checked.push(*i);
            record_check(&mut out.check, *check);
        }
        out.raised.sort_unstable();
        out.failed.sort_unstable();
        out.check.checked.sort_unstable();
        (out, checked)
    }

    /// Writes segment `s` into `points`: a point that moved by more than the tolerance takes
    /// its solve one level up (listed raised), one within it keeps its N, converged; a point
    /// whose solve failed is not converged (listed failed).
    fn write_segment(&self, points: &mut [T::Point], s: Segment<T::Point>, out: &mut RaisedRound) {
        out.failed.extend(&s.failed);
        for i in &s.failed {
            T::orbit_mut(&mut points[*i]).harmonic_check =
                HarmonicCheck::NotConverged { change: None };
        }
        for (i, fine, change) in s.solved {
            if change.iter().all(|&c| c <= self.tolerance) {
                T::orbit_mut(&mut points[i]).harmonic_check = HarmonicCheck::Converged { change };
            } else {
                points[i] = fine;
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
        points: &[T::Point],
        pieces: &[usize],
        round: &Round<'_, T::Level>,
        seed: usize,
        finer: T::Point,
    ) -> Segment<T::Point> {
        let change = self.target.change(&points[seed], &finer);
        let side = |step| self.grow_side(points, pieces, round, (seed, &finer), step);
        let (down, up) = rayon::join(|| side(-1), || side(1));
        let mut segment = Segment::at(seed);
        segment.solved.push((seed, finer.clone(), change));
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
        points: &[T::Point],
        pieces: &[usize],
        round: &Round<'_, T::Level>,
        (seed, finer): (usize, &T::Point),
        step: isize,
    ) -> Segment<T::Point> {
        let mut side = Segment::at(seed);
        let (start, end) = piece_bounds(pieces, points.len(), seed);
        let (mut prev, mut prev_fine) = (seed, finer.clone());
        let (mut quiet, mut fixed) = (0, false);
        let mut j = seed as isize + step;
        while quiet < EDGE && (start as isize..end as isize).contains(&j) {
            let i = j as usize;
            let point = &points[i];
            if !T::orbit(point).touches() || T::orbit(point).harmonics != round.from {
                break;
            }
            let neighbour = (&points[prev], &prev_fine);
            match (self.target).solve_finer(round.to, i, point, neighbour, fixed) {
                Some((fine, change, at_parameter)) => {
                    fixed = at_parameter;
                    let converged = change.iter().all(|&c| c <= self.tolerance);
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

    /// The verdict of a raised point `fine` (point `i`) solved again at `check` (one level
    /// up) on the row normal to the trace at `i`, with that solve when it converged on the
    /// same orbit.
    fn check_above(
        &self,
        check: &T::Level,
        i: usize,
        fine: T::Point,
    ) -> (HarmonicCheck, Option<T::Point>) {
        let solved = self.target.solve_again(check, i, &fine);
        let verdict = verdict(solved.as_ref().map(|s| s.1), self.tolerance);
        (verdict, solved.map(|s| s.0))
    }
}

/// The rounds in one account (`RaisedSegments`): the deciding checks are each round's, less
/// the points a later round's segments raised again; `failed` adds the checked points of the
/// trace that could not be raised.
fn summary<T: RaiseTarget>(
    points: &[T::Point],
    rounds: Vec<RaisedRound>,
    mut failed: Vec<usize>,
) -> RaisedSegments {
    let mut check = CurveHarmonics {
        harmonics: rounds.last().map_or(0, |r| r.harmonics),
        checked: Vec::new(),
        not_converged: 0,
        largest_change: [0.0; 2],
        checkable: rounds.first().is_some_and(|r| r.check.checkable),
        force: None,
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
            record_check(&mut check, T::orbit(&points[i]).harmonic_check);
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
fn representatives<P: Clone>(s: &Segment<P>, tolerance: f64) -> Vec<(usize, P)> {
    let moved = |c: &[f64; 2]| c.iter().any(|&v| v > tolerance);
    let size = |c: &[f64; 2]| c[0].max(c[1]);
    let largest = s
        .solved
        .iter()
        .filter(|(_, _, c)| moved(c))
        .max_by(|a, b| size(&a.2).total_cmp(&size(&b.2)));
    let seed = s.solved.iter().find(|(i, _, c)| *i == s.seed && moved(c));
    let mut out: Vec<(usize, P)> = Vec::new();
    for (i, p, _) in seed.into_iter().chain(largest) {
        if !out.iter().any(|(k, _)| k == i) {
            out.push((*i, p.clone()));
        }
    }
    out
}
