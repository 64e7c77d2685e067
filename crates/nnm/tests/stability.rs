//! Floquet stability by Hill's method (`nlmodes_nnm::floquet`), checked against exact linear
//! multipliers and against the monodromy matrix integrated in time along the same orbit.

mod common;

use faer::Mat;
use nlmodes_nnm::{
    classify, floquet, monodromy_by_integration, AlgorithmParams, BackbonePoint, Bifurcation,
    ContactMethod, FloquetSettings, HarmonicSettings, JacobianInTime, MonodromySettings, Solver,
    Stability, Start, System,
};

/// M = I, K = [[2, -1], [-1, 2]], contact row on DOF 2 (index 1) with gap `gap`, master DOF 2.
fn two_dof(gap: f64) -> System {
    let m = Mat::from_fn(2, 2, |i, j| if i == j { 1.0 } else { 0.0 });
    let k = Mat::from_fn(2, 2, |i, j| if i == j { 2.0 } else { -1.0 });
    let a = Mat::from_fn(1, 2, |_, c| if c == 1 { 1.0 } else { 0.0 });
    System::new(m, k, a, vec![gap], 1).expect("valid 2-DOF system")
}

/// Penalty orbit of the 2-DOF chain (gap 1) at master amplitude `q`, reached from the linear mode
/// through q = 0.9, 1.1, ...
fn penalty_point(sys: &System, kc: f64, harmonics: usize, samples: usize, q: f64) -> BackbonePoint {
    let settings = HarmonicSettings::new(harmonics, samples).expect("settings");
    let params = AlgorithmParams {
        method: ContactMethod::Penalty { stiffness: kc },
        ..AlgorithmParams::default()
    };
    let mut solver = Solver::new(sys, settings, params).expect("solver");
    let mut p = solver
        .solve_point(0.9, Start::LinearMode(0))
        .expect("below grazing");
    let mut level = 0.9;
    while level < q {
        level = (level + 0.2).min(q);
        p = solver
            .solve_point(level, Start::Point(&p))
            .expect("penalty point");
    }
    p
}

/// Largest distance from each multiplier of `a` to the nearest one of `b`, over the non-trivial
/// multipliers of `hill`.
fn nontrivial_distance(hill: &Stability, b: &[[f64; 2]]) -> f64 {
    hill.multipliers
        .iter()
        .enumerate()
        .filter(|(i, _)| !hill.trivial.contains(i))
        .map(|(_, mu)| {
            b.iter()
                .map(|nu| (mu[0] - nu[0]).hypot(mu[1] - nu[1]))
                .fold(f64::INFINITY, f64::min)
        })
        .fold(0.0, f64::max)
}

fn modulus(mu: &[f64; 2]) -> f64 {
    mu[0].hypot(mu[1])
}

#[test]
fn below_grazing_the_multipliers_are_those_of_the_linear_modes() {
    // 3-DOF chain, contact on the free end (gap 1, also the master): at q = 0.5 the orbit is the
    // first linear mode, so Hill's matrix has no contact term and its exponents are exactly
    // +-i w_k: multipliers exp(+-i w_k T), T = 2 pi / w1, the pair of mode 1 at +1 (trivial).
    let sys = common::chain(3, 1.0, &[2], 1.0, 2);
    let settings = HarmonicSettings::new(8, 64).expect("settings");
    let mut solver = Solver::new(&sys, settings, AlgorithmParams::default()).expect("solver");
    let p = solver
        .solve_point(0.5, Start::LinearMode(0))
        .expect("linear point");
    let st = floquet(&sys, &p, &FloquetSettings::default()).expect("floquet");
    let t = p.period();
    assert_eq!(st.modes_kept, 3);
    assert_eq!(st.multipliers.len(), 6);
    let mut expected = Vec::new();
    for w in sys.linear_frequencies() {
        expected.push([(w * t).cos(), (w * t).sin()]);
        expected.push([(w * t).cos(), -(w * t).sin()]);
    }
    // Every expected multiplier is matched one to one (greedy nearest); round-off of the
    // eigensolver on a 2 x 3 x 17 = 102-order matrix with entries up to (N w)^2 ~ 64: ~1e-13;
    // 1e-9 leaves margin, far below any physical effect.
    let mut left = st.multipliers.clone();
    for e in &expected {
        let (i, d) = left
            .iter()
            .enumerate()
            .map(|(i, mu)| (i, (mu[0] - e[0]).hypot(mu[1] - e[1])))
            .min_by(|a, b| a.1.total_cmp(&b.1))
            .expect("multiplier left");
        assert!(
            d <= 1e-9,
            "expected {e:?}, nearest at {d:e}: {:?}",
            st.multipliers
        );
        left.swap_remove(i);
    }
    assert!(st
        .multipliers
        .iter()
        .all(|mu| (modulus(mu) - 1.0).abs() <= 1e-9));
    assert!(st.trivial_pair_error <= 1e-9, "{}", st.trivial_pair_error);
    assert!(
        st.reciprocal_pair_error <= 1e-9,
        "{}",
        st.reciprocal_pair_error
    );
    assert!(st.stable && st.max_multiplier_abs <= 1.0 + 1e-9);
    assert_eq!(classify(&st, &st), None);
    // The selected eigenvectors are centred on harmonic 0 (Lazarus-Thomas criterion).
    assert!(
        st.selection_mean_harmonic_max <= 1e-6,
        "{}",
        st.selection_mean_harmonic_max
    );
}

/// Hill (continuous-time Jacobian) against the monodromy integrated with the same Jacobian along
/// the same orbit, for N = 10, 20, 40 (m = 8N... 512): distance of the non-trivial multipliers.
fn hill_vs_monodromy(kc: f64, q: f64) -> Vec<(usize, f64, f64, f64)> {
    let sys = two_dof(1.0);
    let mut rows = Vec::new();
    for (harmonics, samples) in [(10, 128), (20, 256), (40, 512)] {
        let p = penalty_point(&sys, kc, harmonics, samples, q);
        let hill = floquet(&sys, &p, &FloquetSettings::default()).expect("hill");
        let mono = monodromy_by_integration(
            &sys,
            &p,
            &MonodromySettings {
                steps: 20_000,
                jacobian: JacobianInTime::Continuous,
            },
        )
        .expect("monodromy");
        let d = nontrivial_distance(&hill, &mono.multipliers);
        println!(
            "kc = {kc}, q = {q}, N = {harmonics:2}, m = {samples}: w/w1 = {:.6}, Hill {:?}, \
             monodromy {:?}, distance {d:.2e}, trivial pair error {:.2e}",
            p.omega_ratio, hill.multipliers, mono.multipliers, hill.trivial_pair_error
        );
        // Hamiltonian structure of Hill's linearization: reciprocal pairs to round-off.
        assert!(
            hill.reciprocal_pair_error <= 1e-9,
            "{}",
            hill.reciprocal_pair_error
        );
        rows.push((
            harmonics,
            d,
            hill.trivial_pair_error,
            hill.max_multiplier_abs,
        ));
    }
    rows
}

#[test]
fn hill_agrees_with_the_integrated_monodromy_on_a_penalty_orbit() {
    // Both sides use the same harmonic-balance orbit and the same continuous-time Jacobian
    // (switches located on the reconstructed gap), so what separates them is Hill's truncation of
    // the perturbation to N harmonics (the RK4 error, ~(h w_max)^4 per period with h w_max ~ 3e-3
    // for kc = 50, is ~1e-10). The Jacobian jumps at each switch, so p(t) has a kink-type
    // singularity and the distance falls like N^-3: observed 5.3e-4, 6.2e-5, 7.8e-6 (kc = 5,
    // a stable orbit, multipliers on the circle) and 3.8e-2, 3.8e-3, 4.3e-4 (kc = 50, a
    // period-doubled orbit, mu ~ -1.303) for N = 10, 20, 40. Required: at N = 40 below 2e-5 and
    // 1.5e-3 (3x margin), and at least a 4x decrease per doubling of N.
    for (kc, tolerance) in [(5.0, 2e-5), (50.0, 1.5e-3)] {
        let rows = hill_vs_monodromy(kc, 1.5);
        let last = rows.last().expect("rows");
        assert!(
            last.1 <= tolerance,
            "kc = {kc}: distance {} at N = 40",
            last.1
        );
        for w in rows.windows(2) {
            assert!(w[1].1 * 4.0 <= w[0].1, "kc = {kc}: no convergence {rows:?}");
            // The trivial pair: the sampled orbit is not exactly time-shift invariant; the pair
            // is a Jordan block, so a perturbation delta moves it by ~sqrt(delta). Observed
            // 8.8e-3, 3.3e-3, 2.0e-3 (kc = 5) and 3.9e-2, 4.6e-3, 1.6e-3 (kc = 50).
            assert!(w[1].2 < w[0].2, "kc = {kc}: trivial pair {rows:?}");
        }
        assert!(last.2 <= 4e-3, "kc = {kc}: trivial pair error {}", last.2);
    }
}

#[test]
fn a_period_doubling_is_flagged_where_the_monodromy_shows_it() {
    // Penalty kc = 50 on the 2-DOF chain: stable at q = 1.1, period-doubled at q = 1.5 (mu ~ -1.3,
    // previous test). Sweep q by 0.02 with N = 20, m = 256, flag the transition by `classify`,
    // and check it with the integrated monodromy on both sides (its own N-independent criterion:
    // the most negative real multiplier below or above -1).
    let sys = two_dof(1.0);
    let settings = HarmonicSettings::new(20, 256).expect("settings");
    let params = AlgorithmParams {
        method: ContactMethod::Penalty { stiffness: 50.0 },
        ..AlgorithmParams::default()
    };
    let mut solver = Solver::new(&sys, settings, params).expect("solver");
    let mut p = solver
        .solve_point(0.9, Start::LinearMode(0))
        .expect("linear");
    let analysis =
        nlmodes_nnm::FloquetAnalysis::new(&sys, FloquetSettings::default()).expect("analysis");
    let mut prev: Option<(BackbonePoint, Stability)> = None;
    let mut found = Vec::new();
    let mut q = 1.1;
    while q <= 1.5 + 1e-9 {
        p = solver.solve_point(q, Start::Point(&p)).expect("point");
        let st = analysis.analyze(&p).expect("hill");
        if let Some((pp, ps)) = &prev {
            if let Some(b) = classify(ps, &st) {
                found.push((b, pp.clone(), p.clone(), ps.clone(), st.clone()));
            }
        }
        prev = Some((p.clone(), st));
        q += 0.02;
    }
    assert_eq!(
        found.len(),
        1,
        "one bifurcation expected: {:?}",
        found.iter().map(|f| (f.0, f.1.q)).collect::<Vec<_>>()
    );
    let (kind, before, after, st_before, st_after) = &found[0];
    assert_eq!(*kind, Bifurcation::PeriodDoubling);
    assert!(st_before.stable && !st_after.stable);
    assert_eq!(st_after.unstable.real_negative, 1);
    println!(
        "period doubling between q = {:.2} (w/w1 = {:.5}) and q = {:.2} (w/w1 = {:.5})",
        before.q, before.omega_ratio, after.q, after.omega_ratio
    );
    let most_negative = |point: &BackbonePoint| {
        let mono = monodromy_by_integration(
            &sys,
            point,
            &MonodromySettings {
                steps: 20_000,
                jacobian: JacobianInTime::Continuous,
            },
        )
        .expect("monodromy");
        mono.multipliers
            .iter()
            .filter(|m| m[1].abs() <= 1e-9 * m[0].abs().max(1.0))
            .map(|m| m[0])
            .fold(f64::INFINITY, f64::min)
    };
    let (mb, ma) = (most_negative(before), most_negative(after));
    println!("monodromy: most negative real multiplier {mb} before, {ma} after");
    assert!(mb >= -1.0 && ma < -1.0, "monodromy disagrees: {mb} / {ma}");
}

#[test]
fn floquet_settings_default_reject_unknown_keys_and_validate() {
    let s: FloquetSettings = serde_json::from_str("{}").expect("all fields default");
    assert_eq!(s, FloquetSettings::default());
    let s: FloquetSettings =
        serde_json::from_str(r#"{"mode_cutoff": 3.0, "jacobian": "sample_intervals"}"#)
            .expect("two keys");
    assert_eq!(s.mode_cutoff, 3.0);
    assert_eq!(s.jacobian, JacobianInTime::SampleIntervals);
    assert!(serde_json::from_str::<FloquetSettings>(r#"{"cutoff": 3.0}"#).is_err());
    let bad = FloquetSettings {
        mode_cutoff: -1.0,
        ..FloquetSettings::default()
    };
    let sys = two_dof(1.0);
    assert!(nlmodes_nnm::FloquetAnalysis::new(&sys, bad).is_err());
    // A point from another system is rejected with a typed error, not a panic.
    let other = common::chain(3, 1.0, &[2], 1.0, 2);
    let settings = HarmonicSettings::new(4, 32).expect("settings");
    let p = Solver::new(&other, settings, AlgorithmParams::default())
        .and_then(|mut s| s.solve_point(0.5, Start::LinearMode(0)))
        .expect("point");
    assert!(matches!(
        floquet(&sys, &p, &FloquetSettings::default()),
        Err(nlmodes_nnm::NnmError::StabilityInput { .. })
    ));
}
