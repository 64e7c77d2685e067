//! Quadrature rules on the reference tetrahedron (0,0,0), (1,0,0), (0,1,0), (0,0,1).
//!
//! Weights sum to the reference volume 1/6. All rules here have positive weights and interior
//! points. Which rule the elements use, and why, is in [`crate::element`].

use crate::gauss_jacobi::gauss_jacobi;

/// A quadrature rule on the reference tetrahedron.
#[derive(Clone, Debug, PartialEq)]
pub struct TetRule {
    /// Polynomial degree integrated exactly.
    pub degree: usize,
    /// Points in reference coordinates (xi, eta, zeta).
    pub points: Vec<[f64; 3]>,
    /// Weights (sum 1/6).
    pub weights: Vec<f64>,
}

/// Builds the points of a fully symmetric orbit from barycentric coordinates: all distinct
/// permutations of `bary`, converted to (xi, eta, zeta) = (L1, L2, L3).
fn orbit(bary: [f64; 4], weight: f64, points: &mut Vec<[f64; 3]>, weights: &mut Vec<f64>) {
    let mut seen: Vec<[f64; 4]> = Vec::new();
    let idx = [0usize, 1, 2, 3];
    for a in idx {
        for b in idx {
            for c in idx {
                for d in idx {
                    let mut used = [false; 4];
                    let mut ok = true;
                    for i in [a, b, c, d] {
                        if used[i] {
                            ok = false;
                        }
                        used[i] = true;
                    }
                    if !ok {
                        continue;
                    }
                    let p = [bary[a], bary[b], bary[c], bary[d]];
                    if !seen.contains(&p) {
                        seen.push(p);
                        points.push([p[1], p[2], p[3]]);
                        weights.push(weight);
                    }
                }
            }
        }
    }
}

impl TetRule {
    /// Number of points.
    pub fn len(&self) -> usize {
        self.points.len()
    }

    /// True when the rule has no points (never the case for the constructors here).
    pub fn is_empty(&self) -> bool {
        self.points.is_empty()
    }

    /// 1-point centroid rule, degree 1.
    pub fn centroid() -> Self {
        TetRule {
            degree: 1,
            points: vec![[0.25; 3]],
            weights: vec![1.0 / 6.0],
        }
    }

    /// 4-point rule, degree 2: barycentric (b, a, a, a) and permutations with
    /// a = (5 - sqrt 5) / 20, b = (5 + 3 sqrt 5) / 20, weights 1/24.
    pub fn four_point() -> Self {
        let s5 = 5f64.sqrt();
        let a = (5.0 - s5) / 20.0;
        let b = (5.0 + 3.0 * s5) / 20.0;
        let (mut points, mut weights) = (Vec::new(), Vec::new());
        orbit([b, a, a, a], 1.0 / 24.0, &mut points, &mut weights);
        TetRule {
            degree: 2,
            points,
            weights,
        }
    }

    /// 14-point rule, degree 5, all weights positive (Walkington 2000, "Quadrature on
    /// simplices of arbitrary dimension"; the same rule as Jaskowiec & Sukumar 2020).
    /// Orbits (a, a, a, 1 - 3a) for two values of a and (b, b, 1/2 - b, 1/2 - b).
    /// Constants solved to 25 digits from the moment equations with mpmath, rounded to f64.
    pub fn fourteen_point() -> Self {
        let a1 = 0.092_735_250_310_891_23;
        let a2 = 0.310_885_919_263_300_6;
        let b = 0.045_503_704_125_649_65;
        let w1 = 0.012_248_840_519_393_658;
        let w2 = 0.018_781_320_953_002_642;
        let w3 = 0.007_091_003_462_846_911;
        let (mut points, mut weights) = (Vec::new(), Vec::new());
        orbit([a1, a1, a1, 1.0 - 3.0 * a1], w1, &mut points, &mut weights);
        orbit([a2, a2, a2, 1.0 - 3.0 * a2], w2, &mut points, &mut weights);
        orbit([b, b, 0.5 - b, 0.5 - b], w3, &mut points, &mut weights);
        TetRule {
            degree: 5,
            points,
            weights,
        }
    }

    /// Conical-product (collapsed-coordinate, Stroud) rule exact to `degree`, with
    /// n = degree / 2 + 1 Gauss-Jacobi points per direction (n^3 points, positive weights).
    ///
    /// Map from the unit cube: xi = u, eta = v (1 - u), zeta = w (1 - u)(1 - v), whose
    /// Jacobian (1 - u)^2 (1 - v) is absorbed into Gauss-Jacobi weights (alpha = 2 in u,
    /// alpha = 1 in v, Gauss-Legendre in w). A polynomial of total degree p in (xi, eta, zeta)
    /// is of degree <= p in each of u, v, w, which n points integrate exactly when 2n - 1 >= p.
    pub fn conical_product(degree: usize) -> Self {
        let n = degree / 2 + 1;
        let (su, wu) = gauss_jacobi(n, 2);
        let (sv, wv) = gauss_jacobi(n, 1);
        let (sw, ww) = gauss_jacobi(n, 0);
        let mut points = Vec::with_capacity(n * n * n);
        let mut weights = Vec::with_capacity(n * n * n);
        for (i, &s_u) in su.iter().enumerate() {
            let u = 0.5 * (1.0 + s_u);
            for (j, &s_v) in sv.iter().enumerate() {
                let v = 0.5 * (1.0 + s_v);
                for (k, &s_w) in sw.iter().enumerate() {
                    let w = 0.5 * (1.0 + s_w);
                    points.push([u, v * (1.0 - u), w * (1.0 - u) * (1.0 - v)]);
                    weights.push(wu[i] / 8.0 * wv[j] / 4.0 * ww[k] / 2.0);
                }
            }
        }
        TetRule {
            degree: 2 * n - 1,
            points,
            weights,
        }
    }

    /// Applies the rule to `f` on the reference tetrahedron.
    pub fn integrate(&self, mut f: impl FnMut([f64; 3]) -> f64) -> f64 {
        self.points
            .iter()
            .zip(&self.weights)
            .map(|(&p, &w)| w * f(p))
            .sum()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn factorial(n: u32) -> f64 {
        (1..=n).map(f64::from).product()
    }

    /// Exact integral of xi^a eta^b zeta^c over the reference tetrahedron.
    fn exact(a: u32, b: u32, c: u32) -> f64 {
        factorial(a) * factorial(b) * factorial(c) / factorial(a + b + c + 3)
    }

    /// Largest relative error over all monomials of total degree `deg`.
    fn max_error_at_degree(rule: &TetRule, deg: u32) -> f64 {
        let mut worst: f64 = 0.0;
        for a in 0..=deg {
            for b in 0..=(deg - a) {
                let c = deg - a - b;
                let q = rule
                    .integrate(|p| p[0].powi(a as i32) * p[1].powi(b as i32) * p[2].powi(c as i32));
                let e = exact(a, b, c);
                worst = worst.max((q - e).abs() / e);
            }
        }
        worst
    }

    fn check(rule: &TetRule, claimed_degree: usize) {
        assert_eq!(rule.degree, claimed_degree);
        assert!(rule.weights.iter().all(|&w| w > 0.0), "non-positive weight");
        for p in &rule.points {
            let l0 = 1.0 - p[0] - p[1] - p[2];
            assert!(
                p.iter().all(|&x| x > 0.0) && l0 > 0.0,
                "point {p:?} not interior"
            );
        }
        // Exact up to the claimed degree: sums of <= 512 positive terms of size <= 1,
        // relative round-off a few 1e-15; 1e-13 is safe and far below any rule defect.
        for deg in 0..=claimed_degree as u32 {
            let err = max_error_at_degree(rule, deg);
            assert!(err < 1e-13, "degree {deg}: relative error {err}");
        }
        // and not beyond (otherwise the claimed degree understates it, or the test is blind).
        let err = max_error_at_degree(rule, claimed_degree as u32 + 1);
        assert!(
            err > 1e-8,
            "degree {} unexpectedly exact ({err})",
            claimed_degree + 1
        );
    }

    #[test]
    fn centroid_rule_is_degree_1() {
        check(&TetRule::centroid(), 1);
    }

    #[test]
    fn four_point_rule_is_degree_2() {
        let r = TetRule::four_point();
        assert_eq!(r.len(), 4);
        check(&r, 2);
    }

    #[test]
    fn fourteen_point_rule_is_degree_5() {
        let r = TetRule::fourteen_point();
        assert_eq!(r.len(), 14);
        check(&r, 5);
    }

    #[test]
    fn conical_product_rules_reach_their_degree() {
        for (asked, n) in [(3, 2), (7, 4), (9, 5), (15, 8)] {
            let r = TetRule::conical_product(asked);
            assert_eq!(r.len(), n * n * n);
            check(&r, 2 * n - 1);
        }
    }
}
