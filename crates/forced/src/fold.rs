//! Where the response curve turns (DESIGN §10.5): a fold lies between two consecutive points
//! whose unit tangents have swept-parameter components of opposite signs. The tangent is the
//! exact one of the harmonic-balance equations at each point (`ForcedSolver::tangent`) and the
//! continuation accepts a step only when it turned by less than `MAX_TURN`, so a sign change is
//! the curve turning, not a corner of a sampled law nor a hop between branches. The fold's
//! parameter is the extremum of the cubic Hermite interpolant of the parameter along the arc
//! length between the two points, which uses both tangents (third-order accurate in the step).

/// A fold between two points a and b (scaled parameter P = p / p_ref, its derivatives dP/ds
/// along the unit tangents `slope_a`, `slope_b`, and the scaled distance `ds` between them):
/// the fraction u in [0, 1] of the way from a to b and the scaled parameter there, when the
/// slopes differ in sign.
pub(crate) fn fold_between(
    (pa, slope_a): (f64, f64),
    (pb, slope_b): (f64, f64),
    ds: f64,
) -> Option<(f64, f64)> {
    if slope_a * slope_b >= 0.0 || !(ds.is_finite() && ds > 0.0) {
        return None;
    }
    let (ma, mb) = (ds * slope_a, ds * slope_b);
    // H(u) = h00 pa + h10 ma + h01 pb + h11 mb; H'(u) = A u^2 + B u + C.
    let a = 6.0 * pa + 3.0 * ma - 6.0 * pb + 3.0 * mb;
    let b = -6.0 * pa - 4.0 * ma + 6.0 * pb - 2.0 * mb;
    let c = ma;
    let roots: Vec<f64> = if a.abs() < 1e-14 * (b.abs() + c.abs()) {
        vec![-c / b]
    } else {
        let disc = (b * b - 4.0 * a * c).max(0.0).sqrt();
        vec![(-b - disc) / (2.0 * a), (-b + disc) / (2.0 * a)]
    };
    // H' changes sign on [0, 1] (ma and mb differ in sign): one root lies inside.
    let u = roots
        .into_iter()
        .filter(|u| u.is_finite() && (-1e-12..=1.0 + 1e-12).contains(u))
        .min_by(|x, y| (x - 0.5).abs().total_cmp(&(y - 0.5).abs()))?
        .clamp(0.0, 1.0);
    let (h00, h10) = (
        2.0 * u.powi(3) - 3.0 * u * u + 1.0,
        u.powi(3) - 2.0 * u * u + u,
    );
    let (h01, h11) = (-2.0 * u.powi(3) + 3.0 * u * u, u.powi(3) - u * u);
    Some((u, h00 * pa + h10 * ma + h01 * pb + h11 * mb))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_fold_of_a_circle_is_its_rightmost_point() {
        // Points on the unit circle P = cos(s), the curve turning at s = 0 (P = 1): two points
        // at s = -0.3 and s = 0.2 with slopes dP/ds = -sin(s).
        let (sa, sb) = (-0.3_f64, 0.2_f64);
        let ds = 2.0 * ((sb - sa) / 2.0).sin(); // chord
        let (u, p) = fold_between((sa.cos(), -sa.sin()), (sb.cos(), -sb.sin()), ds).unwrap();
        assert!((p - 1.0).abs() < 1e-3, "fold at {p}");
        assert!((u - 0.6).abs() < 0.05, "u = {u}");
    }

    #[test]
    fn no_fold_without_a_sign_change() {
        assert!(fold_between((0.0, 0.5), (0.1, 0.4), 0.2).is_none());
        assert!(fold_between((0.0, 0.5), (0.1, -0.4), 0.0).is_none());
    }
}
