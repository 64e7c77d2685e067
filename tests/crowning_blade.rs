//! The backbone crowns the blade's forced curves (issue 22: "at two damping levels the peaks of
//! the forced curves lie on the backbone within a distance that shrinks with the damping").
//!
//! On a reduced blade: N = 10 harmonics and 512 time samples per period, the penalty law with
//! kc = 10 x the median static contact stiffness of the rows, a force on the master whose linear
//! resonant peak is LEVEL x the grazing amplitude at each damping ratio (so the peaks reach about
//! the same amplitude). For each zeta the frequency response over 0.9 .. 1.5 w1 gives its peak
//! (W_p, q_p); the backbone of the same law, N and samples, solved at q_p from its main-branch
//! point just below, gives w_b(q_p); the distance is |W_p - w_b(q_p)| / w1.
//!
//! Why 512 samples and level 2: with the default 128 samples the sampled problem's curve
//! zig-zags near the peak in folds whose number grows as the damping falls (2, 6, 29 folds at
//! 0.3, 0.1, 0.03 % on the default blade), and the peak follows the zig-zag; with 512 every
//! curve has its 2 folds. At level 5 the default blade's peak sits on its 4:1 internal
//! resonance (q/g0 = 10.58), where the backbone's w moves by 3.7e-3 within 0.06 g0: not a place
//! to measure crowning. The backbone is solved at q_p rather than interpolated between its points
//! (interpolation alone errs by about 1e-4, more than the distance at 0.1 %).
//!
//! Measured on the coarse blade (peak q/g0 = 9.33): 4.2e-5 at 0.3 %, 5.8e-6 at 0.1 % (a factor
//! 7.3; a phase-resonance argument gives an offset of order zeta^2, a factor 9). Asserted: the
//! distance shrinks, and is below 1e-3 at 0.3 %.
//!
//! The test runs the coarse blade (`common::coarse_blade_model`) at 0.3 % and 0.1 %; the
//! default blade is the ignored test below (`scripts/run` first, then
//! `cargo test --release --test crowning_blade -- --ignored --nocapture`).

use std::path::Path;

use nlmodes_forced::{response_curve, Damping, ForcedSettings, ForcedSolver, FrfSettings, Load};
use nlmodes_modal::ReducedModel;
use nlmodes_nnm::{
    backbone, solve_point, AlgorithmParams, BranchKind, ContactMethod, ContinuationSettings,
    HarmonicSettings, Start, System,
};

mod common;

/// (zeta, peak q/g0, distance / w1, folds) at each damping ratio.
fn crowning(model_dir: &Path, level: f64, zetas: &[f64]) -> Vec<(f64, f64, f64, usize)> {
    let model = ReducedModel::read(model_dir).expect("reduced model");
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
    let harmonics = HarmonicSettings::new(10, 512).expect("harmonics");
    let algorithm = AlgorithmParams {
        method: ContactMethod::Penalty {
            stiffness: 10.0 * ks[ks.len() / 2],
        },
        ..AlgorithmParams::default()
    };
    let q_graze = system.grazing_amplitude(0).unwrap().unwrap().abs();
    let cont = ContinuationSettings {
        q_start: 0.5,
        q_max: 3.0 * level * q_graze / g0,
        ..ContinuationSettings::default()
    };
    let family = backbone(&system, harmonics, algorithm.clone(), &cont, |_| {}).expect("backbone");
    let main: Vec<&nlmodes_nnm::BackbonePoint> = family
        .points
        .iter()
        .filter(|p| {
            !matches!(
                family.branches.get(p.branch).map(|b| &b.kind),
                Some(BranchKind::Tongue { .. })
            )
        })
        .collect();
    let phi = system.linear_mode(0).expect("mode 1");
    zetas
        .iter()
        .map(|&zeta| {
            let force = level * q_graze * 2.0 * zeta * w1 * w1 / (phi[master] * phi[master]);
            let mut shape = vec![0.0; system.n_dofs()];
            shape[master] = force;
            let c = Damping::ModalRatios(vec![zeta]).matrix(&system).expect("C");
            let settings = ForcedSettings {
                harmonics,
                algorithm: algorithm.clone(),
                ..ForcedSettings::new(10).expect("settings")
            };
            let load = Load::fundamental(shape);
            let solver = ForcedSolver::new(&system, &c, &load, settings).expect("solver");
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
            // The backbone at q_p itself: solved from the main-branch point just below it.
            let below = main
                .windows(2)
                .find(|w| (w[0].q - q_p) * (w[1].q - q_p) <= 0.0)
                .map(|w| w[0])
                .expect("the peak's amplitude on the backbone's main branch");
            let w_b = solve_point(&system, harmonics, algorithm.clone(), q_p, Start::Point(below))
                .expect("the backbone at the peak's amplitude")
                .omega;
            let distance = (peak.omega - w_b).abs() / w1;
            eprintln!(
                "zeta {zeta}: {} points, {} folds, {:?}; peak q/g0 = {:.4} at W/w1 = {:.6}, backbone \
                 w/w1 = {:.6}, distance {distance:.2e}",
                curve.points.len(),
                curve.folds.len(),
                curve.termination,
                q_p / g0,
                peak.omega / w1,
                w_b / w1
            );
            (zeta, q_p / g0, distance, curve.folds.len())
        })
        .collect()
}

#[test]
fn peaks_of_the_coarse_blade_lie_on_its_backbone_closer_as_the_damping_falls() {
    let dir = tempfile::tempdir().unwrap();
    let model = common::coarse_blade_model(dir.path());
    let r = crowning(&model, 2.0, &[0.003, 0.001]);
    let (far, near) = (r[0].2, r[1].2);
    assert!(
        near < far,
        "the distance does not shrink: {far:e} at 0.3 %, {near:e} at 0.1 %"
    );
    assert!(
        far < 1e-3,
        "the 0.3 % peak lies {far:e} w1 from the backbone"
    );
}

#[test]
#[ignore = "needs the default case's reduced model: scripts/run, then cargo test --release --test crowning_blade -- --ignored --nocapture (about 4 minutes)"]
fn peaks_of_the_default_blade_lie_on_its_backbone() {
    let model = Path::new(env!("CARGO_MANIFEST_DIR")).join("results/blade/model");
    let r = crowning(&model, 2.0, &[0.003, 0.001, 0.0003]);
    assert!(
        r.windows(2).all(|w| w[1].2 < w[0].2),
        "not shrinking: {r:?}"
    );
}
