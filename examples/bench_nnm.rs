//! Cost of one Newton step of the nonlinear-mode solver against the number of interior
//! (non-contact) modes, at a fixed number of contact rows (24) and harmonics.
//!
//! System: a clamped chain of 600 unit masses and springs, reduced by Craig-Bampton onto 24 DOFs
//! spread along it (every 25th: the constrained segments are stiff, so the harmonics of the first
//! mode stay clear of their resonances) with 40 to 400 fixed-interface modes; contact on those 24
//! DOFs, gap 1.
//! Prints a Markdown table (median of RUNS solves; `cargo run --release --example bench_nnm -- RUNS`).

use nlmodes_modal::{craig_bampton, EigenOptions};
use nlmodes_nnm::{AlgorithmParams, HarmonicSettings, Solver, Start, System};
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
    let n = 600;
    let (k, m) = chain(n);
    let boundary: Vec<usize> = (0..24).map(|j| n - 1 - 25 * j).collect();
    let harmonics = HarmonicSettings::new(10, 128).expect("settings");
    println!("| interior modes | reduced size | Newton iterations | time per Newton step [ms] |");
    println!("|---|---|---|---|");
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
        let grazing = system
            .grazing_amplitude(0)
            .expect("grazing")
            .expect("touches");
        let q = 1.1 * grazing.abs();
        let mut per_step = Vec::new();
        let mut iterations = 0;
        for _ in 0..runs {
            let mut solver =
                Solver::new(&system, harmonics, AlgorithmParams::default()).expect("solver");
            let t = Instant::now();
            match solver.solve_point(q, Start::LinearMode(0)) {
                Ok(p) => {
                    let dt = t.elapsed().as_secs_f64();
                    iterations = p.newton_iterations.max(1);
                    per_step.push(1e3 * dt / iterations as f64);
                }
                Err(e) => {
                    println!("| {modes} | {nr} | failed: {e} | |");
                    break;
                }
            }
        }
        if per_step.len() == runs {
            per_step.sort_by(f64::total_cmp);
            println!(
                "| {modes} | {nr} | {iterations} | {:.3} |",
                per_step[per_step.len() / 2]
            );
        }
    }
}
