//! N converged point by point (DESIGN §10.8): the forced problem at N0, 2 N0, 4 N0, ... up to
//! `max_harmonics`, and the check that decides which N a point in contact needs.
//!
//! A point in contact solved at N on an arc row is solved again at 2N on the same row (its
//! tangent and prediction padded with zero harmonics), from its own orbit padded. When the first
//! harmonic of the master and W move by at most the tolerance (relative), N is enough
//! ([`HarmonicCheck::Converged`]); otherwise the point at 2N replaces it and is checked at 4N,
//! and so on up to the ladder's top ([`HarmonicCheck::NotConverged`]). A point above the base
//! is first compared with N / 2: when that agrees, its solve at N / 2 is kept (converged) and
//! the next steps go down to N / 2. Out of contact the equation is linear and its harmonic balance exact at any
//! N ([`HarmonicCheck::Linear`]).

use nlmodes_hb::contact::Multipliers;

use crate::curve::HarmonicPolicy;
use crate::error::ForcedError;
pub use crate::harmonic_check::HarmonicCheck;
use crate::newton::{ArcRow, OrbitState};
use crate::solver::{ForcedPoint, ForcedSolver, ForcedStart};

/// The largest relative change of the master's first harmonic or of the parameter (W, the
/// speed) between a point and its solve at 2N for the two to be the same orbit (a truncation
/// error; on the test systems the change from N = 10 to 20 is at most 4e-3).
pub(crate) const REFINE_REACH: f64 = 0.05;

/// Whether `a` and its solve `b` at another N, `change` apart (relative [q1, parameter]), are
/// one orbit: within `REFINE_REACH`, and both in contact or both not (next to grazing a row
/// crosses orbits in and out of contact close together).
pub(crate) fn same_orbit(change: [f64; 2], a: &ForcedPoint, b: &ForcedPoint) -> bool {
    !change.iter().any(|&c| c > REFINE_REACH) && a.touches() == b.touches()
}

/// The forced problem at N0 2^k, k = 0, 1, ..., N0 2^k <= `max_harmonics`.
pub struct HarmonicLadder<'a, 's> {
    base: &'a ForcedSolver<'s>,
    finer: Vec<ForcedSolver<'s>>,
    tolerance: f64,
    /// What `converge` does with a point in contact: follow its N, check it once at 2N, or
    /// leave it to the check of the whole curve (`HarmonicPolicy::Retrace`, `curve_harmonics`).
    policy: HarmonicPolicy,
}

impl<'a, 's> HarmonicLadder<'a, 's> {
    /// The ladder above `base` up to `max_harmonics` (at least the base alone), converging
    /// points to `tolerance` (relative).
    pub fn new(
        base: &'a ForcedSolver<'s>,
        max_harmonics: usize,
        tolerance: f64,
    ) -> Result<Self, ForcedError> {
        let mut finer = Vec::new();
        let mut n = 2 * base.basis().harmonics();
        while n <= max_harmonics {
            finer.push(base.with_harmonics(n)?);
            n *= 2;
        }
        Ok(Self {
            base,
            finer,
            tolerance,
            policy: HarmonicPolicy::Follow,
        })
    }

    /// The ladder under `policy` (`new` follows N).
    pub fn with_policy(mut self, policy: HarmonicPolicy) -> Self {
        self.policy = policy;
        self
    }

    /// Number of levels (1 for the base alone).
    pub fn levels(&self) -> usize {
        1 + self.finer.len()
    }

    /// The solver of `level` (0: the base).
    pub fn solver(&self, level: usize) -> &ForcedSolver<'s> {
        if level == 0 {
            self.base
        } else {
            &self.finer[level - 1]
        }
    }

    /// The level whose basis has `harmonics` (the base when none has).
    pub fn level_of(&self, harmonics: usize) -> usize {
        (0..self.levels())
            .find(|&l| self.solver(l).basis().harmonics() == harmonics)
            .unwrap_or(0)
    }

    /// The solver a point was solved with.
    pub fn solver_of(&self, point: &ForcedPoint) -> &ForcedSolver<'s> {
        self.solver(self.level_of(point.harmonics))
    }

    /// Checks `point` (solved at `level` on `arc`, or at fixed W without one) as the module
    /// docs say; returns the point to keep (checked) and the level the next steps take. Above
    /// the base the coarser level is tried first: when it agrees within the tolerance the point
    /// is converged and the next steps go one level down (N falls where the contact eases).
    pub fn converge(
        &self,
        mut point: ForcedPoint,
        mut level: usize,
        arc: Option<&ArcRow>,
    ) -> (ForcedPoint, usize) {
        if !point.touches() {
            point.harmonic_check = HarmonicCheck::Linear;
            return (point, level);
        }
        match self.policy {
            HarmonicPolicy::Follow => {}
            HarmonicPolicy::Check => return (self.checked(point, level, arc), level),
            HarmonicPolicy::Retrace => return (point, level),
        }
        let mut last_change = None;
        if level > 0 {
            if let Some((mut coarser, change)) = self.same_orbit(&point, level - 1, arc) {
                if change.iter().all(|&c| c <= self.tolerance) {
                    // The coarser solve is kept: the next steps start from a point that solves
                    // their own N (a point of the finer N is off their curve by up to the
                    // tolerance, which a short step's corrector reads as a jump).
                    coarser.harmonic_check = HarmonicCheck::Converged { change };
                    return (coarser, level - 1);
                }
                last_change = Some(change);
            }
        }
        while level + 1 < self.levels() {
            let Some((finer_point, change)) = self.same_orbit(&point, level + 1, arc) else {
                point.harmonic_check = HarmonicCheck::NotConverged { change: None };
                return (point, level);
            };
            if change.iter().all(|&c| c <= self.tolerance) {
                point.harmonic_check = HarmonicCheck::Converged { change };
                return (point, level);
            }
            last_change = Some(change);
            (point, level) = (finer_point, level + 1);
        }
        point.harmonic_check = HarmonicCheck::NotConverged {
            change: last_change,
        };
        (point, level)
    }

    /// `point` (in contact, solved at `level`) with the verdict of one solve at the next level,
    /// the point itself kept (unchecked when `level` is the top).
    pub(crate) fn checked(
        &self,
        point: ForcedPoint,
        level: usize,
        arc: Option<&ArcRow>,
    ) -> ForcedPoint {
        self.checked_with_solve(point, level, arc).0
    }

    /// `checked`, with the solve at the next level when it converged on the same orbit.
    pub(crate) fn checked_with_solve(
        &self,
        mut point: ForcedPoint,
        level: usize,
        arc: Option<&ArcRow>,
    ) -> (ForcedPoint, Option<ForcedPoint>) {
        if level + 1 >= self.levels() {
            return (point, None);
        }
        let finer = self.same_orbit(&point, level + 1, arc);
        point.harmonic_check = verdict(finer.as_ref().map(|f| f.1), self.tolerance);
        (point, finer.map(|f| f.0))
    }

    /// The orbit of `point` solved again at `level` on the same row (or at the same W)
    /// (`solve_same_orbit`).
    fn same_orbit(
        &self,
        point: &ForcedPoint,
        level: usize,
        arc: Option<&ArcRow>,
    ) -> Option<(ForcedPoint, [f64; 2])> {
        solve_same_orbit(self.solver(level), point, arc, None)
    }
}

/// The verdict of a check whose solve at the next N moved the point by `change` (`None`: that
/// solve failed or landed on another orbit).
pub(crate) fn verdict(change: Option<[f64; 2]>, tolerance: f64) -> HarmonicCheck {
    match change {
        Some(change) if change.iter().all(|&c| c <= tolerance) => {
            HarmonicCheck::Converged { change }
        }
        Some(change) => HarmonicCheck::NotConverged {
            change: Some(change),
        },
        None => HarmonicCheck::NotConverged { change: None },
    }
}

/// The orbit of `point` solved again by `solver` (another N) on `arc` re-expressed at that N
/// (or at the same W without a row), from `start` (default: the point itself, padded or
/// truncated), and the relative change [q1, W] between the two (`relative_change`); `None`
/// when that solve fails or lands on another orbit (a change beyond `REFINE_REACH`, or in or
/// out of contact when the point is not: next to grazing the row crosses orbits in and out of
/// contact close together).
pub(crate) fn solve_same_orbit(
    solver: &ForcedSolver<'_>,
    point: &ForcedPoint,
    arc: Option<&ArcRow>,
    start: Option<ForcedStart>,
) -> Option<(ForcedPoint, [f64; 2])> {
    let row = arc.map(|a| resize_arc(a, solver));
    let start = start.unwrap_or_else(|| start_at(point, solver));
    let other = match solver.solve(start, row.as_ref()) {
        Ok(p) => p,
        Err(e) => {
            tracing::debug!(
                omega = point.omega,
                harmonics = solver.basis().harmonics(),
                "forced response: the check of N did not converge: {e}"
            );
            return None;
        }
    };
    let change = relative_change(point, &other, solver.system().master());
    if !same_orbit(change, point, &other) {
        tracing::debug!(
            omega = point.omega,
            ?change,
            "forced response: the check of N landed on another orbit"
        );
        return None;
    }
    Some((other, change))
}

/// [|dq1| / q1, |dW| / W] between two solves of one orbit at different N (relative to the one
/// at the larger N; q1 the first harmonic of coordinate `master`).
pub(crate) fn relative_change(a: &ForcedPoint, b: &ForcedPoint, master: usize) -> [f64; 2] {
    let (coarse, fine) = if a.harmonics <= b.harmonics {
        (a, b)
    } else {
        (b, a)
    };
    let (q, qf) = (coarse.first_harmonic(master), fine.first_harmonic(master));
    [
        (q - qf).abs() / qf.abs().max(f64::MIN_POSITIVE),
        (coarse.omega - fine.omega).abs() / fine.omega,
    ]
}

/// A vector of `rows` signals of `from` coefficients each, truncated or padded with zeros to
/// `to` coefficients per signal (the layout `[u_0, a_1, b_1, ...]` of `FullBasis` keeps the low
/// harmonics in front).
pub fn resize_signals(y: &[f64], rows: usize, from: usize, to: usize) -> Vec<f64> {
    let mut out = vec![0.0; rows * to];
    let keep = from.min(to);
    for j in 0..rows {
        out[j * to..j * to + keep].copy_from_slice(&y[j * from..j * from + keep]);
    }
    out
}

/// Samples per period resampled by periodic linear interpolation (`rows` signals of `from`
/// samples each to `to` samples each).
fn resample(v: &[f64], rows: usize, from: usize, to: usize) -> Vec<f64> {
    let mut out = Vec::with_capacity(rows * to);
    for j in 0..rows {
        let s = &v[j * from..(j + 1) * from];
        for k in 0..to {
            let x = k as f64 * from as f64 / to as f64;
            let (i, f) = (x.floor() as usize % from, x.fract());
            out.push((1.0 - f) * s[i] + f * s[(i + 1) % from]);
        }
    }
    out
}

/// The multipliers on another time grid of `samples` points.
fn resample_multipliers(mu: &Multipliers, samples: usize) -> Multipliers {
    let rows = mu.rows();
    Multipliers {
        samples,
        theta: resample(&mu.theta, rows, mu.samples, samples),
        kappa: resample(&mu.kappa, rows, mu.samples, samples),
    }
}

/// The start of a solve at `target`'s N from a point solved at another N.
pub fn start_at(point: &ForcedPoint, target: &ForcedSolver<'_>) -> ForcedStart {
    let rows = target.system().n_contacts();
    let from = point.contact.len() / rows.max(1);
    ForcedStart {
        state: OrbitState {
            y: resize_signals(&point.contact, rows, from, target.basis().terms()),
            omega: point.omega,
            level: point.level,
        },
        multipliers: resample_multipliers(&point.multipliers, target.basis().samples()),
    }
}

/// An arc row re-expressed at `to`'s N (tangent and prediction padded or truncated).
pub fn resize_arc(arc: &ArcRow, to: &ForcedSolver<'_>) -> ArcRow {
    let rows = to.system().n_contacts();
    let (a, b) = (arc.predicted.y.len() / rows.max(1), to.basis().terms());
    ArcRow {
        tangent_y: resize_signals(&arc.tangent_y, rows, a, b),
        predicted: OrbitState {
            y: resize_signals(&arc.predicted.y, rows, a, b),
            ..arc.predicted.clone()
        },
        ..arc.clone()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn resizing_keeps_the_low_harmonics_of_every_row() {
        let y = [1.0, 2.0, 3.0, 10.0, 20.0, 30.0];
        let up = resize_signals(&y, 2, 3, 5);
        assert_eq!(
            up,
            vec![1.0, 2.0, 3.0, 0.0, 0.0, 10.0, 20.0, 30.0, 0.0, 0.0]
        );
        assert_eq!(resize_signals(&up, 2, 5, 3), y.to_vec());
    }

    #[test]
    fn resampling_is_periodic_linear_interpolation() {
        let v = [0.0, 1.0, 2.0, 3.0];
        let r = resample(&v, 1, 4, 8);
        assert_eq!(r, vec![0.0, 0.5, 1.0, 1.5, 2.0, 2.5, 3.0, 1.5]);
    }
}
