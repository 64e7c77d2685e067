//! Floquet stability (Hill's method) on the reduced coarse blade: the cost per point of the
//! modal reduction used by `nlmodes_nnm::FloquetAnalysis`, its convergence with the mode cutoff,
//! and Hill against the integrated monodromy on a modal truncation of the blade.
//!
//! Model: as tests/blade_time_integration.rs (meshes/blade.geo at mesh_size 0.01 m, TET10,
//! titanium, clamped on `root`, 24 `tip_edge` contact nodes, radial rows, g0 = 2e-4 m), reduced by
//! Craig-Bampton onto the 72 tip DOFs plus 40 fixed-interface modes: order 112, as the default
//! blade (cases/blade.toml). `cargo test --release --test blade_stability -- --nocapture` prints
//! the tables quoted in docs/STABILITY.md.

mod common;

use std::sync::OnceLock;
use std::time::Instant;

use common::{blade_mesh, fe_system, titanium};
use faer::Mat;
use nlmodes_modal::{craig_bampton, dense_generalized_eigen, EigenMethod, EigenOptions};
use nlmodes_nnm::{
    backbone, floquet, monodromy_by_integration, AlgorithmParams, BackbonePoint, ContactMethod,
    ContinuationSettings, FloquetAnalysis, FloquetSettings, HarmonicSettings, JacobianInTime,
    MonodromySettings, Solver, Stability, Start, System,
};

const GAP: f64 = 2e-4;
const FIXED_INTERFACE_MODES: usize = 40;

fn blade() -> &'static System {
    static BLADE: OnceLock<System> = OnceLock::new();
    BLADE.get_or_init(|| {
        let mesh = blade_mesh(2, 0.01);
        let fe = fe_system(mesh.clone(), &titanium(), &["root"]);
        let edge = mesh.group("tip_edge").expect("tip_edge").nodes.clone();
        let boundary: Vec<usize> = edge
            .iter()
            .flat_map(|&n| (0..3).map(move |c| 3 * n + c))
            .map(|g| fe.dofs.free_index(g).expect("tip_edge is not clamped"))
            .collect();
        let opts = EigenOptions {
            method: EigenMethod::Arpack,
            ..EigenOptions::default()
        };
        let cb = craig_bampton(&fe.k, &fe.m, &boundary, FIXED_INTERFACE_MODES, &opts)
            .expect("Craig-Bampton reduction");
        let n = cb.n_reduced();
        let mut a = Mat::<f64>::zeros(edge.len(), n);
        for (j, &node) in edge.iter().enumerate() {
            let p = mesh.nodes[node];
            let r = p[1].hypot(p[2]);
            a[(j, 3 * j + 1)] = p[1] / r;
            a[(j, 3 * j + 2)] = p[2] / r;
        }
        // Master: the contact DOF with the largest first-mode amplitude (the CLI's "auto").
        let probe = System::new(
            cb.m_r.clone(),
            cb.k_r.clone(),
            a.clone(),
            vec![GAP; edge.len()],
            0,
        )
        .expect("reduced blade");
        let phi = probe.linear_mode(0).unwrap_or_else(|_| vec![1.0; n]);
        let master = (0..boundary.len())
            .max_by(|&x, &y| phi[x].abs().total_cmp(&phi[y].abs()))
            .expect("tip DOFs");
        System::new(cb.m_r, cb.k_r, a, vec![GAP; edge.len()], master).expect("reduced blade")
    })
}

/// Largest distance from each non-trivial multiplier of `a` to the nearest multiplier of `b`.
fn distance(a: &Stability, b: &[[f64; 2]]) -> f64 {
    a.multipliers
        .iter()
        .enumerate()
        .filter(|(i, _)| !a.trivial.contains(i))
        .map(|(_, mu)| {
            b.iter()
                .map(|nu| (mu[0] - nu[0]).hypot(mu[1] - nu[1]))
                .fold(f64::INFINITY, f64::min)
        })
        .fold(0.0, f64::max)
}

fn blade_backbone() -> &'static Vec<BackbonePoint> {
    static POINTS: OnceLock<Vec<BackbonePoint>> = OnceLock::new();
    POINTS.get_or_init(|| {
        let sys = blade();
        let settings = HarmonicSettings::new(10, 128).expect("settings");
        let params = AlgorithmParams {
            epsilon: 1e-3,
            ..AlgorithmParams::default()
        };
        let cont = ContinuationSettings {
            q_max: 12.0,
            ..ContinuationSettings::default()
        };
        let start = Instant::now();
        let b = backbone(sys, settings, params, &cont, |_| {}).expect("blade backbone");
        println!(
            "blade backbone: {} points to q = {:.2} g0 in {:.2} s",
            b.points.len(),
            b.points.last().map_or(0.0, |p| p.q / GAP),
            start.elapsed().as_secs_f64()
        );
        b.points
    })
}

#[test]
fn blade_hill_cost_and_mode_cutoff_convergence() {
    let sys = blade();
    let w = sys.linear_frequencies();
    println!(
        "reduced blade: order {}, w_k / w1 = {:?}",
        sys.n_dofs(),
        w.iter()
            .take(14)
            .map(|x| (x / w[0] * 100.0).round() / 100.0)
            .collect::<Vec<_>>()
    );
    let points = blade_backbone();
    // Hill's method itself (the massless-boundary shooting would answer for the points in
    // contact; it has its own test below).
    let hill_only = FloquetSettings {
        shooting: false,
        ..FloquetSettings::default()
    };
    let analysis = FloquetAnalysis::new(sys, hill_only.clone()).expect("analysis");
    let mut times = Vec::new();
    let grazing = sys
        .grazing_amplitude(0)
        .expect("mode 1")
        .expect("mode 1 touches");
    for p in points {
        let start = Instant::now();
        let st = analysis.analyze(p).expect("hill");
        times.push(start.elapsed().as_secs_f64());
        if p.branch == 0 && p.q < grazing {
            // The linear segment below grazing: the linear mode, multipliers exp(+-i w_k T) on the circle; the
            // trivial pair at +1 to the accuracy of the dense eigensolver on entries up to
            // (N w)^2 + w_r^2 (observed 1.3e-8: the Jordan block at +1 turns round-off into its
            // square root).
            assert!(
                st.stable && st.max_multiplier_abs <= 1.0 + 1e-9,
                "q = {}",
                p.q
            );
            assert!(
                st.trivial_pair_error <= 1e-6,
                "q = {}: {}",
                p.q,
                st.trivial_pair_error
            );
        }
        // Hamiltonian structure: reciprocal pairs to round-off (observed <= 5e-6 relative with
        // |mu| up to 1.5 on this backbone).
        assert!(
            st.reciprocal_pair_error <= 1e-4,
            "q = {}: {}",
            p.q,
            st.reciprocal_pair_error
        );
        println!(
            "q/g0 = {:6.3} w/w1 = {:.5} r = {} max|mu| = {:.6} stable = {} trivial {:.2e} recip {:.1e} unstable {:?} contact {:.2}",
            p.q / GAP,
            p.omega_ratio,
            st.modes_kept,
            st.max_multiplier_abs,
            st.stable,
            st.trivial_pair_error,
            st.reciprocal_pair_error,
            st.unstable,
            p.contact_fraction.iter().copied().fold(0.0, f64::max)
        );
    }
    times.sort_by(f64::total_cmp);
    println!(
        "Hill per point (default cutoff): median {:.1} ms, max {:.1} ms, total {:.2} s over {} points",
        times[times.len() / 2] * 1e3,
        times.last().copied().unwrap_or(0.0) * 1e3,
        times.iter().sum::<f64>(),
        times.len()
    );
    // Two main-branch points away from internal resonances (the orbit's energy mostly in mode 1
    // at harmonic 1): near a tongue the orbit also lives in the resonating mode, which a small
    // cutoff does not keep dynamically.
    let clean: Vec<_> = points
        .iter()
        .filter(|p| p.branch == 1 && p.primary_share > 0.9)
        .collect();
    assert!(clean.len() >= 2, "main-branch points away from tongues");
    for p in [clean[clean.len() / 2], clean[clean.len() - 1]] {
        let reference = floquet(
            sys,
            p,
            &FloquetSettings {
                mode_cutoff: 6.0,
                ..hill_only.clone()
            },
        )
        .expect("reference");
        for cutoff in [0.5, 1.0, 2.0, 4.0] {
            // The discarded modes act statically on the contact rows; observed distances of the
            // kept multipliers to those of cutoff 6: 1e-6 .. 9e-5 at both points (cutoff 0.5 ..
            // 4); required 1e-3 (10x the largest).
            let start = Instant::now();
            let st = floquet(
                sys,
                p,
                &FloquetSettings {
                    mode_cutoff: cutoff,
                    ..hill_only.clone()
                },
            )
            .expect("hill");
            println!(
                "q/g0 = {:.3}: cutoff {cutoff} -> r = {}, {:.1} ms, distance to cutoff 6 (r = {}) {:.2e}, max|mu| {:.6} vs {:.6}",
                p.q / GAP,
                st.modes_kept,
                start.elapsed().as_secs_f64() * 1e3,
                reference.modes_kept,
                distance(&st, &reference.multipliers),
                st.max_multiplier_abs,
                reference.max_multiplier_abs
            );
            {
                assert!(distance(&st, &reference.multipliers) <= 1e-3);
                assert_eq!(st.stable, reference.stable);
            }
        }
    }
}

#[test]
fn truncated_blade_hill_agrees_with_the_integrated_monodromy() {
    // Modal truncation of the reduced blade to its linear modes below 24 w1 (M = I,
    // K = diag w_k^2, B = A Phi), as in tests/blade_time_integration.rs, with a penalty spring
    // kc = 0.3 x the mean static contact stiffness of the 112-DOF model at q = 1.5 q_graze.
    // Hill keeps every mode (cutoff 2 (N + 1) w > 24 w1), so this compares Hill's truncation of
    // the perturbation with the time integration of the same variational equation along the same
    // orbit (continuous-time Jacobian on both sides).
    let full = blade();
    let (lambda, phi) =
        dense_generalized_eigen(full.stiffness(), full.mass()).expect("reduced modes");
    let w1 = lambda[0].sqrt();
    let band = lambda.iter().filter(|l| l.sqrt() < 24.0 * w1).count();
    let b = full.contact_rows() * &phi;
    let sys = System::new(
        Mat::<f64>::identity(band, band),
        Mat::from_fn(band, band, |i, j| if i == j { lambda[i] } else { 0.0 }),
        Mat::from_fn(b.nrows(), band, |j, k| b[(j, k)]),
        vec![GAP; b.nrows()],
        0,
    )
    .expect("truncated blade");
    let ks = full.contact_stiffness();
    let kc = 0.3 * ks.iter().sum::<f64>() / ks.len() as f64;
    let q = 1.5 * sys.grazing_amplitude(0).expect("mode").expect("touches");
    let mut distances = Vec::new();
    for harmonics in [12, 24, 48] {
        let params = nlmodes_nnm::SolverSettings {
            algorithm: AlgorithmParams {
                method: ContactMethod::Penalty { stiffness: kc },
                ..AlgorithmParams::default()
            },
            // 24 rows on 8 modes are dependent: the dense Newton, as in blade_time_integration.
            condensation: nlmodes_nnm::Condensation::None,
            ..Default::default()
        };
        let settings = HarmonicSettings::new(harmonics, 16 * harmonics).expect("settings");
        let p = Solver::new(&sys, settings, params)
            .and_then(|mut s| s.solve_point(q, Start::LinearMode(0)))
            .expect("penalty orbit");
        let start = Instant::now();
        let all_modes = FloquetSettings {
            mode_cutoff: 1e9,
            ..FloquetSettings::default()
        };
        let hill = floquet(&sys, &p, &all_modes).expect("hill");
        let t_hill = start.elapsed().as_secs_f64();
        let mono = monodromy_by_integration(
            &sys,
            &p,
            &MonodromySettings {
                steps: 200_000,
                jacobian: JacobianInTime::Continuous,
            },
        )
        .expect("monodromy");
        let d = distance(&hill, &mono.multipliers);
        println!(
            "truncated blade ({band} modes), kc = {kc:.3e} N/m, N = {harmonics}: w/w1 = {:.5}, \
             contact {:.3}, Hill ({:.0} ms) max|mu| {:.6} stable {}, monodromy max|mu| {:.6}, \
             distance {d:.2e}, trivial pair {:.1e}",
            p.omega_ratio,
            p.contact_fraction.iter().copied().fold(0.0, f64::max),
            t_hill * 1e3,
            hill.max_multiplier_abs,
            hill.stable,
            mono.multipliers
                .iter()
                .map(|m| m[0].hypot(m[1]))
                .fold(0.0, f64::max),
            hill.trivial_pair_error
        );
        distances.push((d, hill, mono));
    }
    // Observed distances 1.16e-2 (N = 12), 1.14e-2 (N = 24), 6.7e-5 (N = 48): the exponents of
    // the two highest modes (w7, w8 = 23.0, 23.4 w1 ~ 22 w) couple under contact to their
    // conjugate copies 2 w_k / w ~ 44 harmonics away, which N = 12 and 24 do not hold (Hill is
    // converged in N there to 3e-4, to a wrong value); N = 48 does. The orbit has a weak Krein
    // instability of those two modes (a complex quadruple at |mu| = 1.0100) that both methods
    // find at N = 48. Required at N = 48: distance <= 1e-3 (15x the observed), the same
    // instability on both sides.
    let (d, hill, mono) = distances.last().expect("three orders");
    assert!(*d <= 1e-3, "N = 48: distance {d}");
    let mono_max = mono
        .multipliers
        .iter()
        .map(|m| m[0].hypot(m[1]))
        .fold(0.0, f64::max);
    assert!(
        !hill.stable && hill.unstable.complex >= 1,
        "{:?}",
        hill.unstable
    );
    assert!((hill.max_multiplier_abs - mono_max).abs() <= 1e-3);
}

/// The massless contact boundary (docs/STABILITY.md, Sec. 9) on the coarse blade's backbone:
/// every point in contact gets its verdict from the shot orbit, next to the harmonic-balance
/// orbit, confirmed by the independent RK4 integration; and the penalty law in series with the
/// same boundary gives the exact-contact verdict back as kc grows.
#[test]
fn blade_shooting_verdicts_are_checked_and_the_penalty_law_converges_to_them() {
    let sys = blade();
    let points = blade_backbone();
    let every = FloquetSettings {
        verify_every: 1,
        ..FloquetSettings::default()
    };
    let analysis = FloquetAnalysis::new(sys, every.clone()).expect("analysis");
    let g = sys.gap_reference();
    let mut exact = Vec::new();
    let mut undetermined = 0;
    for p in points {
        let st = analysis.analyze_checked(p, true).expect("stability");
        let in_contact = p.contact_force.iter().flatten().any(|&f| f > 0.0);
        if !in_contact {
            continue;
        }
        let check = st.check.clone().expect("checked");
        let word = nlmodes_nnm::verdict_word(&nlmodes_nnm::VerdictInputs::of(&st));
        println!(
            "q/g0 {:6.3} w/w1 {:.5} {:?} r {} switches {} shift {:.1e} trivial {:.1e} max|mu| {:.6} \
             RK4: {} steps, periodic {:.1e}, max|mu| change {:.1e} -> {word}",
            p.q / g,
            p.omega_ratio,
            st.method,
            st.modes_kept,
            st.impacts,
            st.orbit_shift,
            st.trivial_pair_error,
            st.max_multiplier_abs,
            check.steps,
            check.periodicity,
            check.max_multiplier_change
        );
        // Every point in contact is shot and the check confirms it (limit 1e-4; observed
        // <= 3e-7 here, <= 1e-6 on the default blade).
        assert_eq!(
            st.method,
            nlmodes_nnm::StabilityMethod::Shooting,
            "q/g0 {}",
            p.q / g
        );
        assert!(check.agrees(), "q/g0 {}: {check:?}", p.q / g);
        if word == "undetermined" {
            undetermined += 1;
        } else {
            exact.push((p, st));
        }
    }
    // Observed: 1 undetermined of 44 (q/g0 = 12, the last point, after a jump of the
    // continuation: its shot orbit lies 1.3e-2 in w away). Required: at most 10 % (issue 24).
    let total = exact.len() + undetermined;
    println!("{undetermined} undetermined of {total} points in contact");
    assert!(
        total >= 8 && 10 * undetermined <= total,
        "{undetermined} of {total}"
    );
    penalty_convergence(sys, &exact, &every);
}

/// Penalty orbits at the amplitudes of the exact-contact points, kc = 1e7 .. 1e10 N/m, analysed
/// on the massless boundary with the spring in series: the largest |mu| and the verdict approach
/// the exact-contact ones as kc grows.
fn penalty_convergence(
    sys: &System,
    exact: &[(&BackbonePoint, Stability)],
    settings: &FloquetSettings,
) {
    let analysis = FloquetAnalysis::new(sys, settings.clone()).expect("analysis");
    let mut worst = Vec::new();
    for kc in [1e7, 1e8, 1e9, 1e10] {
        let params = nlmodes_nnm::SolverSettings {
            algorithm: AlgorithmParams {
                method: ContactMethod::Penalty { stiffness: kc },
                ..AlgorithmParams::default()
            },
            ..Default::default()
        };
        let settings = HarmonicSettings::new(10, 128).expect("settings");
        let mut solver = Solver::new(sys, settings, params).expect("solver");
        let (mut d_mu, mut d_w, mut disagree) = (0.0_f64, 0.0_f64, 0);
        for (p, st) in exact {
            let pen = solver
                .solve_point(p.q, Start::Point(p))
                .expect("penalty orbit");
            let ps = analysis.analyze(&pen).expect("penalty stability");
            d_mu = d_mu.max((ps.max_multiplier_abs - st.max_multiplier_abs).abs());
            d_w = d_w.max((pen.omega / p.omega - 1.0).abs());
            let words =
                [st, &ps].map(|s| nlmodes_nnm::verdict_word(&nlmodes_nnm::VerdictInputs::of(s)));
            disagree += usize::from(words[0] != words[1]);
        }
        println!(
            "penalty kc = {kc:.0e} N/m: max |w_pen / w - 1| = {d_w:.2e}, max |max|mu| - exact| = \
             {d_mu:.2e}, verdicts differing {disagree} of {}",
            exact.len()
        );
        worst.push((d_w, d_mu, disagree));
    }
    // Converging: the stiffest spring's orbits and multipliers are the closest, and its verdicts
    // are the exact-contact ones.
    let last = worst.last().expect("four springs");
    assert!(
        worst.iter().all(|w| w.0 >= last.0 && w.1 >= last.1),
        "{worst:?}"
    );
    assert_eq!(last.2, 0, "{worst:?}");
}

/// Cost on a reduced-model directory (the default blade: `nlmodes run cases/blade.toml --only
/// reduce`, then NLMODES_STABILITY_MODEL=<results>/blade/model). Not a timed test: prints the
/// backbone time (case settings) and Hill's time over its points, median of 3, for
/// docs/STABILITY.md. `cargo test --release --test blade_stability -- --ignored --nocapture`.
#[test]
#[ignore = "needs a reduced-model directory in NLMODES_STABILITY_MODEL"]
fn default_blade_stability_cost() {
    let Ok(dir) = std::env::var("NLMODES_STABILITY_MODEL") else {
        println!("NLMODES_STABILITY_MODEL not set");
        return;
    };
    let model = nlmodes_modal::ReducedModel::read(std::path::Path::new(&dir)).expect("model");
    let sys = System::new(
        model.m.clone(),
        model.k.clone(),
        model.contact_rows(),
        model.gaps(),
        model.master.dof,
    )
    .expect("system");
    let settings = HarmonicSettings::new(10, 128).expect("settings");
    let params = AlgorithmParams::default(); // the case's (epsilon 1e-4)
    let cont = ContinuationSettings {
        q_start: 0.5,
        q_max: 35.0,
        step: 0.25,
        max_step: 1.0,
        min_step: 1e-4,
        ..ContinuationSettings::default()
    };
    let start = Instant::now();
    let b = backbone(&sys, settings, params, &cont, |_| {}).expect("backbone");
    let t_backbone = start.elapsed().as_secs_f64();
    let analysis = FloquetAnalysis::new(&sys, FloquetSettings::default()).expect("analysis");
    let mut totals = Vec::new();
    let mut results = Vec::new();
    for _ in 0..3 {
        let start = Instant::now();
        results = b
            .points
            .iter()
            .map(|p| analysis.analyze(p).expect("hill"))
            .collect::<Vec<_>>();
        totals.push(start.elapsed().as_secs_f64());
    }
    totals.sort_by(f64::total_cmp);
    let w = sys.linear_frequencies();
    println!(
        "default blade: order {}, {} contact rows, w_k/w1 = {:?}",
        sys.n_dofs(),
        sys.n_contacts(),
        w.iter()
            .take(10)
            .map(|x| (x / w[0] * 100.0).round() / 100.0)
            .collect::<Vec<_>>()
    );
    println!(
        "backbone {} points ({:?}) in {t_backbone:.2} s; Hill over the points: {:?} s (median {:.2} s, {:.1} ms per point)",
        b.points.len(),
        b.termination,
        totals,
        totals[1],
        totals[1] / b.points.len() as f64 * 1e3
    );
    let g = sys.gap_reference();
    for (p, st) in b.points.iter().zip(&results) {
        println!(
            "q/g0 {:7.3} w/w1 {:.5} r {} stable {} max|mu| {:.5} trivial {:.1e} unstable {:?}",
            p.q / g,
            p.omega_ratio,
            st.modes_kept,
            st.stable,
            st.max_multiplier_abs,
            st.trivial_pair_error,
            st.unstable
        );
    }
}
