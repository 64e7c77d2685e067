//! The penalty law lambda = k (y - g0)_+ integrated exactly over one period of a series of the
//! full basis (DESIGN §10.9), instead of sampled on the time grid (Eqs. 18-19).
//!
//! Sampled (AFT), the harmonic-balance residual of a penalty law is continuous but its Jacobian
//! P diag(slope) E jumps by k / m each time a sample enters or leaves contact. Next to a lightly
//! damped resonance, where the linear part K - W^2 M + i W C is of order 2 zeta k, such a jump
//! turns the solution curve by a finite angle: the sampled curve is a polygon whose corners fold
//! back and forth (on a 1-DOF oscillator with kc = 100 k at 1 % damping, N = 20, m = 256: folds
//! every 0.02 in W/w, and a continuation that turns back at W/w = 1.48, short of the peak at
//! 1.605). Integrated exactly, the residual is continuously differentiable (its derivative
//! changes like the square root of the penetration where a contact phase appears) and its
//! curve has the folds of the problem and no others.
//!
//! With y(theta) = y_0 + sum_n (a_n cos n theta + b_n sin n theta), theta = W t, and the phases
//! where y > g0 the union of intervals [theta_1, theta_2] (switch instants located on the series
//! itself to round-off), the coefficients of the force are
//!
//! ```text
//! Lambda_p = w_p int_contact k (y - g0) phi_p dtheta = sum_q J_pq y_q - k g0 w_p int_contact phi_p,
//! J_pq     = k w_p int_contact phi_p phi_q dtheta                      (the exact Jacobian),
//! ```
//!
//! with phi_0 = 1, phi_{2n-1} = cos n theta, phi_{2n} = sin n theta, w_0 = 1 / (2 pi) and
//! w_p = 1 / pi (the analysis of `FullBasis`). Products of basis functions reduce to
//! cos(r theta) and sin(r theta), r = 0..2N, whose integrals over an interval are closed-form.
//! The boundary terms of d Lambda / d y vanish because y - g0 = 0 at the switches. Units: y and
//! g0 in the same length unit, k force per length; Lambda in force units.

use faer::{MatMut, MatRef};

use crate::full_basis::FullBasis;

/// Iterations of the safeguarded Newton search of a switch instant or an extremum (each one either a Newton
/// step inside the bracket or a bisection: 60 bisections reach round-off).
const SWITCH_ITERATIONS: usize = 80;

/// Locates the phases where a series exceeds a level: the series is bracketed on a uniform grid
/// of `grid` points per period (at least 4 (2N + 1), so that between two grid points the series
/// is close to its quadratic Taylor polynomial), a contact phase shorter than the grid spacing
/// is caught by the sign change of the derivative, and every switch is refined on the series
/// by Newton steps kept inside the bracket (bisection where a step would leave it).
#[derive(Clone, Copy, Debug)]
pub struct ContactPhases {
    grid: usize,
}

impl ContactPhases {
    /// A search on `grid` points per period (raised to 4 (2N + 1) for `harmonics` N).
    pub fn new(harmonics: usize, grid: usize) -> Self {
        Self {
            grid: grid.max(4 * (2 * harmonics + 1)),
        }
    }

    /// Points per period of the bracketing grid.
    pub fn grid(&self) -> usize {
        self.grid
    }

    /// The intervals [theta_1, theta_2] (radians, theta_1 in [0, 2 pi), theta_1 < theta_2 <=
    /// theta_1 + 2 pi) where `series` > `level`, in increasing theta_1; one interval [0, 2 pi]
    /// when it never drops to the level. The grid values are summed here; see
    /// [`ContactPhases::above_sampled`] when they are at hand.
    pub fn above(&self, series: &[f64], level: f64) -> Vec<(f64, f64)> {
        let h = std::f64::consts::TAU / self.grid as f64;
        let (values, slopes): (Vec<f64>, Vec<f64>) = (0..self.grid)
            .map(|k| FullBasis::value_and_slope_at(series, k as f64 * h))
            .unzip();
        self.above_sampled(series, &values, &slopes, level)
    }

    /// [`ContactPhases::above`] from the series' values and phase derivatives on the uniform
    /// grid theta_k = 2 pi k / m, k < m (m = `values.len()`, at least the search's grid).
    pub fn above_sampled(
        &self,
        series: &[f64],
        values: &[f64],
        slopes: &[f64],
        level: f64,
    ) -> Vec<(f64, f64)> {
        let m = values.len();
        debug_assert!(m >= self.grid && slopes.len() == m);
        let f = |th: f64| FullBasis::value_at(series, th) - level;
        let h = std::f64::consts::TAU / m as f64;
        let at = |k: usize| {
            let k = if k == m { 0 } else { k };
            (values[k] - level, slopes[k])
        };
        // |y''| <= sum n^2 |c_n|: within h of a grid point the series lies within
        // |f'| h + curvature h^2 / 2 of its value there.
        let curvature: f64 = (1..=series.len() / 2)
            .map(|n| {
                let c =
                    series[FullBasis::cos_index(n)].abs() + series[FullBasis::sin_index(n)].abs();
                (n * n) as f64 * c
            })
            .sum();
        let may_cross = |fa: f64, da: f64| fa.abs() <= da.abs() * h + 0.5 * curvature * h * h;
        // Every phase lies within h / 2 of a grid point, where the series is at most
        // |f'| h / 2 + curvature h^2 / 8 above its value there: a row that stays below by more
        // than that everywhere never touches (most rows at most points of a curve), and the
        // scan below would find no switch either.
        let highest = values.iter().fold(f64::NEG_INFINITY, |a, &v| a.max(v)) - level;
        let steepest = slopes.iter().fold(0.0_f64, |a, &d| a.max(d.abs()));
        if highest + 0.5 * steepest * h + 0.125 * curvature * h * h < 0.0 {
            return Vec::new();
        }
        let mut switches: Vec<(f64, bool)> = Vec::new();
        let (mut fa, mut da) = at(0);
        for k in 1..=m {
            let (a, b) = ((k - 1) as f64 * h, k as f64 * h);
            let (fb, db) = at(k);
            if (fa > 0.0) != (fb > 0.0) {
                switches.push((switch_between(series, level, (a, fa), (b, fb)), fb > 0.0));
            } else if da.signum() != db.signum() && da != 0.0 && db != 0.0 && may_cross(fa, da) {
                // An extremum between the grid points on the same side of the level: a short
                // excursion across it when the extremum's value has the other sign.
                let t = safeguarded_root(
                    |th| FullBasis::slope_and_curvature_at(series, th),
                    (a, da > 0.0),
                    b,
                );
                let ft = f(t);
                if (ft > 0.0) != (fa > 0.0) {
                    switches.push((switch_between(series, level, (a, fa), (t, ft)), fa <= 0.0));
                    switches.push((switch_between(series, level, (t, ft), (b, fb)), fa > 0.0));
                }
            }
            (fa, da) = (fb, db);
        }
        intervals(&switches, values[0] - level > 0.0)
    }
}

/// The phase in [a, b] where the series crosses `level`, given y - level at both ends (of
/// different signs), to round-off ([`safeguarded_root`]).
fn switch_between(series: &[f64], level: f64, (a, fa): (f64, f64), (b, _): (f64, f64)) -> f64 {
    safeguarded_root(
        |t| {
            let (v, d) = FullBasis::value_and_slope_at(series, t);
            (v - level, d)
        },
        (a, fa > 0.0),
        b,
    )
}

/// A root in [a, b] of a function g given with its derivative (`g_and_slope`), of sign
/// `positive_at_a` at a and the other at b: Newton steps, each kept inside the shrinking
/// bracket (a bisection where a step would leave it), to round-off. Used for the switches (g
/// the series minus the level) and for an extremum between two grid points (g its slope): a
/// few evaluations where a bisection to round-off takes 60.
fn safeguarded_root(
    g_and_slope: impl Fn(f64) -> (f64, f64),
    (mut a, positive_at_a): (f64, bool),
    mut b: f64,
) -> f64 {
    let mut t = 0.5 * (a + b);
    for _ in 0..SWITCH_ITERATIONS {
        let (v, d) = g_and_slope(t);
        if v == 0.0 {
            return t;
        }
        if (v > 0.0) == positive_at_a {
            a = t;
        } else {
            b = t;
        }
        let newton = t - v / d;
        let next = if d != 0.0 && newton > a && newton < b {
            newton
        } else {
            0.5 * (a + b)
        };
        if (next - t).abs() <= 4.0 * f64::EPSILON * t.abs().max(1.0) || b - a <= f64::EPSILON {
            return next;
        }
        t = next;
    }
    t
}

/// The intervals above the level from the ordered switches (`true`: entering), the level being
/// exceeded at theta = 0 when `above_at_zero`.
fn intervals(switches: &[(f64, bool)], above_at_zero: bool) -> Vec<(f64, f64)> {
    let tau = std::f64::consts::TAU;
    if switches.is_empty() {
        return if above_at_zero {
            vec![(0.0, tau)]
        } else {
            Vec::new()
        };
    }
    let mut out = Vec::new();
    let mut open: Option<f64> = None;
    let mut wrapped_exit: Option<f64> = None;
    for &(th, entering) in switches {
        match (entering, open) {
            (true, _) => open = Some(th),
            (false, Some(start)) => {
                out.push((start, th));
                open = None;
            }
            // The first exit of a series above the level at theta = 0: the interval started
            // before the period's end.
            (false, None) => wrapped_exit = Some(th),
        }
    }
    match (open, wrapped_exit) {
        (Some(start), Some(exit)) => out.push((start, exit + tau)),
        (Some(start), None) => out.push((start, tau)),
        (None, Some(exit)) => out.insert(0, (0.0, exit)),
        (None, None) => {}
    }
    out.sort_by(|a, b| a.0.total_cmp(&b.0));
    out
}

/// Closed-form integrals of cos(r theta) and sin(r theta), r = 0..2N, over one interval.
struct TrigMoments {
    cos: Vec<f64>,
    sin: Vec<f64>,
}

impl TrigMoments {
    fn over(harmonics: usize, (a, b): (f64, f64)) -> Self {
        let orders = 2 * harmonics + 1;
        let mut cos = vec![0.0; orders];
        let mut sin = vec![0.0; orders];
        cos[0] = b - a;
        // sin(r a), cos(r a) (and at b) by angle addition from one sin_cos each, as
        // `FullBasis::value_at` does: a rounding error of order r eps against 4N calls of
        // sin_cos per interval (the exact law evaluates these at every residual).
        let ((s1a, c1a), (s1b, c1b)) = (a.sin_cos(), b.sin_cos());
        let ((mut sa, mut ca), (mut sb, mut cb)) = ((s1a, c1a), (s1b, c1b));
        for r in 1..orders {
            let rf = r as f64;
            cos[r] = (sb - sa) / rf;
            sin[r] = (ca - cb) / rf;
            (sa, ca) = (sa * c1a + ca * s1a, ca * c1a - sa * s1a);
            (sb, cb) = (sb * c1b + cb * s1b, cb * c1b - sb * s1b);
        }
        Self { cos, sin }
    }

    /// int sin(r theta) for any integer r.
    fn s(&self, r: isize) -> f64 {
        let v = self.sin[r.unsigned_abs()];
        if r < 0 {
            -v
        } else {
            v
        }
    }

    /// Adds int phi_p over the interval, p = 0..2N (basis functions of `FullBasis`), to
    /// `out`.
    fn add_singles(&self, out: &mut [f64]) {
        out[0] += self.cos[0];
        for n in 1..=self.cos.len() / 2 {
            out[FullBasis::cos_index(n)] += self.cos[n];
            out[FullBasis::sin_index(n)] += self.sin[n];
        }
    }

    /// Adds int phi_p phi_q over the interval to `out` ((2N + 1)^2, column-major), from cos a
    /// cos b = (cos(a - b) + cos(a + b)) / 2 and its siblings, harmonic pair by harmonic pair.
    fn add_products(&self, out: &mut [f64]) {
        let harmonics = self.cos.len() / 2;
        let t = 2 * harmonics + 1;
        out[0] += self.cos[0];
        for n in 1..=harmonics {
            for (p, v) in [
                (FullBasis::cos_index(n), self.cos[n]),
                (FullBasis::sin_index(n), self.sin[n]),
            ] {
                out[p] += v;
                out[p * t] += v;
            }
        }
        for j in 1..=harmonics {
            let (qc, qs) = (FullBasis::cos_index(j), FullBasis::sin_index(j));
            let (column_c, column_s) = out[qc * t..(qs + 1) * t].split_at_mut(t);
            for i in 1..=harmonics {
                let (pc, ps) = (FullBasis::cos_index(i), FullBasis::sin_index(i));
                let (minus, plus) = (self.cos[i.abs_diff(j)], self.cos[i + j]);
                let (ii, jj) = (i as isize, j as isize);
                column_c[pc] += 0.5 * (minus + plus);
                column_s[ps] += 0.5 * (minus - plus);
                column_s[pc] += 0.5 * (self.s(jj + ii) + self.s(jj - ii));
                column_c[ps] += 0.5 * (self.s(ii + jj) + self.s(ii - jj));
            }
        }
    }
}

/// The analysis weight w_p of coefficient p (1 / (2 pi) for the mean, 1 / pi otherwise).
fn weight(p: usize) -> f64 {
    if p == 0 {
        0.5 / std::f64::consts::PI
    } else {
        1.0 / std::f64::consts::PI
    }
}

/// One contact row's penalty force integrated exactly (module docs) over the phases `contact`
/// where the row touches ([`ContactPhases::above`]): its coefficients Lambda (2N + 1, force
/// units). When `jacobian` is given ((2N+1)^2), J = d Lambda / d y is written into it (zero when
/// the row never touches).
pub fn penalty_force(
    contact: &[(f64, f64)],
    series: &[f64],
    gap: f64,
    stiffness: f64,
    jacobian: Option<MatMut<'_, f64>>,
) -> Vec<f64> {
    let terms = series.len();
    let harmonics = terms / 2;
    if contact.is_empty() {
        if let Some(mut out) = jacobian {
            out.fill(0.0);
        }
        return vec![0.0; terms];
    }
    // J column-major in one buffer: the exact law fills it at every residual of every row in
    // contact, (2N + 1)^2 entries, and indexed through a matrix view that cost half the fill.
    let mut j = vec![0.0; terms * terms];
    let mut offset = vec![0.0; terms];
    for &interval in contact {
        let moments = TrigMoments::over(harmonics, interval);
        moments.add_products(&mut j);
        moments.add_singles(&mut offset);
    }
    let scale: Vec<f64> = (0..terms).map(|p| stiffness * weight(p)).collect();
    let mut force = vec![0.0; terms];
    for (column, &yq) in j.chunks_exact_mut(terms).zip(series) {
        for ((v, f), &k) in column.iter_mut().zip(force.iter_mut()).zip(&scale) {
            *v *= k;
            *f += *v * yq;
        }
    }
    for (p, f) in force.iter_mut().enumerate() {
        *f -= offset[p] * (scale[p] * gap);
    }
    if let Some(mut out) = jacobian {
        out.copy_from(MatRef::from_column_major_slice(&j, terms, terms));
    }
    force
}

#[cfg(test)]
mod tests {
    use super::*;
    use faer::Mat;

    /// A series that crosses the level twice per period, with one short excursion.
    fn series() -> Vec<f64> {
        // y = 0.2 + cos t + 0.3 sin 2t - 0.05 cos 3t + 0.12 sin 3t
        vec![0.2, 1.0, 0.0, 0.0, 0.3, -0.05, 0.12]
    }

    /// The coefficients by a midpoint rule on `n` points (second order in 1 / n for a law with
    /// kinks).
    fn quadrature(y: &[f64], gap: f64, k: f64, n: usize) -> Vec<f64> {
        let h = std::f64::consts::TAU / n as f64;
        (0..y.len())
            .map(|p| {
                (0..n)
                    .map(|i| {
                        let th = (i as f64 + 0.5) * h;
                        let lam = k * (FullBasis::value_at(y, th) - gap).max(0.0);
                        let phi = match p {
                            0 => 1.0,
                            _ if p % 2 == 1 => (FullBasis::harmonic_of(p) as f64 * th).cos(),
                            _ => (FullBasis::harmonic_of(p) as f64 * th).sin(),
                        };
                        lam * phi * h * weight(p)
                    })
                    .sum()
            })
            .collect()
    }

    #[test]
    fn coefficients_match_a_fine_quadrature_for_many_levels() {
        let y = series();
        let phases = ContactPhases::new(3, 0);
        for gap in [-2.0, -0.1, 0.3, 0.9, 1.2, 1.35, 5.0] {
            let exact = penalty_force(&phases.above(&y, gap), &y, gap, 7.0, None);
            let fine = quadrature(&y, gap, 7.0, 400_000);
            for (a, b) in exact.iter().zip(&fine) {
                // Midpoint error at the kinks: O(k h^2) = 7 (1.6e-5)^2, far below 1e-8.
                assert!((a - b).abs() < 1e-8, "gap {gap}: {a} vs {b}");
            }
        }
    }

    #[test]
    fn the_jacobian_is_the_derivative_of_the_coefficients() {
        let y = series();
        let phases = ContactPhases::new(3, 0);
        let t = y.len();
        for gap in [0.3, 0.9, 1.2] {
            let mut j = Mat::zeros(t, t);
            let f0 = penalty_force(&phases.above(&y, gap), &y, gap, 3.0, Some(j.as_mut()));
            for q in 0..t {
                let h = 1e-7;
                let (mut up, mut down) = (y.clone(), y.clone());
                up[q] += h;
                down[q] -= h;
                let fu = penalty_force(&phases.above(&up, gap), &up, gap, 3.0, None);
                let fd = penalty_force(&phases.above(&down, gap), &down, gap, 3.0, None);
                for p in 0..t {
                    let fd_pq = (fu[p] - fd[p]) / (2.0 * h);
                    assert!(
                        (fd_pq - j[(p, q)]).abs() < 1e-6 * (1.0 + j[(p, q)].abs()),
                        "gap {gap} ({p}, {q}): {fd_pq} vs {}",
                        j[(p, q)]
                    );
                }
            }
            assert!(f0.iter().all(|v| v.is_finite()));
        }
    }

    #[test]
    fn a_contact_shorter_than_the_grid_is_found() {
        // y = (1/8) sum_{n=1..8} cos n (theta - theta0): a peak of 1 at theta0, half-way between
        // the first two grid points (spacing 2 pi / 68), where y ~ 1 - 12.75 (theta - theta0)^2.
        // Above 0.99 only for |theta - theta0| < 0.028: both grid points around it are below.
        let spacing = std::f64::consts::TAU / 68.0;
        let theta0 = 0.5 * spacing;
        let mut y = vec![0.0; 17];
        for n in 1..=8 {
            let (s, c) = (n as f64 * theta0).sin_cos();
            y[FullBasis::cos_index(n)] = c / 8.0;
            y[FullBasis::sin_index(n)] = s / 8.0;
        }
        let phases = ContactPhases::new(8, 0);
        let contact = phases.above(&y, 0.99);
        assert_eq!(contact.len(), 1, "{contact:?}");
        let (a, b) = contact[0];
        assert!(
            a > 0.0 && b < spacing && a < theta0 && b > theta0,
            "{a} {b}"
        );
        for th in [a, b] {
            assert!((FullBasis::value_at(&y, th) - 0.99).abs() < 1e-12);
        }
        // The same bump centred on theta = 0 wraps around the period's start.
        let mut centred = vec![0.0; 17];
        for n in 1..=8 {
            centred[FullBasis::cos_index(n)] = 1.0 / 8.0;
        }
        let wrapped = phases.above(&centred, 0.99);
        assert_eq!(wrapped.len(), 1, "{wrapped:?}");
        assert!(wrapped[0].0 > 6.0 && wrapped[0].1 > std::f64::consts::TAU);
    }

    /// Levels just below and just above a series' maximum, which lies between grid points:
    /// wherever a fine sampling sees the series above the level a contact phase is found (the
    /// search's early return for rows that stay below is never taken then), and none where
    /// the level is above the maximum.
    #[test]
    fn levels_next_to_the_maximum_between_grid_points() {
        let phases = ContactPhases::new(8, 0);
        for shift in [0.13, 0.5, 0.91] {
            let theta0 = shift * std::f64::consts::TAU / phases.grid() as f64;
            let mut y = vec![0.0; 17];
            for n in 1..=8 {
                let (s, c) = (n as f64 * theta0).sin_cos();
                y[FullBasis::cos_index(n)] = c / (8.0 * n as f64);
                y[FullBasis::sin_index(n)] = s / (8.0 * n as f64);
            }
            let fine = 200_000;
            let top = (0..fine)
                .map(|i| FullBasis::value_at(&y, i as f64 * std::f64::consts::TAU / fine as f64))
                .fold(f64::NEG_INFINITY, f64::max);
            for margin in [1e-3, 1e-5, 1e-8] {
                let below = phases.above(&y, top - margin);
                assert!(!below.is_empty(), "shift {shift}, {margin:e} below the top");
                let above = phases.above(&y, top + margin);
                assert!(
                    above.is_empty(),
                    "shift {shift}, {margin:e} above: {above:?}"
                );
            }
        }
    }

    #[test]
    fn a_series_always_above_or_below_the_level() {
        let y = vec![1.0, 0.1, 0.0];
        let phases = ContactPhases::new(1, 0);
        assert_eq!(phases.above(&y, 0.5), vec![(0.0, std::f64::consts::TAU)]);
        assert!(phases.above(&y, 2.0).is_empty());
        // Always in contact: the force is the linear law k (y - g0), coefficient by coefficient.
        let f = penalty_force(&phases.above(&y, 0.5), &y, 0.5, 2.0, None);
        assert!((f[0] - 1.0).abs() < 1e-14 && (f[1] - 0.2).abs() < 1e-14 && f[2].abs() < 1e-14);
    }
}
