mod common;
use nlmodes_nnm::*;

#[test]
fn scratch() {
    let sys = common::lattice_blade(24, 8, 40, 1.0);
    for (n, m) in [(10usize, 128usize)] {
        let settings = HarmonicSettings::new(n, m).unwrap();
        let params = AlgorithmParams::default();
        let levels: Vec<f64> = (0..60).map(|i| 0.5 + (35.0 - 0.5) * i as f64 / 59.0).collect();
        let cont = ContinuationSettings { step: 0.05, min_step: 1e-3, max_step: 1.0, ..Default::default() };
        let t = std::time::Instant::now();
        let mut last = std::time::Instant::now();
        let b = amplitude_sweep(&sys, settings, params, &cont, &levels, |p| { println!("  kmax/ks={:.1e} q={:.2} w/w1={:.4} G={:.1e} outer={} solves={} newton={} ncontact={} jump={} t={:?}", p.multipliers.kappa.iter().cloned().fold(0.0, f64::max) / 1.9, p.q, p.omega_ratio, p.powell_measure, p.outer_iterations, p.inner_solves, p.newton_iterations, p.contact_fraction.iter().filter(|&&x| x > 0.0).count(), p.jump, last.elapsed()); last = std::time::Instant::now(); }).unwrap();
        println!("N={n} m={m}: {} points, {} skipped {:?} {:?}", b.points.len(), b.skipped.len(), b.termination, t.elapsed());
    }
}
