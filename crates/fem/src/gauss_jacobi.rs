//! Gauss-Jacobi quadrature on [-1, 1] with weight (1 - x)^alpha, used to build the
//! collapsed-coordinate (conical product) rules of arbitrary degree on the tetrahedron.

/// Jacobi polynomial P_n^(alpha, 0)(x) and its derivative, by the three-term recurrence.
fn jacobi_and_derivative(n: usize, alpha: f64, x: f64) -> (f64, f64) {
    let beta = 0.0;
    let mut p_prev = 1.0;
    if n == 0 {
        return (1.0, 0.0);
    }
    let mut p = 0.5 * (alpha - beta + (alpha + beta + 2.0) * x);
    for k in 2..=n {
        let k = k as f64;
        let s = 2.0 * k + alpha + beta;
        let a1 = 2.0 * k * (k + alpha + beta) * (s - 2.0);
        let a2 = (s - 1.0) * (alpha * alpha - beta * beta);
        let a3 = (s - 2.0) * (s - 1.0) * s;
        let a4 = 2.0 * (k + alpha - 1.0) * (k + beta - 1.0) * s;
        let p_next = ((a2 + a3 * x) * p - a4 * p_prev) / a1;
        p_prev = p;
        p = p_next;
    }
    // (2n + a + b)(1 - x^2) P_n' = n [(a - b) - (2n + a + b) x] P_n + 2 (n + a)(n + b) P_{n-1}
    let nf = n as f64;
    let s = 2.0 * nf + alpha + beta;
    let dp = (nf * ((alpha - beta) - s * x) * p + 2.0 * (nf + alpha) * (nf + beta) * p_prev)
        / (s * (1.0 - x * x));
    (p, dp)
}

/// Nodes and weights of the n-point Gauss-Jacobi rule for weight (1 - x)^alpha on [-1, 1],
/// `alpha` a non-negative integer. Exact for polynomials of degree 2n - 1 times the weight.
///
/// Roots by Newton's method with deflation from Chebyshev initial guesses; weights
/// w_i = 2^(alpha+1) / ((1 - x_i^2) P_n'(x_i)^2) (the Gamma-function prefactor is 1 for beta = 0).
pub(crate) fn gauss_jacobi(n: usize, alpha: u32) -> (Vec<f64>, Vec<f64>) {
    let a = f64::from(alpha);
    let mut x: Vec<f64> = Vec::with_capacity(n);
    for k in 0..n {
        let mut r = -(std::f64::consts::PI * (2 * k + 1) as f64 / (2 * n) as f64).cos();
        if k > 0 {
            r = 0.5 * (r + x[k - 1]);
        }
        for _ in 0..100 {
            let (p, dp) = jacobi_and_derivative(n, a, r);
            let deflation: f64 = x.iter().map(|&xj| 1.0 / (r - xj)).sum();
            let delta = -p / (dp - deflation * p);
            r += delta;
            if delta.abs() < 1e-16 {
                break;
            }
        }
        x.push(r);
    }
    let w = x
        .iter()
        .map(|&xi| {
            let (_, dp) = jacobi_and_derivative(n, a, xi);
            2f64.powi(alpha as i32 + 1) / ((1.0 - xi * xi) * dp * dp)
        })
        .collect();
    (x, w)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Exact integral of (1 - x)^alpha x^k over [-1, 1], expanding (1 - x)^alpha (alpha <= 2,
    /// at most three terms, no cancellation issue): sum_j C(alpha, j) (-1)^j int x^(k+j),
    /// with int_{-1}^{1} x^m = 2 / (m + 1) for even m and 0 for odd m.
    fn exact(alpha: u32, k: u32) -> f64 {
        let binom = [[1.0, 0.0, 0.0], [1.0, 1.0, 0.0], [1.0, 2.0, 1.0]];
        (0..=alpha)
            .map(|j| {
                let m = k + j;
                let mono = if m.is_multiple_of(2) {
                    2.0 / f64::from(m + 1)
                } else {
                    0.0
                };
                binom[alpha as usize][j as usize] * (-1f64).powi(j as i32) * mono
            })
            .sum()
    }

    #[test]
    fn integrates_monomials_to_degree_2n_minus_1() {
        // Sums of at most 8 terms of size <= 8: round-off ~1e-15; 1e-13 (relative, or absolute
        // for the integrals that vanish) is safe, and a wrong node or weight gives O(1) errors.
        for alpha in 0..=2 {
            for n in 1..=8 {
                let (x, w) = gauss_jacobi(n, alpha);
                for k in 0..(2 * n as u32) {
                    let q: f64 = x
                        .iter()
                        .zip(&w)
                        .map(|(xi, wi)| wi * xi.powi(k as i32))
                        .sum();
                    let e = exact(alpha, k);
                    assert!(
                        (q - e).abs() < 1e-13 * e.abs().max(1.0),
                        "alpha {alpha} n {n} k {k}: {q} vs {e}"
                    );
                }
                // Not exact beyond: the rule must miss x^(2n) (shows the test can fail).
                let k = 2 * n as u32;
                let q: f64 = x
                    .iter()
                    .zip(&w)
                    .map(|(xi, wi)| wi * xi.powi(k as i32))
                    .sum();
                assert!((q - exact(alpha, k)).abs() > 1e-6, "alpha {alpha} n {n}");
            }
        }
    }
}
