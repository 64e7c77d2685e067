//! The exact backbone of the massless contact boundary (`backbone/backbone_boundary.csv` and
//! `.json`; docs/STABILITY.md Sec. 9.3) through `nlmodes backbone`, against a closed form.
//!
//! The system (`common::light_contact_model`, eps = 1e-3, ks = 1): a unit master mass on a unit
//! spring holds the contact coordinate (mass eps) by a spring ks; the stop is on the contact
//! coordinate at gap g = 1. Its second mode (31.6 rad/s) is far above (N + 1) w of the first,
//! so on the massless boundary the first mode q alone is dynamic (the two pads are decoupled
//! from the contact row), behind the residual flexibility R = (K^-1)_11 - b^2 / w1^2 of the
//! discarded mode, b = phi_1 at the contact coordinate. With y = b q / g the boundary model is
//! the bilinear oscillator y'' + w1^2 y = -(b^2 / R) (y - 1)_+, whose period released at rest
//! from y0 > 1 is known in closed form: the contact phase (frequency sqrt(w1^2 + b^2 / R)) down
//! to y = 1, the free arc to the other turning point and back, twice. The test computes w1, b
//! and R from M and K itself (no eigensolver shared with the program) and compares every exact
//! orbit's period (from its q0 in backbone_boundary.json) with the closed form.
//!
//! Tolerance 1e-8 relative: the orbits are exact to the shooting tolerance (1e-10 on the
//! scaled half-period velocity) and the modes to the dense eigensolver's round-off; the closed
//! form uses w1, b and R from the quadratic formula (round-off 1e-15 relative).

mod common;

use common::{light_contact_model, nlmodes, two_dof_frequencies};
use std::f64::consts::PI;
use std::path::PathBuf;

const EPS: f64 = 1e-3;
const KS: f64 = 1.0;

/// w1, b and R of the model (module docs).
fn bilinear_data() -> (f64, f64, f64) {
    let (w1, _) = two_dof_frequencies(EPS, KS);
    let l1 = w1 * w1;
    // (K - l1 M) phi = 0, first row: (1 + ks - l1) phi_0 = ks phi_1; phi^T M phi = 1.
    let ratio = (1.0 + KS - l1) / KS;
    let phi0 = 1.0 / (1.0 + EPS * ratio * ratio).sqrt();
    let b = ratio * phi0;
    // (K^-1)_11 of [[1 + ks, -ks], [-ks, ks]] (det = ks).
    let r = (1.0 + KS) / KS - b * b / l1;
    (w1, b, r)
}

/// The period of y'' + w^2 y = -(k / 1) (y - 1)_+ released at rest from y0 (module docs).
fn bilinear_period(w: f64, k: f64, y0: f64) -> f64 {
    if y0 <= 1.0 {
        return 2.0 * PI / w;
    }
    let s = (w * w + k).sqrt();
    let y_eq = k / (s * s);
    let t1 = ((1.0 - y_eq) / (y0 - y_eq)).acos() / s;
    let v1 = (y0 - y_eq) * s * (s * t1).sin();
    // The free arc from y = 1 at speed v1 to its turning point: y = A cos(w t + phi).
    let phi = (v1 / w).atan2(1.0);
    2.0 * (t1 + (PI - phi) / w)
}

/// The quadratic through three (x, y) points, at x.
fn quadratic(p: &[(f64, f64)], x: f64) -> f64 {
    let [(x0, y0), (x1, y1), (x2, y2)] = [p[0], p[1], p[2]];
    y0 * (x - x1) * (x - x2) / ((x0 - x1) * (x0 - x2))
        + y1 * (x - x0) * (x - x2) / ((x1 - x0) * (x1 - x2))
        + y2 * (x - x0) * (x - x1) / ((x2 - x0) * (x2 - x1))
}

/// `nlmodes backbone MODEL -o OUT ARGS...` on the light-contact model in a fresh directory; the
/// directory (kept alive) and OUT. Fails the test unless the command succeeds.
fn backbone(args: &[&str], settings: Option<&str>) -> (tempfile::TempDir, PathBuf) {
    let dir = tempfile::tempdir().unwrap();
    let (model, out) = (dir.path().join("model"), dir.path().join("out"));
    light_contact_model(&model, EPS, KS);
    let settings_file = dir.path().join("settings.toml");
    let mut all = vec![
        "backbone".to_string(),
        model.display().to_string(),
        "-o".to_string(),
        out.display().to_string(),
    ];
    all.extend(args.iter().map(|a| a.to_string()));
    if let Some(text) = settings {
        std::fs::write(&settings_file, text).unwrap();
        all.extend([
            "--settings".to_string(),
            settings_file.display().to_string(),
        ]);
    }
    let all: Vec<&str> = all.iter().map(String::as_str).collect();
    let run = nlmodes(&all);
    assert!(
        run.status.success(),
        "nlmodes {all:?} failed:\n{}",
        String::from_utf8_lossy(&run.stderr)
    );
    (dir, out)
}

#[test]
fn every_exact_backbone_orbit_has_the_closed_form_period_of_its_bilinear_oscillator() {
    let (_dir, out) = backbone(&["--q-max", "5"], None);
    assert!(out.join("backbone_boundary.csv").is_file());
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("backbone_boundary.json")).unwrap())
            .unwrap();
    let (w1, b, r) = bilinear_data();
    let k = b * b / r;
    let pieces = json["pieces"].as_array().expect("pieces");
    // No internal resonance (the pads are decoupled): one piece from q_start to q_max.
    assert_eq!(pieces.len(), 1, "{json}");
    assert_eq!(pieces[0]["upper_end"]["kind"], "complete");
    let points = pieces[0]["points"].as_array().expect("points");
    let (mut worst, mut in_contact, mut q_top) = (0.0_f64, 0, 0.0_f64);
    for p in points {
        let omega = p["omega"].as_f64().unwrap();
        let y0 = (b * p["q0"][0].as_f64().unwrap()).abs();
        let exact = bilinear_period(w1, k, y0);
        worst = worst.max((2.0 * PI / omega / exact - 1.0).abs());
        in_contact += usize::from(y0 > 1.0);
        q_top = q_top.max(p["q"].as_f64().unwrap().abs());
        // One mode on one row (and two decoupled pads): only the trivial pair and the pads'
        // multipliers on the unit circle: every orbit is stable.
        assert_eq!(p["verdict"], "stable", "{p}");
    }
    println!(
        "{} orbits ({in_contact} in contact) up to q/g0 = {q_top:.3}: worst period error \
         {worst:.1e} (w1 = {w1:.6}, b = {b:.6}, R = {r:.6})",
        points.len()
    );
    assert!(in_contact > 20, "the curve must run in contact");
    assert!(q_top >= 5.0, "up to q_max: {q_top}");
    assert!(worst < 1e-8, "{worst}");
    // The second method: the harmonic balance of the massive model (N = 10) at each main-branch
    // point against the exact curve at the same q (linear between its orbits). The contact
    // coordinate is nearly massless, so the two models differ by O(eps); the N = 10 truncation
    // and the interpolation near grazing dominate. Bound: `truncation_tolerance` (1e-3);
    // measured 2.9e-4.
    let exact: Vec<(f64, f64)> = points
        .iter()
        .map(|p| (p["q"].as_f64().unwrap().abs(), p["omega"].as_f64().unwrap()))
        .collect();
    let csv = std::fs::read_to_string(out.join("backbone.csv")).unwrap();
    let header: Vec<&str> = csv.lines().next().unwrap().split(',').collect();
    let col = |name: &str| header.iter().position(|h| *h == name).expect(name);
    let (iq, iw, ik) = (col("q_m"), col("omega_rad_s"), col("branch_kind"));
    let mut compared = 0;
    let mut largest = 0.0_f64;
    for line in csv.lines().skip(1) {
        let v: Vec<&str> = line.split(',').collect();
        if v[ik] != "main" {
            continue;
        }
        let (q, w) = (v[iq].parse::<f64>().unwrap(), v[iw].parse::<f64>().unwrap());
        let Some(at) = exact.windows(2).find_map(|s| {
            let (a, b) = (s[0], s[1]);
            (a.0.min(b.0) <= q && q <= a.0.max(b.0) && a.0 != b.0)
                .then(|| a.1 + (q - a.0) / (b.0 - a.0) * (b.1 - a.1))
        }) else {
            continue;
        };
        compared += 1;
        largest = largest.max((w - at).abs() / at);
    }
    println!("harmonic balance against the exact curve at {compared} points: {largest:.1e}");
    assert!(compared >= 20, "{compared}");
    assert!(largest < 1e-3, "{largest}");
    // The converged orbit of each main-branch point in contact (docs/STABILITY.md Sec. 9.4), a
    // third method: Newton on the exact orbit at the point's own q (the master's first harmonic
    // prescribed), against the exact curve continued in T (its periods checked above against the
    // closed form) at the same q. Measured 5.9e-7 (the interpolation); bound 5e-6. The modes
    // dynamic at N and at 2N are the same (the first and the two pads), so the 2N estimate is
    // 0 and every orbit is converged at N = 10.
    let (ic, in_, ich, iconv) = (
        col("converged_omega_ratio"),
        col("converged_harmonics"),
        col("converged_omega_change"),
        col("convergence"),
    );
    let (ie, it) = (col("omega_error_to_converged"), col("truncation_warning"));
    let (mut converged, mut worst_converged) = (0, 0.0_f64);
    for line in csv.lines().skip(1) {
        let v: Vec<&str> = line.split(',').collect();
        let Ok(ratio) = v[ic].parse::<f64>() else {
            continue;
        };
        converged += 1;
        assert_eq!(
            (v[iconv], v[in_], v[ich]),
            ("converged", "10", "0"),
            "{line}"
        );
        let w = ratio * w1;
        let q = v[iq].parse::<f64>().unwrap();
        // Quadratic through the three exact orbits around q (q rises along the one piece),
        // from q = 1.25 g0 on: just past grazing (q/g0 = 1) w(q) is not smooth enough for it
        // (there the quadratic is off by up to 1.4e-5 between orbits 0.04 g0 apart).
        let around = exact.windows(2).position(|s| s[0].0 <= q && q <= s[1].0);
        if let Some(i) = around.filter(|_| q >= 1.25) {
            let i = i.clamp(1, exact.len() - 2);
            let at = quadratic(&exact[i - 1..=i + 1], q);
            worst_converged = worst_converged.max((w - at).abs() / at);
        }
        // The "N too small" flag: the harmonic-balance w farther than truncation_tolerance
        // (1e-3) from the converged w.
        let error = v[ie].parse::<f64>().unwrap();
        let hb = v[iw].parse::<f64>().unwrap();
        assert!((error - (hb - w).abs() / w).abs() < 1e-12, "{line}");
        assert_eq!(v[it] == "1", error > 1e-3, "{line}");
    }
    println!("{converged} converged orbits against the exact curve: {worst_converged:.1e}");
    assert!(converged >= 20, "{converged}");
    assert!(worst_converged < 5e-6, "{worst_converged}");
}

#[test]
fn no_exact_backbone_without_shooting() {
    let (_dir, out) = backbone(
        &["--q-max", "3"],
        Some("[stability.hill]\nshooting = false\n"),
    );
    assert!(out.join("backbone.csv").is_file());
    assert!(!out.join("backbone_boundary.csv").exists());
    assert!(!out.join("backbone_boundary.json").exists());
}
