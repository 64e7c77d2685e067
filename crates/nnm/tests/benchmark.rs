//! Timing of a blade-like reduced model. Run explicitly:
//! `cargo test --release -p nlmodes-nnm --test benchmark -- --ignored --nocapture`.
//! Model: a twisted lattice plate (24 x 8 nodes) reduced by Craig-Bampton onto its 24 tip nodes
//! (72 DOFs) plus fixed-interface modes, 24 contact rows (see `common::lattice_blade`).

mod common;

use nlmodes_nnm::testing::amplitude_sweep;
use nlmodes_nnm::{
    backbone, AlgorithmParams, ContactMethod, ContinuationSettings, HarmonicSettings, Solver, Start,
};

#[test]
#[ignore = "benchmark: run explicitly"]
fn newton_iteration_cost_versus_interior_modes() {
    for modes in [40usize, 100, 200, 400] {
        let sys = common::lattice_blade(24, 8, modes, 1.0);
        for (n, m) in [(10usize, 128usize), (20, 256)] {
            let settings = HarmonicSettings::new(n, m).expect("settings");
            let params = AlgorithmParams {
                method: ContactMethod::Penalty { stiffness: 2.0 },
                ..AlgorithmParams::default()
            };
            let t0 = std::time::Instant::now();
            let mut solver = Solver::new(&sys, settings, params.clone()).expect("solver");
            let setup = t0.elapsed().as_secs_f64();
            let cont = ContinuationSettings {
                step: 0.25,
                max_step: 0.5,
                ..ContinuationSettings::default()
            };
            let levels: Vec<f64> = (0..10).map(|i| 2.5 + 0.3 * i as f64).collect();
            let b = amplitude_sweep(&sys, settings, params, &cont, &levels, |_| {}).expect("sweep");
            let start = b.points.last().expect("points").clone();
            // Warm-started solves at nearby amplitudes (in contact): time per Newton iteration,
            // residual evaluations and point assembly included.
            let (mut its, mut secs, mut prev) = (0, 0.0, start.clone());
            for k in 1..=20 {
                let t = std::time::Instant::now();
                match solver.solve_point(start.q * (1.0 - 2e-4 * k as f64), Start::Point(&prev)) {
                    Ok(p) => {
                        secs += t.elapsed().as_secs_f64();
                        its += p.newton_iterations;
                        prev = p;
                    }
                    Err(_) => break,
                }
            }
            println!(
                "n = {:3}, n_o = {:3}, N = {n:2}, m = {m}: setup {:6.1} ms, {:5.2} ms per Newton iteration ({its} iterations, {} rows in contact)",
                sys.n_dofs(),
                sys.n_dofs() - 25,
                1e3 * setup,
                1e3 * secs / its.max(1) as f64,
                start.contact_fraction.iter().filter(|&&f| f > 0.0).count()
            );
        }
    }
}

#[test]
#[ignore = "benchmark: run explicitly"]
fn backbone_of_a_112_dof_model() {
    let sys = common::lattice_blade(24, 8, 40, 1.0);
    let levels: Vec<f64> = (0..60)
        .map(|i| 0.5 + (35.0 - 0.5) * i as f64 / 59.0)
        .collect();
    for (n, m) in [(10usize, 128usize), (20, 256)] {
        let settings = HarmonicSettings::new(n, m).expect("settings");
        let penalty = AlgorithmParams {
            method: ContactMethod::Penalty { stiffness: 2.0 },
            ..AlgorithmParams::default()
        };
        for (name, params) in [
            ("penalty kc = 2", penalty),
            ("Algorithm 1", AlgorithmParams::default()),
        ] {
            let cont = ContinuationSettings {
                q_start: 0.5,
                q_max: 35.0,
                step: 0.25,
                max_step: 2.0,
                max_points: 200,
                ..ContinuationSettings::default()
            };
            let t = std::time::Instant::now();
            let b = backbone(&sys, settings, params.clone(), &cont, |_| {}).expect("backbone");
            let last = b.points.last().expect("points");
            println!(
                "N = {n:2}, m = {m}, {name}: arc length, {} points, last q = {:.2} g0 (w/w1 = {:.4}), {:.2} s, {}",
                b.points.len(),
                last.q,
                last.omega_ratio,
                t.elapsed().as_secs_f64(),
                match &b.termination {
                    nlmodes_nnm::Termination::StepTooSmall { q, .. } => format!("stopped at q = {q:.3}"),
                    t => format!("{t:?}"),
                }
            );
            let t = std::time::Instant::now();
            let cont = ContinuationSettings {
                step: 0.1,
                min_step: 1e-3,
                max_step: 1.0,
                ..ContinuationSettings::default()
            };
            let b = amplitude_sweep(&sys, settings, params, &cont, &levels, |_| {}).expect("sweep");
            println!(
                "N = {n:2}, m = {m}, {name}: sweep of 60 levels 0.5..35 g0: {} solved, {} skipped, {:.2} s",
                b.points.len(),
                b.skipped.len(),
                t.elapsed().as_secs_f64()
            );
        }
    }
}
