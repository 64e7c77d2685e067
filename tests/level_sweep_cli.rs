//! `[forced] level_sweeps` through `nlmodes forced` (issue 22 item 4): the continuation in force
//! level at a fixed frequency, checked against the frequency curve of the same run. On the
//! 2-DOF chain (M = I, K = [[2, -1], [-1, 2]], penalty stop on DOF 2, 1 % modal damping, two
//! uncoupled pad coordinates at 5 w1 to make a 3-coordinate contact node), the frequency curve at
//! level 2 x grazing crosses W0 = 1.05 w1 three times (its hardening overhang), and the level
//! sweep at W0 must cross level 2 at the same three amplitudes: two different continuations of
//! the same equations meeting at the same orbits. The tolerance, 2e-3 relative, is the linear
//! interpolation between the default steps of both curves (measured 2.1e-4); the library test
//! `crates/forced/tests/pwl_exact.rs` makes the same check at fine steps to 1.2e-5 and against
//! exact orbits.

mod common;

use std::process::Command;

use common::chain_model;

/// (x column, q1_over_g0) of the rows of a CSV with frf.csv's columns.
fn curve(csv: &str, x: &str) -> Vec<(f64, f64)> {
    let mut lines = csv.lines();
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    let at = |name: &str| header.iter().position(|h| *h == name).unwrap();
    let (ix, iq) = (at(x), at("q1_over_g0"));
    lines
        .map(|l| {
            let r: Vec<&str> = l.split(',').collect();
            (r[ix].parse().unwrap(), r[iq].parse().unwrap())
        })
        .collect()
}

/// Sorted amplitudes where the polyline (x, q) crosses x = at (linear interpolation).
fn crossings(points: &[(f64, f64)], at: f64) -> Vec<f64> {
    let mut out: Vec<f64> = points
        .windows(2)
        .filter(|w| (w[0].0 - at) * (w[1].0 - at) < 0.0)
        .map(|w| w[0].1 + (w[1].1 - w[0].1) * (at - w[0].0) / (w[1].0 - w[0].0))
        .collect();
    out.sort_by(f64::total_cmp);
    out
}

#[test]
fn level_sweep_meets_the_frequency_curve_at_its_three_orbits() {
    let dir = tempfile::tempdir().unwrap();
    let model = dir.path().join("model");
    chain_model(&model);
    let settings = dir.path().join("forced.toml");
    std::fs::write(
        &settings,
        "[forced]\nlevels = [2.0]\npenalty_factor = 3.0\ndamping_ratio = 0.01\n\
         range = [0.9, 1.6]\nlevel_sweeps = [1.05, 1.3]\nlevel_range = [0.1, 6.0]\n",
    )
    .unwrap();
    let out_dir = dir.path().join("out");
    let out = Command::new(env!("CARGO_BIN_EXE_nlmodes"))
        .args(["--quiet", "forced"])
        .arg(&model)
        .arg("--out")
        .arg(&out_dir)
        .arg("--settings")
        .arg(&settings)
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}{}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
    let frf = std::fs::read_to_string(out_dir.join("frf.csv")).unwrap();
    let sweeps = std::fs::read_to_string(out_dir.join("level_sweeps.csv")).unwrap();
    assert!(out_dir.join("level_sweeps.png").exists());
    let by_w = curve(&frf, "omega_ratio");
    let rows: Vec<(f64, f64)> = curve(&sweeps, "omega_ratio");
    let levels = curve(&sweeps, "level");
    let at_w0: Vec<(f64, f64)> = rows
        .iter()
        .zip(&levels)
        .filter(|((w, _), _)| (w - 1.05).abs() < 1e-12)
        .map(|(_, l)| *l)
        .collect();
    assert!(
        rows.iter()
            .all(|(w, _)| (w - 1.05).abs() < 1e-12 || (w - 1.3).abs() < 1e-12),
        "one curve per sweep frequency"
    );
    let (a, b) = (crossings(&by_w, 1.05), crossings(&at_w0, 2.0));
    eprintln!("at W0 = 1.05 w1, level 2: frequency curve {a:?}, level sweep {b:?}");
    assert_eq!(a.len(), 3, "the frequency curve overhangs W0: {a:?}");
    assert_eq!(a.len(), b.len(), "{a:?} against {b:?}");
    for (x, y) in a.iter().zip(&b) {
        assert!((x - y).abs() <= 2e-3 * x, "{x} against {y}");
    }
    // The force column is the level times the force of level 1.
    let force = curve(&sweeps, "force_N");
    let unit = force[0].0 / levels[0].0;
    let frf_force = curve(&frf, "force_N")[0].0;
    assert!((unit * 2.0 - frf_force).abs() <= 1e-12 * frf_force);
}
