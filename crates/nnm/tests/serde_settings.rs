//! Settings deserialize with documented defaults; points serialize for the output stage.

mod common;

use nlmodes_nnm::{
    AlgorithmParams, Condensation, ContactMethod, ContinuationSettings, HarmonicSettings,
    PenaltyUpdate, PowellMeasure, SolverSettings, Start,
};

#[test]
fn algorithm_parameters_deserialize_with_defaults() {
    let empty: SolverSettings = serde_json::from_str("{}").expect("empty object");
    assert_eq!(empty, SolverSettings::default());
    let p: SolverSettings = serde_json::from_str(
        r#"{"alpha": 2.0, "epsilon": 1e-8, "measure": "row_maximum",
            "penalty_update": "as_printed", "condensation": "none",
            "method": {"kind": "penalty", "stiffness": 100.0},
            "newton": {"tolerance": 1e-12}}"#,
    )
    .expect("parameters");
    assert_eq!(p.algorithm.alpha, 2.0);
    assert_eq!(p.algorithm.beta, AlgorithmParams::default().beta);
    assert_eq!(p.algorithm.measure, PowellMeasure::RowMaximum);
    assert_eq!(p.algorithm.penalty_update, PenaltyUpdate::AsPrinted);
    assert_eq!(p.condensation, Condensation::None);
    assert_eq!(
        p.algorithm.method,
        ContactMethod::Penalty { stiffness: 100.0 }
    );
    assert_eq!(p.newton.tolerance, 1e-12);
    assert_eq!(p.newton.max_iterations, 50);
    // Unknown keys are errors that name the key.
    let err = serde_json::from_str::<SolverSettings>(r#"{"alpah": 2.0}"#).expect_err("typo");
    assert!(err.to_string().contains("alpah"), "{err}");
    let c: ContinuationSettings = serde_json::from_str(r#"{"q_max": 35.0}"#).expect("continuation");
    assert_eq!(c.q_max, 35.0);
    assert_eq!(c.q_start, ContinuationSettings::default().q_start);
    let h: HarmonicSettings =
        serde_json::from_str(r#"{"harmonics": 10, "samples": 128}"#).expect("harmonics");
    assert_eq!(h, HarmonicSettings::new(10, 128).expect("valid"));
}

#[test]
fn points_serialize_without_the_warm_start_state() {
    let sys = common::one_dof(1.0);
    let settings = HarmonicSettings::with_default_samples(4).expect("settings");
    let p = nlmodes_nnm::solve_point(
        &sys,
        settings,
        AlgorithmParams::default(),
        1.5,
        Start::LinearMode(0),
    )
    .expect("point");
    let json = serde_json::to_value(&p).expect("serialize");
    for key in [
        "q",
        "omega",
        "omega_ratio",
        "frequency_hz",
        "energy",
        "mean_gap",
        "max_gap",
        "contact_fraction",
        "powell_measure",
        "fold",
        "jump",
        "coefficients",
        "contact_force",
        "truncation_share",
    ] {
        assert!(json.get(key).is_some(), "missing {key}");
    }
    assert!(json.get("multipliers").is_none());
    assert_eq!(json["coefficients"].as_array().map(Vec::len), Some(5));
    assert_eq!(json["contact_force"][0].as_array().map(Vec::len), Some(64));
}

#[test]
fn modes_default_to_the_single_mode() {
    let single = ContinuationSettings {
        mode: 2,
        ..Default::default()
    };
    assert_eq!(single.modes_to_trace(), vec![2]);
    let several: ContinuationSettings =
        serde_json::from_str(r#"{"modes": [0, 1, 2]}"#).expect("json");
    assert_eq!(several.modes_to_trace(), vec![0, 1, 2]);
}

#[test]
fn a_mode_listed_twice_is_refused() {
    let twice: ContinuationSettings =
        serde_json::from_str(r#"{"modes": [0, 2, 1, 2]}"#).expect("json");
    let err = twice.validate().expect_err("mode 2 is listed twice");
    assert_eq!(
        err.to_string(),
        "parameter modes = 2 is invalid: expected each mode listed once (0-based linear mode indices)"
    );
    let once: ContinuationSettings = serde_json::from_str(r#"{"modes": [2, 0, 1]}"#).expect("json");
    once.validate().expect("distinct modes");
}
