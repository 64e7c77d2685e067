//! Floquet multipliers of a harmonic-balance orbit of M x'' + C x' + K x + A^T lambda(A x) = f(t)
//! from its sampled contact slopes (DESIGN §10.6): the monodromy of the variational equation
//!
//!   M y'' + C y' + (K + A^T D(t) A) y = 0,  D(t) = diag_j(d lambda_j / d g_j),
//!
//! with D held constant on the interval of length T / m centred on each time sample (the reading
//! `SampleIntervals` of the free modes' integrated monodromy), integrated exactly: on each
//! interval the first-order system z' = B_k z, z = (y, y'), B_k = [[0, I], [-M^-1 (K + A^T D_k A),
//! -M^-1 C]], has the flow exp(B_k T / m), so the monodromy is the ordered product of matrix
//! exponentials (computed once per distinct D_k: the open samples share one). No time step, no
//! truncation error beyond the sampling of D.
//!
//! Liouville: tr B_k = -tr(M^-1 C) for every k, so det(monodromy) = exp(-T tr(M^-1 C)) exactly;
//! the relative error of the product of the computed multipliers against it
//! ([`SampledMonodromy::liouville_error`]) measures the accuracy of the exponentials and of the
//! eigen-solve, and enters the verdict's margin. [`switched_monodromy`] reads D(t) from the
//! reconstructed gaps instead of the samples (the switching instants located in time).

use std::collections::HashMap;

use faer::{Mat, MatRef, Par, Side};
use nlmodes_dense::eigenvalues_checked;

use crate::contact::Multipliers;
use crate::error::HbError;
use crate::full_basis::FullBasis;

/// The monodromy of one orbit and its multipliers.
#[derive(Clone, Debug)]
pub struct SampledMonodromy {
    /// The 2n x 2n monodromy matrix in the scaled modal state (W Phi^-1 y, Phi^-1 y') (see
    /// `ScaledModal`): similar to the monodromy of (y, y'), same multipliers.
    pub matrix: Mat<f64>,
    /// Multipliers (re, im), by decreasing modulus.
    pub multipliers: Vec<[f64; 2]>,
    /// |prod |mu| / exp(-T tr(M^-1 C)) - 1|, or `None` when exp(-T tr(M^-1 C)) is below
    /// [`LIOUVILLE_FLOOR`]: the product of the multipliers then sits below the round-off of
    /// the eigen-solve (|mu|_max eps), the strongly damped modes' multipliers are not resolved
    /// (nor needed for the verdict), and the check says nothing.
    pub liouville_error: Option<f64>,
}

/// Verdict on the stability of a (damped, forced) orbit.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Verdict {
    /// Every multiplier inside the unit circle by more than the margin.
    Stable,
    /// A multiplier outside the unit circle by more than the margin.
    Unstable,
    /// The largest modulus is within the margin of 1: the method cannot tell.
    Undetermined,
}

impl SampledMonodromy {
    /// Largest multiplier modulus.
    pub fn largest(&self) -> f64 {
        self.multipliers.first().map_or(0.0, |m| m[0].hypot(m[1]))
    }

    /// The verdict with margin `margin` + the Liouville error (when it applies) around
    /// |mu| = 1.
    pub fn verdict(&self, margin: f64) -> Verdict {
        self.verdict_of(self.largest(), margin)
    }

    /// The verdict of a largest |mu| `largest` judged with this monodromy's margin: `margin` +
    /// its Liouville error (another orbit's multiplier measured against the same tolerance).
    pub fn verdict_of(&self, largest: f64, margin: f64) -> Verdict {
        let tol = margin + self.liouville_error.unwrap_or(0.0);
        if largest > 1.0 + tol {
            Verdict::Unstable
        } else if largest < 1.0 - tol {
            Verdict::Stable
        } else {
            Verdict::Undetermined
        }
    }
}

/// The monodromy over the period `period` (s) of the orbit whose contact slopes at the m samples
/// are `slopes` (c x m, row-major j m + k, force per length), for M, C, K (n x n) and contact
/// rows A (c x n): the reading `SampleIntervals` (see module docs).
pub fn sampled_monodromy(
    m: MatRef<'_, f64>,
    c: MatRef<'_, f64>,
    k: MatRef<'_, f64>,
    rows: MatRef<'_, f64>,
    slopes: &[f64],
    period: f64,
) -> Result<SampledMonodromy, HbError> {
    let nc = rows.nrows();
    let samples = slopes.len().checked_div(nc).unwrap_or(0).max(1);
    let dt = period / samples as f64;
    let pieces: Vec<Piece> = (0..samples)
        .map(|s| Piece {
            slopes: (0..nc).map(|j| slopes[j * samples + s]).collect(),
            duration: dt,
        })
        .collect();
    monodromy_of_pieces(m, c, k, rows, &pieces, period)
}

/// The contact side of an orbit for [`switched_monodromy`]: its contact coordinates on the
/// full basis and the law's variables.
pub struct ContactOrbit<'a> {
    /// The basis of `contact`.
    pub basis: &'a FullBasis,
    /// Contact coordinates y_j (c x (2N + 1), signal-major).
    pub contact: &'a [f64],
    /// Initial gaps g0 (c).
    pub gaps: &'a [f64],
    /// theta and kappa of the law (c x m).
    pub multipliers: &'a Multipliers,
}

/// The monodromy with the reading `Continuous`: row j is active where the reconstructed
/// g_j(t) + theta_{j,k(t)} > 0 (k(t) the sample interval, centred on its sample, containing t),
/// with slope kappa_{j,k(t)}; the switching instants are located by bisection on the Fourier
/// series (to 2^-60 of a sample interval). For a penalty orbit (theta = 0, kappa = kc) this is the
/// exact linearization of the penalty equation along the harmonic-balance orbit, without the
/// O(T / m) error of the sampled contact durations.
pub fn switched_monodromy(
    m: MatRef<'_, f64>,
    c: MatRef<'_, f64>,
    k: MatRef<'_, f64>,
    rows: MatRef<'_, f64>,
    orbit: &ContactOrbit<'_>,
    period: f64,
) -> Result<SampledMonodromy, HbError> {
    let samples = orbit.basis.samples();
    let dt = period / samples as f64;
    let mut pieces = Vec::new();
    for s in 0..samples {
        let mut cuts = vec![0.0, 1.0];
        for j in 0..orbit.gaps.len() {
            cuts.extend(switches_in_interval(orbit, j, s));
        }
        cuts.sort_by(f64::total_cmp);
        for w in cuts.windows(2) {
            if w[1] > w[0] {
                let mid = 0.5 * (w[0] + w[1]);
                pieces.push(Piece {
                    slopes: active_slopes(orbit, s, mid),
                    duration: (w[1] - w[0]) * dt,
                });
            }
        }
    }
    monodromy_of_pieces(m, c, k, rows, &pieces, period)
}

/// g_j + theta_{j,s} at the fraction `x` in 0..1 of sample interval s (centred on sample s).
fn shifted_gap(orbit: &ContactOrbit<'_>, j: usize, s: usize, x: f64) -> f64 {
    let (t, m) = (orbit.basis.terms(), orbit.basis.samples());
    let phase = 2.0 * std::f64::consts::PI * (s as f64 + x - 0.5) / m as f64;
    FullBasis::value_at(&orbit.contact[j * t..(j + 1) * t], phase) - orbit.gaps[j]
        + orbit.multipliers.theta[j * m + s]
}

/// Fractions of interval s where row j switches (scan of `SCAN_POINTS`, then bisection).
fn switches_in_interval(orbit: &ContactOrbit<'_>, j: usize, s: usize) -> Vec<f64> {
    let mut roots = Vec::new();
    let f = |x: f64| shifted_gap(orbit, j, s, x);
    for i in 0..SCAN_POINTS {
        let (mut a, mut b) = (
            i as f64 / SCAN_POINTS as f64,
            (i + 1) as f64 / SCAN_POINTS as f64,
        );
        let (fa, fb) = (f(a), f(b));
        if (fa > 0.0) == (fb > 0.0) {
            continue;
        }
        for _ in 0..BISECTION_STEPS {
            let mid = 0.5 * (a + b);
            if (f(mid) > 0.0) == (fa > 0.0) {
                a = mid;
            } else {
                b = mid;
            }
        }
        roots.push(0.5 * (a + b));
    }
    roots
}

/// Slopes of every row at fraction `x` of interval s: kappa where active, else 0.
fn active_slopes(orbit: &ContactOrbit<'_>, s: usize, x: f64) -> Vec<f64> {
    let m = orbit.basis.samples();
    (0..orbit.gaps.len())
        .map(|j| {
            if shifted_gap(orbit, j, s, x) > 0.0 {
                orbit.multipliers.kappa[j * m + s]
            } else {
                0.0
            }
        })
        .collect()
}

/// Smallest exact det(monodromy) = exp(-T tr(M^-1 C)) at which the Liouville check applies.
pub const LIOUVILLE_FLOOR: f64 = 1e-12;

/// Sub-intervals scanned per sample interval for switches.
const SCAN_POINTS: usize = 16;
/// Bisection steps per switch (the interval / 2^60: below round-off).
const BISECTION_STEPS: usize = 60;

/// A stretch of the period with constant contact slopes.
struct Piece {
    slopes: Vec<f64>,
    duration: f64,
}

/// The ordered product of the pieces' flows (consecutive pieces with equal slopes merged, each
/// distinct (slopes, duration) exponentiated once), its multipliers and Liouville error.
fn monodromy_of_pieces(
    m: MatRef<'_, f64>,
    c: MatRef<'_, f64>,
    k: MatRef<'_, f64>,
    rows: MatRef<'_, f64>,
    pieces: &[Piece],
    period: f64,
) -> Result<SampledMonodromy, HbError> {
    let coords = ScaledModal::new(m, c, k, rows)?;
    let merged = merge_pieces(pieces);
    let mut flows: HashMap<Vec<u64>, Mat<f64>> = HashMap::new();
    let n2 = 2 * m.nrows();
    let mut phi = Mat::<f64>::identity(n2, n2);
    for piece in &merged {
        let mut key: Vec<u64> = piece.slopes.iter().map(|v| v.to_bits()).collect();
        key.push(piece.duration.to_bits());
        if !flows.contains_key(&key) {
            let b_dt = coords.exponent(&piece.slopes, piece.duration);
            flows.insert(key.clone(), expm(b_dt.as_ref()));
        }
        phi = product(flows[&key].as_ref(), phi.as_ref());
    }
    let trace: f64 = (0..coords.damping.nrows())
        .map(|i| coords.damping[(i, i)])
        .sum();
    multipliers_of(phi, trace, period)
}

/// The variational equation in scaled modal coordinates, where the flow of the structure alone
/// is a rotation (norm 1) and the exponentials are well conditioned: with the mass-normalized
/// modes Phi of (K, M), Lambda = diag(w_k^2), W = diag(w_k), y = Phi W^-1 xi_1, y' = Phi xi_2,
///
///   xi' = [[0, W], [-(Lambda + Psi^T D Psi) W^-1, -Phi^T C Phi]] xi,  Psi = A Phi.
///
/// A similarity of the (y, y') system: same multipliers, same trace -tr(M^-1 C). In (y, y') the
/// exponent has norm ~ w_max^2 tau and the squarings of the exponential amplify round-off by the
/// condition of the eigenvectors (~ w_max): on the blade (112 DOFs, w_max ~ 1e6 rad/s) the
/// monodromy overflowed; here its norm is ~ w_max tau.
struct ScaledModal {
    /// w_k (rad/s), floored at 1e-6 w_max for a singular K.
    w: Vec<f64>,
    /// Psi = A Phi (c x n).
    psi: Mat<f64>,
    /// Phi^T C Phi (n x n).
    damping: Mat<f64>,
}

impl ScaledModal {
    fn new(
        m: MatRef<'_, f64>,
        c: MatRef<'_, f64>,
        k: MatRef<'_, f64>,
        rows: MatRef<'_, f64>,
    ) -> Result<Self, HbError> {
        let llt = m
            .llt(Side::Lower)
            .map_err(|e| HbError::NotPositiveDefinite {
                name: "M",
                detail: format!("Cholesky factorization failed ({e})"),
            })?;
        // L^-1 K L^-T = Q Lambda Q^T, Phi = L^-T Q.
        let l = llt.L();
        let n = m.nrows();
        let mut lk = k.to_owned();
        faer::linalg::triangular_solve::solve_lower_triangular_in_place(l, lk.as_mut(), Par::Seq);
        let mut sym = lk.transpose().to_owned();
        faer::linalg::triangular_solve::solve_lower_triangular_in_place(l, sym.as_mut(), Par::Seq);
        let sym = Mat::from_fn(n, n, |i, j| 0.5 * (sym[(i, j)] + sym[(j, i)]));
        let eig = sym
            .self_adjoint_eigen(Side::Lower)
            .map_err(|e| HbError::Decomposition {
                what: "modes of (K, M) for the monodromy",
                detail: format!("{e:?}"),
            })?;
        let mut phi = eig.U().to_owned();
        faer::linalg::triangular_solve::solve_upper_triangular_in_place(
            l.transpose(),
            phi.as_mut(),
            Par::Seq,
        );
        let lambda: Vec<f64> = (0..n).map(|i| eig.S()[i]).collect();
        let w_max = lambda.iter().fold(0.0_f64, |a, &v| a.max(v)).sqrt();
        let w = lambda
            .iter()
            .map(|&v| v.max(0.0).sqrt().max(1e-6 * w_max).max(f64::MIN_POSITIVE))
            .collect();
        let psi = product(rows, phi.as_ref());
        let damping = product(product(phi.transpose(), c).as_ref(), phi.as_ref());
        Ok(Self { w, psi, damping })
    }

    /// B tau in the scaled coordinates for contact slopes D (see the type's docs).
    fn exponent(&self, slopes: &[f64], tau: f64) -> Mat<f64> {
        let n = self.w.len();
        let mut stiff = Mat::from_fn(
            n,
            n,
            |i, j| {
                if i == j {
                    self.w[i] * self.w[i]
                } else {
                    0.0
                }
            },
        );
        for (j, &dj) in slopes.iter().enumerate() {
            if dj != 0.0 {
                let a = self.psi.row(j);
                stiff += Mat::from_fn(n, n, |p, q| dj * a[p] * a[q]);
            }
        }
        Mat::from_fn(2 * n, 2 * n, |p, q| match (p < n, q < n) {
            (true, true) => 0.0,
            (true, false) => f64::from(u8::from(q - n == p)) * self.w[p] * tau,
            (false, true) => -stiff[(p - n, q)] / self.w[q] * tau,
            (false, false) => -self.damping[(p - n, q - n)] * tau,
        })
    }
}

/// Consecutive pieces with bitwise equal slopes joined into one.
fn merge_pieces(pieces: &[Piece]) -> Vec<Piece> {
    let mut out: Vec<Piece> = Vec::new();
    for p in pieces {
        match out.last_mut() {
            Some(last) if last.slopes == p.slopes => last.duration += p.duration,
            _ => out.push(Piece {
                slopes: p.slopes.clone(),
                duration: p.duration,
            }),
        }
    }
    out
}

/// Multipliers of the monodromy `phi` (of a first-order system whose generator has trace
/// -`trace_minv_c` throughout the period `period`) and its Liouville error.
pub fn multipliers_of(
    phi: Mat<f64>,
    trace_minv_c: f64,
    period: f64,
) -> Result<SampledMonodromy, HbError> {
    if phi.col_iter().any(|col| col.iter().any(|v| !v.is_finite())) {
        return Err(HbError::NonFiniteResult {
            what: "monodromy matrix",
        });
    }
    let what = "monodromy eigenvalues";
    let eig = eigenvalues_checked(phi.as_ref(), what).map_err(HbError::dense(what))?;
    let mut multipliers: Vec<[f64; 2]> = eig.iter().map(|z| [z.re, z.im]).collect();
    multipliers.sort_by(|a, b| b[0].hypot(b[1]).total_cmp(&a[0].hypot(a[1])));
    let log_det: f64 = multipliers.iter().map(|z| z[0].hypot(z[1]).ln()).sum();
    let exact_log_det = -period * trace_minv_c;
    let liouville_error =
        (exact_log_det >= LIOUVILLE_FLOOR.ln()).then(|| (log_det - exact_log_det).exp_m1().abs());
    Ok(SampledMonodromy {
        matrix: phi,
        multipliers,
        liouville_error,
    })
}

/// exp(a) by scaling and squaring with a degree-18 Taylor polynomial: a / 2^s has 1-norm at most
/// 1/2, where the truncation error is below 0.5^19 / 19! ~ 1e-23 relative. The polynomial is
/// evaluated by Paterson-Stockmeyer (powers up to X^5, then Horner in X^5): 7 products, not 18.
pub fn expm(a: MatRef<'_, f64>) -> Mat<f64> {
    const DEGREE: usize = 18;
    const BLOCK: usize = 5;
    let n = a.nrows();
    let norm = (0..n)
        .map(|j| (0..n).map(|i| a[(i, j)].abs()).sum::<f64>())
        .fold(0.0_f64, f64::max);
    let squarings = if norm > 0.5 {
        (norm / 0.5).log2().ceil() as i32
    } else {
        0
    };
    let scale = 0.5_f64.powi(squarings);
    let mut powers = vec![
        Mat::<f64>::identity(n, n),
        Mat::from_fn(n, n, |i, j| a[(i, j)] * scale),
    ];
    for p in 2..=BLOCK {
        let next = product(powers[p - 1].as_ref(), powers[1].as_ref());
        powers.push(next);
    }
    // 1 / i! for i = 0..=DEGREE.
    let coeff: Vec<f64> = (0..=DEGREE)
        .scan(1.0, |f, i| {
            if i > 0 {
                *f /= i as f64;
            }
            Some(*f)
        })
        .collect();
    let chunk = |c: usize| {
        let mut b = Mat::<f64>::zeros(n, n);
        for j in 0..BLOCK.min(DEGREE + 1 - c * BLOCK) {
            b += &powers[j] * coeff[c * BLOCK + j];
        }
        b
    };
    let chunks = DEGREE / BLOCK;
    let mut result = chunk(chunks);
    for c in (0..chunks).rev() {
        result = product(result.as_ref(), powers[BLOCK].as_ref()) + chunk(c);
    }
    for _ in 0..squarings {
        result = product(result.as_ref(), result.as_ref());
    }
    result
}

/// A B on the calling thread (the levels of a forced study run in parallel instead).
fn product(a: MatRef<'_, f64>, b: MatRef<'_, f64>) -> Mat<f64> {
    let mut out = Mat::zeros(a.nrows(), b.ncols());
    faer::linalg::matmul::matmul(out.as_mut(), faer::Accum::Replace, a, b, 1.0, Par::Seq);
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn expm_of_a_rotation_generator_is_the_rotation() {
        let t = 7.3; // several turns: exercises the scaling and squaring
        let a = Mat::from_fn(2, 2, |i, j| match (i, j) {
            (0, 1) => t,
            (1, 0) => -t,
            _ => 0.0,
        });
        let e = expm(a.as_ref());
        let want = [[t.cos(), t.sin()], [-t.sin(), t.cos()]];
        for i in 0..2 {
            for j in 0..2 {
                assert!((e[(i, j)] - want[i][j]).abs() < 1e-13, "{i}{j}");
            }
        }
    }

    #[test]
    fn a_damped_oscillator_has_the_multipliers_of_its_exponents() {
        // y'' + 2 z w y' + w^2 y = 0 (no contact row): mu = exp(s T), s = -z w +- i w sqrt(1 - z^2).
        let (w, z, period) = (2.0, 0.05, 1.3);
        let one = |v: f64| Mat::from_fn(1, 1, |_, _| v);
        let rows = Mat::<f64>::zeros(0, 1);
        let mono = sampled_monodromy(
            one(1.0).as_ref(),
            one(2.0 * z * w).as_ref(),
            one(w * w).as_ref(),
            rows.as_ref(),
            &[],
            period,
        )
        .unwrap();
        let modulus = (-z * w * period).exp();
        let arg = w * (1.0 - z * z).sqrt() * period;
        for m in &mono.multipliers {
            assert!((m[0].hypot(m[1]) - modulus).abs() < 1e-13);
            assert!((m[1].atan2(m[0]).abs() - arg).abs() < 1e-12);
        }
        assert!(mono.liouville_error.unwrap() < 1e-13);
        assert_eq!(mono.verdict(1e-6), Verdict::Stable);
    }
}
