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
    /// Checks the values (finite, non-negative, the matrix of the system's order and symmetric).
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

    /// The damping matrix C of `system` (n x n).
    pub fn matrix(&self, system: &System) -> Result<Mat<f64>, ForcedError> {
        let n = system.n_dofs();
        self.validate(n)?;
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
