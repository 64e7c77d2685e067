//! How far the forced peaks of the blade lie from its backbone, at several damping ratios (issue
//! 22: "at two damping levels the peaks of the forced curves lie on the backbone within a
//! distance that shrinks with the damping").
//!
//! `cargo run --release --example crowning_blade -- MODEL_DIR [SAMPLES] [KC_FACTOR] [LEVEL]`:
//! the reduced model of `nlmodes run` (e.g. results/blade/model), N = 10 harmonics and SAMPLES
//! time samples per period (default 128, the default of N = 10), the penalty law with kc =
//! KC_FACTOR (default 10) x the median static contact stiffness of the rows, a force on the
//! master whose linear resonant peak is LEVEL (default 5) x the grazing amplitude at each damping
//! ratio (so the peaks reach about the same amplitude). For zeta = 0.3 %, 0.1 % and 0.03 % it
//! traces the frequency response over 0.9 .. 1.5 w1 and prints the peak (W_p, q_p), the
//! backbone's frequency at q_p on its main branch (the same law, N and samples), and their
//! distance |W_p - w_b(q_p)| / w1.

use std::path::Path;

use nlmodes_forced::{response_curve, Damping, ForcedSettings, ForcedSolver, FrfSettings, Load};
use nlmodes_modal::ReducedModel;
use nlmodes_nnm::{
    backbone, AlgorithmParams, BranchKind, ContactMethod, ContinuationSettings, HarmonicSettings,
    System,
};

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let dir = args
        .get(1)
        .expect("usage: crowning_blade MODEL_DIR [SAMPLES] [KC_FACTOR] [LEVEL]");
    let samples: usize = args.get(2).map_or(128, |s| s.parse().expect("SAMPLES"));
    let kc_factor: f64 = args.get(3).map_or(10.0, |s| s.parse().expect("KC_FACTOR"));
    let level: f64 = args.get(4).map_or(5.0, |s| s.parse().expect("LEVEL"));
    let model = ReducedModel::read(Path::new(dir)).expect("reduced model");
    let system = System::new(
        model.m.clone(),
        model.k.clone(),
        model.contact_rows(),
        model.gaps(),
        model.master.dof,
    )
    .expect("system");
    let (w1, g0, master) = (
        system.linear_frequencies()[0],
        system.gap_reference(),
        system.master(),
    );
    let mut ks = system.contact_stiffness().to_vec();
    ks.sort_by(f64::total_cmp);
    let kc = kc_factor * ks[ks.len() / 2];
    let harmonics = HarmonicSettings::new(10, samples).expect("harmonics");
    let algorithm = AlgorithmParams {
        method: ContactMethod::Penalty { stiffness: kc },
        ..AlgorithmParams::default()
    };
    let q_graze = system.grazing_amplitude(0).expect("mode").expect("touches");
    let cont = ContinuationSettings {
        q_start: 0.5,
        q_max: 3.0 * level * q_graze.abs() / g0,
        ..ContinuationSettings::default()
    };
    let family = backbone(&system, harmonics, algorithm.clone(), &cont, |_| {}).expect("backbone");
    let main: Vec<(f64, f64)> = family
        .points
        .iter()
        .filter(|p| {
            !matches!(
                family.branches.get(p.branch).map(|b| &b.kind),
                Some(BranchKind::Tongue { .. })
            )
        })
        .map(|p| (p.q, p.omega))
        .collect();
    let phi = system.linear_mode(0).expect("mode 1");
    println!(
        "samples {samples}, kc = {kc:.3e} N/m, level {level}; backbone: {} points ({} on the main branch) up to q/g0 = {:.3}, {:?}",
        family.points.len(),
        main.len(),
        main.last().map_or(0.0, |p| p.0 / g0),
        family.termination
    );
    for zeta in [0.003, 0.001, 0.0003] {
        let force = level * q_graze.abs() * 2.0 * zeta * w1 * w1 / (phi[master] * phi[master]);
        let mut shape = vec![0.0; system.n_dofs()];
        shape[master] = force;
        let c = Damping::ModalRatios(vec![zeta]).matrix(&system).expect("C");
        let settings = ForcedSettings {
            harmonics,
            algorithm: algorithm.clone(),
            ..ForcedSettings::new(10).expect("settings")
        };
        let solver = ForcedSolver::new(&system, &c, &Load::fundamental(shape), settings).unwrap();
        let frf = FrfSettings {
            stability: false,
            ..FrfSettings::new(0.9 * w1, 1.5 * w1)
        };
        let curve = response_curve(&solver, &frf, |_| {}).expect("curve");
        let amp = |p: &nlmodes_forced::ForcedPoint| {
            p.coefficients[(master, 1)].hypot(p.coefficients[(master, 2)])
        };
        let peak = curve
            .points
            .iter()
            .max_by(|a, b| amp(a).total_cmp(&amp(b)))
            .expect("points");
        let q_p = amp(peak);
        let w_b = main
            .windows(2)
            .find(|w| (w[0].0 - q_p) * (w[1].0 - q_p) <= 0.0)
            .map(|w| w[0].1 + (w[1].1 - w[0].1) * (q_p - w[0].0) / (w[1].0 - w[0].0));
        println!(
            "zeta {zeta}: {} points, {} folds, {:?}; peak q/g0 = {:.4} at W/w1 = {:.6}; backbone there w/w1 = {}; distance {}",
            curve.points.len(),
            curve.folds.len(),
            curve.termination,
            q_p / g0,
            peak.omega / w1,
            w_b.map_or("-".into(), |w| format!("{:.6}", w / w1)),
            w_b.map_or("-".into(), |w| format!("{:.2e}", (peak.omega - w).abs() / w1)),
        );
    }
}
