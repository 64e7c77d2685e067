//! The nonlinear branch starts at the grazing orbit and follows the exact one-impact mode (issue
//! 12; docs/DESIGN.md §8.1), checked against the exact oracle of `oracle::impact` (piecewise-linear
//! flight between elastic impacts, docs/oracle_impact.md).
//!
//! System: M = I, K = [[2, -1], [-1, 2]], rigid stop on DOF 2 (gap g = 1), master DOF 1. The
//! exact branch leaves grazing (w = w1 = 1, q = 1) with dq/dw = -1.12, turns at the fold
//! w = 1.028333, q = 0.985464, and stiffens (q back at 1 for w = 1.0607).
//!
//! Settings: N = 40, m = 512 (the issue's), and epsilon = 1e-6 g0: the fold is shallow (q dips
//! 1.45 % below grazing) and a looser epsilon lets the orbit penetrate by up to epsilon g0, which
//! moves q by about as much near grazing. Measured with these settings: fold at w = 1.02859,
//! q = 0.98802 (exact 1.02833, 0.98546: 0.03 % and 0.26 %); q within 0.3-1.4 % of the exact
//! branch for 1 < w <= 1.2 (the rigid-stop orbit's velocity jump makes harmonic balance converge
//! like 1/N, docs/VERIFICATION.md).

mod oracle;

use faer::Mat;
use nlmodes_nnm::{
    backbone, floquet, AlgorithmParams, Backbone, BranchKind, ContinuationSettings,
    FloquetSettings, HarmonicSettings, StabilityMethod, System, Termination,
};
use oracle::impact::ImpactChain;

fn chain() -> System {
    let m = Mat::from_fn(2, 2, |i, j| if i == j { 1.0 } else { 0.0 });
    let k = Mat::from_fn(2, 2, |i, j| if i == j { 2.0 } else { -1.0 });
    let a = Mat::from_fn(1, 2, |_, j| if j == 1 { 1.0 } else { 0.0 });
    System::new(m, k, a, vec![1.0], 0).expect("2-DOF chain")
}

fn run(harmonics: usize, samples: usize, epsilon: f64) -> Backbone {
    let settings = HarmonicSettings::new(harmonics, samples).expect("settings");
    let params = AlgorithmParams {
        epsilon,
        ..AlgorithmParams::default()
    };
    let cont = ContinuationSettings {
        q_start: 0.5,
        q_max: 1.6,
        ..ContinuationSettings::default()
    };
    backbone(&chain(), settings, params, &cont, |_| {}).expect("run")
}

#[test]
fn branch_from_grazing_follows_the_exact_one_impact_mode() {
    let sys = chain();
    let exact = ImpactChain::from_system(&sys);
    // Solver convention of q (impact at t = 0, q > 0 at grazing).
    let sign = exact.q_impact_closed_form(1.0 + 1e-9).0.signum();
    let q_exact = |w: f64| sign * exact.q_impact_closed_form(w).0;
    let fold = exact.fold_near(1.0 + 1e-9, 1.06).expect("exact fold");
    let (w_fold, q_fold) = (fold.omega, sign * fold.q_impact);
    let b = run(40, 512, 1e-6);
    for p in &b.points {
        println!(
            "branch {} w {:.6} q {:.6} exact q {:.6} fold {} jump {} pre_fold {} G {:.1e}",
            p.branch,
            p.omega_ratio,
            p.q,
            if p.omega_ratio > 1.0 {
                q_exact(p.omega_ratio)
            } else {
                f64::NAN
            },
            p.fold,
            p.jump,
            p.pre_fold,
            p.powell_measure
        );
    }
    println!(
        "exact fold w {w_fold:.6} q {q_fold:.6}; {:?}",
        b.termination
    );
    assert_eq!(b.termination, Termination::ReachedMaxAmplitude);
    assert_eq!(b.branches[0].kind, BranchKind::Linear);
    assert_eq!(b.branches[1].kind, BranchKind::Main);
    // The linear segment ends exactly at grazing, and no point is a jump.
    let graze = b
        .points
        .iter()
        .rposition(|p| p.branch == 0)
        .expect("linear");
    assert!((b.points[graze].q - 1.0).abs() < 1e-9);
    assert!((b.points[graze].omega_ratio - 1.0).abs() < 1e-9);
    assert!(b.points.iter().all(|p| !p.jump), "no jump");
    // Points just after grazing (1 < w <= 1.2) lie within 2 % in q of the exact branch.
    let near: Vec<_> = b
        .points
        .iter()
        .filter(|p| p.branch == 1 && p.omega_ratio > 1.0 + 1e-6 && p.omega_ratio <= 1.2)
        .collect();
    assert!(near.len() >= 3, "{} points with 1 < w <= 1.2", near.len());
    for p in &near {
        let e = q_exact(p.omega_ratio);
        assert!(
            (p.q - e).abs() <= 0.02 * e,
            "w {} q {} exact {e}",
            p.omega_ratio,
            p.q
        );
    }
    // The fold of q is found within 1 % in q and w, and the points between grazing and the fold
    // are on the output, flagged as such.
    let f = b.points.iter().find(|p| p.fold).expect("a fold of q");
    assert!(
        (f.omega_ratio - w_fold).abs() <= 0.01 * w_fold,
        "fold w {}",
        f.omega_ratio
    );
    assert!((f.q - q_fold).abs() <= 0.01 * q_fold, "fold q {}", f.q);
    let before = b.points.iter().filter(|p| p.pre_fold).count();
    assert!(before >= 3, "{before} points between grazing and the fold");
    assert!(b
        .points
        .iter()
        .filter(|p| p.pre_fold)
        .all(|p| p.omega_ratio < f.omega_ratio));
}

/// Issue 13 on the same branch: just after grazing the exact one-impact orbit is unstable (a real
/// multiplier above 1) up to w = 1.032392 (a pair through +1 at the energy minimum, 0.4 % above the
/// fold of q), then stable (docs/oracle_impact.md). The program's Floquet analysis of its
/// continuation output must agree at every point more than 1 % in w from that transition, and flag
/// the transition within 1 % in w, as the only stability change of the stretch.
///
/// N = 40 (the issue's) and 60, m = 512, epsilon = 1e-6 g0, default stability settings. The
/// augmented-Lagrangian orbit carries its impact on one sample: the analysis uses the event-based
/// monodromy (free flow times saltation matrix, docs/STABILITY.md Sec. 3), on the harmonic-balance
/// orbit's data (impact time, impulse, displacement at the impact). Where unstable, max |mu| is
/// also compared with the oracle's at the same w: within 2 %, the accuracy of the orbit itself
/// (q within 0.3-1.4 % of the exact branch, O(1/N)); observed <= 0.05 %.
#[test]
fn stability_after_grazing_changes_where_the_exact_orbit_does() {
    for harmonics in [40, 60] {
        check_stability_after_grazing(harmonics);
    }
}

fn check_stability_after_grazing(harmonics: usize) {
    const W_PLUS_ONE: f64 = 1.032_392_122_730;
    let sys = chain();
    let settings = HarmonicSettings::new(harmonics, 512).expect("settings");
    let params = AlgorithmParams {
        epsilon: 1e-6,
        ..AlgorithmParams::default()
    };
    let cont = ContinuationSettings {
        q_start: 0.5,
        q_max: 1.08,
        ..ContinuationSettings::default()
    };
    let mut b = backbone(&sys, settings, params, &cont, |_| {}).expect("run");
    let failed = nlmodes_nnm::analyze_backbone(&sys, &mut b, &Default::default(), |_, _| {})
        .expect("analysis");
    assert_eq!(failed, 0);
    let main: Vec<_> = b.points.iter().filter(|p| p.branch == 1).collect();
    let exact = ImpactChain::from_system(&sys);
    println!("N = {harmonics}");
    for p in &main {
        let w = p.omega_ratio;
        let s = p.stability.as_ref().expect("stability");
        let orbit = exact
            .orbit_at_omega(w)
            .expect("exact orbit at the point's w");
        let (oracle_stable, oracle_max) = (
            exact.instability(&orbit) <= 0.0,
            exact.max_multiplier_modulus(&orbit),
        );
        println!(
            "w {w:.5} q {:.5} {:?} stable {} max|mu| {:.4} trivial pair {:.1e} {:?} | \
             exact: stable {oracle_stable} max|mu| {oracle_max:.4}",
            p.q, s.method, s.stable, s.max_multiplier_abs, s.trivial_pair_error, p.bifurcation,
        );
        assert_eq!(
            s.method,
            StabilityMethod::Saltation,
            "N = {harmonics}, w = {w}"
        );
        if (w - W_PLUS_ONE).abs() > 0.01 * W_PLUS_ONE {
            assert_eq!(s.stable, w > W_PLUS_ONE, "N = {harmonics}, w = {w}");
            assert_eq!(s.stable, oracle_stable, "N = {harmonics}, w = {w}");
            assert!(
                (s.max_multiplier_abs - oracle_max).abs() <= 0.02 * oracle_max,
                "N = {harmonics}, w = {w}: max |mu| {} exact {oracle_max}",
                s.max_multiplier_abs
            );
        }
    }
    let flagged: Vec<_> = main
        .windows(2)
        .filter(|w| w[1].bifurcation.is_some())
        .map(|w| {
            (
                w[1].bifurcation,
                0.5 * (w[0].omega_ratio + w[1].omega_ratio),
            )
        })
        .collect();
    assert_eq!(flagged.len(), 1, "N = {harmonics}: {flagged:?}");
    assert_eq!(
        flagged[0].0,
        Some(nlmodes_nnm::Bifurcation::FoldOrBranchPoint)
    );
    assert!(
        (flagged[0].1 - W_PLUS_ONE).abs() <= 0.01 * W_PLUS_ONE,
        "N = {harmonics}: {flagged:?}"
    );
}

/// Study behind docs/STABILITY.md Sec. 3 (not a check: run with `-- --ignored --nocapture`): on
/// the augmented-Lagrangian points just after grazing, how Hill's multipliers move with the
/// penalty kappa of the Jacobian (the orbit's final kappa scaled by 1, 10, 100), with N and m,
/// and with the impact-equivalent spring, against the event-based monodromy and the exact orbit.
#[test]
#[ignore = "study printed for the docs (about 1 min)"]
fn hill_near_grazing_study() {
    let sys = chain();
    let exact = ImpactChain::from_system(&sys);
    for (harmonics, samples) in [(40, 256), (40, 512), (40, 1024), (60, 512)] {
        let b = run_to(harmonics, samples, 1.02);
        for target in [1.01, 1.02, 1.05] {
            let p = b
                .points
                .iter()
                .filter(|p| p.branch == 1)
                .min_by(|x, y| {
                    (x.omega_ratio - target)
                        .abs()
                        .total_cmp(&(y.omega_ratio - target).abs())
                })
                .expect("a point");
            let orbit = exact.orbit_at_omega(p.omega_ratio).expect("exact orbit");
            let active = p.contact_force[0].iter().filter(|&&l| l > 0.0).count();
            let max_abs = |settings: FloquetSettings, scale: f64| {
                let mut q = p.clone();
                q.multipliers.kappa.iter_mut().for_each(|k| *k *= scale);
                floquet(&sys, &q, &settings)
                    .expect("analysis")
                    .max_multiplier_abs
            };
            let raw = FloquetSettings {
                impact_width: 0.0,
                ..FloquetSettings::default()
            };
            let hill_equivalent = FloquetSettings {
                saltation: false,
                ..FloquetSettings::default()
            };
            println!(
                "N {harmonics} m {samples} w {:.4} active samples {active} kappa {:.2e} | Hill raw \
                 x1 {:.4} x10 {:.4} x100 {:.4} | Hill impact-equivalent {:.4} | saltation {:.4} | \
                 exact {:.4}",
                p.omega_ratio,
                p.multipliers.kappa[0],
                max_abs(raw.clone(), 1.0),
                max_abs(raw.clone(), 10.0),
                max_abs(raw, 100.0),
                max_abs(hill_equivalent, 1.0),
                max_abs(FloquetSettings::default(), 1.0),
                exact.max_multiplier_modulus(&orbit)
            );
        }
    }
}

fn run_to(harmonics: usize, samples: usize, q_max: f64) -> Backbone {
    let settings = HarmonicSettings::new(harmonics, samples).expect("settings");
    let params = AlgorithmParams {
        epsilon: 1e-6,
        ..AlgorithmParams::default()
    };
    let cont = ContinuationSettings {
        q_start: 0.5,
        q_max,
        ..ContinuationSettings::default()
    };
    backbone(&chain(), settings, params, &cont, |_| {}).expect("run")
}
