//! The exact response curve of a `Pwl` system over a frequency range, by pseudo-arc-length
//! continuation of its periodic orbits in (z(0), W), z = (x, v), through the folds; independent
//! of the crates under test and of the curve they report.
//!
//! Variables are scaled, X = (z(0) / g_s, W / w_s) with `scales` = (g_s, w_s). From the linear
//! response at the start of the range (the open regime's exact orbit, made periodic by
//! `periodic_at` if it touches), each step predicts X + h t along the unit tangent t (the null
//! vector of [monodromy - I, dz(T)/dW], `exact_tangent`, oriented like the last one) and corrects
//! on the hyperplane through the prediction normal to t (`periodic_on_plane`). A step is
//! accepted when the corrector converges within `MAX_ITERATIONS`, lands within h of the
//! prediction and the tangent turns by at most `MAX_TURN`; otherwise h is halved. The turn bound
//! keeps the samples dense where the curve bends: a fold shows as a change of sign of W's
//! component of the tangent between two samples, and two folds could hide between samples only
//! in a wiggle that turns the tangent by less than 0.1 rad; the chord between two samples lies
//! within h MAX_TURN / 8 (6e-4 at the largest step) of the curve (except across a grazing
//! corner, below).
//!
//! A grazing corner: where the orbits of a stiff penalty law first touch the stop, the period
//! map's derivative changes by about kc tau over contacts of duration tau ~ sqrt(penetration),
//! so the tangent turns by O(1) within a penetration far below the smallest step (the light
//! chain of tests/forced_oracle_cli.rs, kc = 1500 N/m at 0.3 %: 75 degrees within 1e-6 w1 in W,
//! the largest multiplier from 0.98 to 1.53 across it). When the step has been halved below
//! `MIN_STEP`, the trace hops: the orbit at W moved by `GRAZING_HOP` w_s the way W moves, shot
//! from the last sample, is the next sample if it lies in the other regime (switches appear or
//! vanish), within `HOP_REACH` (scaled) of the last sample, and W moves on the same way at it;
//! otherwise the trace stops with an error. A fold hidden in the corner would lie within
//! `GRAZING_HOP` w_s of it in W, far below the 1e-3 the comparisons resolve. The curves compared
//! do not move when `GRAZING_HOP` is 1e-7 instead (the ordinary steps after the hop then finish
//! the turn); at 1e-5 the shooting from the last sample does not converge.
//!
//! A fold is where W's component of the tangent changes sign between two samples: it is solved
//! for by `fold_near` (a multiplier at +1) from the sample with the smaller component, checked to
//! lie between the two (W beyond both, within their distance of each) and inserted between them
//! as a sample of its own, so that the polyline of the samples reaches every fold's W. A fold
//! `fold_near` does not find between them (in a grazing corner of a stiff stop its Newton fails;
//! next to another fold it may converge to that one) is located by bisection between the two
//! samples when they lie within `CORNER_FOLD` of each other (`fold_in_corner`; the held-out
//! systems of tests/forced_heldout_cli.rs). The peak
//! (largest first harmonic of the observed coordinate) is the vertex of the parabola through
//! the largest sample and its neighbours on a local re-trace at `PEAK_STEP`.

use super::{exact_tangent, fold_near, periodic_at, periodic_on_plane, Dense, Integrator, Orbit};
use super::{Pwl, STEPS};

/// First, smallest and largest scaled step.
const FIRST_STEP: f64 = 5e-3;
const MIN_STEP: f64 = 1e-7;
const MAX_STEP: f64 = 5e-2;
/// Largest angle (rad) between the tangents of two consecutive samples.
const MAX_TURN: f64 = 0.1;
/// Most corrector iterations of an accepted step; fewer than `EASY_ITERATIONS` grows h by 1.5.
const MAX_ITERATIONS: usize = 8;
const EASY_ITERATIONS: usize = 4;
/// Most samples of a trace (the curves compared need a few hundred).
const MAX_SAMPLES: usize = 20_000;
/// Scaled step of the local re-trace around the peak.
const PEAK_STEP: f64 = 1e-3;
/// The step in W / w_s across a grazing corner, and how far (scaled) the orbit on its far side
/// may lie from the last sample (module docs).
const GRAZING_HOP: f64 = 1e-6;
const HOP_REACH: f64 = 1e-3;
/// The largest scaled distance between two samples around a fold that `fold_in_corner` locates
/// by bisection when `fold_near` fails, unless their tangents lie within `MAX_TURN` (as every
/// ordinary step's): then each hyperplane normal to their chord meets the arc between them once.
const CORNER_FOLD: f64 = 1e-3;

/// One sample of the exact curve: the periodic orbit, its unit scaled tangent and the first
/// harmonic (m) of the observed coordinate.
#[derive(Clone, Debug)]
pub struct Sample {
    pub orbit: Orbit,
    pub tangent: Vec<f64>,
    pub q1: f64,
}

/// A fold of the exact curve: the index of its sample (its orbit has a multiplier at +1), and
/// whether W rose before it (`turns_back`: W is largest there) or fell (W is smallest).
#[derive(Clone, Copy, Debug)]
pub struct Fold {
    pub sample: usize,
    pub turns_back: bool,
}

/// The exact curve from the start of a range past its end.
pub struct ExactCurve {
    pub sys: Pwl,
    /// The coordinate whose first harmonic is reported (unit vector on x).
    pub observed: Vec<f64>,
    pub scales: (f64, f64),
    pub tol: f64,
    pub samples: Vec<Sample>,
    pub folds: Vec<Fold>,
    /// The samples reached across a grazing corner (`across_grazing`).
    pub corners: Vec<usize>,
}

/// (x, v)(0) of the open regime's steady response to fc cos(W t) + fs sin(W t):
/// (K - W^2 M + i W C) X = fc - i fs, x = Re(X e^{i W t}).
pub fn linear_state(sys: &Pwl, omega: f64) -> Vec<f64> {
    let n = sys.n;
    let big = Dense::from_fn(2 * n, |p, q| {
        let (i, j) = (p % n, q % n);
        let d = sys.k.at(i, j) - omega * omega * sys.m.at(i, j);
        let e = omega * sys.c.at(i, j);
        match (p < n, q < n) {
            (true, true) | (false, false) => d,
            (true, false) => -e,
            (false, true) => e,
        }
    });
    let mut rhs = sys.fc.clone();
    rhs.extend(sys.fs.iter().map(|v| -v));
    let x = big.solve(&rhs);
    let mut z: Vec<f64> = x[..n].to_vec();
    z.extend(x[n..].iter().map(|im| -omega * im));
    z
}

/// Gauss-Legendre nodes per piece of `first_harmonic`. A piece lasts at most T / `STEPS`; the
/// integrand x(t) cos(W t) is a sum of exponentials e^{lambda t} with |lambda| below the closed
/// regime's highest frequency plus W (at most 41 rad/s on the systems of
/// tests/forced_oracle_cli.rs, the light chain's 38.8 + 1.25; |lambda| dt < 1.1 with
/// dt <= 2 pi / 0.9 / 256 s), where the q-point rule errs by
/// (|lambda| dt)^{2q} (q!)^4 / ((2q + 1) ((2q)!)^3) relative, 6e-16 at q = 6 (the 12 of
/// `Integrator::fourier` serve its higher harmonics).
const FIRST_HARMONIC_NODES: usize = 6;

/// First-harmonic amplitude of `coord . x` along an orbit.
pub fn first_harmonic(sys: &Pwl, orbit: &Orbit, coord: &[f64]) -> f64 {
    let integ = Integrator::new(sys, orbit.omega, STEPS);
    let c = integ.fourier_nodes(&orbit.flow, coord, 1, FIRST_HARMONIC_NODES);
    c[1].hypot(c[2])
}

fn distance(a: &[f64], b: &[f64]) -> f64 {
    a.iter()
        .zip(b)
        .map(|(x, y)| (x - y).powi(2))
        .sum::<f64>()
        .sqrt()
}

fn dot(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| x * y).sum()
}

impl ExactCurve {
    /// The scaled point X of an orbit.
    pub fn scaled(&self, orbit: &Orbit) -> Vec<f64> {
        let mut v: Vec<f64> = orbit.z0.iter().map(|x| x / self.scales.0).collect();
        v.push(orbit.omega / self.scales.1);
        v
    }

    fn sample(&self, orbit: Orbit, tangent: Vec<f64>) -> Sample {
        let q1 = first_harmonic(&self.sys, &orbit, &self.observed);
        Sample { orbit, tangent, q1 }
    }

    /// One predictor-corrector step of scaled length h from `from`, if accepted (module docs).
    fn step(&self, from: &Sample, h: f64) -> Option<(Sample, usize)> {
        let (gs, ws) = self.scales;
        let t = &from.tangent;
        let dim = from.orbit.z0.len();
        let z: Vec<f64> = (0..dim).map(|i| from.orbit.z0[i] + h * t[i] * gs).collect();
        let w = from.orbit.omega + h * t[dim] * ws;
        let next = periodic_on_plane(&self.sys, &z, w, t, self.scales, self.tol)?;
        let predicted: Vec<f64> = self
            .scaled(&from.orbit)
            .iter()
            .zip(t)
            .map(|(x, d)| x + h * d)
            .collect();
        if next.iterations > MAX_ITERATIONS || distance(&self.scaled(&next), &predicted) > h {
            return None;
        }
        let tangent = exact_tangent(&self.sys, &next, t, self.scales);
        if dot(&tangent, t) < MAX_TURN.cos() {
            return None;
        }
        let iterations = next.iterations;
        Some((self.sample(next, tangent), iterations))
    }

    /// Traces the curve from the linear response at `w_start` (rad/s), W increasing at first,
    /// until W exceeds `w_end` or falls below `w_start`; an error says where it stopped.
    pub fn trace(
        sys: Pwl,
        observed: Vec<f64>,
        (w_start, w_end): (f64, f64),
        scales: (f64, f64),
        tol: f64,
    ) -> Result<Self, String> {
        let first = periodic_at(&sys, w_start, &linear_state(&sys, w_start), tol).ok_or(
            format!("no periodic orbit at the start W = {w_start} rad/s"),
        )?;
        let mut forward = vec![0.0; first.z0.len()];
        forward.push(1.0);
        let tangent = exact_tangent(&sys, &first, &forward, scales);
        let mut curve = Self {
            sys,
            observed,
            scales,
            tol,
            samples: Vec::new(),
            folds: Vec::new(),
            corners: Vec::new(),
        };
        curve.samples.push(curve.sample(first, tangent));
        let mut h = FIRST_STEP;
        loop {
            let last = curve.samples.last().expect("a first sample");
            let w = last.orbit.omega;
            if w > w_end || (curve.samples.len() > 1 && w < w_start) {
                return Ok(curve);
            }
            if curve.samples.len() >= MAX_SAMPLES {
                return Err(format!("{MAX_SAMPLES} samples, stopped at W = {w} rad/s"));
            }
            match curve.step(last, h) {
                Some((next, iterations)) => {
                    curve.insert_fold(&next)?;
                    curve.samples.push(next);
                    if iterations < EASY_ITERATIONS {
                        h = (1.5 * h).min(MAX_STEP);
                    }
                }
                None if h > MIN_STEP => h *= 0.5,
                None => {
                    let next = curve
                        .across_grazing(last)
                        .map_err(|e| format!("step below {MIN_STEP} at W = {w} rad/s, and {e}"))?;
                    curve.corners.push(curve.samples.len());
                    curve.samples.push(next);
                    h = GRAZING_HOP;
                }
            }
        }
    }

    /// The sample across a grazing corner from `last` (module docs): the orbit at W moved by
    /// `GRAZING_HOP` w_s the way W moves at `last`, shot from `last`'s state, if it lies in the
    /// other regime (its switches appear or vanish), within `HOP_REACH` of `last` and W moves on
    /// the same way there (no fold in the corner).
    fn across_grazing(&self, last: &Sample) -> Result<Sample, String> {
        let dim = last.orbit.z0.len();
        let way = last.tangent[dim].signum();
        let w = last.orbit.omega + way * GRAZING_HOP * self.scales.1;
        let orbit = periodic_at(&self.sys, w, &last.orbit.z0, self.tol)
            .ok_or(format!("no orbit at W = {w} rad/s across it"))?;
        let mut like = vec![0.0; dim];
        like.push(way);
        let tangent = exact_tangent(&self.sys, &orbit, &like, self.scales);
        let switched = orbit.flow.events.is_empty() != last.orbit.flow.events.is_empty();
        let reach = distance(&self.scaled(&orbit), &self.scaled(&last.orbit));
        if !switched || reach > HOP_REACH || tangent[dim] * way <= 0.0 {
            return Err(format!(
                "the orbit at W = {w} rad/s is no grazing corner's far side (switches {} -> {}, \
                 {reach:.1e} away, W's tangent component {:.1e} -> {:.1e})",
                last.orbit.flow.events.len(),
                orbit.flow.events.len(),
                last.tangent[dim],
                tangent[dim]
            ));
        }
        Ok(self.sample(orbit, tangent))
    }

    /// The fold between the last sample and `next`, if W turns between them (module docs).
    fn insert_fold(&mut self, next: &Sample) -> Result<(), String> {
        let a = self.samples.last().expect("a sample");
        let dim = a.orbit.z0.len();
        let (ta, tb) = (a.tangent[dim], next.tangent[dim]);
        if ta * tb >= 0.0 {
            return Ok(());
        }
        let near = if ta.abs() <= tb.abs() { a } else { next };
        let (wa, wb) = (a.orbit.omega, next.orbit.omega);
        let turns_back = ta > 0.0;
        let between = |orbit: &Orbit| self.lies_between(a, next, orbit, turns_back);
        let orbit = fold_near(&self.sys, &near.orbit.z0, near.orbit.omega, self.tol)
            .filter(|o| between(o))
            .or_else(|| {
                self.fold_in_corner(a, next, turns_back)
                    .filter(|o| between(o))
            })
            .ok_or(format!(
                "no fold found between the samples at W = {wa} and {wb} rad/s"
            ))?;
        let tangent = exact_tangent(&self.sys, &orbit, &a.tangent, self.scales);
        self.folds.push(Fold {
            sample: self.samples.len(),
            turns_back,
        });
        let sample = self.sample(orbit, tangent);
        self.samples.push(sample);
        Ok(())
    }

    /// Whether a fold's orbit lies between the samples `a` and `b`: W beyond both (to the fold
    /// solver's 1e-11 in W) and within their distance of each.
    fn lies_between(&self, a: &Sample, b: &Sample, orbit: &Orbit, turns_back: bool) -> bool {
        let (wa, wb) = (a.orbit.omega, b.orbit.omega);
        let beyond = if turns_back {
            orbit.omega >= wa.max(wb) * (1.0 - 1e-10)
        } else {
            orbit.omega <= wa.min(wb) * (1.0 + 1e-10)
        };
        let span = distance(&self.scaled(&a.orbit), &self.scaled(&b.orbit));
        let x = self.scaled(orbit);
        beyond
            && [&a.orbit, &b.orbit]
                .iter()
                .all(|o| distance(&x, &self.scaled(o)) <= span)
    }

    /// A fold that `fold_near` cannot solve for, or solves for elsewhere on the curve: in a
    /// grazing corner (a stiff stop: the determinant it zeroes changes like the square root of a
    /// penetration far below its finite-difference steps), or next to another fold (the second
    /// resonance of the 3-DOF chain of tests/forced_heldout_cli.rs), when the samples `a` and `b`
    /// around it lie within `CORNER_FOLD` of each other or their tangents within `MAX_TURN`: bisection on the sign of W's tangent component between them, on the
    /// hyperplanes normal to their chord (`periodic_on_plane`), until the bracket is below 1e-13
    /// or an orbit is not found; the orbit with W largest (`turns_back`) or smallest among the
    /// bracket's ends and `a`, `b`. Its W is the fold's within the bracket, far below the 1e-3
    /// the comparisons resolve.
    fn fold_in_corner(&self, a: &Sample, b: &Sample, turns_back: bool) -> Option<Orbit> {
        let (xa, xb) = (self.scaled(&a.orbit), self.scaled(&b.orbit));
        let span = distance(&xa, &xb);
        if span > CORNER_FOLD && dot(&a.tangent, &b.tangent) < MAX_TURN.cos() {
            return None;
        }
        let dim = a.orbit.z0.len();
        let chord: Vec<f64> = xa.iter().zip(&xb).map(|(p, q)| (q - p) / span).collect();
        let (gs, ws) = self.scales;
        let (mut lo, mut hi) = (0.0, span);
        let mut ends = vec![a.orbit.clone(), b.orbit.clone()];
        while hi - lo > 1e-13 {
            let s = 0.5 * (lo + hi);
            let z: Vec<f64> = (0..dim).map(|i| (xa[i] + s * chord[i]) * gs).collect();
            let w = (xa[dim] + s * chord[dim]) * ws;
            let Some(orbit) = periodic_on_plane(&self.sys, &z, w, &chord, self.scales, self.tol)
            else {
                break;
            };
            let tangent = exact_tangent(&self.sys, &orbit, &chord, self.scales);
            if tangent[dim] * a.tangent[dim] > 0.0 {
                lo = s;
            } else {
                hi = s;
            }
            ends.push(orbit);
        }
        let sign = if turns_back { 1.0 } else { -1.0 };
        ends.into_iter()
            .max_by(|p, q| (sign * p.omega).total_cmp(&(sign * q.omega)))
    }

    /// The peak: (W rad/s, first harmonic m) at the largest first harmonic (module docs).
    pub fn peak(&self) -> Result<(f64, f64), String> {
        let top = (0..self.samples.len())
            .max_by(|&a, &b| self.samples[a].q1.total_cmp(&self.samples[b].q1))
            .expect("samples");
        self.peak_near(top)
    }

    /// The index of the first sample beyond `w_end` (rad/s): the samples before it are the part
    /// of the curve a continuation from the start of the range meets before it leaves the range
    /// (all of them when none is beyond).
    pub fn leaves_at(&self, w_end: f64) -> usize {
        self.samples
            .iter()
            .position(|s| s.orbit.omega > w_end)
            .unwrap_or(self.samples.len())
    }

    /// The peak of the part of the curve before it leaves the range at `w_end` (rad/s,
    /// `leaves_at`): (W rad/s, first harmonic m, whether it is the range's end). When that part
    /// still rises at its end (the orbit at W = `w_end` on it, shot from the samples around it,
    /// is above every sample before it), the end; otherwise the peak refined around the largest
    /// sample before it, as `peak`.
    pub fn peak_before(&self, w_end: f64) -> Result<(f64, f64, bool), String> {
        let cut = self.leaves_at(w_end);
        let top = (0..cut)
            .max_by(|&a, &b| self.samples[a].q1.total_cmp(&self.samples[b].q1))
            .expect("samples");
        if cut < self.samples.len() {
            let end = self.orbit_on_segment(cut - 1, w_end).ok_or(format!(
                "no orbit where the curve leaves the range, W = {w_end}"
            ))?;
            let q_end = first_harmonic(&self.sys, &end, &self.observed);
            if q_end >= self.samples[top].q1 {
                return Ok((w_end, q_end, true));
            }
        }
        let (w, q) = self.peak_near(top)?;
        Ok((w, q, false))
    }

    /// The periodic orbit at W (rad/s) on the segment from sample `i` to `i + 1` (W between
    /// theirs), shot at W from the state interpolated linearly in W between the two.
    pub fn orbit_on_segment(&self, i: usize, w: f64) -> Option<Orbit> {
        let (a, b) = (&self.samples[i].orbit, &self.samples[i + 1].orbit);
        let u = if b.omega == a.omega {
            0.0
        } else {
            (w - a.omega) / (b.omega - a.omega)
        };
        let z: Vec<f64> =
            a.z0.iter()
                .zip(&b.z0)
                .map(|(x, y)| x + u * (y - x))
                .collect();
        periodic_at(&self.sys, w, &z, self.tol)
    }

    /// `peak` around the sample `top`.
    fn peak_near(&self, top: usize) -> Result<(f64, f64), String> {
        let mut local = vec![(0.0, self.samples[top].orbit.omega, self.samples[top].q1)];
        for sign in [1.0, -1.0] {
            let mut at = self.samples[top].clone();
            at.tangent.iter_mut().for_each(|v| *v *= sign);
            let (mut s, mut falls) = (0.0, 0);
            while falls < 3 {
                // A step across a grazing corner next to the peak may not converge (the
                // chain driven through its second mode: the peak 1e-4 w1 from the fold at the
                // corner): a quarter, then a sixteenth of it.
                let (h, next) = [1.0, 0.25, 0.0625]
                    .iter()
                    .find_map(|f| {
                        let h = f * PEAK_STEP;
                        self.step(&at, h).map(|(next, _)| (h, next))
                    })
                    .ok_or(format!(
                        "re-trace lost near the peak, W = {}",
                        at.orbit.omega
                    ))?;
                s += sign * h;
                falls = if next.q1 < at.q1 { falls + 1 } else { 0 };
                local.push((s, next.orbit.omega, next.q1));
                at = next;
            }
        }
        local.sort_by(|a, b| a.0.total_cmp(&b.0));
        let k = (1..local.len() - 1)
            .max_by(|&a, &b| local[a].2.total_cmp(&local[b].2))
            .expect("three samples");
        Ok(parabola_vertex([local[k - 1], local[k], local[k + 1]]))
    }
}

/// Through three samples (s, W, q): the vertex s* of the parabola q(s), and (W(s*), q(s*)) on
/// the parabolas through the same three.
fn parabola_vertex(p: [(f64, f64, f64); 3]) -> (f64, f64) {
    let (d01, d12) = (
        (p[1].2 - p[0].2) / (p[1].0 - p[0].0),
        (p[2].2 - p[1].2) / (p[2].0 - p[1].0),
    );
    let second = (d12 - d01) / (p[2].0 - p[0].0);
    let s = 0.5 * (p[0].0 + p[1].0) - d01 / (2.0 * second);
    let lagrange = |f: fn(&(f64, f64, f64)) -> f64| {
        (0..3)
            .map(|i| {
                let (j, k) = ((i + 1) % 3, (i + 2) % 3);
                f(&p[i]) * (s - p[j].0) * (s - p[k].0) / ((p[i].0 - p[j].0) * (p[i].0 - p[k].0))
            })
            .sum::<f64>()
    };
    (lagrange(|x| x.1), lagrange(|x| x.2))
}
