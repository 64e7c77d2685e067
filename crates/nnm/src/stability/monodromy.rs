//! Independent check of Hill's multipliers: the monodromy matrix by time integration of the
//! variational equation M y'' + K y + A^T D(t) A y = 0 over one period along the same orbit.
//!
//! The period is cut into pieces on which D is constant, and each piece is integrated with the
//! classical RK4 scheme (at most T / `steps` per step), so the scheme keeps its fourth order: no
//! step straddles a jump of D. Two readings of D(t):
//! * [`JacobianInTime::SampleIntervals`]: D(t) = the sampled Jacobian of sample k
//!   (kappa_{j,k} where g_j(t_k) + theta_{j,k} > 0) on the interval of length T / m centred on
//!   t_k. Hill sees the same samples through their moments up to order 2N; this function has all
//!   moments (and the moments it shares with Hill's differ by the factor sinc(pi p / m) of the
//!   piecewise-constant hold), so the two agree as N grows with m fixed only up to that hold.
//! * [`JacobianInTime::Continuous`]: row j active where the reconstructed g_j(t) + theta_{j,k(t)} > 0
//!   (k(t) the sample interval containing t), with the switching instants located by bisection:
//!   for a penalty orbit (theta = 0, kappa = kc) this is the exact linearization of the penalty
//!   equation along the harmonic-balance orbit (a continuous, piecewise-linear force has no
//!   saltation). The active intervals then differ from the sampled ones by up to T / (2 m) at each
//!   end, an O(1/m) change of the impact duration, which is the O(1/m) difference between the two
//!   readings (and between Hill at finite m and the continuous problem).

use faer::linalg::solvers::DenseSolveCore;
use faer::{Mat, MatRef, Side};
use nlmodes_dense::eigenvalues_checked;
use serde::{Deserialize, Serialize};

use super::sort_multipliers;
use crate::integrate::check_rk4_step;
use crate::point::BackbonePoint;
use crate::NnmError;
use nlmodes_hb::system::System;

/// Bisection steps locating a contact switch (interval / 2^60: below round-off).
const BISECTION_STEPS: usize = 60;

/// Sub-intervals per sample interval scanned for sign changes of g + theta.
const SCAN_POINTS: usize = 16;

/// How the contact Jacobian varies in time in the integration (see the module docs).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize, Default)]
#[serde(rename_all = "snake_case")]
pub enum JacobianInTime {
    /// Piecewise constant on the intervals of length T / m centred on the samples.
    #[default]
    SampleIntervals,
    /// Active where the reconstructed gap g(t) + theta > 0, switches located in time.
    Continuous,
}

/// Settings of [`monodromy_by_integration`].
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct MonodromySettings {
    /// Minimal number of RK4 steps per period (default 20000); pieces are split further so that
    /// no step crosses a switch of D.
    pub steps: usize,
    /// Reading of D(t) (default sample intervals).
    pub jacobian: JacobianInTime,
}

impl Default for MonodromySettings {
    fn default() -> Self {
        Self {
            steps: 20_000,
            jacobian: JacobianInTime::SampleIntervals,
        }
    }
}

/// The monodromy matrix and its eigenvalues.
#[derive(Clone, Debug)]
pub struct Monodromy {
    /// 2n x 2n matrix mapping (y(0), y'(0)) to (y(T), y'(T)).
    pub matrix: Mat<f64>,
    /// Its 2n eigenvalues (re, im), sorted like [`crate::Stability::multipliers`].
    pub multipliers: Vec<[f64; 2]>,
    /// RK4 steps taken.
    pub steps: usize,
}

/// Monodromy matrix of the variational equation along `point` (physical coordinates; meant for
/// small models: the cost is O(n^3) per step).
pub fn monodromy_by_integration(
    system: &System,
    point: &BackbonePoint,
    settings: &MonodromySettings,
) -> Result<Monodromy, NnmError> {
    let (n, c) = (system.n_dofs(), system.n_contacts());
    let mult = &point.multipliers;
    let m = mult.samples;
    if point.coefficients.iter().any(|u| u.len() != n)
        || mult.theta.len() != c * m
        || mult.kappa.len() != c * m
        || m == 0
    {
        return Err(NnmError::StabilityInput {
            detail: format!("the point does not match the system ({n} DOFs, {c} contact rows)"),
        });
    }
    if settings.steps == 0 {
        return Err(NnmError::InvalidParameter {
            name: "steps",
            value: 0.0,
            expected: ">= 1",
        });
    }
    let period = point.period();
    let h_max = period / settings.steps as f64;
    check_step(system, &mult.kappa, h_max, period)?;
    let pieces = constant_pieces(system, point, settings.jacobian);
    let minv = inverse_mass(system)?;
    let mut y = Mat::<f64>::zeros(n, 2 * n);
    let mut v = Mat::<f64>::zeros(n, 2 * n);
    for i in 0..n {
        y[(i, i)] = 1.0;
        v[(i, n + i)] = 1.0;
    }
    let mut steps = 0;
    for piece in &pieces {
        let stiffness = piece_stiffness(system, &piece.kappa);
        let accel = &minv * &stiffness; // y'' = -accel y
        let count = ((piece.end - piece.start) / h_max).ceil().max(1.0) as usize;
        let h = (piece.end - piece.start) / count as f64;
        for _ in 0..count {
            rk4_step(accel.as_ref(), &mut y, &mut v, h);
        }
        steps += count;
    }
    let matrix = Mat::from_fn(
        2 * n,
        2 * n,
        |i, j| if i < n { y[(i, j)] } else { v[(i - n, j)] },
    );
    if (0..2 * n).any(|i| (0..2 * n).any(|j| !matrix[(i, j)].is_finite())) {
        return Err(NnmError::NonFiniteResult {
            what: "monodromy integration",
        });
    }
    let what = "monodromy eigenvalues";
    let eig = eigenvalues_checked(matrix.as_ref(), what).map_err(|e| NnmError::Decomposition {
        what,
        detail: e.to_string(),
    })?;
    let mut multipliers: Vec<[f64; 2]> = eig.iter().map(|z| [z.re, z.im]).collect();
    sort_multipliers(&mut multipliers);
    Ok(Monodromy {
        matrix,
        multipliers,
        steps,
    })
}

/// A time interval with a constant contact stiffness per row (0 = inactive).
pub(crate) struct Piece {
    pub start: f64,
    pub end: f64,
    pub kappa: Vec<f64>,
    /// Per row: the augmented-Lagrangian multiplier theta of the piece's sample is > 0.
    pub theta_positive: Vec<bool>,
}

/// Errors when T / steps exceeds the RK4 limit for the stiffest state (all rows active at their
/// largest kappa).
fn check_step(system: &System, kappa: &[f64], h: f64, period: f64) -> Result<(), NnmError> {
    let c = system.n_contacts();
    let m = kappa.len().checked_div(c).unwrap_or(0);
    let kmax: Vec<f64> = (0..c)
        .map(|j| {
            kappa[j * m..(j + 1) * m]
                .iter()
                .fold(0.0, |a: f64, b| a.max(*b))
        })
        .collect();
    check_rk4_step(system, piece_stiffness(system, &kmax).as_ref(), h, period)
}

/// K + A^T diag(kappa) A.
fn piece_stiffness(system: &System, kappa: &[f64]) -> Mat<f64> {
    let (a, k) = (system.contact_rows(), system.stiffness());
    let n = system.n_dofs();
    Mat::from_fn(n, n, |i, j| {
        k[(i, j)]
            + kappa
                .iter()
                .enumerate()
                .map(|(l, kl)| kl * a[(l, i)] * a[(l, j)])
                .sum::<f64>()
    })
}

/// M^-1 (dense, by Cholesky).
fn inverse_mass(system: &System) -> Result<Mat<f64>, NnmError> {
    let llt = system
        .mass()
        .llt(Side::Lower)
        .map_err(|e| NnmError::NotPositiveDefinite {
            name: "M",
            detail: format!("{e:?}"),
        })?;
    Ok(llt.inverse())
}

/// One RK4 step of y'' = -accel y for the 2n columns of (y, v).
fn rk4_step(accel: MatRef<'_, f64>, y: &mut Mat<f64>, v: &mut Mat<f64>, h: f64) {
    let k1y = v.clone();
    let k1v = -(accel * &*y);
    let k2y = &*v + faer::Scale(0.5 * h) * &k1v;
    let k2v = -(accel * (&*y + faer::Scale(0.5 * h) * &k1y));
    let k3y = &*v + faer::Scale(0.5 * h) * &k2v;
    let k3v = -(accel * (&*y + faer::Scale(0.5 * h) * &k2y));
    let k4y = &*v + faer::Scale(h) * &k3v;
    let k4v = -(accel * (&*y + faer::Scale(h) * &k3y));
    let w = h / 6.0;
    *y += faer::Scale(w) * (&k1y + faer::Scale(2.0) * &k2y + faer::Scale(2.0) * &k3y + &k4y);
    *v += faer::Scale(w) * (&k1v + faer::Scale(2.0) * &k2v + faer::Scale(2.0) * &k3v + &k4v);
}

/// Cuts [0, T] into pieces of constant D: the sample-interval edges (k + 1/2) T / m, and in
/// continuous mode the roots of g_j(t) + theta_{j,k} inside each interval.
pub(crate) fn constant_pieces(
    system: &System,
    point: &BackbonePoint,
    mode: JacobianInTime,
) -> Vec<Piece> {
    let mult = &point.multipliers;
    let (m, c) = (mult.samples, system.n_contacts());
    let period = point.period();
    let dt = period / m as f64;
    let sampled_gaps = point.gap_samples(system, m);
    let gap_coefficients: Vec<Vec<f64>> = (0..c)
        .map(|j| {
            point
                .coefficients
                .iter()
                .map(|u| system.contact_displacement(j, u))
                .collect()
        })
        .collect();
    let g0 = system.gaps();
    let shifted_gap = |j: usize, k: usize, t: f64| {
        nlmodes_hb::fourier::cosine_series(&gap_coefficients[j], point.omega * t) - g0[j]
            + mult.theta[j * m + k]
    };
    let bounds: Vec<SwitchFreeBound> = gap_coefficients
        .iter()
        .zip(g0)
        .map(|(c, &g)| SwitchFreeBound::of(c, g, point.omega))
        .collect();
    // Interval of sample k: [(k - 1/2) dt, (k + 1/2) dt), split at 0 for k = 0.
    let mut edges: Vec<(f64, f64, usize)> = Vec::with_capacity(m + 1);
    edges.push((0.0, 0.5 * dt, 0));
    for k in 1..m {
        edges.push(((k as f64 - 0.5) * dt, (k as f64 + 0.5) * dt, k));
    }
    edges.push(((m as f64 - 0.5) * dt, period, 0));
    let mut pieces = Vec::new();
    for (start, end, k) in edges {
        let mut cuts = vec![start, end];
        if mode == JacobianInTime::Continuous {
            let (mid, half_width) = (0.5 * (start + end), 0.5 * (end - start));
            for (j, bound) in bounds.iter().enumerate() {
                let theta = mult.theta[j * m + k];
                if bound.excludes(shifted_gap(j, k, mid), theta, half_width) {
                    continue;
                }
                cuts.extend(roots_in(|t| shifted_gap(j, k, t), start, end));
            }
            cuts.sort_by(f64::total_cmp);
        }
        for w in cuts.windows(2) {
            if w[1] - w[0] <= 1e-15 * period {
                continue;
            }
            let mid = 0.5 * (w[0] + w[1]);
            let kappa = (0..c)
                .map(|j| {
                    let active = match mode {
                        JacobianInTime::SampleIntervals => {
                            sampled_gaps[j][k] + mult.theta[j * m + k] > 0.0
                        }
                        JacobianInTime::Continuous => shifted_gap(j, k, mid) > 0.0,
                    };
                    if active {
                        mult.kappa[j * m + k]
                    } else {
                        0.0
                    }
                })
                .collect();
            let theta_positive = (0..c).map(|j| mult.theta[j * m + k] > 0.0).collect();
            pieces.push(Piece {
                start: w[0],
                end: w[1],
                kappa,
                theta_positive,
            });
        }
    }
    pieces
}

/// A proof that a shifted gap g_j(t) - g0_j + theta has no sign change on an interval, so that
/// its scan can be skipped: |d g_j / dt| <= w sum_n n |c_n| (the rate bound), so the value at the
/// interval's middle keeps its sign over a half-width h when it exceeds that bound times h. A
/// margin of 1e-9 of the series' scale covers the round-off of the evaluations the scan would
/// make, so a skipped interval is one whose scan finds no root: the pieces, hence the
/// multipliers, are the same bits with and without the bound (it only saves time: 70 % of the
/// stability stage on the default blade was this scan).
struct SwitchFreeBound {
    /// w sum_n n |c_n| (m/s).
    rate: f64,
    /// sum_n |c_n| + |g0| (m): the scale of the evaluated values.
    scale: f64,
}

impl SwitchFreeBound {
    fn of(coefficients: &[f64], g0: f64, omega: f64) -> Self {
        let (mut rate, mut scale) = (0.0, g0.abs());
        for (n, c) in coefficients.iter().enumerate() {
            rate += n as f64 * c.abs();
            scale += c.abs();
        }
        Self {
            rate: omega * rate,
            scale,
        }
    }

    /// Whether `value_at_middle` (g + theta at the middle of an interval of half-width
    /// `half_width`, s) proves that g + theta keeps its sign on the whole interval.
    fn excludes(&self, value_at_middle: f64, theta: f64, half_width: f64) -> bool {
        let margin = 1e-9 * (self.scale + theta.abs());
        value_at_middle.abs() > self.rate * half_width + margin
    }
}

/// Sign changes of `f` on [a, b] (scanned on SCAN_POINTS sub-intervals), refined by bisection.
fn roots_in(f: impl Fn(f64) -> f64, a: f64, b: f64) -> Vec<f64> {
    let mut out = Vec::new();
    let step = (b - a) / SCAN_POINTS as f64;
    let mut left = a;
    let mut f_left = f(a);
    for i in 1..=SCAN_POINTS {
        let right = if i == SCAN_POINTS {
            b
        } else {
            a + step * i as f64
        };
        let f_right = f(right);
        if (f_left > 0.0) != (f_right > 0.0) {
            let (mut lo, mut hi, lo_positive) = (left, right, f_left > 0.0);
            for _ in 0..BISECTION_STEPS {
                let mid = 0.5 * (lo + hi);
                if (f(mid) > 0.0) == lo_positive {
                    lo = mid;
                } else {
                    hi = mid;
                }
            }
            out.push(0.5 * (lo + hi));
        }
        left = right;
        f_left = f_right;
    }
    out
}
