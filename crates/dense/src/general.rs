//! Eigenvalues and eigenvectors of a general real matrix, checked before they are used.
//!
//! faer 0.24's nonsymmetric eigen-solver can return wrong eigenvalues without an error: on a
//! massless-boundary monodromy of the coarse blade (8 x 8, entries from 1e-6 to 2e4, every
//! multiplier on the unit circle, det = 1) it returned four exact zeros in place of two complex
//! pairs (session 29; the matrix is this module's test fixture, LAPACK's dgeev via numpy gives
//! the pairs). A verdict read from such values is wrong (here: no verdict; elsewhere it could
//! be a wrong one), so every general eigen-decomposition of the workspace goes through this
//! module: faer's result is checked by invariants it must satisfy, and where the check fails
//! (or faer reports an error) the decomposition is made again of an exactly similar matrix
//! (balanced by powers of two, then transposed, or with its rows and columns in reverse
//! order); where none passes, a typed error says so.
//!
//! The checks. Eigenvalues: the power sums sum l^k = tr(X^k), k = 1, 2, which are exact
//! polynomials of the entries: a backward-stable solver meets them to about n eps ||X||_F^k
//! however ill-conditioned single eigenvalues are; the tolerance is [`CHECK`] n ||X||_F^k.
//! Eigenvectors: the eigenvalues' power sums as above, and the residual of two combinations of
//! the pairs, ||X U z - U diag(l) z|| <= [`CHECK`] ||X||_F sum |z_k| ||u_k||, with fixed,
//! unequal weights z_k: a wrong column shows in both combinations unless its residual cancels
//! against others' for both weight sets at once. Two products with vectors instead of one with
//! U (O(n^2), not O(n^3): the Hill matrices hold hundreds of rows).

use faer::{c64, Mat, MatRef};

use crate::balance::balance;
use crate::eigen::DenseError;

/// Relative tolerance of the checks (their misses are scaled by n ||X||_F^k): about 5e4 times
/// the unit round-off a backward-stable solver meets them to, far below the O(1) misses of a
/// failed decomposition.
pub const CHECK: f64 = 1e-11;

/// The eigenvalues of the square matrix `x`, checked (module docs). `what` names the matrix
/// in the error.
pub fn eigenvalues_checked(x: MatRef<'_, f64>, what: &'static str) -> Result<Vec<c64>, DenseError> {
    if x.nrows() == 0 {
        return Ok(Vec::new());
    }
    finite(x, what)?;
    let sums = PowerSums::of(x);
    let mut attempts = Attempts::new(what);
    for candidate in similar_matrices(x) {
        match candidate.eigenvalues() {
            Ok(values) => {
                let error = sums.error(&values);
                if error <= CHECK {
                    return Ok(values);
                }
                attempts.missed(error);
            }
            Err(e) => attempts.failed(format!("{e:?}")),
        }
    }
    Err(attempts.error())
}

/// The eigen-decomposition of the square matrix `x` (values, and vectors as columns), checked
/// by the values' power sums and the pairs' weighted residuals (module docs). Tried on `x` itself, then with rows and columns
/// in reverse order (the vectors' entries put back), so that a caller's balancing is kept.
pub fn eigen_checked(
    x: MatRef<'_, f64>,
    what: &'static str,
) -> Result<(Vec<c64>, Mat<c64>), DenseError> {
    let n = x.nrows();
    if n == 0 {
        return Ok((Vec::new(), Mat::zeros(0, 0)));
    }
    finite(x, what)?;
    let norm = x.norm_l2().max(f64::MIN_POSITIVE);
    let sums = PowerSums::of(x);
    let mut attempts = Attempts::new(what);
    for reversed in [false, true] {
        let candidate = if reversed { reverse(x) } else { x.to_owned() };
        let eig = match candidate.eigen() {
            Ok(eig) => eig,
            Err(e) => {
                attempts.failed(format!("{e:?}"));
                continue;
            }
        };
        let values: Vec<c64> = (0..n).map(|k| eig.S()[k]).collect();
        let vectors = Mat::from_fn(n, n, |i, k| {
            eig.U()[(if reversed { n - 1 - i } else { i }, k)]
        });
        let error = sums
            .error(&values)
            .max(probe_residual(x, &values, &vectors) / norm);
        if error <= CHECK {
            return Ok((values, vectors));
        }
        attempts.missed(error);
    }
    Err(attempts.error())
}

/// What the attempts at one decomposition gave when none passed: the smallest miss of a check,
/// or faer's last error where no attempt returned.
struct Attempts {
    what: &'static str,
    smallest_miss: Option<f64>,
    failure: Option<String>,
}

impl Attempts {
    fn new(what: &'static str) -> Self {
        Self {
            what,
            smallest_miss: None,
            failure: None,
        }
    }

    fn missed(&mut self, error: f64) {
        self.smallest_miss = Some(self.smallest_miss.map_or(error, |e| e.min(error)));
    }

    fn failed(&mut self, detail: String) {
        self.failure = Some(detail);
    }

    fn error(self) -> DenseError {
        match (self.smallest_miss, self.failure) {
            (Some(error), _) => DenseError::Unchecked {
                what: self.what,
                error,
            },
            (None, detail) => DenseError::General {
                what: self.what,
                detail: detail.unwrap_or_else(|| "no attempt".to_string()),
            },
        }
    }
}

/// Refuses a matrix with a NaN or infinite entry (no decomposition of it means anything).
fn finite(x: MatRef<'_, f64>, what: &'static str) -> Result<(), DenseError> {
    if x.col_iter().all(|col| col.iter().all(|v| v.is_finite())) {
        Ok(())
    } else {
        Err(DenseError::General {
            what,
            detail: "an entry is not finite".to_string(),
        })
    }
}

/// `x` itself, its balanced form D^-1 X D and that form's transpose: the same eigenvalues.
fn similar_matrices(x: MatRef<'_, f64>) -> impl Iterator<Item = Mat<f64>> + '_ {
    let mut balanced = None;
    (0..3).map(move |k| match k {
        0 => x.to_owned(),
        1 => balanced.get_or_insert_with(|| balance(x).matrix).clone(),
        _ => balanced
            .get_or_insert_with(|| balance(x).matrix)
            .transpose()
            .to_owned(),
    })
}

/// P X P with P the reversal of the order (P = P^T = P^-1).
fn reverse(x: MatRef<'_, f64>) -> Mat<f64> {
    let n = x.nrows();
    Mat::from_fn(n, n, |i, j| x[(n - 1 - i, n - 1 - j)])
}

/// The larger of the residuals ||X U z - U diag(l) z|| / sum |z_k| ||u_k|| of two weight sets
/// z (module docs): z_k = (1 + k / n) / ||u_k|| and (2 - k / n) (-1)^k / ||u_k||.
fn probe_residual(x: MatRef<'_, f64>, values: &[c64], vectors: &Mat<c64>) -> f64 {
    let n = x.nrows();
    let sizes: Vec<f64> = (0..n)
        .map(|k| {
            let size = vectors
                .col(k)
                .iter()
                .map(|u| u.norm_sqr())
                .sum::<f64>()
                .sqrt();
            size.max(f64::MIN_POSITIVE)
        })
        .collect();
    let mut worst = 0.0_f64;
    for probe in 0..2 {
        let weight = |k: usize| {
            let t = k as f64 / n as f64;
            match probe {
                0 => (1.0 + t) / sizes[k],
                _ => (2.0 - t) * if k.is_multiple_of(2) { 1.0 } else { -1.0 } / sizes[k],
            }
        };
        let total: f64 = (0..n).map(|k| weight(k).abs() * sizes[k]).sum();
        let (mut v, mut lv) = (vec![c64::new(0.0, 0.0); n], vec![c64::new(0.0, 0.0); n]);
        for k in 0..n {
            let (z, lz) = (weight(k), values[k] * weight(k));
            for i in 0..n {
                v[i] += vectors[(i, k)] * z;
                lv[i] += vectors[(i, k)] * lz;
            }
        }
        let residual: f64 = (0..n)
            .map(|i| {
                let xv: c64 = (0..n).map(|j| v[j] * x[(i, j)]).sum();
                (xv - lv[i]).norm_sqr()
            })
            .sum::<f64>()
            .sqrt();
        let relative = residual / total;
        worst = worst.max(if relative.is_nan() {
            f64::INFINITY
        } else {
            relative
        });
    }
    worst
}

/// tr X, tr X^2 and the scales n ||X||_F, n ||X||_F^2 they are checked to.
struct PowerSums {
    traces: [f64; 2],
    scales: [f64; 2],
}

impl PowerSums {
    fn of(x: MatRef<'_, f64>) -> Self {
        let n = x.nrows();
        let trace: f64 = (0..n).map(|i| x[(i, i)]).sum();
        let square: f64 = (0..n)
            .flat_map(|i| (0..n).map(move |j| (i, j)))
            .map(|(i, j)| x[(i, j)] * x[(j, i)])
            .sum();
        let frobenius = x.norm_l2().max(f64::MIN_POSITIVE);
        let count = n as f64;
        Self {
            traces: [trace, square],
            scales: [count * frobenius, count * frobenius * frobenius],
        }
    }

    /// The larger relative miss |sum l^k - tr X^k| / (n ||X||_F^k), k = 1, 2 (infinite for a
    /// NaN eigenvalue).
    fn error(&self, values: &[c64]) -> f64 {
        let first: c64 = values.iter().copied().sum();
        let second: c64 = values.iter().map(|l| l * l).sum();
        let miss = [
            (first - c64::new(self.traces[0], 0.0)).norm() / self.scales[0],
            (second - c64::new(self.traces[1], 0.0)).norm() / self.scales[1],
        ];
        let worst = miss[0].max(miss[1]);
        if worst.is_nan() {
            f64::INFINITY
        } else {
            worst
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The monodromy of the coarse blade's massless boundary at q = 11.63 g0 on which faer
    /// 0.24.4 returned four zero eigenvalues (module docs; entries in Rust's round-trip form).
    const MONODROMY: [[f64; 8]; 8] = [
        [
            9.579803184441396e-1,
            -4.941079304722786e-2,
            -7.735875232857739e-2,
            -2.0458631966469829e-1,
            1.9213162420323075e-5,
            -1.416986885465732e-5,
            -4.880256085050476e-6,
            1.7114970744726484e-5,
        ],
        [
            8.121186890478607e-2,
            7.207133357308667e-1,
            -3.051405848626111e-1,
            -3.057616329439955e-1,
            -1.4169868854657369e-5,
            -1.03113711492963e-5,
            -7.419693782600824e-5,
            2.4785791744699012e-5,
        ],
        [
            1.700734127237985e-1,
            -1.427711582285523e-1,
            4.9150539218503253e-1,
            7.46449719082436e-2,
            -4.880256085050558e-6,
            -7.41969378260083e-5,
            -5.5800486518760216e-5,
            -4.213256993683618e-6,
        ],
        [
            -1.1072745074207274e-1,
            -8.896343931844444e-2,
            8.854324282283071e-2,
            6.050289703233332e-1,
            1.711497074472642e-5,
            2.4785791744699012e-5,
            -4.213256993683645e-6,
            3.1482733610379815e-5,
        ],
        [
            -7.558899948262104e3,
            -3.257345697719646e3,
            8.145272746170264e2,
            1.5343009026144416e3,
            9.57980318444141e-1,
            8.121186890478704e-2,
            1.7007341272379822e-1,
            -1.1072745074207395e-1,
        ],
        [
            -3.2573456977196506e3,
            -2.312341363359954e3,
            6.692032995631354e3,
            5.128194216876062e2,
            -4.941079304722665e-2,
            7.207133357308684e-1,
            -1.4277115822855302e-1,
            -8.896343931844516e-2,
        ],
        [
            8.145272746170252e2,
            6.692032995631352e3,
            4.030769702090317e3,
            -9.536172024452102e2,
            -7.735875232857795e-2,
            -3.051405848626118e-1,
            4.9150539218503353e-1,
            8.854324282283099e-2,
        ],
        [
            1.5343009026144605e3,
            5.128194216876125e2,
            -9.536172024452162e2,
            -1.9708062888102897e4,
            -2.0458631966470453e-1,
            -3.057616329439976e-1,
            7.464497190824368e-2,
            6.050289703233352e-1,
        ],
    ];

    /// Its multipliers by LAPACK's dgeev (numpy 2, the same matrix): two pairs at arguments
    /// 1.152 and 1.101 rad, one at 0.410 rad and the trivial pair at 1.
    const DGEEV: [(f64, f64); 4] = [
        (0.4056735483418656, 0.9140180371172749),
        (0.45228953417479384, 0.8918711662992311),
        (0.9172649341664882, 0.3982775930978398),
        (1.0, 1.49e-7),
    ];

    fn monodromy() -> Mat<f64> {
        Mat::from_fn(8, 8, |i, j| MONODROMY[i][j])
    }

    #[test]
    fn the_monodromy_faer_loses_gets_its_multipliers_back() {
        let x = monodromy();
        // The fixture still exercises the fallback: faer's own answer fails the check. (If a
        // faer release computes this one right, the assertion fails: find another fixture.)
        let plain = x.eigenvalues().expect("faer");
        assert!(
            PowerSums::of(x.as_ref()).error(&plain) > 1e3 * CHECK,
            "{plain:?}"
        );
        let values = eigenvalues_checked(x.as_ref(), "fixture").expect("checked");
        for (re, im) in DGEEV {
            for wanted in [c64::new(re, im), c64::new(re, -im)] {
                let nearest = values
                    .iter()
                    .map(|v| (v - wanted).norm())
                    .fold(f64::INFINITY, f64::min);
                // Simple eigenvalues of a matrix of norm 2e4: 1e-9 absolute; the trivial pair
                // is a defective double 1 split by round-off to 1.5e-7, compared to 1e-6.
                let tolerance = if re == 1.0 { 1e-6 } else { 1e-9 };
                assert!(
                    nearest < tolerance,
                    "{wanted:?}: {nearest:e} from {values:?}"
                );
            }
        }
        let (values, vectors) =
            eigen_checked(balance(x.as_ref()).matrix.as_ref(), "fixture").expect("checked vectors");
        assert_eq!(values.len(), 8);
        assert_eq!(vectors.ncols(), 8);
    }

    /// Over many random matrices of orders 1..24, scaled over 12 decades, the checks accept
    /// faer's answers where the power sums hold (no false alarms at [`CHECK`]).
    #[test]
    fn well_computed_decompositions_pass_the_checks() {
        let mut seed = 0x2545_f491_4f6c_dd1d_u64;
        let mut next = || {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            (seed >> 11) as f64 / (1u64 << 53) as f64 - 0.5
        };
        for n in 1..=24 {
            for _ in 0..4 {
                let scales: Vec<f64> = (0..n).map(|_| 10f64.powf(12.0 * next())).collect();
                let x = Mat::from_fn(n, n, |i, j| next() * scales[i] / scales[j]);
                let values = eigenvalues_checked(x.as_ref(), "random").expect("values");
                assert_eq!(values.len(), n);
                let (values, _) = eigen_checked(x.as_ref(), "random").expect("pairs");
                assert_eq!(values.len(), n);
            }
        }
    }

    /// Every single wrong column of a correct decomposition of the monodromy (balanced) fails
    /// the probes, as does a wrong eigenvalue; the correct one passes.
    #[test]
    fn a_wrong_pair_fails_the_probes() {
        let x = balance(monodromy().as_ref()).matrix;
        let (values, vectors) = eigen_checked(x.as_ref(), "fixture").expect("checked");
        let norm = x.norm_l2();
        assert!(probe_residual(x.as_ref(), &values, &vectors) / norm <= CHECK);
        for k in 0..8 {
            let mut wrong = vectors.clone();
            let j = (k + 3) % 8;
            for i in 0..8 {
                wrong[(i, k)] = vectors[(i, j)];
            }
            let error = probe_residual(x.as_ref(), &values, &wrong) / norm;
            assert!(
                error > 1e3 * CHECK,
                "column {k} swapped with {j}: {error:e}"
            );
            let mut shifted = values.clone();
            shifted[k] += c64::new(1e-6, 0.0);
            let error = probe_residual(x.as_ref(), &shifted, &vectors) / norm;
            assert!(error > 10.0 * CHECK, "value {k} moved by 1e-6: {error:e}");
        }
    }

    #[test]
    fn a_matrix_with_a_nan_is_refused() {
        let mut x = monodromy();
        x[(2, 3)] = f64::NAN;
        let err = eigenvalues_checked(x.as_ref(), "fixture").expect_err("NaN");
        assert!(err.to_string().contains("fixture"), "{err}");
    }
}
