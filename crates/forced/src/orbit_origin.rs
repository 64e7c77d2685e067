//! A forced orbit seen from another time origin (issue 39, session 21; docs/ROTATION.md "The
//! casing study's N"): the casing study shoots the massless boundary of a point in contact from
//! the sample farthest from contact rather than from t = 0, where a casing at phase 0 strikes.
//! The orbit and its Floquet multipliers are the same from any origin.

use nlmodes_hb::FullBasis;

use crate::solver::ForcedPoint;

/// The orbit `point` seen from a time origin advanced by `j` of its m time samples (tau =
/// j T / m, theta = W tau = 2 pi j / m): every series' harmonic k turned by k theta, the samples
/// (contact forces, gaps, multipliers) rotated by j; the same periodic orbit, so the same
/// Floquet multipliers (the monodromy from t = tau is similar to the one from 0). Returns the
/// orbit and theta.
pub fn advanced_orbit(point: &ForcedPoint, j: usize) -> (ForcedPoint, f64) {
    let terms = 2 * point.harmonics + 1;
    let rows = point.contact.len() / terms;
    let m = point.contact_force.len() / rows.max(1);
    let theta = std::f64::consts::TAU * j as f64 / m.max(1) as f64;
    let turn = |series: &mut [f64]| {
        for k in 1..=point.harmonics {
            let (s, c) = (k as f64 * theta).sin_cos();
            let (a, b) = (
                series[FullBasis::cos_index(k)],
                series[FullBasis::sin_index(k)],
            );
            series[FullBasis::cos_index(k)] = a * c + b * s;
            series[FullBasis::sin_index(k)] = b * c - a * s;
        }
    };
    let rotate = |samples: &[f64], m: usize| -> Vec<f64> {
        (samples.chunks(m.max(1)))
            .flat_map(|row| (0..row.len()).map(move |i| row[(i + j) % row.len()]))
            .collect()
    };
    let mut out = point.clone();
    for i in 0..out.coefficients.nrows() {
        let mut series: Vec<f64> = (0..terms).map(|k| out.coefficients[(i, k)]).collect();
        turn(&mut series);
        (0..terms).for_each(|k| out.coefficients[(i, k)] = series[k]);
    }
    out.contact.chunks_mut(terms).for_each(turn);
    out.contact_force = rotate(&point.contact_force, m);
    out.gaps = rotate(&point.gaps, m);
    let mu = &point.multipliers;
    out.multipliers.theta = rotate(&mu.theta, mu.samples);
    out.multipliers.kappa = rotate(&mu.kappa, mu.samples);
    (out, theta)
}

/// The time sample of `point` farthest from contact (the largest clearance of its most
/// penetrating row: argmin over samples j of max over rows of g_j; g = A u - g(t) > 0 in
/// contact), where its state is smooth: the origin from which the massless boundary is shot.
pub fn most_open_sample(point: &ForcedPoint) -> usize {
    let terms = 2 * point.harmonics + 1;
    let rows = (point.contact.len() / terms).max(1);
    let m = point.gaps.len() / rows;
    (0..m)
        .map(|j| {
            let deepest = (0..rows)
                .map(|r| point.gaps[r * m + j])
                .fold(f64::MIN, f64::max);
            (j, deepest)
        })
        .min_by(|a, b| a.1.total_cmp(&b.1))
        .map_or(0, |(j, _)| j)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::distortion::CasingDistortion;

    /// An orbit advanced by j of its m samples is the same orbit seen from t = j T / m: every
    /// series evaluated at theta equals the original at theta + 2 pi j / m, the samples rotate,
    /// the casing's intrusion at theta is the original's at theta + 2 pi j / m, and the
    /// sample farthest from contact is the one of the largest clearance.
    #[test]
    fn an_advanced_orbit_is_the_same_orbit_from_a_later_origin() {
        let (n, m, rows) = (3, 8, 2);
        let terms = 2 * n + 1;
        let series = |seed: f64| -> Vec<f64> {
            (0..terms).map(|k| (seed + 0.37 * k as f64).sin()).collect()
        };
        let contact: Vec<f64> = [series(0.1), series(0.9)].concat();
        let gaps: Vec<f64> = (0..rows * m)
            .map(|i| if i % m == 5 { -2.0 } else { 0.1 * i as f64 })
            .collect();
        let point = ForcedPoint {
            omega: 3.0,
            level: 1.0,
            coefficients: faer::Mat::from_fn(2, terms, |i, k| series(2.0 + i as f64)[k]),
            contact,
            contact_force: (0..rows * m).map(|i| i as f64).collect(),
            gaps,
            multipliers: nlmodes_hb::Multipliers::uniform(&[1.0, 2.0], m),
            powell_measure: 0.0,
            inner_solves: 0,
            newton_iterations: 0,
            harmonics: n,
            touching: true,
            harmonic_check: crate::harmonic_check::HarmonicCheck::Unchecked,
        };
        assert_eq!(most_open_sample(&point), 5);
        let j = 3;
        let (later, theta) = advanced_orbit(&point, j);
        let tau = std::f64::consts::TAU * j as f64 / m as f64;
        assert!((theta - tau).abs() < 1e-15);
        for q in 0..40 {
            let th = 0.17 * q as f64;
            for r in 0..rows {
                let (a, b) = (
                    &later.contact[r * terms..(r + 1) * terms],
                    &point.contact[r * terms..(r + 1) * terms],
                );
                let d = FullBasis::value_at(a, th) - FullBasis::value_at(b, th + tau);
                assert!(d.abs() < 1e-13, "{d}");
                let row = |c: &faer::Mat<f64>| (0..terms).map(|k| c[(r, k)]).collect::<Vec<_>>();
                let d = FullBasis::value_at(&row(&later.coefficients), th)
                    - FullBasis::value_at(&row(&point.coefficients), th + tau);
                assert!(d.abs() < 1e-13, "{d}");
            }
            let casing = CasingDistortion {
                harmonic: 2,
                amplitude: 1e-4,
                phase: 0.4,
            };
            let d = casing.advanced(theta).intrusion_at(th) - casing.intrusion_at(th + tau);
            assert!(d.abs() < 1e-18, "{d}");
        }
        assert_eq!(later.contact_force[0], point.contact_force[j]);
        assert_eq!(
            later.contact_force[m + m - 1],
            point.contact_force[m + (m - 1 + j) % m]
        );
        assert_eq!(later.gaps[m + 2], point.gaps[m + 5]);
    }
}
