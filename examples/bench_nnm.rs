//! Cost of one Newton step of the nonlinear-mode solver against the number of interior
//! (non-contact) modes, at a fixed number of contact rows (24) and harmonics.
//!
//! System: a clamped chain of 600 unit masses and springs, reduced by Craig-Bampton onto 24 DOFs
//! spread along it (every 25th: the constrained segments are stiff, so the harmonics of the first
//! mode stay clear of their resonances) with 40 to 400 fixed-interface modes; contact on those 24
//! DOFs, gap 1.
//! Columns: the linear algebra of one Newton step alone (`nlmodes_nnm::newton_step_timing`: every
//! contact row active over 15 % of the period, w = 1.5 w1, N = 10, m = 128), with the exact
//! condensation and with the uncondensed dense LU, and a whole Newton iteration of a solve at
//! 1.1 x grazing for comparison.
//! Prints a Markdown table (medians over RUNS repeats; `cargo run --release --example bench_nnm -- RUNS`).
//! With reduced-model directories after RUNS (`-- RUNS DIR...`), times the same linear solve on
//! those models instead (`scripts/bench nnm` passes the coarse blade reduced with 40 to 400 modes).

use nlmodes_modal::{craig_bampton, EigenOptions};
use nlmodes_nnm::testing::newton_step_timing;
use nlmodes_nnm::{
    AlgorithmParams, Condensation, HarmonicSettings, NewtonSettings, Solver, Start, System,
};
use sprs::TriMat;
use std::time::Instant;

fn chain(n: usize) -> (sprs::CsMat<f64>, sprs::CsMat<f64>) {
    let mut k = TriMat::new((n, n));
    let mut m = TriMat::new((n, n));
    for i in 0..n {
        let diag = if i + 1 < n { 2.0 } else { 1.0 };
        k.add_triplet(i, i, diag);
        m.add_triplet(i, i, 1.0);
        if i + 1 < n {
            k.add_triplet(i, i + 1, -1.0);
            k.add_triplet(i + 1, i, -1.0);
        }
    }
    (k.to_csc(), m.to_csc())
}

fn main() {
    let runs: usize = std::env::args()
        .nth(1)
        .and_then(|s| s.parse().ok())
        .unwrap_or(3);
    let models: Vec<String> = std::env::args().skip(2).collect();
    if !models.is_empty() {
        reduced_models(runs, &models);
        return;
    }
    let n = 600;
    let (k, m) = chain(n);
    let boundary: Vec<usize> = (0..24).map(|j| n - 1 - 25 * j).collect();
    let harmonics = HarmonicSettings::new(10, 128).expect("settings");
    println!(
        "| interior modes | reduced size | Newton unknowns | linear solve, condensed [ms] | \
         linear solve, uncondensed [ms] | whole Newton iteration [ms] |"
    );
    println!("|---|---|---|---|---|---|");
    for modes in [40, 100, 200, 400] {
        let cb =
            craig_bampton(&k, &m, &boundary, modes, &EigenOptions::default()).expect("reduction");
        let nr = cb.n_reduced();
        let mut a = faer::Mat::<f64>::zeros(24, nr);
        for j in 0..24 {
            a[(j, j)] = 1.0;
        }
        let gaps = vec![1.0; 24];
        let system = System::new(cb.m_r.clone(), cb.k_r.clone(), a, gaps, 0).expect("system");
        let step = |condensation| step_ms(&system, harmonics, condensation, runs);
        let condensed = step(Condensation::Exact);
        // The dense uncondensed LU grows as ((N + 1) n)^3: measured up to 100 modes only.
        let full = if modes <= 100 {
            format!("{:.3}", step(Condensation::None))
        } else {
            "-".to_string()
        };
        let unknowns = harmonics.terms() * nr + 2;
        println!(
            "| {modes} | {nr} | {unknowns} | {condensed:.3} | {full} | {} |",
            whole_iteration(&system, harmonics, runs)
        );
    }
}

/// A whole Newton iteration (residuals, transforms, line search included) at 1.1 x grazing:
/// median over RUNS solves of time / iterations, in ms.
fn whole_iteration(system: &System, harmonics: HarmonicSettings, runs: usize) -> String {
    let grazing = match system.grazing_amplitude(0) {
        Ok(Some(g)) => g.abs(),
        _ => return "no grazing".to_string(),
    };
    let mut per_step = Vec::new();
    for _ in 0..runs {
        let mut solver =
            Solver::new(system, harmonics, AlgorithmParams::default()).expect("solver");
        let t = Instant::now();
        match solver.solve_point(1.1 * grazing, Start::LinearMode(0)) {
            Ok(p) => {
                per_step.push(1e3 * t.elapsed().as_secs_f64() / p.newton_iterations.max(1) as f64)
            }
            // The full message is long; the table names the failure, the log has the rest.
            Err(e) => {
                eprintln!("whole-iteration solve at 1.1 x grazing: {e}");
                return "no convergence (see stderr)".to_string();
            }
        }
    }
    per_step.sort_by(f64::total_cmp);
    format!("{:.3}", per_step[per_step.len() / 2])
}

/// The linear algebra of one Newton step on reduced-model directories (`nlmodes reduce` output,
/// e.g. the coarse blade reduced with 40 to 400 fixed-interface modes by `scripts/bench nnm`),
/// every contact row active over 15 % of the period at w = 1.5 w1, N = 10, m = 128.
fn reduced_models(runs: usize, dirs: &[String]) {
    let harmonics = HarmonicSettings::new(10, 128).expect("settings");
    println!(
        "| model | reduced size | contact rows | interior modes | Newton unknowns | \
         linear solve, condensed [ms] | linear solve, uncondensed [ms] |"
    );
    println!("|---|---|---|---|---|---|---|");
    for dir in dirs {
        let model = match nlmodes_modal::ReducedModel::read(std::path::Path::new(dir)) {
            Ok(m) => m,
            Err(e) => {
                eprintln!("{dir}: {e}");
                std::process::exit(2);
            }
        };
        let system = System::new(
            model.m.clone(),
            model.k.clone(),
            model.contact_rows(),
            model.gaps(),
            model.master.dof,
        )
        .expect("system");
        let step = |condensation| step_ms(&system, harmonics, condensation, runs);
        let n = system.n_dofs();
        let c = system.n_contacts();
        let full = if n <= 200 {
            format!("{:.3}", step(Condensation::None))
        } else {
            "-".to_string()
        };
        println!(
            "| {dir} | {n} | {c} | {} | {} | {:.3} | {full} |",
            n - 3 * c,
            harmonics.terms() * n + 2,
            step(Condensation::Exact)
        );
    }
}

/// The linear algebra of one Newton step alone (every contact row active over 15 % of the
/// period, w = 1.5 w1): median of 25 solves, then median over `runs` repeats, in ms.
fn step_ms(
    system: &System,
    harmonics: HarmonicSettings,
    condensation: Condensation,
    runs: usize,
) -> f64 {
    let window = NewtonSettings::default().resonance_window;
    let w1 = system.linear_frequencies()[0];
    let mut medians: Vec<f64> = (0..runs)
        .map(|_| {
            newton_step_timing(system, harmonics, condensation, window, 1.5 * w1, 0.15, 25)
                .expect("step timing")
                .median_seconds
        })
        .collect();
    medians.sort_by(f64::total_cmp);
    1e3 * medians[medians.len() / 2]
}
