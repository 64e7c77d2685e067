//! The Floquet multipliers of forced orbits under a moving gap (a casing distortion, docs/
//! STABILITY.md Sec. 9.5; issue 39) against an independent reference: the finite-difference
//! monodromy of the exact piecewise-linear flow of the penalty equation (`pwl`, independent of
//! the crates: its own exponentials, its switches found as events, its own eigenvalues).
//!
//! The system is the 3-DOF one of `distortion.rs` at rest (contact row 0.2 x0 + x2, gap 0.5,
//! 2 % modal damping, kc = 10 x the static contact stiffness, N = 12), excited by the casing
//! alone at W = 0.7 w1: its gap 0.5 - delta cos(h W t + 0.3), h = 1 (one strike per period:
//! two switches) or h = 2 (two strikes: four switches).
//!
//! - The massless boundary with the moving gap (`nlmodes_boundary`, every mode kept: the
//!   penalty equation itself) at points of the distortion sweep: its largest |mu| equals the
//!   reference's, and its RK4 check (`check_driven_by_rk4`) agrees.
//! - The sweep's own verdicts (`casing_sweep` with stability): the points in contact
//!   determined but where the harmonic-balance orbit is too far from the exact one, their
//!   largest |mu| the reference's within the harmonic balance's error; the same with a stiff
//!   coordinate coupled to nothing added to the model (k = 1e6, m = 1, as FE models have):
//!   nothing becomes undetermined and every verdict stays.

mod common;
mod pwl;

use faer::Mat;
use nlmodes_boundary::{check_driven_by_rk4, DrivenInputs, GapHarmonic, SHOOTING_CHECK_LIMIT};
use nlmodes_forced::{
    casing_sweep, CasingPoint, CasingSweepSettings, Damping, ForcedSettings, Verdict,
    BOUNDARY_SHIFT_LIMIT,
};
use nlmodes_hb::{AlgorithmParams, ContactMethod, HarmonicSettings, System};
use pwl::{Dense, GapWave, Pwl};

const GAP: f64 = 0.5;
const ZETA: f64 = 0.02;
const PHASE: f64 = 0.3;

/// The 3-DOF system, or the same with a fourth coordinate of mass 1 and stiffness 1e6 coupled
/// to nothing (`padded`).
fn system(padded: bool) -> System {
    let rest = common::three_dof(GAP);
    if !padded {
        return rest;
    }
    let grow = |a: faer::MatRef<'_, f64>, last: f64| {
        Mat::from_fn(4, 4, |i, j| match (i < 3 && j < 3, i == j) {
            (true, _) => a[(i, j)],
            (false, true) => last,
            _ => 0.0,
        })
    };
    let rows = Mat::from_fn(1, 4, |_, j| {
        if j < 3 {
            rest.contact_rows()[(0, j)]
        } else {
            0.0
        }
    });
    System::new(
        grow(rest.mass(), 1.0),
        grow(rest.stiffness(), 1e6),
        rows,
        vec![GAP],
        2,
    )
    .unwrap()
}

/// N = 12 on 128 samples, kc = 10 x the static contact stiffness of the 3-DOF system.
fn settings() -> ForcedSettings {
    ForcedSettings {
        harmonics: HarmonicSettings::new(12, 128).unwrap(),
        algorithm: AlgorithmParams {
            method: ContactMethod::Penalty { stiffness: kc() },
            ..AlgorithmParams::default()
        },
        ..ForcedSettings::new(12).unwrap()
    }
}

fn kc() -> f64 {
    10.0 * system(false).contact_stiffness()[0]
}

/// The oracle of the 3-DOF system under the gap 0.5 - delta cos(h W t + PHASE).
fn oracle(delta: f64, harmonic: usize) -> Pwl {
    let s = system(false);
    let c = Damping::ModalRatios(vec![ZETA]).matrix(&s).unwrap();
    let wave = GapWave {
        harmonic,
        amplitude: delta,
        phase: PHASE,
    };
    let matrices = [s.mass(), c.as_ref(), s.stiffness()];
    let a = (0..3).map(|j| s.contact_rows()[(0, j)]).collect();
    Pwl::with_gap_wave(matrices, a, (GAP, kc()), vec![0.0; 3], wave)
}

/// The reference at a point: the exact periodic orbit of the oracle shot from the point's
/// state (x, v)(0), its switches per period, the largest |mu| of the central-difference
/// monodromy of its flow (steps 1e-6 of each state component's scale: truncation O(h^2) on
/// the smooth flow map between switch sequences, rounding 1e-16 / h) and the largest
/// difference between that monodromy and the oracle's product of exponential blocks.
struct Reference {
    switches: usize,
    largest: f64,
    product_error: f64,
}

fn reference(delta: f64, harmonic: usize, w: f64, z: &[f64]) -> Reference {
    let sys = oracle(delta, harmonic);
    let orbit = pwl::periodic_at(&sys, w, z, 1e-12)
        .unwrap_or_else(|| panic!("no exact orbit at delta = {delta}"));
    let integ = pwl::Integrator::new(&sys, w, pwl::STEPS);
    let scale = |k: usize| if k < 3 { GAP } else { GAP * w };
    let end = |k: usize, d: f64| {
        let mut s = orbit.z0.clone();
        s[k] += d;
        integ.end_state(&s)
    };
    let mut fd = Dense::zeros(6);
    for k in 0..6 {
        let h = 1e-6 * scale(k);
        let (up, down) = (end(k, h), end(k, -h));
        for i in 0..6 {
            fd.a[i * 6 + k] = (up[i] - down[i]) / (2.0 * h);
        }
    }
    let product_error = (0..36)
        .map(|i| (fd.a[i] - orbit.flow.monodromy.a[i]).abs())
        .fold(0.0, f64::max);
    let largest = fd.eigenvalues()[0];
    Reference {
        switches: orbit.flow.events.len(),
        largest: largest.0.hypot(largest.1),
        product_error,
    }
}

/// (x, v)(0) of a point's harmonic-balance orbit at W (rad/s).
fn start_of(p: &CasingPoint, w: f64) -> Vec<f64> {
    common::state_at_zero(&p.point.coefficients, w)
}

/// The distortion sweep at W = 0.7 w1 (delta from 0 to 2 gaps in steps of 0.1 gap), the gap at
/// harmonic `harmonic` of W, with the sweep's stability.
fn sweep(padded: bool, harmonic: usize) -> (System, Mat<f64>, Vec<CasingPoint>, f64) {
    let s = system(padded);
    let damping = Damping::ModalRatios(vec![ZETA]).matrix(&s).unwrap();
    let w = 0.7 * system(false).linear_frequencies()[0];
    let amplitudes: Vec<f64> = (0..=20).map(|i| 0.1 * GAP * i as f64).collect();
    let mut cs = CasingSweepSettings::new(w, amplitudes, settings());
    cs.phase = PHASE;
    cs.harmonic = harmonic;
    let out = casing_sweep(&s, &damping, &cs, |_| {}).unwrap();
    assert!(out.stopped.is_none(), "{:?}", out.stopped);
    (s, damping, out.points, w)
}

/// The massless boundary with the moving gap, every mode kept (the penalty equation shot
/// exactly), at every point in contact of the sweeps with one strike and with two strikes per
/// period: its largest |mu| within 1e-6 of the finite-difference reference's at the shot
/// orbit's W (both exact up to their shooting tolerance and the difference's 1e-9), the
/// boundary's RK4 check within `SHOOTING_CHECK_LIMIT`, the oracle's block product within 1e-6
/// of its difference (no saltation at the moving switches).
#[test]
fn the_moving_gap_boundary_has_the_exact_multipliers() {
    for harmonic in [1, 2] {
        let (s, damping, points, w) = sweep(false, harmonic);
        let (mut worst, mut product, mut compared, mut switches) = (0.0_f64, 0.0_f64, 0, vec![]);
        for p in points.iter().filter(|p| p.point.touches()) {
            let (sn, co) = PHASE.sin_cos();
            let inputs = DrivenInputs {
                system: &s,
                damping: damping.as_ref(),
                load: Vec::new(),
                penalty: Some(kc()),
                harmonics: p.point.harmonics,
                keep_all: true,
                gap_motion: vec![GapHarmonic {
                    harmonic,
                    intrusion: [vec![p.amplitude * co], vec![-p.amplitude * sn]],
                }],
            };
            let b = nlmodes_boundary::boundary_monodromy(&inputs, &p.point.coefficients, w)
                .unwrap()
                .expect("the boundary shoots the orbit");
            let check = check_driven_by_rk4(&b).unwrap();
            // The shot orbit lies on the boundary's curve at its own W (shooting keeps W free,
            // docs/STABILITY.md Sec. 9.1): the reference there, from its start x = Phi q.
            let phi = s.modes();
            let physical = |part: &[f64]| -> Vec<f64> {
                (0..3)
                    .map(|i| (0..3).map(|k| phi[(i, k)] * part[k]).sum::<f64>())
                    .collect()
            };
            let z = [physical(&b.start[..3]), physical(&b.start[3..])].concat();
            let exact = reference(p.amplitude, harmonic, b.model.omega, &z);
            let mu = b.monodromy.largest();
            println!(
                "h = {harmonic}, delta = {:.3} g0: {} switches, |mu| {mu:.10} (shift {:.1e}, W \
                 {:+.1e}), reference {:.10}; RK4 {:.8} (periodic to {:.1e}); block product \
                 against the difference {:.1e}",
                p.amplitude / GAP,
                exact.switches,
                b.shift,
                b.model.omega / w - 1.0,
                exact.largest,
                check.max_multiplier_abs,
                check.periodicity,
                exact.product_error
            );
            assert!(check.agrees(), "{check:?}");
            worst = worst.max((mu - exact.largest).abs());
            product = product.max(exact.product_error);
            switches.push(exact.switches);
            compared += 1;
        }
        println!(
            "h = {harmonic}: {compared} points, largest |mu| within {worst:.1e} of the \
             reference, switches per period {switches:?}"
        );
        assert!(compared >= 8, "{compared}");
        assert!(switches.iter().any(|&k| k >= 2 * harmonic), "{switches:?}");
        assert!(worst < 1e-6, "{worst}");
        assert!(product < 1e-6, "{product}");
    }
}

/// Above delta = this x the gap every point of the sweeps is determined: below it, next to the
/// onset (delta = the gap), the casing's strike is a short grazing contact that N = 12 does not
/// resolve (the shot orbit lies 0.02-0.15 from the harmonic-balance one, measured).
const ONSET_BAND: f64 = 1.02;

/// The sweep's own verdicts (`casing_sweep` with stability), on the 3-DOF system and on the
/// same padded with a stiff coordinate coupled to nothing: the padded sweep's verdicts those of
/// the plain one; a point undetermined only where the shot orbit lies farther than
/// `BOUNDARY_SHIFT_LIMIT` from the harmonic-balance one, within `ONSET_BAND` of the onset
/// (N = 12 not converged there), at least 10 points determined per sweep; the largest |mu| within 1e-2 of the
/// reference at the sweep's W, from the point's state (the verdicts are those of the shot
/// orbit, at its own W within the shift, or of the harmonic-balance orbit, N = 12, backed by its
/// period check), and the verdict the reference's where that is farther than 1e-2 from 1; the
/// sweep's RK4 checks (every fourth point in contact) within `SHOOTING_CHECK_LIMIT`.
#[test]
fn the_casing_sweep_gives_every_point_in_contact_a_verdict() {
    for harmonic in [1, 2] {
        let (_, _, plain, w) = sweep(false, harmonic);
        let (_, _, padded, _) = sweep(true, harmonic);
        assert_eq!(plain.len(), padded.len());
        let (mut counts, mut worst_boundary, mut worst_massive) = ([0; 3], 0.0_f64, 0.0_f64);
        let mut undetermined_far = 0;
        let mut unrefined = 0;
        for (p, q) in plain.iter().zip(&padded).filter(|(p, _)| p.point.touches()) {
            if p.harmonic_failed || q.harmonic_failed {
                // The sweep's own flag: its solve at 2N failed (next to a row starting to
                // touch), so the point stays at N = 12, unconverged; the oracle's shooting
                // from that orbit's state does not converge either.
                assert!(p.amplitude < ONSET_BAND * GAP, "delta = {}", p.amplitude);
                unrefined += 1;
                continue;
            }
            let exact = reference(p.amplitude, harmonic, w, &start_of(p, w)).largest;
            for (st, model) in [(p, "plain"), (q, "padded")]
                .map(|(x, m)| (x.stability.expect("stability asked"), m))
            {
                let mu = st.largest_multiplier.expect("a multiplier");
                println!(
                    "h = {harmonic}, delta = {:.2} g0, {model}: {:?}, |mu| {mu:.8} \
                     (reference {exact:.8}; boundary shift {:?}, period residual {:?})",
                    p.amplitude / GAP,
                    st.verdict,
                    st.boundary_shift,
                    st.period_residual
                );
                let error = (mu - exact).abs();
                match st.boundary_shift {
                    Some(_) => worst_boundary = worst_boundary.max(error),
                    None => worst_massive = worst_massive.max(error),
                }
                if st.verdict == Verdict::Undetermined {
                    assert!(
                        st.boundary_shift.is_some_and(|d| d > BOUNDARY_SHIFT_LIMIT)
                            && p.amplitude < ONSET_BAND * GAP,
                        "undetermined without a reason at delta = {}",
                        p.amplitude
                    );
                    undetermined_far += 1;
                } else if (exact - 1.0).abs() > 1e-2 {
                    let expected = if exact > 1.0 {
                        Verdict::Unstable
                    } else {
                        Verdict::Stable
                    };
                    assert_eq!(st.verdict, expected, "delta = {}", p.amplitude);
                }
                counts[match st.verdict {
                    Verdict::Stable => 0,
                    Verdict::Unstable => 1,
                    Verdict::Undetermined => 2,
                }] += 1;
            }
            let (a, b) = (p.stability.unwrap(), q.stability.unwrap());
            assert_eq!(a.verdict, b.verdict, "delta = {}", p.amplitude);
        }
        println!("h = {harmonic}: {unrefined} points whose refinement to 2N failed (not compared)");
        assert!(unrefined <= 10, "{unrefined}");
        println!(
            "h = {harmonic}: stable / unstable / undetermined over both sweeps {counts:?}; \
             largest |mu| off the reference by {worst_boundary:.1e} (boundary), \
             {worst_massive:.1e} (massive model)"
        );
        let checked: Vec<f64> = (plain.iter().chain(&padded))
            .filter_map(|p| p.stability?.rk4_change)
            .collect();
        let rk4 = checked.iter().fold(0.0_f64, |a, &v| a.max(v));
        println!(
            "h = {harmonic}: {} verdicts checked by RK4, largest change {rk4:.1e}",
            checked.len()
        );
        assert!(checked.len() >= 4 && rk4 <= SHOOTING_CHECK_LIMIT);
        let changes: Vec<String> = (plain.iter())
            .filter_map(|p| {
                let b = p.stability?.bifurcation?;
                Some(format!("{b:?} at delta = {:.3} g0", p.amplitude / GAP))
            })
            .collect();
        println!("h = {harmonic}: changes of stability {changes:?}");
        // The one-strike sweep loses its instability between 1.1 and 1.2 gaps (reference
        // |mu| 1.174 and 0.800 there).
        assert!(harmonic != 1 || !changes.is_empty());
        assert_eq!(counts[2], undetermined_far);
        assert!(counts[0] + counts[1] >= 2 * 10, "{counts:?}");
        assert!(worst_boundary.max(worst_massive) < 1e-2);
    }
}
