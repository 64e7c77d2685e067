//! The contribution of the high "other" modes to the per-harmonic Schur complement, summed once.
//!
//! In the condensed coordinates (see `condensation`), harmonic n (s = (n w)^2) needs
//!
//! ```text
//! T(s) = sum_i (kt_i - s mt_i)(kt_i - s mt_i)^T / (Lambda_i - s)
//! ```
//!
//! over the n_o other modes (kt_i, mt_i: columns of Kt and Mt). Summed term by term this costs
//! O(r^2 n_o) per harmonic and Newton step, the only part of a step that grows with the number of
//! non-contact modes. For the modes with Lambda_i >= s / rho (rho <= 1/4) the geometric series
//! 1 / (Lambda - s) = sum_p s^p / Lambda^(p+1) converges fast, so
//!
//! ```text
//! sum_{i >= cut} ... = sum_q s^q C_q,
//! C_q = sum_{i >= cut} [ Lambda_i^-(q+1) kt kt^T [q <= P]
//!                       - Lambda_i^-q (kt mt^T + mt kt^T) [1 <= q <= P + 1]
//!                       + Lambda_i^-(q-1) mt mt^T [2 <= q <= P + 2] ]
//! ```
//!
//! with the series cut after p = P, where rho^(P+1) / (1 - rho) <= 1e-17: the neglected tail is
//! below double-precision round-off, so the condensation stays exact in floating point. The C_q
//! are precomputed for a ladder of cut indices (every `CUT_STRIDE` modes); for each harmonic the
//! lowest cut whose Lambda is at least s / rho is used and the modes below it are summed
//! explicitly. As n_o grows, the added modes are high ones and land in the tail: the cost of a
//! Newton step stays flat (O(r^2 (cut + P)) per harmonic).

use faer::{Mat, MatMut};

/// Cut indices are multiples of this stride.
const CUT_STRIDE: usize = 8;
/// Bound on the relative truncation error of the series.
const SERIES_TOLERANCE: f64 = 1e-17;

/// Precomputed series coefficients of the high-mode part of T(s).
pub struct ModalTail {
    /// Convergence ratio bound: the tail is used only where s <= rho Lambda_cut.
    rho: f64,
    /// Kept coordinates r (each coefficient is r x r).
    r: usize,
    /// Series order P for the worst ratio rho (C_0 .. C_{P+2} are stored).
    order: usize,
    /// Cut indices, ascending.
    cuts: Vec<usize>,
    /// Lambda at each cut (the smallest eigenvalue summed by that ladder entry).
    cut_lambda: Vec<f64>,
    /// For each cut, C_0 .. C_{P+2}, each r x r column-major, stored one after the other.
    coeffs: Vec<Vec<f64>>,
}

impl ModalTail {
    /// Builds the ladder for modes `lambda` (ascending) with coupling columns `kt`, `mt` (r x n_o).
    /// `rho` < 1 is the largest s / Lambda_cut allowed.
    pub fn new(lambda: &[f64], kt: &Mat<f64>, mt: &Mat<f64>, rho: f64) -> Self {
        let n_o = lambda.len();
        let r = kt.nrows();
        // Series order P: rho^(P+1) / (1 - rho) <= tolerance.
        let order = ((SERIES_TOLERANCE * (1.0 - rho)).ln() / rho.ln()).ceil() as usize;
        let terms = order + 3;
        let cuts: Vec<usize> = (1..)
            .map(|k| k * CUT_STRIDE)
            .take_while(|&c| c < n_o)
            .collect();
        let mut running: Vec<Mat<f64>> = (0..terms).map(|_| Mat::zeros(r, r)).collect();
        let mut coeffs: Vec<Vec<f64>> = vec![Vec::new(); cuts.len()];
        let mut next_cut = cuts.len();
        for i in (0..n_o).rev() {
            let l = lambda[i];
            let (k, m) = (kt.col(i), mt.col(i));
            for (q, c) in running.iter_mut().enumerate() {
                let qi = q as i32;
                let a = if q <= order { l.powi(-qi - 1) } else { 0.0 };
                let b = if (1..=order + 1).contains(&q) {
                    -l.powi(-qi)
                } else {
                    0.0
                };
                let d = if q >= 2 { l.powi(1 - qi) } else { 0.0 };
                for col in 0..r {
                    let (kc, mc) = (k[col], m[col]);
                    for row in 0..r {
                        c[(row, col)] +=
                            a * k[row] * kc + b * (k[row] * mc + m[row] * kc) + d * m[row] * mc;
                    }
                }
            }
            if next_cut > 0 && cuts[next_cut - 1] == i {
                next_cut -= 1;
                coeffs[next_cut] = running
                    .iter()
                    .flat_map(|c| (0..r).flat_map(move |col| (0..r).map(move |row| c[(row, col)])))
                    .collect();
            }
        }
        let cut_lambda = cuts.iter().map(|&c| lambda[c]).collect();
        Self {
            rho,
            r,
            order,
            cuts,
            cut_lambda,
            coeffs,
        }
    }

    /// Series order for s / Lambda_cut = `ratio` <= rho, by the same rule as the stored order
    /// (ratio^(P+1) / (1 - ratio) <= tolerance, rounded up), never above the stored order.
    fn order_for(&self, ratio: f64) -> usize {
        if ratio <= 0.0 {
            return 0;
        }
        let p = ((SERIES_TOLERANCE * (1.0 - ratio)).ln() / ratio.ln()).ceil();
        (p.max(0.0) as usize).min(self.order)
    }

    /// The first mode summed by the series at s: the lowest cut with Lambda_cut >= s / rho, with
    /// its ladder index; (n_o, None) when no cut qualifies (all modes summed explicitly).
    pub fn split(&self, lambda: &[f64], s: f64) -> (usize, Option<usize>) {
        let first = lambda.partition_point(|&l| l * self.rho < s);
        let k = self.cuts.partition_point(|&c| c < first);
        match self.cuts.get(k) {
            Some(&cut) => (cut, Some(k)),
            None => (lambda.len(), None),
        }
    }

    /// out -= sum_{i >= cut} (kt_i - s mt_i)(kt_i - s mt_i)^T / (Lambda_i - s) for ladder entry
    /// `which` (from [`ModalTail::split`] at the same s). Only the terms the actual ratio
    /// s / Lambda_cut needs are summed (one term at s = 0): the truncation bound is the same as for
    /// the full series, ratio^(P+1) / (1 - ratio) <= 1e-17, with P chosen for this s.
    pub fn subtract(&self, which: usize, s: f64, mut out: MatMut<'_, f64>) {
        let rr = self.r * self.r;
        let ratio = s / self.cut_lambda[which];
        // C_q holds kt kt^T terms of order q, cross terms of order q - 1 and mt mt^T terms of
        // order q - 2: a series of order P needs C_0 .. C_{P+2}.
        let terms = self.order_for(ratio) + 3;
        let coeffs = &self.coeffs[which];
        let mut sum = vec![0.0; rr];
        let mut power = 1.0;
        for c in coeffs.chunks_exact(rr).take(terms) {
            for (acc, v) in sum.iter_mut().zip(c) {
                *acc += power * v;
            }
            power *= s;
            if power == 0.0 {
                break;
            }
        }
        for col in 0..self.r {
            let column = &sum[col * self.r..(col + 1) * self.r];
            for (row, v) in column.iter().enumerate() {
                out[(row, col)] -= v;
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Deterministic pseudo-random numbers in [-1, 1).
    fn lcg(state: &mut u64) -> f64 {
        *state = state
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        ((*state >> 11) as f64 / (1u64 << 53) as f64) * 2.0 - 1.0
    }

    #[test]
    fn series_matches_the_explicit_sum_to_round_off() {
        let lambda: Vec<f64> = (0..40).map(|i| (1.0 + i as f64).powi(3)).collect();
        check(&lambda, &[0.5, 3.0, 40.0, 900.0, 5000.0]);
        // Small eigenvalues and frequencies (a long unit chain): high powers of Lambda.
        let lambda: Vec<f64> = (0..40).map(|i| 0.0158 + 0.1 * i as f64).collect();
        check(&lambda, &[1e-8, 6.8e-4, 1e-2]);
    }

    fn check(lambda: &[f64], levels: &[f64]) {
        let (r, n_o) = (5, lambda.len());
        let mut st = 7;
        let kt = Mat::from_fn(r, n_o, |_, _| lcg(&mut st));
        let mt = Mat::from_fn(r, n_o, |_, _| lcg(&mut st));
        let tail = ModalTail::new(lambda, &kt, &mt, 0.25);
        for &s in levels {
            let (cut, which) = tail.split(lambda, s);
            let which = which.expect("a cut qualifies");
            assert!(lambda[cut] * 0.25 >= s, "cut {cut} too low for s = {s}");
            let explicit = |from: usize| {
                Mat::from_fn(r, r, |a, b| {
                    (from..n_o)
                        .map(|i| {
                            (kt[(a, i)] - s * mt[(a, i)]) * (kt[(b, i)] - s * mt[(b, i)])
                                / (lambda[i] - s)
                        })
                        .sum::<f64>()
                })
            };
            let exact = explicit(cut);
            let mut series = Mat::<f64>::zeros(r, r);
            tail.subtract(which, s, series.as_mut());
            let scale = exact.norm_max();
            let err = (&series + &exact).norm_max() / scale;
            assert!(err < 1e-14, "s = {s}: relative error {err:e}");
        }
        // Past the last cut nothing qualifies.
        assert_eq!(tail.split(lambda, 1e9), (n_o, None));
    }
}
