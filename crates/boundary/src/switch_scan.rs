//! The contact switches of a piece of the massless boundary's flow (docs/STABILITY.md Sec. 9):
//! the one scan the free and the driven flows use, and the active set of a state.
//!
//! On a piece of constant active set every row has an event function f_j(t) (m): R_jj (-lambda_j)
//! for a closed row, its penetration for an open one; a row switches where f_j rises through 0.
//! The scan steps 1 / `SCAN_PER_PERIOD` of the piece's fastest period and bisects where a row has
//! passed the threshold. A contact shorter than a step (a grazing excursion: f_j rises above the
//! threshold and falls back between two scan points) is found from the rates: where f_j' changes
//! sign from + to - within a step and f_j(t0) + f_j'(t0) h + |f_j''|max h^2 / 2 passes the
//! threshold, the maximum is bisected on f_j' and, past the threshold, the switch on f_j before it.
//! Where every row is far enough below its threshold that its Taylor bound f_j + f_j' h +
//! M_j h^2 / 2 (M_j the curvature bound, grown by the piece's fastest-growing term) cannot reach
//! it, the scan leaps over that stretch (`clear_stretch`): no crossing and no excursion can lie
//! in it (the forced blade at level 5: 33.3 s of CPU instead of 37.2, every verdict the same).

use faer::c64;
use nlmodes_hb::HbError;

/// Scan points per shortest period of a piece when looking for a switch.
const SCAN_PER_PERIOD: f64 = 16.0;
/// Bisection steps locating a switch (interval / 2^60: below round-off).
const BISECTION_STEPS: usize = 60;
/// The scan leaps over a stretch no row can cross (`clear_stretch`) only when it spans at
/// least this many scan steps: a leap evaluates every row from the start and their bounds,
/// about the cost of three steps.
const LEAP_STEPS: f64 = 4.0;

/// Every row's event function and its rate at one instant of a piece, and the per-term bounds
/// [`EventPath::curvature_bound`] reads.
pub(crate) struct RowsAt {
    pub events: Vec<f64>,
    pub rates: Vec<f64>,
    pub curvatures: Vec<f64>,
    /// The path's own terms at this instant, from which [`EventPath::rows_advanced`] steps on
    /// (empty where the path has none).
    pub terms: Vec<c64>,
}

/// Scan steps taken by [`EventPath::rows_advanced`] between two evaluations from the start
/// ([`EventPath::rows_at`]), which bound the round-off a product of step factors accumulates
/// (about 16 eps relative).
const EXACT_EVERY: usize = 16;

/// The event functions of one piece of a flow along the solution from its start (tau = 0).
pub(crate) trait EventPath {
    /// Event function of row j at tau (s from the piece's start), m.
    fn event(&self, j: usize, tau: f64) -> f64;
    /// Its rate f_j'(tau) (m/s).
    fn event_rate(&self, j: usize, tau: f64) -> f64;
    /// f_j, f_j' and f_j'' at tau (m, m/s, m/s^2), for the switch searches' Newton steps; by
    /// default from [`Self::event`] and [`Self::event_rate`], f_j'' unknown (NaN: the search
    /// on the rate then bisects).
    fn event_jet(&self, j: usize, tau: f64) -> [f64; 3] {
        [self.event(j, tau), self.event_rate(j, tau), f64::NAN]
    }
    /// Every row's event function and rate at tau, with the terms of the curvature bound.
    fn rows_at(&self, tau: f64) -> RowsAt;
    /// Factors that advance this path's terms by `step` (s), for [`Self::rows_advanced`];
    /// none by default.
    fn step_factors(&self, _step: f64) -> Vec<c64> {
        Vec::new()
    }
    /// The rows one scan step after `before`, from the `factors` of [`Self::step_factors`]
    /// (exp(l_k step) for a path of exponential terms: no exponential evaluated). A path
    /// without factors is never asked.
    fn rows_advanced(&self, before: &RowsAt, _factors: &[c64]) -> RowsAt {
        debug_assert!(false, "rows_advanced on a path without step factors");
        RowsAt {
            events: before.events.clone(),
            rates: before.rates.clone(),
            curvatures: before.curvatures.clone(),
            terms: before.terms.clone(),
        }
    }
    /// A bound on |f_j''| over [t0, t1] from the rows at both ends (m/s^2).
    fn curvature_bound(&self, j: usize, a: &RowsAt, b: &RowsAt) -> f64;
    /// Every row's [`Self::curvature_bound`] with both ends at `at` (m/s^2).
    fn curvature_bounds(&self, at: &RowsAt) -> Vec<f64> {
        (0..self.rows())
            .map(|j| self.curvature_bound(j, at, at))
            .collect()
    }
    /// The piece's fastest circular frequency (rad/s).
    fn fastest(&self) -> f64;
    /// The largest growth rate of a term of the curvature bound (1/s, at least 0): each term of
    /// [`Self::curvature_bound`] read at t0 bounds itself over [t0, t0 + h] once multiplied by
    /// exp(rate h), which lets the scan leap over a stretch where no row can reach its
    /// threshold (`clear_stretch`). `None` (the default): the scan takes every step.
    fn growth_rate(&self) -> Option<f64> {
        None
    }
    /// The number of rows.
    fn rows(&self) -> usize;
}

/// The first switch within `horizon` (s): (time, row). A row already past its boundary (event
/// above `tol`, m) at the start switches at once, except the row `toggled` at this very instant
/// (its event function is 0 there up to round-off: it switches again only on a crossing found by
/// the scan).
pub(crate) fn next_switch(
    path: &impl EventPath,
    tol: f64,
    horizon: f64,
    toggled: Option<usize>,
) -> Option<(f64, usize)> {
    let c = path.rows();
    // Every row at the start from one evaluation (one exponential per term, not per row).
    let mut before = path.rows_at(0.0);
    if let Some(j) = (0..c).find(|&j| Some(j) != toggled && before.events[j] > tol) {
        return Some((0.0, j));
    }
    let step = 2.0 * std::f64::consts::PI / (SCAN_PER_PERIOD * path.fastest());
    let factors = path.step_factors(step);
    let mut t0 = 0.0;
    let growth = path.growth_rate();
    for taken in 1.. {
        if t0 >= horizon {
            break;
        }
        // A leap is looked for every `LEAP_STEPS` steps (next to a row near its threshold
        // none is possible, and looking costs a step).
        if let (Some(rate), 1) = (growth, taken % LEAP_STEPS as usize) {
            let clear = clear_stretch(path, &before, tol, rate, horizon - t0);
            if clear >= LEAP_STEPS * step {
                t0 = (t0 + clear).min(horizon);
                before = path.rows_at(t0);
                continue;
            }
        }
        let t1 = (t0 + step).min(horizon);
        // A whole step from terms not too far from an exact evaluation advances by the
        // factors; otherwise (a path without them, the last partial step, every
        // `EXACT_EVERY` steps) the rows are evaluated at t1 from the start.
        let after = if factors.is_empty() || t1 < t0 + step || taken % EXACT_EVERY == 0 {
            path.rows_at(t1)
        } else {
            path.rows_advanced(&before, &factors)
        };
        let crossing = (0..c)
            .filter_map(|j| {
                if after.events[j] > tol {
                    return Some((bisect(path, j, t0, t1), j));
                }
                // A short excursion past the boundary between two scan points (a grazing
                // contact, shorter than the scan step): the event function rises, then falls;
                // its maximum, where its rate vanishes, is past the threshold. Within the step
                // it stays below f(t0) + f'(t0) h + |f''| h^2 / 2: no excursion when that is
                // below the threshold.
                let h = t1 - t0;
                let reach = || {
                    before.events[j]
                        + before.rates[j] * h
                        + 0.5 * path.curvature_bound(j, &before, &after) * h * h
                };
                if before.rates[j] > 0.0 && after.rates[j] < 0.0 && reach() > tol {
                    let top = bisect_rate(path, j, t0, t1);
                    if path.event(j, top) > tol {
                        return Some((bisect(path, j, t0, top), j));
                    }
                }
                None
            })
            .min_by(|a, b| a.0.total_cmp(&b.0));
        if crossing.is_some() {
            return crossing;
        }
        (t0, before) = (t1, after);
    }
    None
}

/// How far past t0 (s, at most `remaining`) no row can reach `tol`, from the rows `at` t0:
/// on [t0, t0 + h] f_j <= f_j(t0) + max(f_j'(t0), 0) h + M_j h^2 / 2, M_j the curvature bound
/// read at t0 ([`EventPath::curvature_bound`] with both ends at t0) grown by exp(`rate`
/// `remaining`) (docs/STABILITY.md Sec. 9); the stretch is the smallest h where one row's
/// bound meets `tol` (0 where a row is at or past it). A row below `tol` all along this stretch crosses
/// neither at a scan point nor in a short excursion between two, so the scan may leap over it.
fn clear_stretch(path: &impl EventPath, at: &RowsAt, tol: f64, rate: f64, remaining: f64) -> f64 {
    if at.events.iter().any(|&f| f >= tol || f.is_nan()) {
        return 0.0;
    }
    let grown = (rate * remaining).exp();
    let bounds = path.curvature_bounds(at);
    let mut clear = remaining;
    for ((&f, &d), &m) in at.events.iter().zip(&at.rates).zip(&bounds) {
        let (margin, slope, curvature) = (tol - f, d.max(0.0), m * grown);
        // The positive root of curvature h^2 / 2 + slope h - margin, in the form without
        // cancellation.
        let h = 2.0 * margin / (slope + (slope * slope + 2.0 * curvature * margin).sqrt());
        if !h.is_finite() {
            return 0.0;
        }
        clear = clear.min(h);
    }
    clear
}

/// The time in (a, b) where row j's event rate falls through 0 (positive at a, negative at b):
/// the event function's maximum.
fn bisect_rate(path: &impl EventPath, j: usize, a: f64, b: f64) -> f64 {
    let (lo, hi) = bracket_root(
        |t| {
            let [_, rate, curvature] = path.event_jet(j, t);
            (rate, curvature)
        },
        (a, b),
        false,
    );
    0.5 * (lo + hi)
}

/// The time in (a, b] where row j's event function rises through 0 (the end on the positive
/// side, so that the switch happens with the row just past its boundary).
fn bisect(path: &impl EventPath, j: usize, a: f64, b: f64) -> f64 {
    let (_, hi) = bracket_root(
        |t| {
            let [event, rate, _] = path.event_jet(j, t);
            (event, rate)
        },
        (a, b),
        true,
    );
    hi
}

/// The bracket [lo, hi] of a root of g in (a, b) closed to round-off, g given with its
/// derivative, g(hi) > 0 >= g(lo) when `positive_at_b` (else g(lo) > 0 >= g(hi)): Newton steps
/// kept inside the shrinking bracket (its midpoint where a step would leave it or the
/// derivative is not finite: at worst the bisection it replaces), each evaluation moving the
/// bracket's end on its side; once a step falls to round-off the next point is taken just
/// beyond the estimate on the other side, so that both ends close on the root. A few
/// evaluations where the bisection took 60, each an exponential per term of the piece (the
/// massless boundary's largest cost after its eigen-decompositions, session 28).
fn bracket_root(
    g_and_slope: impl Fn(f64) -> (f64, f64),
    (a, b): (f64, f64),
    positive_at_b: bool,
) -> (f64, f64) {
    let (mut lo, mut hi) = (a, b);
    let resolution = 4.0 * f64::EPSILON * a.abs().max(b.abs()).max(f64::MIN_POSITIVE);
    let mut t = 0.5 * (lo + hi);
    for _ in 0..BISECTION_STEPS {
        if !(t > lo && t < hi) || hi - lo <= resolution {
            break;
        }
        let (v, d) = g_and_slope(t);
        let past = (v > 0.0) == positive_at_b;
        if past {
            hi = t;
        } else {
            lo = t;
        }
        let newton = t - v / d;
        let inside = |x: f64| x.is_finite() && x > lo && x < hi;
        t = if !inside(newton) {
            0.5 * (lo + hi)
        } else if (newton - t).abs() > resolution {
            newton
        } else {
            // Converged on the estimate: step past it to the bracket's other end.
            let beyond = if past {
                newton - resolution
            } else {
                newton + resolution
            };
            if inside(beyond) {
                beyond
            } else {
                0.5 * (lo + hi)
            }
        };
    }
    (lo, hi)
}

/// The active set of `c` rows by Murty's least-index principal pivoting, from `start`:
/// `first_violator(active)` names the first row whose event function on that set is past its
/// boundary (`None`: the set is the solution). Finite for a P-matrix (the flexibility R is
/// positive definite): at most 4 c^2 + 16 pivots are tried before the set is declared
/// unsettled, with the error's `detail`.
pub(crate) fn settle_active_set(
    c: usize,
    start: Vec<bool>,
    detail: &str,
    mut first_violator: impl FnMut(&[bool]) -> Result<Option<usize>, HbError>,
) -> Result<Vec<bool>, HbError> {
    let mut active = start;
    for _ in 0..(4 * c * c + 16) {
        match first_violator(&active)? {
            Some(j) => active[j] = !active[j],
            None => return Ok(active),
        }
    }
    Err(HbError::StabilityInput {
        detail: detail.to_string(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::cell::Cell;

    /// Rows f_j(t) = sum_k a_jk cos(w_k t + p_jk) + b_j: exact values, rates and jets, the
    /// curvature terms |w_k|^2 per frequency (amplitudes in the row's bound), and a count of
    /// the evaluations of every row at once. `leaps` says whether the scan may leap.
    struct Cosines {
        freqs: Vec<f64>,
        /// (amplitude, phase) per row and frequency.
        terms: Vec<Vec<(f64, f64)>>,
        offsets: Vec<f64>,
        leaps: bool,
        evaluations: Cell<usize>,
    }

    impl EventPath for Cosines {
        fn event(&self, j: usize, t: f64) -> f64 {
            self.event_jet(j, t)[0]
        }
        fn event_rate(&self, j: usize, t: f64) -> f64 {
            self.event_jet(j, t)[1]
        }
        fn event_jet(&self, j: usize, t: f64) -> [f64; 3] {
            let mut jet = [self.offsets[j], 0.0, 0.0];
            for (&w, &(a, p)) in self.freqs.iter().zip(&self.terms[j]) {
                let (s, c) = (w * t + p).sin_cos();
                jet[0] += a * c;
                jet[1] -= a * w * s;
                jet[2] -= a * w * w * c;
            }
            jet
        }
        fn rows_at(&self, t: f64) -> RowsAt {
            self.evaluations.set(self.evaluations.get() + 1);
            let jets: Vec<[f64; 3]> = (0..self.rows()).map(|j| self.event_jet(j, t)).collect();
            RowsAt {
                events: jets.iter().map(|x| x[0]).collect(),
                rates: jets.iter().map(|x| x[1]).collect(),
                curvatures: self.freqs.iter().map(|w| w * w).collect(),
                terms: Vec::new(),
            }
        }
        fn curvature_bound(&self, j: usize, a: &RowsAt, _: &RowsAt) -> f64 {
            (self.terms[j].iter().zip(&a.curvatures))
                .map(|((amp, _), c)| amp.abs() * c)
                .sum()
        }
        fn fastest(&self) -> f64 {
            self.freqs.iter().fold(0.0_f64, |a, &w| a.max(w))
        }
        fn rows(&self) -> usize {
            self.offsets.len()
        }
        fn growth_rate(&self) -> Option<f64> {
            self.leaps.then_some(0.0)
        }
    }

    /// Row 0 peaks once a period at t = `at`, `above` past 0 (a wide crossing or, for a small
    /// `above`, a grazing excursion shorter than a scan step); row 1 stays 0.5 below 0 and
    /// carries the fast term that sets the scan step (w = 60 rad/s: 0.0065 s).
    fn path(at: f64, above: f64, leaps: bool) -> Cosines {
        Cosines {
            freqs: vec![1.0, 60.0],
            terms: vec![vec![(1.0, -at), (1e-9, 0.3)], vec![(0.1, 0.0), (0.2, 1.0)]],
            offsets: vec![above - 1.0, -0.8],
            leaps,
            evaluations: Cell::new(0),
        }
    }

    /// Row 0's crossing in (a, b) (below at a, above at b) by 200 bisections.
    fn first_root(p: &Cosines, mut a: f64, mut b: f64) -> f64 {
        assert!(p.event(0, a) < 0.0 && p.event(0, b) > 0.0);
        for _ in 0..200 {
            let m = 0.5 * (a + b);
            if p.event(0, m) > 0.0 {
                b = m;
            } else {
                a = m;
            }
        }
        b
    }

    /// The leaping scan finds the switch the stepping scan finds, to round-off, with less than
    /// half the evaluations of every row: for a wide crossing and for a grazing excursion of
    /// 1e-7 of the amplitude (0.9 mrad wide, a seventh of a scan step), placed at several phases
    /// of the period; both at the crossing bisected on the row itself (row 0 rises through 0
    /// once between at - 2 acos(1 - above) and at).
    #[test]
    fn leaps_find_the_switches_steps_find_with_fewer_evaluations() {
        let tol = 1e-12;
        for above in [1e-2, 1e-7] {
            for at in [0.7, 2.0, 3.3, 5.9] {
                let stepping = path(at, above, false);
                let leaping = path(at, above, true);
                let horizon = 2.0 * std::f64::consts::PI;
                let s = next_switch(&stepping, tol, horizon, None).expect("a switch");
                let l = next_switch(&leaping, tol, horizon, None).expect("a switch");
                let exact = first_root(&stepping, at - 2.0 * (1.0 - above).acos(), at);
                assert_eq!(s.1, 0);
                assert_eq!(l.1, 0);
                assert!(
                    (l.0 - s.0).abs() <= 1e-12,
                    "above {above}, at {at}: {l:?} {s:?}"
                );
                assert!(
                    (l.0 - exact).abs() <= 1e-12,
                    "above {above}, at {at}: {l:?} vs {exact}"
                );
                let (ns, nl) = (stepping.evaluations.get(), leaping.evaluations.get());
                assert!(
                    2 * nl < ns,
                    "above {above}, at {at}: {nl} vs {ns} evaluations"
                );
            }
        }
    }

    /// No switch within the horizon: neither scan reports one, and a row that never comes
    /// within 1e-3 of its threshold is leapt over in a few evaluations.
    #[test]
    fn a_row_that_stays_below_is_never_reported() {
        for leaps in [false, true] {
            let p = path(3.0, -1e-3, leaps);
            assert_eq!(
                next_switch(&p, 1e-12, 2.0 * std::f64::consts::PI, None),
                None
            );
        }
    }
}
