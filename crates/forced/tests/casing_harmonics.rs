//! N converged point by point in the casing-distortion sweep (`casing_sweep` under
//! `SpeedHarmonics::Retrace`; docs/ROTATION.md "The casing study's N", issue 39 session 21).
//!
//! The 3-DOF system of `distortion.rs` at rest (gap 0.5, contact row 0.2 x0 + x2, master x2,
//! 2 % modal damping, kc = 10 x the static contact stiffness, no load) at W = 0.7 w1, a casing
//! intrusion delta from 0 to 2 gaps, traced at N = 8 with `max_harmonics` = 32: every point in
//! contact is solved again at 16 and, where that moves its first harmonic by more than the
//! tolerance (1e-3), at 32. Against the periodic orbit of the exact piecewise-linear flow with
//! the moving gap (`pwl`, independent of the crate), shot from each point's state:
//! - every point in contact carries an N above the trace's (its check at 2N always runs), at
//!   least one 32, and the points whose last doubling moved them by at most the tolerance are
//!   within 1e-3 of the exact first harmonic (measured: 1.5e-5 at worst, 12 of 13 converged);
//! - the same sweep at N = 8 unrefined (`Fixed`) is farther than 1e-3 from the exact orbits
//!   (measured 5.4e-2 next to the onset): the refinement is what brings the points there;
//! - the sweep's count of points not converged is the points' own.
//!
//! And each point's largest contact force on its exact orbit (`CasingPoint::exact_force`, shot
//! on the settled boundary for its stability) is the oracle's orbit's at its W within 1e-6.
//!
//! Under a second each, about 1 s with the build.

mod common;
mod pwl;

use nlmodes_forced::{
    casing_sweep, CasingSweep, CasingSweepSettings, Damping, ForcedSettings, SpeedHarmonics,
};
use nlmodes_hb::{AlgorithmParams, ContactMethod, HarmonicSettings, System};
use pwl::{GapWave, Pwl};

const GAP: f64 = 0.5;
const ZETA: f64 = 0.02;
const PHASE: f64 = 0.3;

/// N = 8 on 64 samples, kc = 10 x the static contact stiffness, up to N = 32.
fn sweep(system: &System, policy: SpeedHarmonics) -> (CasingSweep, f64, f64) {
    sweep_with(system, policy, false)
}

/// `sweep`, with each point's stability (its settled boundary shot) when `stability`.
fn sweep_with(system: &System, policy: SpeedHarmonics, stability: bool) -> (CasingSweep, f64, f64) {
    let kc = 10.0 * system.contact_stiffness()[0];
    let solver = ForcedSettings {
        harmonics: HarmonicSettings::new(8, 64).unwrap(),
        algorithm: AlgorithmParams {
            method: ContactMethod::Penalty { stiffness: kc },
            ..AlgorithmParams::default()
        },
        ..ForcedSettings::new(8).unwrap()
    };
    let damping = Damping::ModalRatios(vec![ZETA]).matrix(system).unwrap();
    let w = 0.7 * system.linear_frequencies()[0];
    let amplitudes: Vec<f64> = (0..=20).map(|i| 0.1 * GAP * i as f64).collect();
    let mut settings = CasingSweepSettings::new(w, amplitudes, solver);
    settings.phase = PHASE;
    settings.stability = stability;
    settings.harmonic_policy = policy;
    settings.max_harmonics = 32;
    let out = casing_sweep(system, &damping, &settings, |_| {}).unwrap();
    assert!(out.stopped.is_none(), "{:?}", out.stopped);
    (out, w, kc)
}

/// The exact system with the moving gap at amplitude `delta`.
fn oracle(system: &System, delta: f64, kc: f64) -> Pwl {
    let c = Damping::ModalRatios(vec![ZETA]).matrix(system).unwrap();
    let wave = GapWave {
        harmonic: 1,
        amplitude: delta,
        phase: PHASE,
    };
    let matrices = [system.mass(), c.as_ref(), system.stiffness()];
    let a = (0..3).map(|j| system.contact_rows()[(0, j)]).collect();
    Pwl::with_gap_wave(matrices, a, (GAP, kc), vec![0.0; 3], wave)
}

/// Per point in contact: (delta, N, converged, |q1 / q1_exact - 1|).
fn errors(system: &System, out: &CasingSweep, w: f64, kc: f64) -> Vec<(f64, usize, bool, f64)> {
    (out.points.iter())
        .filter(|p| p.point.touches())
        .map(|p| {
            let z = common::state_at_zero(&p.point.coefficients, w);
            let sys = oracle(system, p.amplitude, kc);
            let orbit = pwl::periodic_at(&sys, w, &z, 1e-12)
                .unwrap_or_else(|| panic!("no exact orbit at delta = {}", p.amplitude));
            let exact = pwl::trace::first_harmonic(&sys, &orbit, &[0.0, 0.0, 1.0]);
            let q1 = p.point.first_harmonic(2);
            (
                p.amplitude,
                p.point.harmonics,
                p.converged(1e-3),
                (q1 / exact - 1.0).abs(),
            )
        })
        .collect()
}

#[test]
fn the_casing_sweep_raises_n_where_its_check_asks() {
    let system = common::three_dof(GAP);
    let (refined, w, kc) = sweep(&system, SpeedHarmonics::Retrace);
    let (fixed, _, _) = sweep(&system, SpeedHarmonics::Fixed);
    let r = errors(&system, &refined, w, kc);
    let f = errors(&system, &fixed, w, kc);
    for ((delta, n, ok, e), (_, _, _, e3)) in r.iter().zip(&f) {
        println!(
            "delta/gap {:.2}: N = {n:2} converged {ok:5}: {e:.2e} (N = 8: {e3:.2e})",
            delta / GAP
        );
    }
    assert!(r.len() >= 8, "points in contact: {}", r.len());
    assert!(r.iter().all(|&(_, n, _, _)| n == 16 || n == 32), "{r:?}");
    assert!(
        r.iter().any(|&(_, n, _, _)| n == 32),
        "none raised to 32: {r:?}"
    );
    let converged: Vec<f64> = (r.iter()).filter(|p| p.2).map(|p| p.3).collect();
    assert!(converged.len() * 2 > r.len(), "{r:?}");
    let worst = converged.iter().copied().fold(0.0, f64::max);
    let worst_fixed = f.iter().map(|p| p.3).fold(0.0, f64::max);
    println!(
        "converged points: {} of {}, worst {worst:.2e}; N = 8: {worst_fixed:.2e}",
        converged.len(),
        r.len()
    );
    assert!(worst < 1e-3, "{worst}");
    assert!(worst_fixed > 1e-3, "{worst_fixed}");
    assert_eq!(
        refined.not_converged(1e-3),
        r.len() - converged.len(),
        "the count of points not converged"
    );
}

/// The exact orbits' forces of the casing sweep (`CasingPoint::exact_force`) against the
/// oracle's orbit at the same W, shot from the point's state (`pwl::largest_penalty_force`):
/// within 1e-6 relative (both flows exact; tests/forced_oracle_cli.rs measures 7e-10), at every
/// point in contact; the harmonic balance's force at the point's N printed beside it.
#[test]
fn the_casing_sweeps_exact_contact_forces_are_the_oracles() {
    let system = common::three_dof(GAP);
    let (out, w, kc) = sweep_with(&system, SpeedHarmonics::Retrace, true);
    let mut compared = 0;
    for p in out.points.iter().filter(|p| p.point.touches()) {
        let exact = p
            .exact_force
            .unwrap_or_else(|| panic!("no exact force at delta = {}", p.amplitude));
        let z = common::state_at_zero(&p.point.coefficients, w);
        let sys = oracle(&system, p.amplitude, kc);
        let orbit = pwl::periodic_at(&sys, exact.omega, &z, 1e-12)
            .unwrap_or_else(|| panic!("no exact orbit at delta = {}", p.amplitude));
        let oracle_force = pwl::largest_penalty_force(&sys, &orbit, 1000);
        let error = (exact.force / oracle_force - 1.0).abs();
        println!(
            "delta/gap {:.2}: exact orbit {:.8e}, oracle {oracle_force:.8e} ({error:.1e}); \
             harmonic balance at N = {}: {:.8e}",
            p.amplitude / GAP,
            exact.force,
            p.point.harmonics,
            p.point.largest_contact_force()
        );
        assert!(error <= 1e-6, "delta = {}: {error:e}", p.amplitude);
        assert!(
            (exact.omega / w - 1.0).abs() <= 1e-2,
            "{} against {w}",
            exact.omega
        );
        compared += 1;
    }
    assert!(compared >= 8, "points in contact: {compared}");
}
