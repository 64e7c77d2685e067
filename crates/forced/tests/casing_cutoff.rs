//! The massless boundary's dynamic modes under a casing distortion (docs/STABILITY.md Sec. 9.6;
//! issue 39): a mode above (N + 1) W that the strike excites must stay dynamic, or the
//! boundary is another model with other multipliers. The default blade has one (its fourth
//! mode at 11.8 W with N = 10); here a 2-DOF blade-like chain, a body (m = 1) on a root
//! spring (k = 1) and a light tip (m = 0.05) on a stiff spring (k = 10) whose own mode lies at
//! 21.5 W (W = 0.69 w1, N = 12: (N + 1) W = 13 W discards it), the contact on the tip, the
//! gap 1 - delta cos(W t), 2 % modal damping, kc = 10 x the static contact stiffness; a stiff
//! coordinate coupled to nothing (k = 1e6) is added, as FE models have, so the boundary applies
//! with the tip mode kept.
//!
//! The reference is the exact piecewise-linear flow of the 2-DOF penalty equation (`pwl`,
//! independent of the crates), shot to its periodic orbit, its largest |mu| from its monodromy.

mod common;
mod pwl;

use common::{
    penalty_settings, tip_chain as system, tip_chain_damping as damping, tip_chain_kc as kc,
    TIP_CHAIN_GAP,
};

use nlmodes_boundary::{boundary_with_converged_cutoff, DrivenInputs, GapHarmonic};
use nlmodes_forced::{casing_sweep, CasingPoint, CasingSweepSettings, SpeedHarmonics, Verdict};
use pwl::{GapWave, Pwl};

const GAP: f64 = TIP_CHAIN_GAP;
const N: usize = 12;

fn omega() -> f64 {
    0.69 * system(false).linear_frequencies()[0]
}

/// The 2-DOF oracle under the gap 1 - delta cos(W t).
fn oracle(delta: f64) -> Pwl {
    let s = system(false);
    let c = damping(&s);
    let wave = GapWave {
        harmonic: 1,
        amplitude: delta,
        phase: 0.0,
    };
    Pwl::with_gap_wave(
        [s.mass(), c.as_ref(), s.stiffness()],
        vec![0.0, 1.0],
        (GAP, kc()),
        vec![0.0; 2],
        wave,
    )
}

/// The largest |mu| of the oracle's periodic orbit at W = `w` shot from (x, v) = `z`.
fn reference(delta: f64, w: f64, z: &[f64]) -> f64 {
    let orbit = pwl::periodic_at(&oracle(delta), w, z, 1e-12)
        .unwrap_or_else(|| panic!("no exact orbit at delta = {delta}"));
    let mu = orbit.flow.monodromy.eigenvalues()[0];
    mu.0.hypot(mu.1)
}

/// The sweep of the padded chain, delta from 0 to 2 gaps in steps of 0.1, N = 12 kept.
fn sweep(stability: bool) -> Vec<CasingPoint> {
    let s = system(true);
    let settings = penalty_settings(N, 128, kc());
    let amplitudes: Vec<f64> = (0..=20).map(|i| 0.1 * GAP * i as f64).collect();
    let mut cs = CasingSweepSettings::new(omega(), amplitudes, settings);
    cs.harmonic_policy = SpeedHarmonics::Fixed;
    cs.stability = stability;
    let out = casing_sweep(&s, &damping(&s), &cs, |_| {}).unwrap();
    assert!(out.stopped.is_none(), "{:?}", out.stopped);
    out.points
}

/// At every point in contact: the boundary at the default cutoff (N + 1) W keeps the body mode
/// alone and its largest |mu| is off the reference by more than 1e-2 somewhere (the tip mode is
/// dynamic in the strike: a different model); with the cutoff raised until the orbit settles
/// it keeps the tip mode too (not the free coordinate), is the penalty equation itself, and
/// its largest |mu| is the reference's at its shot orbit within 1e-6 (both exact up to their
/// shooting tolerances).
#[test]
fn the_boundary_keeps_the_modes_the_strike_excites() {
    let s = system(true);
    let c = damping(&s);
    let phi = s.modes();
    let (mut default_worst, mut settled_worst, mut compared) = (0.0_f64, 0.0_f64, 0);
    for p in sweep(false).iter().filter(|p| p.point.touches()) {
        let inputs = DrivenInputs {
            system: &s,
            damping: c.as_ref(),
            load: Vec::new(),
            penalty: Some(kc()),
            harmonics: N,
            keep_all: false,
            gap_motion: vec![GapHarmonic {
                harmonic: 1,
                intrusion: [vec![p.amplitude], vec![0.0]],
            }],
        };
        let (coefficients, w) = (&p.point.coefficients, p.point.omega);
        let default = nlmodes_boundary::boundary_monodromy(&inputs, coefficients, w)
            .unwrap()
            .expect("the default boundary shoots");
        let settled = boundary_with_converged_cutoff(&inputs, coefficients, w, 1, 1e-3)
            .unwrap()
            .expect("the settled boundary shoots");
        let b = &settled.boundary;
        assert_eq!((default.modes, b.modes), (1, 2));
        let r = b.modes;
        let physical = |part: &[f64]| -> Vec<f64> {
            (0..2)
                .map(|i| (0..r).map(|k| phi[(i, k)] * part[k]).sum::<f64>())
                .collect()
        };
        let z = [physical(&b.start[..r]), physical(&b.start[r..])].concat();
        let exact = reference(p.amplitude, b.model.omega, &z);
        let (mu_default, mu) = (default.monodromy.largest(), b.monodromy.largest());
        println!(
            "delta = {:.2} gaps: |mu| reference {exact:.8}, settled {mu:.8} ({} modes, cutoff \
             {:.1} W, last change {:.1e}), default cutoff {mu_default:.8} (1 mode)",
            p.amplitude / GAP,
            r,
            settled.cutoff / w,
            settled.change[1]
        );
        default_worst = default_worst.max((mu_default - exact).abs());
        settled_worst = settled_worst.max((mu - exact).abs());
        compared += 1;
    }
    println!(
        "{compared} points: largest |mu| off the reference by {settled_worst:.1e} (settled), \
         {default_worst:.1e} (default cutoff)"
    );
    assert!(compared >= 8, "{compared}");
    assert!(default_worst > 1e-2, "{default_worst}");
    assert!(settled_worst < 1e-6, "{settled_worst}");
}

/// The sweep's own verdicts (N = 12): every determined point in contact has the reference's
/// verdict (the exact orbit shot from the point's harmonic-balance state (x, v)(0); the chain's
/// coordinates are the padded system's first two) where that is farther than 1e-2
/// from 1, and at least 8 points in contact are determined.
#[test]
fn the_casing_sweep_verdicts_are_the_exact_ones() {
    let (mut determined, mut counts) = (0, [0; 3]);
    for p in sweep(true).iter().filter(|p| p.point.touches()) {
        let st = p.stability.expect("stability asked");
        let c = &p.point.coefficients;
        let w = p.point.omega;
        let series = |i: usize| (0..c.ncols()).map(|q| c[(i, q)]).collect::<Vec<f64>>();
        let z: Vec<f64> = (0..2)
            .map(|i| nlmodes_hb::FullBasis::value_at(&series(i), 0.0))
            .chain((0..2).map(|i| nlmodes_hb::FullBasis::rate_at(&series(i), w, 0.0)))
            .collect();
        let exact = reference(p.amplitude, w, &z);
        println!(
            "delta = {:.2} gaps: {:?}, |mu| {:?} (reference {exact:.6}), orbit distance {:?}",
            p.amplitude / GAP,
            st.verdict,
            st.largest_multiplier,
            st.boundary_shift
        );
        counts[match st.verdict {
            Verdict::Stable => 0,
            Verdict::Unstable => 1,
            Verdict::Undetermined => 2,
        }] += 1;
        if st.verdict == Verdict::Undetermined {
            continue;
        }
        determined += 1;
        if (exact - 1.0).abs() > 1e-2 {
            let expected = if exact > 1.0 {
                Verdict::Unstable
            } else {
                Verdict::Stable
            };
            assert_eq!(st.verdict, expected, "delta = {}", p.amplitude);
        }
    }
    println!("stable / unstable / undetermined {counts:?}");
    assert!(determined >= 8, "{counts:?}");
}
