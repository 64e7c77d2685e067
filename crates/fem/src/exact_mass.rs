//! Exact consistent mass of TET4/TET10 elements, curved or not.
//!
//! For these elements det J is a polynomial of degree <= 3 in the reference coordinates, so it
//! equals its cubic Lagrange interpolant on the 20 points xi_k = alpha / 3 (multi-indices
//! |alpha| = 3 in barycentric coordinates). Hence
//! `M_ab = rho int N_a N_b det J = rho sum_k W_abk det J(xi_k)` with `W_abk = int N_a N_b L_k`,
//! a polynomial of degree <= 7 integrated once, exactly, with the degree-7 conical-product rule.
//! An element mass then costs 20 evaluations of det J instead of a 64-point quadrature.

use crate::geometry::{det3, AffineJacobian};
use crate::quadrature::TetRule;
use crate::shape;
use crate::tet_kind::TetKind;

/// Number of cubic Lagrange points on the tetrahedron.
pub const CUBIC_POINTS: usize = 20;

/// Barycentric multi-indices alpha (|alpha| = 3) of the cubic Lagrange points.
fn cubic_multi_indices() -> Vec<[usize; 4]> {
    let mut out = Vec::with_capacity(CUBIC_POINTS);
    for i in 0..=3 {
        for j in 0..=(3 - i) {
            for k in 0..=(3 - i - j) {
                out.push([i, j, k, 3 - i - j - k]);
            }
        }
    }
    out
}

/// Cubic Lagrange basis function of multi-index `alpha` at barycentric `l`:
/// prod_m prod_{s < alpha_m} (3 l_m - s) / (s + 1).
fn cubic_lagrange(alpha: [usize; 4], l: [f64; 4]) -> f64 {
    let mut v = 1.0;
    for m in 0..4 {
        for s in 0..alpha[m] {
            v *= (3.0 * l[m] - s as f64) / (s as f64 + 1.0);
        }
    }
    v
}

/// The weights W_abk of one element kind.
#[derive(Clone, Debug)]
pub struct CubicMassWeights {
    kind: TetKind,
    /// Reference coordinates of the 20 interpolation points.
    points: Vec<[f64; 3]>,
    /// W_abk at `[(a * npe + b) * 20 + k]`, exactly symmetric in (a, b).
    weights: Vec<f64>,
}

impl CubicMassWeights {
    /// Computes the weights for `kind` (once per process, see `ElementRules`).
    pub fn new(kind: TetKind) -> Self {
        let npe = kind.nodes_per_element();
        let alphas = cubic_multi_indices();
        let points: Vec<[f64; 3]> = alphas
            .iter()
            .map(|a| [a[1] as f64 / 3.0, a[2] as f64 / 3.0, a[3] as f64 / 3.0])
            .collect();
        let rule = TetRule::conical_product(7);
        let mut weights = vec![0.0; npe * npe * CUBIC_POINTS];
        let mut n = [0.0; 10];
        for (&p, &w) in rule.points.iter().zip(&rule.weights) {
            shape::values_into(kind, p, &mut n);
            let l = [1.0 - p[0] - p[1] - p[2], p[0], p[1], p[2]];
            let lk: Vec<f64> = alphas.iter().map(|&a| cubic_lagrange(a, l)).collect();
            for a in 0..npe {
                for b in a..npe {
                    let c = w * n[a] * n[b];
                    let row = &mut weights
                        [(a * npe + b) * CUBIC_POINTS..(a * npe + b + 1) * CUBIC_POINTS];
                    for (r, &v) in row.iter_mut().zip(&lk) {
                        *r += c * v;
                    }
                }
            }
        }
        for a in 0..npe {
            for b in 0..a {
                let (dst, src) = ((a * npe + b) * CUBIC_POINTS, (b * npe + a) * CUBIC_POINTS);
                weights.copy_within(src..src + CUBIC_POINTS, dst);
            }
        }
        CubicMassWeights {
            kind,
            points,
            weights,
        }
    }

    /// Element consistent mass (kg) into `out` (row-major `(3 npe)^2`, overwritten), for
    /// density `density` (kg/m^3) and node coordinates `coords` (m).
    pub fn element_mass(&self, coords: &[[f64; 3]], density: f64, out: &mut [f64]) {
        let npe = self.kind.nodes_per_element();
        let n = 3 * npe;
        let jac = AffineJacobian::new(self.kind, coords);
        let mut det = [0.0; CUBIC_POINTS];
        for (d, &p) in det.iter_mut().zip(&self.points) {
            *d = density * det3(&jac.at(p));
        }
        let out = &mut out[..n * n];
        out.fill(0.0);
        for a in 0..npe {
            for b in a..npe {
                let w =
                    &self.weights[(a * npe + b) * CUBIC_POINTS..(a * npe + b + 1) * CUBIC_POINTS];
                let v: f64 = w.iter().zip(&det).map(|(x, y)| x * y).sum();
                for i in 0..3 {
                    out[(3 * a + i) * n + 3 * b + i] = v;
                    out[(3 * b + i) * n + 3 * a + i] = v;
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cubic_lagrange_basis_is_nodal_and_a_partition_of_unity() {
        // Products of small rationals: exact to a few ulp (1e-14).
        let alphas = cubic_multi_indices();
        assert_eq!(alphas.len(), CUBIC_POINTS);
        for (j, &aj) in alphas.iter().enumerate() {
            let l = aj.map(|v| v as f64 / 3.0);
            for (i, &ai) in alphas.iter().enumerate() {
                let e = if i == j { 1.0 } else { 0.0 };
                assert!((cubic_lagrange(ai, l) - e).abs() < 1e-14);
            }
        }
        let l = [0.1, 0.2, 0.3, 0.4];
        let s: f64 = alphas.iter().map(|&a| cubic_lagrange(a, l)).sum();
        assert!((s - 1.0).abs() < 1e-14);
    }
}
