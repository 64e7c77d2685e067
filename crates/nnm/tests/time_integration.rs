//! docs/DESIGN.md §5: a computed orbit, integrated in time (RK4, penalty contact law, no harmonic balance)
//! from its own t = 0 state, comes back to itself after one period T = 2 pi / w.

mod common;

use nlmodes_nnm::{
    backbone, check_periodicity, AlgorithmParams, ContactMethod, ContinuationSettings,
    HarmonicSettings,
};

const KC: f64 = 0.3;

/// Periodicity errors (displacement, velocity) of the penalty backbone point closest to q = 2.5
/// gaps, for N harmonics.
fn errors(harmonics: usize) -> (f64, f64, f64) {
    // 3 unit masses, unit springs, wall on the left, contact on the free end (mass 2, also the
    // master), penalty kc = 0.3. Its main branch rises from w/w1 = 1 to about 1.08 at q = 2.5
    // gaps; the 4:1 tongue with mode 3 near w = 1.0125 w1 is followed as a branch of its own.
    let sys = common::chain(3, 1.0, &[2], 1.0, 2);
    let settings = HarmonicSettings::with_default_samples(harmonics).expect("settings");
    let params = AlgorithmParams {
        method: ContactMethod::Penalty { stiffness: KC },
        ..AlgorithmParams::default()
    };
    let cont = ContinuationSettings {
        q_start: 0.5,
        q_max: 2.5,
        step: 0.1,
        max_step: 0.5,
        ..ContinuationSettings::default()
    };
    let b = backbone(&sys, settings, params, &cont, |_| {}).expect("backbone");
    assert_eq!(b.termination, nlmodes_nnm::Termination::ReachedMaxAmplitude);
    // The main branch has no fold (the tongue near w3 / 4 = 1.0125 w1 is a branch of its own).
    assert!(b.points.iter().filter(|p| p.branch == 1).all(|p| !p.fold));
    let p = b.points.last().expect("points");
    assert!(p.contact_fraction[0] > 0.05, "contact expected");
    // RK4 with 40000 steps per period: h w_max ~ 2e-3 (w_max ~ 1.9 rad/s with the penalty), so
    // the integration error (~(h w_max)^4 per period, ~1e-11) is negligible against the harmonic
    // truncation error measured here.
    let chk = check_periodicity(&sys, &[KC], p, 40_000).expect("integration");
    (chk.displacement_error, chk.velocity_error, p.omega_ratio)
}

#[test]
fn penalty_orbit_returns_to_its_start_after_one_period() {
    let (du8, dv8, _) = errors(8);
    let (du64, dv64, w) = errors(64);
    println!("N = 8: du = {du8:.2e}, dv = {dv8:.2e}; N = 64: du = {du64:.2e}, dv = {dv64:.2e}, w/w1 = {w:.5}");
    // The penalty force has a slope jump at contact onset: coefficients of u decay like n^-4, of
    // u' like n^-3, and the sampled contact onset is located to O(1/m): the mismatch after one
    // period falls with N (m = 8N). Observed: 1.7e-4 / 4.0e-4 at N = 8, 8.5e-7 / 2.0e-6 at N = 64
    // (relative to max |u(0)| and to w max |u(0)|), unchanged when the RK4 steps are doubled, so
    // the integrator does not limit them. Tolerances: 5e-6 and 1e-5 at N = 64, and a decrease by
    // at least 50x from N = 8 to N = 64.
    assert!(
        du64 <= 5e-6 && dv64 <= 1e-5,
        "N = 64: du = {du64}, dv = {dv64}"
    );
    assert!(
        du64 * 50.0 <= du8 && dv64 * 50.0 <= dv8,
        "no convergence with N: {du8} -> {du64}, {dv8} -> {dv64}"
    );
}

#[test]
fn integrator_keeps_a_linear_mode_periodic_and_rejects_unstable_steps() {
    // Below grazing the exact orbit is the linear mode: RK4 error only.
    let sys = common::chain(3, 1.0, &[2], 10.0, 2);
    let w1 = sys.linear_frequencies()[0];
    let phi = sys.linear_mode(0).expect("mode");
    let state = nlmodes_nnm::MotionState {
        u: phi.clone(),
        v: vec![0.0; 3],
    };
    let t = 2.0 * std::f64::consts::PI / w1;
    let end = nlmodes_nnm::integrate_penalty(&sys, &[KC], &state, t, 10_000).expect("integrate");
    // h w_max = 2 pi (w3 / w1) / 1e4 ~ 2.5e-3: RK4 phase error ~ (h w)^4 / 120 per step, ~1e-12
    // over the period; 1e-9 leaves margin for round-off.
    for (u, ph) in end.u.iter().zip(&phi) {
        assert!((u - ph).abs() <= 1e-9, "{:?}", end.u);
    }
    // 10 steps over a period: h w_max ~ 2.7 > 2.5, refused with a clear error.
    let err = nlmodes_nnm::integrate_penalty(&sys, &[KC], &state, t, 10).expect_err("too large");
    assert!(
        matches!(err, nlmodes_nnm::NnmError::StepTooLarge { .. }),
        "{err}"
    );
}
