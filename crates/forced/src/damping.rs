//! Viscous damping of the reduced model, C (N s/m for SI matrices; DESIGN §10.2).
//!
//! Three ways to give it, as NLvib, pyHarm and code_aster do: Rayleigh (C = alpha M + beta K),
//! modal damping ratios zeta_k on the linear modes of the reduced model
//! (C = M Phi diag(2 zeta_k w_k) Phi^T M, so that Phi^T C Phi = diag(2 zeta_k w_k) exactly), or a
//! matrix (the reduced-model directory's `C.mtx`). [`modal_ratios`] states what each linear mode
//! gets, for the report.

use faer::Mat;
use nlmodes_hb::System;

use crate::error::ForcedError;

/// A damping matrix C may have no eigenvalue below minus this times its largest |eigenvalue|
/// (positive semi-definite: u'^T C u' >= 0, the damping never feeds energy into the motion).
/// The dense symmetric eigensolver is backward stable, its eigenvalues off by about
/// n eps max|lambda| (2.2e-13 max|lambda| at n = 1000), and a C assembled elsewhere as sums and
/// products and written with 17 digits carries rounding of the same order: 1e-10 leaves a margin
/// of 400 at n = 1000 for a rank-deficient C (zero eigenvalues, e.g. dashpots on a few
/// coordinates or modes without damping). The same bound as the symmetry test (1e-10 of the
/// largest entry).
pub const SEMIDEFINITE_TOLERANCE: f64 = 1e-10;

/// How the damping matrix is defined.
#[derive(Clone, Debug, PartialEq)]
pub enum Damping {
    /// C = alpha M + beta K (alpha in 1/s, beta in s), both >= 0.
    Rayleigh {
        /// Mass-proportional coefficient (1/s).
        alpha: f64,
        /// Stiffness-proportional coefficient (s).
        beta: f64,
    },
    /// Damping ratios on the linear modes of the reduced model, ascending frequency; one value
    /// applies to every mode, a shorter list leaves the remaining modes at its last value.
    ModalRatios(Vec<f64>),
    /// A symmetric positive semi-definite matrix in the reduced coordinates (N s/m).
    Matrix(Mat<f64>),
}

impl Damping {
    /// Checks the values: finite and non-negative, at most one ratio per linear mode (n), the
    /// matrix of the system's order, finite and symmetric. Positive semi-definiteness of a
    /// matrix: [`check_semidefinite`] (in [`Damping::matrix`]).
    pub fn validate(&self, n: usize) -> Result<(), ForcedError> {
        let bad = |what: String, value: f64, expected: &'static str| {
            Err(ForcedError::Damping {
                what,
                value,
                expected,
            })
        };
        match self {
            Damping::Rayleigh { alpha, beta } => {
                for (name, v) in [("rayleigh.alpha", *alpha), ("rayleigh.beta", *beta)] {
                    if !(v.is_finite() && v >= 0.0) {
                        return bad(name.to_string(), v, "a finite value >= 0");
                    }
                }
            }
            Damping::ModalRatios(z) => {
                if z.is_empty() {
                    return bad("modal_ratios".into(), 0.0, "at least one ratio");
                }
                if z.len() > n {
                    return Err(ForcedError::Shape {
                        what: "the list of modal damping ratios".into(),
                        found: format!("{} ratios", z.len()),
                        expected: format!("at most one per linear mode of the model, {n}"),
                    });
                }
                for (k, &v) in z.iter().enumerate() {
                    if !(v.is_finite() && v >= 0.0) {
                        return bad(format!("modal_ratios[{k}]"), v, "a finite ratio >= 0");
                    }
                }
            }
            Damping::Matrix(c) => check_matrix(c, n)?,
        }
        Ok(())
    }

    /// The damping matrix C of `system` (n x n), every value checked ([`Damping::validate`]) and
    /// a given matrix positive semi-definite ([`check_semidefinite`]).
    pub fn matrix(&self, system: &System) -> Result<Mat<f64>, ForcedError> {
        let n = system.n_dofs();
        self.validate(n)?;
        if let Damping::Matrix(c) = self {
            check_semidefinite(c)?;
        }
        let (m, k) = (system.mass(), system.stiffness());
        Ok(match self {
            Damping::Rayleigh { alpha, beta } => {
                Mat::from_fn(n, n, |i, j| alpha * m[(i, j)] + beta * k[(i, j)])
            }
            Damping::ModalRatios(z) => {
                let phi = system.modes();
                let w = system.linear_frequencies();
                let mphi = m * phi;
                let d: Vec<f64> = (0..n).map(|r| 2.0 * ratio(z, r) * w[r]).collect();
                let scaled = Mat::from_fn(n, n, |i, r| mphi[(i, r)] * d[r]);
                &scaled * mphi.transpose()
            }
            Damping::Matrix(c) => c.clone(),
        })
    }
}

/// The ratio list's value for mode `r` (the last value repeats).
fn ratio(z: &[f64], r: usize) -> f64 {
    z[r.min(z.len() - 1)]
}

fn check_matrix(c: &Mat<f64>, n: usize) -> Result<(), ForcedError> {
    if c.nrows() != n || c.ncols() != n {
        return Err(ForcedError::Shape {
            what: "damping matrix C".into(),
            found: format!("{}x{}", c.nrows(), c.ncols()),
            expected: format!("{n}x{n}"),
        });
    }
    let scale = (0..n)
        .flat_map(|i| (0..n).map(move |j| (i, j)))
        .fold(0.0_f64, |a, (i, j)| a.max(c[(i, j)].abs()));
    for i in 0..n {
        for j in 0..n {
            let v = c[(i, j)];
            if !v.is_finite() {
                return Err(ForcedError::Damping {
                    what: format!("C[{i}][{j}]"),
                    value: v,
                    expected: "a finite entry",
                });
            }
            if (v - c[(j, i)]).abs() > 1e-10 * scale {
                return Err(ForcedError::Damping {
                    what: format!("C[{i}][{j}] - C[{j}][{i}]"),
                    value: v - c[(j, i)],
                    expected: "a symmetric matrix (within 1e-10 of its largest entry)",
                });
            }
        }
    }
    Ok(())
}

/// C (symmetric, finite, checked by [`Damping::validate`]) has no eigenvalue below
/// -[`SEMIDEFINITE_TOLERANCE`] times its largest |eigenvalue| (N s/m).
pub fn check_semidefinite(c: &Mat<f64>) -> Result<(), ForcedError> {
    let n = c.nrows();
    if n == 0 {
        return Ok(());
    }
    let identity = Mat::<f64>::identity(n, n);
    let eigen = nlmodes_dense::generalized_eigen(c.as_ref(), identity.as_ref())
        .map_err(nlmodes_hb::HbError::dense("I"))?;
    let values = &eigen.values;
    let largest = values.iter().fold(0.0_f64, |a, v| a.max(v.abs()));
    let lowest = values[0];
    if lowest < -SEMIDEFINITE_TOLERANCE * largest {
        let negative = values
            .iter()
            .filter(|&&v| v < -SEMIDEFINITE_TOLERANCE * largest)
            .count();
        return Err(ForcedError::Damping {
            what: format!(
                "matrix C: {negative} negative eigenvalue(s) (largest |eigenvalue| {largest:e} \
                 N s/m); the lowest"
            ),
            value: lowest,
            expected: "a positive semi-definite C (every eigenvalue >= -1e-10 x the largest \
                       |eigenvalue|): a negative eigenvalue is a negative damping that feeds \
                       energy into the motion",
        });
    }
    Ok(())
}

/// The damping ratio each linear mode of `system` gets from C: zeta_k = phi_k^T C phi_k / (2 w_k)
/// (exact for Rayleigh and modal damping; for a general C the diagonal of the modal damping, the
/// couplings aside). Modes with w_k = 0 get 0.
pub fn modal_ratios(system: &System, c: &Mat<f64>) -> Vec<f64> {
    let phi = system.modes();
    let w = system.linear_frequencies();
    let cphi = c * phi;
    (0..system.n_dofs())
        .map(|k| {
            let d: f64 = (0..system.n_dofs())
                .map(|i| phi[(i, k)] * cphi[(i, k)])
                .sum();
            if w[k] > 0.0 {
                d / (2.0 * w[k])
            } else {
                0.0
            }
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A deterministic pseudo-random matrix (entries in [-1, 1)).
    fn random(rows: usize, cols: usize, seed: u64) -> Mat<f64> {
        let mut state = seed;
        Mat::from_fn(rows, cols, |_, _| {
            state = state
                .wrapping_mul(6_364_136_223_846_793_005)
                .wrapping_add(1_442_695_040_888_963_407);
            (state >> 11) as f64 / (1u64 << 52) as f64 - 1.0
        })
    }

    /// C = A diag(d) A^T, rank-deficient where d has zeros: positive semi-definite in exact
    /// arithmetic, so its rounding (about n eps max|lambda|) must pass the 1e-10 test.
    fn semidefinite(n: usize, zeros: usize, seed: u64) -> Mat<f64> {
        let a = random(n, n, seed);
        let d: Vec<f64> = (0..n)
            .map(|k| if k < zeros { 0.0 } else { 1.0 + k as f64 })
            .collect();
        let ad = Mat::from_fn(n, n, |i, k| a[(i, k)] * d[k]);
        let c = &ad * a.transpose();
        Mat::from_fn(n, n, |i, j| 0.5 * (c[(i, j)] + c[(j, i)]))
    }

    #[test]
    fn rank_deficient_semidefinite_matrices_pass() {
        for (n, zeros) in [(5, 2), (92, 40), (200, 150)] {
            let c = semidefinite(n, zeros, n as u64);
            check_semidefinite(&c).unwrap_or_else(|e| panic!("n = {n}: {e}"));
        }
        check_semidefinite(&Mat::zeros(4, 4)).unwrap();
    }

    /// A negative eigenvalue above the rounding level is refused, with the count and the lowest.
    #[test]
    fn negative_eigenvalues_are_refused() {
        let n = 92;
        let c = semidefinite(n, 0, 7);
        let minus = Mat::from_fn(n, n, |i, j| -0.01 * c[(i, j)]);
        let e = check_semidefinite(&minus).unwrap_err().to_string();
        assert!(e.contains("92 negative eigenvalue(s)"), "{e}");
        assert!(e.contains("expected a positive semi-definite C"), "{e}");
        // One direction with damping -1e-6 of the largest: indefinite, refused.
        let v = random(n, 1, 3);
        let largest = 2.0 * n as f64 * n as f64;
        let mut c = semidefinite(n, 10, 11);
        for i in 0..n {
            for j in 0..n {
                c[(i, j)] -= 1e-6 * largest * v[(i, 0)] * v[(j, 0)];
            }
        }
        let e = check_semidefinite(&c).unwrap_err().to_string();
        assert!(e.contains("negative eigenvalue(s)"), "{e}");
    }

    #[test]
    fn more_ratios_than_modes_are_refused() {
        let e = Damping::ModalRatios(vec![0.01; 4]).validate(3).unwrap_err();
        assert!(e.to_string().contains("4 ratios"), "{e}");
        Damping::ModalRatios(vec![0.01; 3]).validate(3).unwrap();
    }
}
