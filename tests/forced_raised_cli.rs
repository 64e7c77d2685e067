//! N raised point by point on a retraced curve (DESIGN §10.8, `crates/forced/src/
//! raised_segments.rs`), through `nlmodes forced`, against the exact periodic orbits of
//! `pwl::trace` (the oracle of tests/forced_oracle_cli.rs, reused through the same module path).
//!
//! The 2-DOF chain of issue 37 (M = I, K = [[2, -1], [-1, 2]], the stop on the second mass
//! with kc = 100 x 1.5 N/m beyond g = 1 m, 0.5 % on both modes, 0.1 N on the first mass, about
//! 5 x grazing) under `adapt_harmonics = "retrace"` is run twice from N = 10:
//!
//! * `max_harmonics = 10`: the curve at N = 10 alone (nothing to check it with);
//! * `max_harmonics = 20`: the same trace at N = 10, checked at 20; its checked points in
//!   contact move by up to 7e-3 (more than `harmonic_tolerance` = 1e-3) and 4N = 40 is above
//!   max_harmonics, so the curve is not traced again: N is raised to 20 around the points that
//!   moved, and the raised points are checked at 40.
//!
//! Checked: both exit 0 with a complete curve; the second reports raised segments, no point
//! failed, its check at 40 converged (frf.json `raised`); frf.csv's `harmonics` is 20 exactly on
//! the raised points and 10 elsewhere; every other point is the first run's to the last digit
//! (the trace is the same), and so are the folds (raising moves no fold and adds none); and on
//! the exact curve, the raised points are nearer the exact orbits at their W than the same
//! points at N = 10: their median error at least `GAIN` times smaller and their largest within
//! `RAISED_ERROR` away from the exact folds. A raising that solved the wrong orbit, failed to replace the points, or
//! replaced them at the old N fails these. Wall time about 5-10 s (two runs of about 1 s, the
//! oracle the rest).

mod common;
#[path = "../crates/forced/tests/pwl/mod.rs"]
mod pwl;

use std::path::{Path, PathBuf};

use common::{csv_columns, nlmodes, padded_contact_model};
use pwl::trace::{first_harmonic, ExactCurve};
use pwl::{Dense, Orbit, Pwl};

/// `harmonic_tolerance`: the default.
const TOLERANCE: f64 = 1e-3;
/// A tolerance the check at 40 of the points raised to 20 does not meet (it moves them by up
/// to 3.4e-4): their segments must be raised again, to 40, and checked at 80.
const TIGHT_TOLERANCE: f64 = 1e-4;
/// The gap (m): `padded_contact_model`'s.
const GAP: f64 = 1.0;
/// The oracle's shooting tolerance on |z(T) - z(0)| (m, m/s), far below every difference.
const ORBIT_TOL: f64 = 1e-10;
/// The chain's damping ratio, force (N) and penalty factor.
const ZETA: f64 = 0.005;
const FORCE: f64 = 0.1;
const PENALTY_FACTOR: f64 = 100.0;
/// Range in W / w1 (w1 = 1 rad/s), and how far past it the oracle traces.
const RANGE: (f64, f64) = (0.8, 1.6);
const TRACE_BEYOND: f64 = 0.05;
/// The raised points' median error against the exact orbits must be at least this many times
/// smaller than at N = 10. The program's check says N = 10 moves them by up to 7e-3 and
/// N = 20 by at most 3.4e-4 at 40: a factor of 20 in the truncation; 3 leaves room for the
/// points near the folds, where the first harmonic changes fast with W.
const GAIN: f64 = 3.0;
/// Largest error (relative, first harmonic of the master) of a raised point against the exact
/// orbit at its W, away from the folds: twice the harmonic tolerance (its check at 40 moves it
/// by at most 3.4e-4; the exact orbit is the untruncated limit).
const RAISED_ERROR: f64 = 2e-3;
/// Within this (relative W) of an exact fold the first harmonic at a fixed W changes without
/// bound, and a W error of 3e-5 (the check's) is worth more than `RAISED_ERROR` in q1: such
/// points count in the median only (as `NEAR_FOLD_OMEGA` of tests/forced_oracle_cli.rs).
const NEAR_FOLD_OMEGA: f64 = 1e-3;

/// One run's frf.csv and frf.json.
struct Run {
    omega: Vec<f64>,
    q1: Vec<f64>,
    harmonics: Vec<usize>,
    folds: Vec<serde_json::Value>,
    raised: serde_json::Value,
}

fn chain() -> (Vec<Vec<f64>>, Vec<Vec<f64>>) {
    let mass = vec![vec![1.0, 0.0], vec![0.0, 1.0]];
    let stiffness = vec![vec![2.0, -1.0], vec![-1.0, 2.0]];
    (mass, stiffness)
}

/// `nlmodes forced` on the chain from N = 10 up to `max_harmonics` at `tolerance`
/// (`harmonic_tolerance`), into `root/{name}`.
fn run(root: &Path, name: &str, max_harmonics: usize, tolerance: f64) -> Run {
    let (model, out) = (root.join("model"), root.join(name));
    let settings = root.join(format!("{name}.toml"));
    std::fs::write(
        &settings,
        format!(
            "[forced]\nrange = [{:?}, {:?}]\nload = \"master\"\nlevels = [{FORCE:?}]\n\
             level_unit = \"N\"\ncontact = \"penalty\"\npenalty_factor = {PENALTY_FACTOR:?}\n\
             damping_ratio = {ZETA:?}\nadapt_harmonics = \"retrace\"\nharmonics = 10\n\
             max_harmonics = {max_harmonics}\nharmonic_tolerance = {tolerance:?}\n\
             stability = false\nexact_curve = false\n",
            RANGE.0, RANGE.1
        ),
    )
    .unwrap();
    let run = nlmodes(&[
        "forced",
        model.to_str().unwrap(),
        "--settings",
        settings.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
    ]);
    let log = format!(
        "{}{}",
        String::from_utf8_lossy(&run.stdout),
        String::from_utf8_lossy(&run.stderr)
    );
    assert_eq!(
        run.status.code(),
        Some(0),
        "max_harmonics {max_harmonics}:\n{log}"
    );
    let read = |f: &str| std::fs::read_to_string(out.join(f)).unwrap();
    let json: serde_json::Value = serde_json::from_str(&read("frf.json")).unwrap();
    let curve = &json["curves"][0];
    assert!(
        curve["termination"]
            .as_str()
            .unwrap()
            .starts_with("complete"),
        "max_harmonics {max_harmonics}: {}",
        curve["termination"]
    );
    let g = json["gap_reference_m"].as_f64().unwrap();
    let rows = csv_columns(
        &read("frf.csv"),
        &["omega_rad_s", "q1_over_g0", "harmonics"],
    );
    Run {
        omega: rows.iter().map(|r| r[0].parse().unwrap()).collect(),
        q1: rows
            .iter()
            .map(|r| r[1].parse::<f64>().unwrap() * g)
            .collect(),
        harmonics: rows.iter().map(|r| r[2].parse().unwrap()).collect(),
        folds: curve["folds"].as_array().unwrap().clone(),
        raised: curve["raised"].clone(),
    }
}

/// The chain's exact curve (penalty equation, no truncation) over the range.
fn exact_curve() -> ExactCurve {
    let (mass, stiffness) = chain();
    // Modes of K (M = I): w = 1 (1, 1) / sqrt 2, w = sqrt 3 (1, -1) / sqrt 2.
    let shapes = [(1.0, [1.0, 1.0]), (3.0_f64.sqrt(), [1.0, -1.0])];
    let c = Dense::from_fn(2, |i, j| {
        shapes
            .iter()
            .map(|(w, s)| 2.0 * ZETA * w * s[i] * s[j] / 2.0)
            .sum()
    });
    // kc = penalty_factor / (K^-1)_11, (K^-1)_11 = 2 / 3.
    let kc = PENALTY_FACTOR * 1.5;
    let sys = Pwl {
        n: 2,
        m: Dense::from_fn(2, |i, j| mass[i][j]),
        c,
        k: Dense::from_fn(2, |i, j| stiffness[i][j]),
        a: vec![0.0, 1.0],
        gap: GAP,
        kc,
        fc: vec![FORCE, 0.0],
        fs: vec![0.0; 2],
        distortion: None,
    };
    let range = (RANGE.0, RANGE.1 + TRACE_BEYOND);
    ExactCurve::trace(sys, vec![1.0, 0.0], range, (GAP, 1.0), ORBIT_TOL)
        .unwrap_or_else(|e| panic!("the exact curve: {e}"))
}

/// The exact orbits at W: one per crossing of W by the traced curve.
fn orbits_at(curve: &ExactCurve, w: f64) -> Vec<Orbit> {
    (0..curve.samples.len() - 1)
        .filter(|&i| {
            let (a, b) = (
                curve.samples[i].orbit.omega,
                curve.samples[i + 1].orbit.omega,
            );
            (a - w) * (b - w) <= 0.0
        })
        .filter_map(|i| curve.orbit_on_segment(i, w))
        .collect()
}

/// The smallest relative error of `q` against the exact orbits at `w` (infinite where there is
/// none: just past a fold).
fn error_at(curve: &ExactCurve, w: f64, q: f64) -> f64 {
    orbits_at(curve, w)
        .iter()
        .map(|o| (first_harmonic(&curve.sys, o, &curve.observed) / q - 1.0).abs())
        .fold(f64::INFINITY, f64::min)
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

#[test]
fn raising_n_around_the_points_that_moved_brings_them_onto_the_exact_curve() {
    let root: PathBuf = Path::new(env!("CARGO_TARGET_TMPDIR")).join("forced_raised");
    let _ = std::fs::remove_dir_all(&root);
    let (mass, stiffness) = chain();
    padded_contact_model(
        &root.join("model"),
        &mass,
        &stiffness,
        (1, 0),
        &[1.0, 3.0_f64.sqrt()],
    );
    let coarse = run(&root, "out10", 10, TOLERANCE);
    let raised_run = run(&root, "out20", 20, TOLERANCE);
    assert!(
        coarse.raised.is_null(),
        "nothing to raise at max_harmonics = N"
    );

    let raised = &raised_run.raised;
    let list = |key: &str| -> Vec<usize> {
        raised[key]
            .as_array()
            .unwrap_or_else(|| panic!("frf.json raised.{key}: {raised}"))
            .iter()
            .map(|v| v.as_u64().unwrap() as usize)
            .collect()
    };
    let (points, failed) = (list("raised"), list("failed"));
    let check = &raised["check"];
    println!(
        "raised {} points in {} segments, failed {}, check at 40: {check}",
        points.len(),
        raised["segments"].as_array().unwrap().len(),
        failed.len()
    );
    assert!(!points.is_empty(), "no point raised: {raised}");
    assert!(failed.is_empty(), "raised solves failed: {failed:?}");
    assert_eq!(check["harmonics"].as_u64(), Some(20));
    assert!(!check["checked"].as_array().unwrap().is_empty());
    assert_eq!(check["not_converged"].as_u64(), Some(0), "{check}");

    assert_eq!(coarse.omega.len(), raised_run.omega.len(), "the same trace");
    for i in 0..coarse.omega.len() {
        if points.contains(&i) {
            assert_eq!(raised_run.harmonics[i], 20, "point {i}");
        } else {
            assert_eq!(raised_run.harmonics[i], 10, "point {i}");
            assert_eq!(raised_run.omega[i], coarse.omega[i], "point {i}");
            assert_eq!(raised_run.q1[i], coarse.q1[i], "point {i}");
        }
    }
    assert_eq!(raised_run.folds, coarse.folds, "raising moves no fold");

    let exact = exact_curve();
    let folds: Vec<f64> = exact
        .folds
        .iter()
        .map(|f| exact.samples[f.sample].orbit.omega)
        .collect();
    let (mut before, mut after, mut largest) = (Vec::new(), Vec::new(), 0.0_f64);
    for &i in &points {
        let (w, q) = (raised_run.omega[i], raised_run.q1[i]);
        let e0 = error_at(&exact, coarse.omega[i], coarse.q1[i]);
        let e1 = error_at(&exact, w, q);
        if e0.is_finite() && e1.is_finite() {
            before.push(e0);
            after.push(e1);
            if folds.iter().all(|f| (w / f - 1.0).abs() > NEAR_FOLD_OMEGA) {
                largest = largest.max(e1);
            }
        }
    }
    let (m0, m1) = (median(before.clone()), median(after.clone()));
    println!(
        "{} of {} raised points with exact orbits at their W: median error {m0:.2e} at N = 10, \
         {m1:.2e} raised (largest {:.2e}, away from the folds {largest:.2e}; at N = 10 {:.2e})",
        after.len(),
        points.len(),
        after.iter().copied().fold(0.0, f64::max),
        before.iter().copied().fold(0.0, f64::max)
    );
    assert!(
        after.len() * 10 >= points.len() * 9,
        "most raised points have an exact orbit"
    );
    assert!(m1 * GAIN <= m0, "median error {m0:.2e} -> {m1:.2e}");
    assert!(
        largest <= RAISED_ERROR,
        "largest error of a raised point {largest:.2e}"
    );
}

/// A segment whose check at 4N still moves is raised again (`raised_segments`, round 2): at
/// `harmonic_tolerance = TIGHT_TOLERANCE` the points raised to 20 move by more than it at 40, so
/// their segments are raised to 40 (within twice max_harmonics) among the points at 20 and
/// checked at 80. Checked: the deciding check is at 80 (`raised.check.harmonics` = 40) and
/// converged, nothing failed; the points at 40 are raised points and lie within
/// `2 TIGHT_TOLERANCE` of the exact orbits at their W away from the folds, nearer than the same
/// points of the default-tolerance run at 20; every point at N = 10 is the N = 10 run's. A
/// raising that left a segment moving at 4N unraised (session 21's) fails the first assertion.
#[test]
fn a_segment_still_moving_at_4n_is_raised_again() {
    let root: PathBuf = Path::new(env!("CARGO_TARGET_TMPDIR")).join("forced_raised_again");
    let _ = std::fs::remove_dir_all(&root);
    let (mass, stiffness) = chain();
    padded_contact_model(
        &root.join("model"),
        &mass,
        &stiffness,
        (1, 0),
        &[1.0, 3.0_f64.sqrt()],
    );
    let once = run(&root, "out20", 20, TOLERANCE);
    let again = run(&root, "tight20", 20, TIGHT_TOLERANCE);
    let raised = &again.raised;
    let check = &raised["check"];
    let at_40: Vec<usize> = (0..again.omega.len())
        .filter(|&i| again.harmonics[i] == 40)
        .collect();
    println!(
        "tolerance {TIGHT_TOLERANCE:e}: {} points at 40, segments {}, deciding check {check}",
        at_40.len(),
        raised["segments"]
    );
    assert_eq!(check["harmonics"].as_u64(), Some(40), "{raised}");
    assert_eq!(check["not_converged"].as_u64(), Some(0), "{check}");
    assert!(raised["failed"].as_array().unwrap().is_empty(), "{raised}");
    assert!(!at_40.is_empty());
    // frf.json's rounds: to 20 (its check at 40 moving), then to 40 (its check converged).
    let rounds = raised["rounds"].as_array().expect("rounds");
    let n_of = |k: &serde_json::Value| k["harmonics"].as_u64();
    assert_eq!(
        rounds.iter().map(n_of).collect::<Vec<_>>(),
        [Some(20), Some(40)]
    );
    assert!(
        rounds[0]["check"]["not_converged"].as_u64() > Some(0),
        "{raised}"
    );
    assert_eq!(rounds[1]["check"]["not_converged"].as_u64(), Some(0));
    let listed: Vec<u64> = raised["raised"]
        .as_array()
        .unwrap()
        .iter()
        .map(|v| v.as_u64().unwrap())
        .collect();
    assert_eq!(once.omega.len(), again.omega.len(), "the same trace");
    for i in 0..again.omega.len() {
        match again.harmonics[i] {
            10 => assert_eq!(again.q1[i], once.q1[i], "point {i} at N = 10"),
            _ => assert!(listed.contains(&(i as u64)), "point {i} not listed raised"),
        }
    }

    let exact = exact_curve();
    let folds: Vec<f64> = exact
        .folds
        .iter()
        .map(|f| exact.samples[f.sample].orbit.omega)
        .collect();
    let (mut at_20, mut raised_40, mut largest) = (Vec::new(), Vec::new(), 0.0_f64);
    for &i in &at_40 {
        let (w, q) = (again.omega[i], again.q1[i]);
        let e = error_at(&exact, w, q);
        let e20 = error_at(&exact, once.omega[i], once.q1[i]);
        if e.is_finite() && e20.is_finite() && once.harmonics[i] == 20 {
            at_20.push(e20);
            raised_40.push(e);
        }
        if e.is_finite() && folds.iter().all(|f| (w / f - 1.0).abs() > NEAR_FOLD_OMEGA) {
            largest = largest.max(e);
        }
    }
    println!(
        "points at 40: median error {:.2e} (the same points at 20: {:.2e}), largest away from \
         the folds {largest:.2e}",
        median(raised_40.clone()),
        median(at_20.clone())
    );
    assert!(
        largest <= 2.0 * TIGHT_TOLERANCE,
        "largest error at 40 {largest:.2e}"
    );
    assert!(median(raised_40) < median(at_20));
}
