//! A passage past a tongue continues the traced mode's branch or stops; it never lands on another
//! mode's family (issue 12, docs/DESIGN.md §8.3).
//!
//! System: the 3-DOF chain with a stop of `saltation_oracle.rs` (non-diagonal M, contact row
//! a = (0.2, 0, 1), gap 0.5, master DOF 3), traced from 0.5 to 3 times its grazing amplitude with
//! N = 20, m = 256. Its first mode meets a 3:1 tongue with mode 3 near w/w1 = 1.14 (passed) and a
//! 2:1 tongue with mode 3 near w/w1 = 1.53, where mode 3 takes most of the energy. Before the
//! guard, some runs "reached q_max" past that tongue on the second mode's backbone: with the
//! augmented Lagrangian and step 0.5, 92 % down to 64 % of the energy in linear mode 2's
//! fundamental and 1 % to 5 % in mode 1's (w/w1 = 1.98 .. 2.12); with the penalty law kc = 100 and
//! step 0.1, 100 % in mode 2 (w/w1 = 1.92 .. 2.05). Such a point is not the first mode's
//! nonlinear mode.
//!
//! Checked: every main-branch point keeps the traced mode's fundamental at least as energetic as
//! any other component (the modal shares of `System::modal_shares`), and a run that cannot pass
//! a tongue says so (`Termination::InternalResonance`, the tongue recorded as not passed).

use faer::Mat;
use nlmodes_nnm::{
    backbone, AlgorithmParams, BranchKind, ContactMethod, ContinuationSettings, HarmonicSettings,
    System, Termination,
};

fn three_dof() -> System {
    let m = [[2.0, 0.3, 0.0], [0.3, 1.0, 0.2], [0.0, 0.2, 1.5]];
    let k = [[3.0, -1.0, 0.0], [-1.0, 2.5, -1.0], [0.0, -1.0, 1.2]];
    let a = [0.2, 0.0, 1.0];
    System::new(
        Mat::from_fn(3, 3, |i, j| m[i][j]),
        Mat::from_fn(3, 3, |i, j| k[i][j]),
        Mat::from_fn(1, 3, |_, j| a[j]),
        vec![0.5],
        2,
    )
    .expect("3-DOF system")
}

fn check(method: ContactMethod, step: f64) {
    let sys = three_dof();
    let qg = sys.grazing_amplitude(0).expect("grazing").expect("touches") / sys.gap_reference();
    let settings = HarmonicSettings::new(20, 256).expect("settings");
    let params = AlgorithmParams {
        method: method.clone(),
        ..AlgorithmParams::default()
    };
    let cont = ContinuationSettings {
        q_start: 0.5 * qg,
        q_max: 3.0 * qg,
        step,
        max_step: step,
        max_points: 3000,
        ..ContinuationSettings::default()
    };
    let b = backbone(&sys, settings, params, &cont, |_| {}).expect("run");
    let main: Vec<_> = b
        .points
        .iter()
        .filter(|p| b.branches[p.branch].kind == BranchKind::Main)
        .collect();
    assert!(
        main.len() >= 5,
        "{method:?}, step {step}: {} main points",
        main.len()
    );
    for p in &main {
        assert!(
            p.secondary_share <= p.primary_share,
            "{method:?}, step {step}: main-branch point at w/w1 = {:.4}, q/qg = {:.3} has {:.0} % \
             of its energy in mode {} harmonic {} and {:.0} % in the traced fundamental",
            p.omega_ratio,
            p.q / sys.gap_reference() / qg,
            100.0 * p.secondary_share,
            p.secondary_mode + 1,
            p.secondary_harmonic,
            100.0 * p.primary_share
        );
    }
    match &b.termination {
        Termination::ReachedMaxAmplitude => {}
        Termination::InternalResonance { .. } => assert!(
            b.internal_resonances.iter().any(|r| r.passed.is_none()),
            "{method:?}, step {step}: stopped at a tongue not recorded as unpassed"
        ),
        other => panic!("{method:?}, step {step}: {other:?}"),
    }
    println!(
        "{method:?}, step {step}: {:?}, last main w/w1 {:.4}",
        b.termination,
        main.last().expect("main").omega_ratio
    );
}

#[test]
fn a_passage_never_lands_on_another_modes_family() {
    for step in [0.02, 0.1, 0.5] {
        check(ContactMethod::AugmentedLagrangian, step);
        check(ContactMethod::Penalty { stiffness: 100.0 }, step);
    }
}
