//! docs/DESIGN.md §5 oracle: 1 DOF, x'' + x = 0 with a rigid stop at x = g, solved by Algorithm 1 to
//! G <= 1e-8 (units of g), compared with w/w0 = pi / (pi - arccos(g/A)).

mod common;

use nlmodes_nnm::{AlgorithmParams, HarmonicSettings, Solver, Start};

/// Relative frequency error at A/g = `a_over_g` for N harmonics (m = default samples).
fn rigid_error(harmonics: usize, a_over_g: f64) -> (f64, nlmodes_nnm::BackbonePoint) {
    let g = 1.0;
    let sys = common::one_dof(g);
    let settings = HarmonicSettings::with_default_samples(harmonics).expect("settings");
    // G <= 1e-8 needs penalties above the default cap (1e4 x contact stiffness): the 1-DOF inner
    // problem stays easy for Newton at any penalty, so the cap is lifted.
    let params = AlgorithmParams {
        epsilon: 1e-8,
        max_penalty: 1e10,
        ..AlgorithmParams::default()
    };
    let mut solver = Solver::new(&sys, settings, params).expect("solver");
    let start = solver
        .solve_point(0.9, Start::LinearMode(0))
        .expect("below grazing");
    let p = common::solve_at_free_amplitude(&mut solver, &start, a_over_g * g);
    assert!(p.powell_measure <= 1e-8, "G = {}", p.powell_measure);
    let exact = common::rigid_stop_ratio(a_over_g);
    ((p.omega_ratio - exact).abs() / exact, p)
}

#[test]
fn rigid_stop_error_decreases_with_harmonics() {
    let orders = [4usize, 8, 16, 32, 64];
    let mut table = Vec::new();
    for &a_over_g in &[2.0, 5.0] {
        let mut errors = Vec::new();
        for &n in &orders {
            let (err, p) = rigid_error(n, a_over_g);
            table.push((a_over_g, n, p.omega_ratio, err));
            errors.push(err);
        }
        // The velocity jumps at impact, so coefficients decay like 1/n^2 and the frequency error
        // like 1/N: each doubling of N must reduce it (by at least a factor 1.5; about 2 observed).
        for w in errors.windows(2) {
            assert!(w[1] < w[0] / 1.5, "A/g = {a_over_g}: errors {errors:?}");
        }
        // N = 64: first-order convergence from about 0.2 at N = 1 gives ~3e-3; allow 5e-3.
        assert!(
            errors[errors.len() - 1] < 5e-3,
            "A/g = {a_over_g}: {errors:?}"
        );
    }
    println!("rigid stop, Algorithm 1 to G <= 1e-8, m = max(8N, 64) rounded to a power of 2");
    println!("| A/g | N | w/w0 (HB) | w/w0 exact | relative error |");
    println!("|---|---|---|---|---|");
    for (a, n, w, e) in table {
        println!(
            "| {a} | {n} | {w:.6} | {:.6} | {e:.2e} |",
            common::rigid_stop_ratio(a)
        );
    }
}

#[test]
fn complementarity_holds_on_every_sample_at_convergence() {
    let (_, p) = rigid_error(16, 3.0);
    let sys = common::one_dof(1.0);
    let m = p.contact_force[0].len();
    let gaps = p.gap_samples(&sys, m);
    let lambda_max = p.contact_force[0].iter().cloned().fold(0.0, f64::max);
    assert!(lambda_max > 0.0, "contact expected at A/g = 3");
    for (k, (&l, &g)) in p.contact_force[0].iter().zip(&gaps[0]).enumerate() {
        assert!(l >= 0.0, "lambda < 0 at sample {k}");
        // G <= 1e-8 bounds penetration by 1e-8 g0 (g0 = 1) ...
        assert!(g <= 1e-8, "penetration {g} at sample {k}");
        // ... and, where lambda > 0, |g| by 1e-8 g0 too: |lambda g| <= 1e-8 lambda_max.
        assert!(
            (l * g).abs() <= 1e-8 * lambda_max,
            "lambda g = {} at sample {k}",
            l * g
        );
    }
}

#[test]
fn row_maximum_reading_of_eq_21_accepts_a_wrong_orbit() {
    // Why `PowellMeasure::Entrywise` is the default: with docs/DESIGN.md §3's literal reading,
    // G = max_j |max_k max(g, -theta)|, any open sample with theta = 0 makes max_k >= 0, so
    // negative entries (a multiplier pushing where the gap is open) never count. Here Algorithm 1
    // exactly as printed (penalty update included) stops with G = 0 while lambda > 0 on samples
    // where the gap is far from closed; the same algorithm with the entrywise measure converges
    // to a complementary orbit.
    let sys = common::one_dof(1.0);
    let settings = HarmonicSettings::with_default_samples(16).expect("settings");
    let run = |measure| {
        let params = AlgorithmParams {
            epsilon: 1e-8,
            max_penalty: 1e10,
            measure,
            penalty_update: nlmodes_nnm::PenaltyUpdate::AsPrinted,
            ..AlgorithmParams::default()
        };
        let mut solver = Solver::new(&sys, settings, params).expect("solver");
        let p0 = solver
            .solve_point(1.0, Start::LinearMode(0))
            .expect("grazing");
        let p1 = solver.solve_point(1.2, Start::Point(&p0)).expect("contact");
        solver.solve_point(1.5, Start::Point(&p1)).expect("contact")
    };
    let violation = |p: &nlmodes_nnm::BackbonePoint| {
        let gaps = p.gap_samples(&sys, p.contact_force[0].len());
        let lmax = p.contact_force[0].iter().cloned().fold(0.0, f64::max);
        p.contact_force[0]
            .iter()
            .zip(&gaps[0])
            .fold(0.0_f64, |a, (l, g)| a.max((l * g).abs()))
            / lmax
    };
    let literal = run(nlmodes_nnm::PowellMeasure::RowMaximum);
    let entrywise = run(nlmodes_nnm::PowellMeasure::Entrywise);
    println!(
        "row maximum: G = {:e}, max |lambda g| / max lambda = {:.2e}; entrywise: G = {:e}, {:.2e}",
        literal.powell_measure,
        violation(&literal),
        entrywise.powell_measure,
        violation(&entrywise)
    );
    assert!(literal.powell_measure <= 1e-8);
    assert!(
        violation(&literal) > 1e-2,
        "the literal reading happened to be complementary"
    );
    assert!(violation(&entrywise) <= 1e-8);
}
