//! Independent references for the nonlinear-mode oracle tests (`nnm_oracles.rs`): small
//! spring-mass systems, a dense generalized eigensolver (own Cholesky + cyclic Jacobi, sharing no
//! code with `nlmodes-nnm`), direct cosine sums and the closed-form 1-DOF contact oscillators of
//! docs/DESIGN.md §5.
//!
//! Units: lengths in units of the gap g (gaps are 1 unless stated), masses and stiffnesses
//! dimensionless, circular frequencies in rad per unit time.

// Only `nnm_oracles` includes this module; keep the helpers usable from any future test binary.
#![allow(dead_code)]

use std::f64::consts::PI;

use faer::Mat;

/// Fixed-free spring-mass chain: mass i (lumped, `masses[i]`) is tied to mass i-1 by spring
/// `springs[i]` (mass 0 to the ground). Returns (M, K), both n x n.
pub fn chain(masses: &[f64], springs: &[f64]) -> (Mat<f64>, Mat<f64>) {
    assert_eq!(masses.len(), springs.len(), "one spring per mass");
    let n = masses.len();
    let m = Mat::from_fn(n, n, |i, j| if i == j { masses[i] } else { 0.0 });
    let mut k = Mat::<f64>::zeros(n, n);
    for (i, &s) in springs.iter().enumerate() {
        k[(i, i)] += s;
        if i > 0 {
            k[(i - 1, i - 1)] += s;
            k[(i - 1, i)] -= s;
            k[(i, i - 1)] -= s;
        }
    }
    (m, k)
}

/// A 4-mass chain with a rich modal content: masses 1, 1.5, 0.8, 1.2; springs 3 (ground), 2, 1.5, 1.
/// w_k / w_1 = 1, 2.354, 4.220, 5.188: harmonics of the fundamental meet the higher modes soon
/// after grazing (4:1 with mode 3 at w / w_1 = 1.055). Used where that does not matter (below
/// grazing, penalty orbit against time integration).
pub fn soft_chain() -> (Mat<f64>, Mat<f64>) {
    chain(&SOFT_CHAIN_MASSES, &[3.0, 2.0, 1.5, 1.0])
}

/// Masses of [`soft_chain`].
pub const SOFT_CHAIN_MASSES: [f64; 4] = [1.0, 1.5, 0.8, 1.2];

/// A 4-mass chain whose first mode dominates: a unit mass on a unit spring carrying three light
/// masses (0.3, 0.2, 0.1) on stiff springs (200, 300, 400). w_2 / w_1 = 26.3, so no harmonic n <= 12
/// of a fundamental up to 2 w_1 meets a higher mode: the nonlinear mode is free of internal
/// resonances and unique, as needed by complementarity checks and the backbone test.
pub fn stiff_chain() -> (Mat<f64>, Mat<f64>) {
    chain(&[1.0, 0.3, 0.2, 0.1], &[1.0, 200.0, 300.0, 400.0])
}

/// Unit row selecting DOF `dof` of an n-DOF system, as a 1 x n matrix.
pub fn selector_row(n: usize, dof: usize) -> Mat<f64> {
    Mat::from_fn(1, n, |_, i| if i == dof { 1.0 } else { 0.0 })
}

/// 1 x 1 matrix.
pub fn scalar(v: f64) -> Mat<f64> {
    Mat::from_fn(1, 1, |_, _| v)
}

/// Eigen-decomposition of a symmetric matrix by the cyclic Jacobi method: eigenvalues ascending and
/// orthonormal eigenvectors (column j of the returned row-major `vectors[i][j]`). Sweeps until the
/// off-diagonal Frobenius norm is below 1e-15 of the whole norm, which gives eigenvalues to a few
/// ulps of the largest.
pub fn jacobi_eigen(a: &[Vec<f64>]) -> (Vec<f64>, Vec<Vec<f64>>) {
    let n = a.len();
    let mut a: Vec<Vec<f64>> = a.to_vec();
    let mut v: Vec<Vec<f64>> = (0..n)
        .map(|i| (0..n).map(|j| if i == j { 1.0 } else { 0.0 }).collect())
        .collect();
    let total: f64 = a.iter().flatten().map(|x| x * x).sum::<f64>().sqrt();
    for _sweep in 0..100 {
        let off: f64 = (0..n)
            .flat_map(|i| (0..n).filter(move |&j| j != i).map(move |j| (i, j)))
            .map(|(i, j)| a[i][j] * a[i][j])
            .sum::<f64>()
            .sqrt();
        if off <= 1e-15 * total {
            break;
        }
        for p in 0..n {
            for q in (p + 1)..n {
                if a[p][q] == 0.0 {
                    continue;
                }
                // Rotation annihilating a[p][q] (Golub & Van Loan, Alg. 8.4.1).
                let tau = (a[q][q] - a[p][p]) / (2.0 * a[p][q]);
                let t = tau.signum() / (tau.abs() + (1.0 + tau * tau).sqrt());
                let t = if tau == 0.0 { 1.0 } else { t };
                let c = 1.0 / (1.0 + t * t).sqrt();
                let s = t * c;
                // A <- A J (columns p, q), then A <- J^T A (rows p, q).
                for row in a.iter_mut() {
                    let (akp, akq) = (row[p], row[q]);
                    row[p] = c * akp - s * akq;
                    row[q] = s * akp + c * akq;
                }
                let (head, tail) = a.split_at_mut(q);
                for (apk, aqk) in head[p].iter_mut().zip(tail[0].iter_mut()) {
                    let (x, y) = (*apk, *aqk);
                    *apk = c * x - s * y;
                    *aqk = s * x + c * y;
                }
                for row in v.iter_mut() {
                    let (vp, vq) = (row[p], row[q]);
                    row[p] = c * vp - s * vq;
                    row[q] = s * vp + c * vq;
                }
            }
        }
    }
    let mut order: Vec<usize> = (0..n).collect();
    order.sort_by(|&i, &j| a[i][i].total_cmp(&a[j][j]));
    let values = order.iter().map(|&i| a[i][i]).collect();
    let vectors = (0..n)
        .map(|r| order.iter().map(|&c| v[r][c]).collect())
        .collect();
    (values, vectors)
}

/// Lower Cholesky factor of a symmetric positive definite matrix (row-major), by the textbook
/// column algorithm. Panics if the matrix is not SPD (test inputs only).
fn cholesky(a: &[Vec<f64>]) -> Vec<Vec<f64>> {
    let n = a.len();
    let mut l = vec![vec![0.0; n]; n];
    for j in 0..n {
        let d = a[j][j] - (0..j).map(|k| l[j][k] * l[j][k]).sum::<f64>();
        assert!(d > 0.0, "test matrix is not positive definite");
        l[j][j] = d.sqrt();
        for i in (j + 1)..n {
            l[i][j] = (a[i][j] - (0..j).map(|k| l[i][k] * l[j][k]).sum::<f64>()) / l[j][j];
        }
    }
    l
}

/// Linear modes of (K, M): squared circular frequencies ascending and mass-normalized mode shapes
/// (`modes[r][i]` = component i of mode r), each with a positive component at `sign_dof`.
/// Computed as the Jacobi eigen-decomposition of L^-1 K L^-T with M = L L^T.
pub fn linear_modes(m: &Mat<f64>, k: &Mat<f64>, sign_dof: usize) -> (Vec<f64>, Vec<Vec<f64>>) {
    let n = m.nrows();
    let dense = |a: &Mat<f64>| -> Vec<Vec<f64>> {
        (0..n)
            .map(|i| (0..n).map(|j| a[(i, j)]).collect())
            .collect()
    };
    let l = cholesky(&dense(m));
    let kd = dense(k);
    // X = L^-1 K (forward substitution on each column), then C = L^-1 X^T (K symmetric).
    let forward = |b: &[f64]| -> Vec<f64> {
        let mut x = vec![0.0; n];
        for i in 0..n {
            x[i] = (b[i] - (0..i).map(|k| l[i][k] * x[k]).sum::<f64>()) / l[i][i];
        }
        x
    };
    let cols: Vec<Vec<f64>> = (0..n)
        .map(|j| forward(&(0..n).map(|i| kd[i][j]).collect::<Vec<_>>()))
        .collect();
    // cols[j] = column j of X = L^-1 K; column i of C = L^-1 (row i of X), C symmetric.
    let c: Vec<Vec<f64>> = (0..n)
        .map(|i| forward(&(0..n).map(|j| cols[j][i]).collect::<Vec<_>>()))
        .collect();
    let sym: Vec<Vec<f64>> = (0..n)
        .map(|i| (0..n).map(|j| 0.5 * (c[i][j] + c[j][i])).collect())
        .collect();
    let (values, vectors) = jacobi_eigen(&sym);
    // phi = L^-T y (back substitution).
    let modes = (0..n)
        .map(|r| {
            let y: Vec<f64> = (0..n).map(|i| vectors[i][r]).collect();
            let mut phi = vec![0.0; n];
            for i in (0..n).rev() {
                phi[i] = (y[i] - ((i + 1)..n).map(|k| l[k][i] * phi[k]).sum::<f64>()) / l[i][i];
            }
            if phi[sign_dof] < 0.0 {
                phi.iter_mut().for_each(|v| *v = -*v);
            }
            phi
        })
        .collect();
    (values, modes)
}

/// f(phase) = sum_n c_n cos(n phase), summed directly.
pub fn cosine_sum(coeffs: &[f64], phase: f64) -> f64 {
    coeffs
        .iter()
        .enumerate()
        .map(|(n, c)| c * (n as f64 * phase).cos())
        .sum()
}

/// Coordinate `dof` of every harmonic: [u_0[dof], u_1[dof], ..., u_N[dof]].
pub fn dof_series(coefficients: &[Vec<f64>], dof: usize) -> Vec<f64> {
    coefficients.iter().map(|u| u[dof]).collect()
}

/// Minimum over one period of a cosine series, on `count` equally spaced phases (count even, so that
/// phase pi, the second turning point of an even orbit, is a grid point).
pub fn series_minimum(coeffs: &[f64], count: usize) -> f64 {
    (0..count)
        .map(|i| cosine_sum(coeffs, 2.0 * PI * i as f64 / count as f64))
        .fold(f64::INFINITY, f64::min)
}

/// Classical RK4 integration of M u'' + K u + A^T lambda = 0 with lambda_j = kc_j (A_j u - g0_j)_+,
/// for a diagonal M (`masses`), returning the displacement after each of `steps` steps of size
/// `h` (entry 0 is the initial state). Written independently of `nlmodes_nnm::integrate_penalty`.
pub struct PenaltyChain<'a> {
    /// Lumped masses.
    pub masses: &'a [f64],
    /// Stiffness matrix.
    pub k: &'a Mat<f64>,
    /// Contact rows (c x n).
    pub rows: &'a Mat<f64>,
    /// Initial gaps.
    pub gaps: &'a [f64],
    /// Penalty stiffness per contact row.
    pub penalty: &'a [f64],
}

impl PenaltyChain<'_> {
    fn acceleration(&self, u: &[f64]) -> Vec<f64> {
        let n = u.len();
        let mut f: Vec<f64> = (0..n)
            .map(|i| -(0..n).map(|j| self.k[(i, j)] * u[j]).sum::<f64>())
            .collect();
        for (j, (&g0, &kc)) in self.gaps.iter().zip(self.penalty).enumerate() {
            let g = (0..n).map(|i| self.rows[(j, i)] * u[i]).sum::<f64>() - g0;
            let lambda = kc * g.max(0.0);
            for (i, fi) in f.iter_mut().enumerate() {
                *fi -= self.rows[(j, i)] * lambda;
            }
        }
        f.iter().zip(self.masses).map(|(fi, mi)| fi / mi).collect()
    }

    /// Displacements at t = i h, i = 0..=steps, from (u0, v0).
    pub fn trajectory(&self, u0: &[f64], v0: &[f64], h: f64, steps: usize) -> Vec<Vec<f64>> {
        let axpy = |x: &[f64], a: f64, y: &[f64]| -> Vec<f64> {
            x.iter().zip(y).map(|(xi, yi)| xi + a * yi).collect()
        };
        let (mut u, mut v) = (u0.to_vec(), v0.to_vec());
        let mut out = Vec::with_capacity(steps + 1);
        out.push(u.clone());
        for _ in 0..steps {
            let a1 = self.acceleration(&u);
            let (u2, v2) = (axpy(&u, 0.5 * h, &v), axpy(&v, 0.5 * h, &a1));
            let a2 = self.acceleration(&u2);
            let (u3, v3) = (axpy(&u, 0.5 * h, &v2), axpy(&v, 0.5 * h, &a2));
            let a3 = self.acceleration(&u3);
            let (u4, v4) = (axpy(&u, h, &v3), axpy(&v, h, &a3));
            let a4 = self.acceleration(&u4);
            for i in 0..u.len() {
                u[i] += h / 6.0 * (v[i] + 2.0 * v2[i] + 2.0 * v3[i] + v4[i]);
                v[i] += h / 6.0 * (a1[i] + 2.0 * a2[i] + 2.0 * a3[i] + a4[i]);
            }
            out.push(u.clone());
        }
        out
    }
}
