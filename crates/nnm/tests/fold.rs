//! The pseudo-arc-length continuation follows a turning point of q (a fold), where w(q) is not
//! single-valued, and both orbits found at the same q are genuine (time integration).
//!
//! System: 3 unit masses, unit springs, wall on the left, penalty contact (kc = 0.3) on the free
//! end, which is also the master. Linear frequencies w3 / w1 = 4.05, so as the contact stiffens
//! the mode, 4 w crosses w3 at w = 1.0125 w1: a 4:1 internal resonance. There the backbone enters
//! a tongue: the energy keeps growing (it flows into the third mode at 4 w) while the
//! first-harmonic amplitude q of the master passes a maximum and decreases.

mod common;

use nlmodes_nnm::{
    backbone, check_periodicity, AlgorithmParams, BranchKind, ContactMethod, ContinuationSettings,
    HarmonicSettings, Solver, Start, System, Termination,
};

const KC: f64 = 0.3;

/// The 3-mass chain with penalty contact, N = 16, and continuation steps up to 0.1 (scaled arc
/// length), which resolve the tongue; much larger steps can jump over it.
fn tongue_chain(
    max_points: usize,
    skip: bool,
) -> (
    System,
    HarmonicSettings,
    AlgorithmParams,
    ContinuationSettings,
) {
    let sys = common::chain(3, 1.0, &[2], 1.0, 2);
    let settings = HarmonicSettings::with_default_samples(16).expect("settings");
    let params = AlgorithmParams {
        method: ContactMethod::Penalty { stiffness: KC },
        ..AlgorithmParams::default()
    };
    let cont = ContinuationSettings {
        q_start: 0.5,
        q_max: 10.0,
        step: 0.05,
        max_step: 0.1,
        max_points,
        skip_internal_resonances: skip,
        ..ContinuationSettings::default()
    };
    (sys, settings, params, cont)
}

/// With the default settings the same tongue is detected by its modal energy shares (mode 3 at
/// harmonic 4 outweighs mode 1 at harmonic 1), not followed, and hopped over at fixed q: every kept
/// point is dominated by the primary component and q keeps growing past the tongue.
#[test]
fn continuation_skips_an_internal_resonance_tongue() {
    let (sys, settings, params, cont) = tongue_chain(200, true);
    let b = backbone(&sys, settings, params, &cont, |_| {}).expect("backbone");
    println!(
        "termination {:?}, resonances {:?}",
        b.termination, b.internal_resonances
    );
    let first = b
        .internal_resonances
        .first()
        .expect("the tongue is detected");
    assert_eq!((first.mode, first.harmonic), (2, 4), "{first:?}");
    assert!(first.passed.is_some(), "{first:?}");
    assert!(first.detuning.abs() < 0.02, "{first:?}");
    for p in &b.points {
        assert!(
            p.secondary_harmonic < 2 || p.secondary_share <= p.primary_share,
            "a tongue point was kept at q = {}",
            p.q
        );
    }
    let last = b.points.last().expect("points");
    assert!(last.q > first.q, "the backbone did not go past the tongue");
    assert_eq!(b.termination, Termination::ReachedMaxAmplitude);
}

#[test]
fn continuation_follows_the_tongue_through_its_fold_of_q() {
    // Follow the tongue as its own branch (the default): the main branch rises in q up to the
    // turning point, the tongue branch leaves it with q falling.
    let (sys, settings, params, cont) = tongue_chain(300, false);
    let b = backbone(&sys, settings, params.clone(), &cont, |_| {}).expect("backbone");
    let tongue = b
        .branches
        .iter()
        .find(|br| {
            br.kind
                == BranchKind::Tongue {
                    mode: 2,
                    harmonic: 4,
                }
        })
        .expect("the 4:1 tongue with mode 3 is a branch");
    assert_eq!(tongue.parent, Some(1));
    let first = b
        .points
        .iter()
        .position(|p| p.branch == tongue.id)
        .expect("tongue points");
    let rising = b.points[..first].iter().filter(|p| p.branch == 1);
    let falling = b.points.iter().filter(|p| p.branch == tongue.id);
    let pts: Vec<_> = rising.chain(falling).cloned().collect();
    let fold = pts
        .iter()
        .position(|p| p.fold)
        .expect("a fold of q is flagged");
    assert!(
        fold >= 2 && fold + 3 < pts.len(),
        "turning point at {fold} of {}",
        pts.len()
    );
    // q rose before the fold and falls after it, while the energy keeps growing along the main
    // branch and on into the tongue.
    assert!(pts[fold - 1].q > pts[fold - 2].q && pts[fold + 1].q < pts[fold].q);
    assert!(
        pts.windows(2).all(|w| w[1].energy > w[0].energy),
        "energy must grow along s"
    );
    // The turning point sits at the 4:1 resonance, w ~ w3 / 4 (within 1 % of it).
    let w3_over_4 = sys.linear_frequencies()[2] / 4.0;
    assert!(
        (pts[fold].omega - w3_over_4).abs() < 0.01 * w3_over_4,
        "w = {}",
        pts[fold].omega
    );
    // The main branch goes on past the tongue.
    assert_eq!(b.termination, Termination::ReachedMaxAmplitude);
    assert!(b.points.last().expect("points").q > pts[fold].q);

    // Two orbits at the same q*, one on each side of the fold (the falling side's point after
    // the fold whose q is closest to q*, a q reached on the rising side too).
    let q_star = pts[fold + 3].q.max(pts[fold - 2].q);
    let near = |range: &[nlmodes_nnm::BackbonePoint]| {
        range
            .iter()
            .min_by(|a, b| (a.q - q_star).abs().total_cmp(&(b.q - q_star).abs()))
            .cloned()
            .expect("points")
    };
    let mut solver = Solver::new(&sys, settings, params).expect("solver");
    let pa = solver
        .solve_point(q_star, Start::Point(&near(&pts[..fold])))
        .expect("rising side");
    let pb = solver
        .solve_point(q_star, Start::Point(&near(&pts[fold..])))
        .expect("falling side");
    println!(
        "fold at q = {:.4}, w/w1 = {:.5}; q* = {q_star:.4}: (w/w1, energy) = ({:.6}, {:.4}) and ({:.6}, {:.4})",
        pts[fold - 1].q,
        pts[fold].omega_ratio,
        pa.omega_ratio,
        pa.energy,
        pb.omega_ratio,
        pb.energy
    );
    // Distinct orbits at the same q: the energies differ by far more than any solver tolerance.
    assert!(
        pb.energy > 1.2 * pa.energy,
        "{} vs {}",
        pa.energy,
        pb.energy
    );
    // Both are genuine periodic orbits of the penalty system (independent of harmonic balance).
    // Tolerances 2e-4 (displacement, relative to max |u(0)|) and 2e-3 (velocity, relative to
    // w max |u(0)|): they cover the N = 16 truncation error in the resonant tongue (observed below)
    // while a non-periodic initial state would miss by O(1).
    for p in [&pa, &pb] {
        let chk = check_periodicity(&sys, &[KC], p, 40_000).expect("integration");
        println!(
            "  w/w1 = {:.6}: du = {:.2e}, dv = {:.2e}",
            p.omega_ratio, chk.displacement_error, chk.velocity_error
        );
        assert!(
            chk.displacement_error <= 2e-4 && chk.velocity_error <= 2e-3,
            "{chk:?}"
        );
    }
}
