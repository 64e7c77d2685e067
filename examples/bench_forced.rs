//! One forced-response curve of a reduced model: time, points, folds and how it ended.
//!
//! `cargo run --release --example bench_forced -- MODEL_DIR [RUNS] [LEVEL] [ZETA] [METHOD]`:
//! the reduced model of `nlmodes run` (e.g. results/blade/model), modal damping ZETA on every
//! mode (default 0.003), a harmonic force on the master coordinate at the fundamental whose
//! linear peak amplitude would be LEVEL times the grazing amplitude of mode 1 (default 3),
//! swept from 0.9 to 1.5 w1 with N = 10 and the default samples; METHOD `al` (Algorithm 1,
//! default) or a penalty stiffness in N/m. Prints the median time of RUNS runs (default 3).
//! STABILITY=0 leaves out the Floquet multipliers; VERBOSE=1 prints every point (W, inner
//! solves, Newton iterations, Powell's measure, seconds); EXACT=1 also traces the exact curve on
//! the massless contact boundary (`[forced] exact_curve`), timed inside the run and apart.

use std::path::Path;
use std::time::Instant;

use nlmodes_forced::{response_curve, Damping, ForcedSettings, ForcedSolver, FrfSettings, Load};
use nlmodes_modal::ReducedModel;
use nlmodes_nnm::{ContactMethod, System};

fn main() {
    tracing_subscriber::fmt()
        .with_env_filter(tracing_subscriber::EnvFilter::from_default_env())
        .with_writer(std::io::stderr)
        .with_ansi(false)
        .init();
    if std::env::var("PAR").is_ok_and(|v| v == "seq") {
        faer::set_global_parallelism(faer::Par::Seq);
    }
    let args: Vec<String> = std::env::args().collect();
    let dir = args
        .get(1)
        .expect("usage: bench_forced MODEL_DIR [RUNS] [LEVEL] [ZETA] [METHOD]");
    let runs: usize = args.get(2).map_or(3, |s| s.parse().expect("RUNS"));
    let level: f64 = args.get(3).map_or(3.0, |s| s.parse().expect("LEVEL"));
    let zeta: f64 = args.get(4).map_or(0.003, |s| s.parse().expect("ZETA"));
    let model = ReducedModel::read(Path::new(dir)).expect("reduced model");
    let system = System::new(
        model.m.clone(),
        model.k.clone(),
        model.contact_rows(),
        model.gaps(),
        model.master.dof,
    )
    .expect("system");
    let w1 = system.linear_frequencies()[0];
    let phi = system.linear_mode(0).expect("mode 1");
    let master = system.master();
    let q_graze = system
        .grazing_amplitude(0)
        .expect("mode")
        .expect("mode 1 touches");
    // Linear peak of the master: F phi_m^2 / (2 zeta w1^2) = level q_graze.
    let force = level * q_graze * 2.0 * zeta * w1 * w1 / (phi[master] * phi[master]);
    let mut shape = vec![0.0; system.n_dofs()];
    shape[master] = force;
    let c = Damping::ModalRatios(vec![zeta])
        .matrix(&system)
        .expect("damping");
    let mut settings = ForcedSettings::new(10).expect("settings");
    if let Some(m) = args.get(5).filter(|m| m.as_str() != "al") {
        settings.algorithm.method = ContactMethod::Penalty {
            stiffness: m.parse().expect("METHOD"),
        };
    }
    let solver =
        ForcedSolver::new(&system, &c, &Load::fundamental(shape), settings).expect("solver");
    let stability = std::env::var("STABILITY").map_or(true, |v| v != "0");
    let frf = FrfSettings {
        stability,
        ..FrfSettings::new(0.9 * w1, 1.5 * w1)
    };
    let exact = std::env::var("EXACT").is_ok_and(|v| v == "1");
    let mut times = Vec::new();
    let mut exact_times = Vec::new();
    for run in 0..runs {
        let t0 = Instant::now();
        let verbose = std::env::var("VERBOSE").is_ok_and(|v| v == "1");
        let t_point = std::cell::Cell::new(Instant::now());
        let curve = response_curve(&solver, &frf, |p| {
            if verbose {
                eprintln!(
                    "W/w1 = {:.6} solves {} newton {} G {:.2e} {:.3} s",
                    p.omega / w1,
                    p.inner_solves,
                    p.newton_iterations,
                    p.powell_measure,
                    t_point.get().elapsed().as_secs_f64()
                );
                t_point.set(Instant::now());
            }
        })
        .expect("curve");
        if exact {
            let t1 = Instant::now();
            let e = solver
                .boundary_curve(&curve.points, frf.end, frf.stability_margin)
                .expect("exact curve");
            exact_times.push(t1.elapsed().as_secs_f64());
            if let (0, Some(e)) = (run, e) {
                let folds: Vec<f64> = e
                    .points
                    .iter()
                    .filter(|p| p.fold)
                    .map(|p| p.omega / w1)
                    .collect();
                println!(
                    "exact curve: {} points, {} modes dynamic, folds at W/w1 {folds:.5?}, {}",
                    e.points.len(),
                    e.modes,
                    nlmodes_boundary::driven_end_text(&e.end)
                );
            }
        }
        times.push(t0.elapsed().as_secs_f64());
        if run == 0 {
            let amp = |p: &nlmodes_forced::ForcedPoint| {
                p.coefficients[(master, 1)].hypot(p.coefficients[(master, 2)])
            };
            let peak = curve
                .points
                .iter()
                .max_by(|a, b| amp(a).total_cmp(&amp(b)))
                .expect("points");
            let count = |v| curve.stability.iter().filter(|s| s.verdict == v).count();
            let unstable = count(nlmodes_forced::Verdict::Unstable);
            let undetermined = count(nlmodes_forced::Verdict::Undetermined);
            if let Some(worst) = curve
                .stability
                .iter()
                .filter_map(|s| s.liouville_error)
                .max_by(f64::total_cmp)
            {
                println!("undetermined {undetermined}, largest Liouville error {worst:.3e}");
            }
            if std::env::var("VERDICTS").is_ok_and(|v| v == "1") {
                for (p, st) in curve.points.iter().zip(&curve.stability) {
                    println!(
                        "W/w1 {:.5} q/g0 {:.3} {:?} |mu| {:?} {:?}",
                        p.omega / w1,
                        amp(p) / system.gap_reference(),
                        st.verdict,
                        st.largest_multiplier,
                        st.bifurcation
                    );
                }
            }
            for (i, f) in curve.folds.iter().enumerate() {
                println!("fold {i}: W/w1 = {:.5} {:?}", f.at / w1, f.kind);
            }
            println!(
                "{} points, {} folds, {} hops, {unstable} unstable, end: {:?}\npeak q/g0 = {:.3} at W/w1 = {:.5}, force {force:.3e} N",
                curve.points.len(),
                curve.folds.len(),
                curve.hops.len(),
                curve.termination,
                amp(peak) / system.gap_reference(),
                peak.omega / w1
            );
        }
    }
    times.sort_by(f64::total_cmp);
    println!("median of {runs}: {:.2} s", times[runs / 2]);
    if exact {
        exact_times.sort_by(f64::total_cmp);
        println!(
            "of which the exact curve, median of {runs}: {:.2} s",
            exact_times[runs / 2]
        );
    }
}
