//! Balancing of a general square matrix before its eigen-decomposition (Parlett and Reinsch,
//! Numer. Math. 13, 1969; LAPACK's `dgebal` without the permutation step): a diagonal
//! similarity X_b = D^-1 X D by powers of 2, so exact in floating point, that makes each
//! row's and column's off-diagonal norms comparable. The eigenvalues are unchanged; the
//! eigenvectors of a matrix whose entries span many orders of magnitude (the massless
//! boundary's augmented generator: displacements, velocities, unit drive states and
//! stiffnesses up to w_max^2) come out with errors relative to the balanced norm instead of
//! the largest entry.

use faer::{Mat, MatRef};

/// X_b = D^-1 X D and D's diagonal (powers of 2).
#[derive(Clone, Debug)]
pub struct Balanced {
    pub matrix: Mat<f64>,
    pub scales: Vec<f64>,
}

/// A sweep stops scaling a row and column once that reduces their summed norms by less than
/// this fraction (LAPACK's 0.95).
const IMPROVEMENT: f64 = 0.95;
/// Most sweeps (each row and column once per sweep; convergence takes a few).
const MAX_SWEEPS: usize = 100;

/// Balances the square matrix `x` (module docs). Rows or columns with no off-diagonal entry
/// are left alone.
pub fn balance(x: MatRef<'_, f64>) -> Balanced {
    let n = x.nrows();
    let mut a = x.to_owned();
    let mut scales = vec![1.0; n];
    for _ in 0..MAX_SWEEPS {
        let mut done = true;
        for i in 0..n {
            let col: f64 = (0..n).filter(|&j| j != i).map(|j| a[(j, i)].abs()).sum();
            let row: f64 = (0..n).filter(|&j| j != i).map(|j| a[(i, j)].abs()).sum();
            if col == 0.0 || row == 0.0 || !(col + row).is_finite() {
                continue;
            }
            let f = power_of_two_factor(col, row);
            if col * f + row / f < IMPROVEMENT * (col + row) {
                done = false;
                scales[i] *= f;
                for j in 0..n {
                    a[(j, i)] *= f;
                    a[(i, j)] /= f;
                }
            }
        }
        if done {
            break;
        }
    }
    Balanced { matrix: a, scales }
}

/// The power of 2 f that brings col f and row / f within a factor 2 of each other.
fn power_of_two_factor(col: f64, row: f64) -> f64 {
    let (mut c, mut r, mut f) = (col, row, 1.0);
    while c < r / 2.0 {
        c *= 2.0;
        r /= 2.0;
        f *= 2.0;
    }
    while c / 2.0 >= r {
        c /= 2.0;
        r *= 2.0;
        f /= 2.0;
    }
    f
}

#[cfg(test)]
mod tests {
    use super::*;
    use faer::c64;
    use faer::linalg::solvers::Solve;

    /// A damped oscillator chain's first-order generator with a unit drive state, scaled as
    /// the boundary's: q ~ 1e-5, q' ~ W q, stiffnesses up to 1e9 rad^2/s^2, forces ~ 1e3.
    fn badly_scaled() -> Mat<f64> {
        let w2 = [2.9e6, 3.1e7, 2.2e8, 1.4e9];
        let r = w2.len();
        let n = 2 * r + 3;
        let mut x = Mat::<f64>::zeros(n, n);
        for i in 0..r {
            x[(i, r + i)] = 1.0;
            x[(r + i, i)] = -w2[i];
            x[(r + i, r + i)] = -2.0 * 0.003 * w2[i].sqrt();
            for k in 0..r {
                x[(r + i, k)] -= 1e6 * ((i + 1) * (k + 1)) as f64; // contact stiffness B^T R^-1 B
            }
            x[(r + i, 2 * r)] = 1e3 * (i as f64 + 1.0); // drive cos
            x[(r + i, 2 * r + 2)] = -3e2; // the gap's constant
        }
        let w = 1.8e3;
        x[(2 * r, 2 * r + 1)] = w;
        x[(2 * r + 1, 2 * r)] = -w;
        x
    }

    #[test]
    fn balancing_is_an_exact_similarity_by_powers_of_two() {
        let x = badly_scaled();
        let b = balance(x.as_ref());
        let n = x.nrows();
        for i in 0..n {
            assert_eq!(b.scales[i].log2().fract(), 0.0, "scale {}", b.scales[i]);
            for j in 0..n {
                // D X_b D^-1 reproduces X bit for bit.
                assert_eq!(b.matrix[(i, j)] * b.scales[i] / b.scales[j], x[(i, j)]);
            }
        }
        assert!(b.scales.iter().any(|&s| s != 1.0), "nothing balanced");
    }

    /// The largest error of V diag(l) V^-1 against x, entry (i, j) relative to the balanced
    /// scale of that entry, s_i / s_j max|X_b| (a q row must be right to the accuracy of q,
    /// not to that of the largest stiffness).
    fn reconstruction_error(x: &Mat<f64>, scales: &[f64], reference: &Balanced) -> f64 {
        let n = x.nrows();
        let b = Mat::from_fn(n, n, |i, j| x[(i, j)] / scales[i] * scales[j]);
        let eig = b.eigen().unwrap();
        let u = eig.U().to_owned();
        let u_inv = u.partial_piv_lu().solve(Mat::<c64>::identity(n, n));
        let v = Mat::from_fn(n, n, |i, k| u[(i, k)] * scales[i]);
        let v_inv = Mat::from_fn(n, n, |i, k| u_inv[(i, k)] / scales[k]);
        let l = Mat::from_fn(n, n, |i, k| {
            if i == k {
                eig.S()[i]
            } else {
                c64::new(0.0, 0.0)
            }
        });
        let back = &v * &l * &v_inv;
        let top = reference.matrix.norm_max();
        let mut worst = 0.0_f64;
        for i in 0..n {
            for j in 0..n {
                let scale = reference.scales[i] / reference.scales[j] * top;
                let err = (back[(i, j)].re - x[(i, j)]).abs() + back[(i, j)].im.abs();
                worst = worst.max(err / scale);
            }
        }
        worst
    }

    #[test]
    fn balanced_eigenvectors_reconstruct_the_badly_scaled_matrix() {
        let x = badly_scaled();
        let reference = balance(x.as_ref());
        let balanced = reconstruction_error(&x, &reference.scales, &reference);
        let plain = reconstruction_error(&x, &vec![1.0; x.nrows()], &reference);
        eprintln!("reconstruction error: balanced {balanced:e}, unbalanced {plain:e}");
        assert!(balanced <= 1e-12, "{balanced:e}");
    }
}
