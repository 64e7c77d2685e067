//! Every bad input is a typed error whose message names what is wrong; non-convergence is
//! reported with the last Powell measure and the iteration counts.

mod common;

use faer::Mat;
use nlmodes_nnm::{
    AlgorithmParams, ContinuationSettings, HarmonicSettings, NnmError, Solver, Start, System,
};

fn eye(n: usize) -> Mat<f64> {
    Mat::from_fn(n, n, |i, j| if i == j { 1.0 } else { 0.0 })
}

fn k2() -> Mat<f64> {
    Mat::from_fn(2, 2, |i, j| [[2.0, -1.0], [-1.0, 2.0]][i][j])
}

fn row(n: usize) -> Mat<f64> {
    Mat::from_fn(1, n, |_, j| if j == n - 1 { 1.0 } else { 0.0 })
}

#[test]
fn matrices_that_are_not_spd_are_named() {
    let not_spd = Mat::from_fn(2, 2, |i, j| [[1.0, 2.0], [2.0, 1.0]][i][j]);
    let err = System::new(not_spd.clone(), k2(), row(2), vec![1.0], 0).expect_err("M not SPD");
    assert!(
        matches!(err, NnmError::NotPositiveDefinite { name: "M", .. }),
        "{err}"
    );
    assert!(err.to_string().contains("matrix M"));
    let err = System::new(eye(2), not_spd, row(2), vec![1.0], 0).expect_err("K not SPD");
    assert!(
        matches!(err, NnmError::NotPositiveDefinite { name: "K", .. }),
        "{err}"
    );
    let asym = Mat::from_fn(2, 2, |i, j| [[2.0, -1.0], [-0.5, 2.0]][i][j]);
    let err = System::new(eye(2), asym, row(2), vec![1.0], 0).expect_err("K asymmetric");
    assert!(
        matches!(err, NnmError::NotSymmetric { name: "K", .. }),
        "{err}"
    );
    assert!(
        err.to_string().contains("5e-1"),
        "the asymmetry is reported: {err}"
    );
    let err = System::new(eye(3), k2(), row(2), vec![1.0], 0).expect_err("size");
    assert!(matches!(err, NnmError::Shape { name: "K", .. }), "{err}");
    let nan = Mat::from_fn(2, 2, |i, j| if i == 1 && j == 1 { f64::NAN } else { 1.0 });
    let err = System::new(nan, k2(), row(2), vec![1.0], 0).expect_err("NaN");
    assert!(
        matches!(
            err,
            NnmError::NonFinite {
                name: "M",
                row: 1,
                col: 1,
                ..
            }
        ),
        "{err}"
    );
}

#[test]
fn contact_data_and_master_are_checked() {
    let err = System::new(eye(2), k2(), row(3), vec![1.0], 0).expect_err("width");
    assert!(
        matches!(
            err,
            NnmError::ContactRowsWidth {
                cols: 3,
                expected: 2
            }
        ),
        "{err}"
    );
    let err = System::new(eye(2), k2(), row(2), vec![1.0, 1.0], 0).expect_err("gap count");
    assert!(
        matches!(err, NnmError::GapCount { gaps: 2, rows: 1 }),
        "{err}"
    );
    for bad in [0.0, -1.0, f64::NAN] {
        let err = System::new(eye(2), k2(), row(2), vec![bad], 0).expect_err("gap");
        assert!(
            matches!(err, NnmError::NonPositiveGap { index: 0, .. }),
            "{err}"
        );
    }
    let zero = Mat::<f64>::zeros(1, 2);
    let err = System::new(eye(2), k2(), zero, vec![1.0], 0).expect_err("zero row");
    assert!(
        matches!(err, NnmError::InvalidContactRow { row: 0, .. }),
        "{err}"
    );
    let err = System::new(eye(2), k2(), row(2), vec![1.0], 2).expect_err("master");
    assert!(
        matches!(err, NnmError::MasterOutOfRange { master: 2, dofs: 2 }),
        "{err}"
    );
}

#[test]
fn harmonic_settings_amplitudes_and_parameters_are_checked() {
    let err = HarmonicSettings::new(10, 20).expect_err("m < 2N+1");
    assert!(err.to_string().contains("2N + 1 = 21"), "{err}");
    assert!(HarmonicSettings::new(0, 64).is_err());
    let sys = common::one_dof(1.0);
    let settings = HarmonicSettings::with_default_samples(4).expect("settings");
    let bad_settings = HarmonicSettings {
        harmonics: 10,
        samples: 8,
    };
    assert!(Solver::new(&sys, bad_settings, AlgorithmParams::default()).is_err());
    let mut solver = Solver::new(&sys, settings, AlgorithmParams::default()).expect("solver");
    for q in [-1.0, 0.0, f64::INFINITY] {
        let err = solver
            .solve_point(q, Start::LinearMode(0))
            .expect_err("bad q");
        assert!(
            matches!(err, NnmError::InvalidParameter { name: "q", .. }),
            "{err}"
        );
    }
    let err = solver
        .solve_point(0.5, Start::LinearMode(3))
        .expect_err("mode");
    assert!(
        matches!(err, NnmError::ModeOutOfRange { mode: 3, count: 1 }),
        "{err}"
    );
    let params = AlgorithmParams {
        alpha: 1.0,
        ..AlgorithmParams::default()
    };
    let err = Solver::new(&sys, settings, params)
        .err()
        .expect("alpha <= 1");
    assert!(
        matches!(err, NnmError::InvalidParameter { name: "alpha", .. }),
        "{err}"
    );
    let cont = ContinuationSettings {
        q_max: 0.1,
        q_start: 0.5,
        ..ContinuationSettings::default()
    };
    let err = nlmodes_nnm::backbone(&sys, settings, AlgorithmParams::default(), &cont, |_| {})
        .expect_err("q_max < q_start");
    assert!(
        matches!(err, NnmError::InvalidParameter { name: "q_max", .. }),
        "{err}"
    );
}

#[test]
fn warm_start_from_another_system_is_refused() {
    let one = common::one_dof(1.0);
    let settings = HarmonicSettings::with_default_samples(4).expect("settings");
    let p = nlmodes_nnm::solve_point(
        &one,
        settings,
        AlgorithmParams::default(),
        0.5,
        Start::LinearMode(0),
    )
    .expect("point");
    let chain = common::chain(3, 1.0, &[2], 1.0, 2);
    let err = nlmodes_nnm::solve_point(
        &chain,
        settings,
        AlgorithmParams::default(),
        0.5,
        Start::Point(&p),
    )
    .expect_err("size mismatch");
    assert!(matches!(err, NnmError::WarmStart { .. }), "{err}");
}

#[test]
fn non_convergence_is_reported_with_the_last_measure() {
    // Rigid stop well past grazing, but Algorithm 1 allowed a single accepted iteration.
    let sys = common::one_dof(1.0);
    let settings = HarmonicSettings::with_default_samples(8).expect("settings");
    let params = AlgorithmParams {
        max_iterations: 1,
        epsilon: 1e-12,
        ..AlgorithmParams::default()
    };
    let err = nlmodes_nnm::solve_point(&sys, settings, params, 1.5, Start::LinearMode(0))
        .expect_err("cannot converge in one iteration");
    match &err {
        NnmError::NotConverged {
            measure,
            accepted,
            solves,
            newton_iterations,
            epsilon,
            ..
        } => {
            assert!(measure.is_finite() && *measure > 1e-12);
            assert_eq!(*accepted, 1);
            assert!(*solves >= 1 && *newton_iterations >= 1);
            assert_eq!(*epsilon, 1e-12);
        }
        other => panic!("unexpected error {other}"),
    }
    assert!(err.to_string().contains("i_max"), "{err}");
    // Newton failure is reported too (one iteration allowed, far from the solution).
    let params = nlmodes_nnm::SolverSettings {
        newton: nlmodes_nnm::NewtonSettings {
            max_iterations: 1,
            ..Default::default()
        },
        ..Default::default()
    };
    let err = nlmodes_nnm::solve_point(&sys, settings, params, 3.0, Start::LinearMode(0))
        .expect_err("Newton cannot converge in one iteration");
    assert!(err.to_string().contains("Newton"), "{err}");
}
