//! A solve does not depend on the solves made before it with the same [`Solver`]: the solver keeps
//! FFT plans, the condensation basis and Newton buffers between amplitudes (docs/DESIGN.md §3.7),
//! but no state that could change an outcome. A continuation tries many predictors in an order
//! of its choosing (docs/DESIGN.md §8.3); if a failed or distant attempt could change the next
//! one, the branch would depend on the order of attempts, not only on the equations.
//!
//! Checked bitwise: the same solve from the same start, on a fresh solver and on one that has
//! just done converged, failed and far-away solves, gives the same point (w, q, every harmonic
//! coefficient, the multipliers) or the same error.

mod common;

use nlmodes_nnm::{
    AlgorithmParams, BackbonePoint, Condensation, ContactMethod, HarmonicSettings, Solver,
    SolverSettings, Start, System,
};

/// The outcome of a solve, in a form compared bitwise.
fn fingerprint(r: &Result<BackbonePoint, nlmodes_nnm::NnmError>) -> Vec<u64> {
    match r {
        Ok(p) => {
            let mut v = vec![p.omega.to_bits(), p.q.to_bits()];
            v.extend(p.coefficients.iter().flatten().map(|x| x.to_bits()));
            v.extend(p.multipliers.theta.iter().map(|x| x.to_bits()));
            v.extend(p.multipliers.kappa.iter().map(|x| x.to_bits()));
            v
        }
        Err(e) => vec![u64::MAX, e.to_string().len() as u64],
    }
}

/// Solves `target` from `base` on a fresh solver, then on one that first ran `history` (each a
/// q and whether to start from `base` or from the linear mode), and compares.
fn check_history_free(
    sys: &System,
    settings: HarmonicSettings,
    solver: SolverSettings,
    base_q: f64,
    history: &[(f64, bool)],
    targets: &[f64],
) {
    let mut fresh = Solver::new(sys, settings, solver.clone()).expect("solver");
    let base = fresh
        .solve_point(base_q, Start::LinearMode(0))
        .expect("base point");
    for &target in targets {
        let mut fresh = Solver::new(sys, settings, solver.clone()).expect("solver");
        let expected = fresh.solve_point(target, Start::Point(&base));
        let mut used = Solver::new(sys, settings, solver.clone()).expect("solver");
        let mut outcomes = Vec::new();
        for &(q, from_base) in history {
            let start = if from_base {
                Start::Point(&base)
            } else {
                Start::LinearMode(0)
            };
            outcomes.push(used.solve_point(q, start).is_ok());
        }
        let got = used.solve_point(target, Start::Point(&base));
        println!(
            "target q = {target}: fresh {:?}, history outcomes {outcomes:?}",
            expected.as_ref().map(|p| p.omega)
        );
        assert!(
            outcomes.iter().any(|&ok| ok),
            "the history must contain converged solves"
        );
        assert_eq!(
            fingerprint(&expected),
            fingerprint(&got),
            "the solve at q = {target} depends on the solver's history"
        );
    }
}

/// Augmented Lagrangian (Algorithm 1) on the condensed lattice blade: the history holds converged
/// points, jumps far beyond the base and solves from the linear mode deep in contact.
#[test]
fn augmented_lagrangian_condensed_solve_is_history_free() {
    let sys = common::lattice_blade(6, 4, 6, 1.0);
    let settings = HarmonicSettings::with_default_samples(8).expect("settings");
    let solver = SolverSettings::from(AlgorithmParams::default());
    let history = [
        (1.5, true),
        (6.0, true),
        (4.0, false),
        (30.0, true),
        (1.2, true),
    ];
    check_history_free(&sys, settings, solver, 1.3, &history, &[1.4, 2.5]);
}

/// The penalty law with the dense (uncondensed) Newton on the 3-mass chain.
#[test]
fn penalty_dense_solve_is_history_free() {
    let sys = common::chain(3, 1.0, &[2], 1.0, 2);
    let settings = HarmonicSettings::with_default_samples(12).expect("settings");
    let solver = SolverSettings {
        algorithm: AlgorithmParams {
            method: ContactMethod::Penalty { stiffness: 50.0 },
            ..AlgorithmParams::default()
        },
        condensation: Condensation::None,
        ..SolverSettings::default()
    };
    let history = [(1.5, true), (8.0, false), (3.0, true), (50.0, true)];
    check_history_free(&sys, settings, solver, 1.2, &history, &[1.4, 2.2]);
}

/// Algorithm 1 at a tight Powell tolerance on the 3-DOF impact system of `saltation_oracle.rs`
/// (N = 40, m = 512), where the continuation's hard solves (passages past the 3:1 tongue) happen.
#[test]
fn augmented_lagrangian_impact_system_solve_is_history_free() {
    let sys = common::three_dof_stop();
    let qg = sys.grazing_amplitude(0).expect("grazing").expect("touches");
    let settings = HarmonicSettings::new(40, 512).expect("settings");
    let solver = SolverSettings::from(AlgorithmParams {
        epsilon: 1e-6,
        ..AlgorithmParams::default()
    });
    let history = [
        (1.05 * qg, true),
        (1.6 * qg, true),
        (1.3 * qg, false),
        (3.0 * qg, true),
    ];
    check_history_free(
        &sys,
        settings,
        solver,
        1.02 * qg,
        &history,
        &[1.1 * qg, 1.4 * qg],
    );
}
