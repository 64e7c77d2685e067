//! docs/DESIGN.md §5: below grazing every solution is the linear mode, w = w_1 to solver tolerance.

mod common;

use nlmodes_nnm::{AlgorithmParams, HarmonicSettings, Solver, Start};

#[test]
fn below_grazing_the_orbit_is_the_linear_mode() {
    // 6-mass chain, contact rows on masses 5 and 3, master mass 1.
    let sys = common::chain(6, 1.0, &[5, 3], 1.0, 1);
    let qg = sys
        .grazing_amplitude(0)
        .expect("mode 0")
        .expect("contact rows move");
    let w1 = sys.linear_frequencies()[0];
    let phi = sys.linear_mode(0).expect("mode");
    let settings = HarmonicSettings::with_default_samples(8).expect("settings");
    for mode_start in [true, false] {
        let mut solver = Solver::new(&sys, settings, AlgorithmParams::default()).expect("solver");
        let mut prev = None;
        for f in [0.2, 0.6, 0.99] {
            let q = f * qg;
            // From the linear mode itself, and warm-started from a point at another amplitude
            // (scaled by Newton to the new q).
            let p = match (&prev, mode_start) {
                (Some(pp), false) => solver.solve_point(q, Start::Point(pp)),
                _ => solver.solve_point(q, Start::LinearMode(0)),
            }
            .expect("linear point");
            // Tolerance 1e-10: the Newton tolerance (1e-10 relative residual) bounds the error of
            // a well-conditioned linear solve at that level.
            assert!(
                (p.omega - w1).abs() <= 1e-10 * w1,
                "w = {}, w1 = {w1}",
                p.omega
            );
            let scale = q / phi[sys.master()];
            for (i, &ph) in phi.iter().enumerate() {
                assert!(
                    (p.coefficients[1][i] - scale * ph).abs() <= 1e-10 * q,
                    "dof {i}"
                );
            }
            for (n, u) in p.coefficients.iter().enumerate() {
                if n != 1 {
                    assert!(
                        u.iter().all(|v| v.abs() <= 1e-10 * q),
                        "harmonic {n}: {u:?}"
                    );
                }
            }
            assert!(p.contact_fraction.iter().all(|&c| c == 0.0));
            assert!(p.max_gap_overall < 0.0);
            // Energy of the linear mode: (1/2) w1^2 (q / phi_m)^2 for a mass-normalized mode.
            let energy = 0.5 * w1 * w1 * scale * scale;
            assert!((p.energy - energy).abs() <= 1e-10 * energy);
            prev = Some(p);
        }
    }
}

#[test]
fn a_system_without_contact_rows_is_linear_at_any_amplitude() {
    let sys = nlmodes_nnm::System::new(
        faer::Mat::from_fn(2, 2, |i, j| if i == j { 1.0 } else { 0.0 }),
        faer::Mat::from_fn(2, 2, |i, j| [[2.0, -1.0], [-1.0, 2.0]][i][j]),
        faer::Mat::<f64>::zeros(0, 2),
        Vec::new(),
        0,
    )
    .expect("no contact rows");
    assert_eq!(sys.grazing_amplitude(0).expect("mode"), None);
    let settings = HarmonicSettings::with_default_samples(4).expect("settings");
    let cont = nlmodes_nnm::ContinuationSettings {
        q_max: 3.0,
        ..Default::default()
    };
    let b = nlmodes_nnm::backbone(&sys, settings, AlgorithmParams::default(), &cont, |_| {})
        .expect("backbone");
    assert_eq!(b.termination, nlmodes_nnm::Termination::ReachedMaxAmplitude);
    // w1 = 1 for K = [[2,-1],[-1,2]], M = I; Newton tolerance 1e-10 bounds the error.
    assert!(b
        .points
        .iter()
        .all(|p| (p.omega_ratio - 1.0).abs() <= 1e-10 && p.powell_measure == 0.0));
}
