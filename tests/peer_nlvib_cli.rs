//! `nlmodes forced` against a peer (issue: "the same forced curve as an established HB code on a
//! small penalty system"): NLvib (M. Krack, github.com/maltekrack/NLvib) on its own example
//! EXAMPLES/03_twoDOFoscillator_unilateralSpring, run in GNU Octave by
//! `scripts/peer/nlvib_unilateral.m`; its curve is `tests/data/peer/nlvib_unilateral.csv`.
//! docs/PEER_NLVIB.md has the system, both codes' settings and the full comparison.
//!
//! The system: M = I, K = [[1, -1], [-1, 2]], C = 0.03 K, f = (0, 0.1) cos(W t) N, a unilateral
//! spring 100 (q1 - 1)_+ on DOF 1; H = 21 harmonics, 1024 time samples per period in both codes,
//! W from 0.5 to 0.8 rad/s (w1 = 0.618 rad/s). Here the contact node of the reduced-model format
//! is DOF 1 with two decoupled pads (unit mass, k = 400, c = 12: w = 20 rad/s, above 21 W, so no
//! harmonic of the response meets them; unforced and uncoupled, they stay at rest); the penalty
//! kc = penalty_factor x the static contact stiffness 1 / (K^-1)_11 = 200 x 0.5 = 100.
//!
//! Both codes solve the same discrete equations (Galerkin HB with the penalty force sampled at
//! 1024 points): NLvib's residual at nlmodes' 304 orbits is at most 2.8e-9 and NLvib's Newton
//! from them moves the first harmonics by at most 3e-10 (`scripts/peer/nlvib_crosscheck.m`).
//! This test cannot run NLvib, so it compares nlmodes' points with the stored peer curve: for
//! each point, the distance in the plane (W / w1, y / g0) to the peer's polyline (1991 points)
//! for y = the first-harmonic amplitude of DOF 1 and of DOF 2 and the mean of DOF 1 (the mean
//! tells which side the stop is on, which the amplitudes cannot: the system is odd).
//!
//! Both run at H = 21 (`max_harmonics = 21`: the `[forced]` default would raise N where an
//! orbit needs it, and the distance to the peer's H = 21 curve is then its truncation, 6.9e-4).
//! nlmodes integrates the penalty force exactly over the contact phases (DESIGN §10.9) where
//! NLvib samples it at 1024 points: measured (session 17) largest distance 1.69e-4 (a1), 1.68e-4
//! (a2), 1.66e-4 (mean), all at the grazing corner W = 0.6534 where the peer's polyline cuts the
//! corner of the curve; median 2.0e-6, 3.0e-6, 1.8e-6 (the sampled law's kinks; session 16, with
//! the sampled law in both codes: largest 1.10e-4, median 6.2e-7). Tolerances: largest 3e-4 (about 3x the measured corner chord; the
//! sampled problem's curve also wiggles by up to 6e-4 in a1 near the peak, a kink each time a time
//! sample enters or leaves contact, which both codes follow); median 1e-5 (16x the measured; the
//! peer's interpolation on the smooth parts). What these catch (measured by rerunning with one
//! change): C 1 % larger, largest 1.6e-3; kc 1 % larger, largest 5.2e-4 and median 8.3e-5; the
//! stop on the other side, mean 0.37; H = 20 instead of 21, median 4.8e-5 (its largest, 2.0e-4,
//! is below the largest-distance tolerance). Folds: W of the jump frequencies within 3e-4 w1 of
//! the peer's (measured 5.1e-6 w1 at the upper fold and 1.5e-4 w1 at the lower one, which is the
//! grazing corner: the peer's points step over it by 1e-4 rad/s). Cost about 2 s.

use std::fmt::Write as _;
use std::path::Path;

const W1: f64 = 0.618_033_988_749_894_8; // sqrt((3 - sqrt 5) / 2), rad/s
const GAP: f64 = 1.0;

fn write(path: &Path, text: &str) {
    std::fs::write(path, text).unwrap();
}

/// The reduced-model directory of NLvib's example (with the two pads of the contact node).
fn model_dir(dir: &Path) {
    std::fs::create_dir_all(dir).unwrap();
    let symmetric = |entries: &[(usize, usize, f64)]| {
        let mut s = format!(
            "%%MatrixMarket matrix coordinate real symmetric\n4 4 {}\n",
            entries.len()
        );
        for (i, j, v) in entries {
            let _ = writeln!(s, "{i} {j} {v:e}");
        }
        s
    };
    write(
        &dir.join("M.mtx"),
        &symmetric(&[(1, 1, 1.0), (2, 2, 1.0), (3, 3, 1.0), (4, 4, 1.0)]),
    );
    let k = [
        (1, 1, 1.0),
        (2, 1, -1.0),
        (2, 2, 2.0),
        (3, 3, 400.0),
        (4, 4, 400.0),
    ];
    write(&dir.join("K.mtx"), &symmetric(&k));
    let c: Vec<_> = k.iter().map(|&(i, j, v)| (i, j, 0.03 * v)).collect();
    write(&dir.join("C.mtx"), &symmetric(&c));
    write(
        &dir.join("F.mtx"),
        "%%MatrixMarket matrix array real general\n4 1\n0\n1\n0\n0\n",
    );
    let hz = |w: f64| w / (2.0 * std::f64::consts::PI);
    let w2 = ((3.0 + 5f64.sqrt()) / 2.0).sqrt();
    let model = serde_json::json!({
        "format": "nlmodes-reduced-model",
        "format_version": 1,
        "units": "SI: m, kg, s; K in N/m, M in kg",
        "n": 4,
        "contact_nodes": [{"dofs": [0, 2, 3], "position": [1.0, 0.0, 0.0],
                           "radial": [1.0, 0.0, 0.0], "gap": GAP}],
        "rotor_axis": {"point": [0.0, 0.0, 0.0], "direction": [0.0, 0.0, 1.0]},
        "master": {"dof": 0, "description": "DOF 1 of NLvib's 2-DOF chain (the spring's)"},
        "linear_frequencies_hz": [hz(W1), hz(w2), hz(20.0), hz(20.0)],
    });
    write(&dir.join("model.json"), &model.to_string());
}

/// The peer's curve: (W rad/s, a1 of DOF 1, a1 of DOF 2, mean of DOF 1) in continuation order.
fn peer() -> Vec<[f64; 4]> {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/peer/nlvib_unilateral.csv");
    let text = std::fs::read_to_string(&path).unwrap();
    let mut lines = text.lines().filter(|l| !l.starts_with('#'));
    let head: Vec<&str> = lines.next().unwrap().split(',').collect();
    assert_eq!(
        head[..4],
        ["omega_rad_s", "a1_dof1", "a1_dof2", "mean_dof1"],
        "{}",
        path.display()
    );
    lines
        .map(|l| {
            let v: Vec<f64> = l.split(',').map(|s| s.parse().unwrap()).collect();
            [v[0], v[1], v[2], v[3]]
        })
        .collect()
}

/// Distance from (x, y) to the polyline through `pts`.
fn distance_to_polyline(pts: &[(f64, f64)], (x, y): (f64, f64)) -> f64 {
    pts.windows(2)
        .map(|s| {
            let ((ax, ay), (bx, by)) = (s[0], s[1]);
            let (dx, dy) = (bx - ax, by - ay);
            let len2 = dx * dx + dy * dy;
            let t = if len2 > 0.0 {
                (((x - ax) * dx + (y - ay) * dy) / len2).clamp(0.0, 1.0)
            } else {
                0.0
            };
            (x - ax - t * dx).hypot(y - ay - t * dy)
        })
        .fold(f64::INFINITY, f64::min)
}

/// The peer's folds: where W turns and then retreats by more than 1e-4 rad/s (the curve of the
/// sampled problem wiggles by less), at the extreme point (W rad/s, turning back?).
fn peer_folds(w: &[f64]) -> Vec<(f64, bool)> {
    let mut folds = Vec::new();
    let (mut k0, mut up) = (0, w[1] > w[0]);
    for k in 1..w.len() {
        let ahead = if up { w[k] - w[k0] } else { w[k0] - w[k] };
        if ahead > 0.0 {
            k0 = k;
        } else if -ahead > 1e-4 {
            // Turning back = W was rising (a sweep up jumps down there).
            folds.push((w[k0], up));
            up = !up;
            k0 = k;
        }
    }
    folds
}

#[test]
fn forced_curve_of_nlvibs_unilateral_spring_example_matches_nlvib() {
    let dir = tempfile::tempdir().unwrap();
    let model = dir.path().join("model");
    model_dir(&model);
    let settings = dir.path().join("forced.toml");
    write(
        &settings,
        &format!(
            "[forced]\nmode = 0\nrange = [{}, {}]\nharmonics = 21\nmax_harmonics = 21\nsamples = 1024\n\
             damping_matrix = true\nload = \"file\"\nlevels = [0.1]\nlevel_unit = \"N\"\n\
             contact = \"penalty\"\npenalty_factor = 200.0\nstability = false\n\
             keep_peaks = false\n",
            0.5 / W1,
            0.8 / W1
        ),
    );
    let out_dir = dir.path().join("out");
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_nlmodes"))
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
        "nlmodes forced failed:\n{}{}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out_dir.join("frf.json")).unwrap()).unwrap();
    assert_eq!(json["penalty_stiffness_n_per_m"].as_f64().unwrap(), 100.0);
    let curve = &json["curves"][0];
    assert_eq!(curve["termination"], "complete");

    // nlmodes' points: (W, a1 DOF 1, a1 DOF 2, mean DOF 1); coefficients [c0, a1, b1, a2, ...].
    let points: Vec<[f64; 4]> = curve["orbits"]
        .as_array()
        .unwrap()
        .iter()
        .map(|o| {
            let c = |dof: usize, i: usize| o["coefficients"][dof][i].as_f64().unwrap();
            [
                o["omega"].as_f64().unwrap(),
                c(0, 1).hypot(c(0, 2)),
                c(1, 1).hypot(c(1, 2)),
                c(0, 0),
            ]
        })
        .collect();
    let peer = peer();
    let (w_lo, w_hi) = peer
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), p| {
            (lo.min(p[0]), hi.max(p[0]))
        });
    let inside: Vec<&[f64; 4]> = points
        .iter()
        .filter(|p| (w_lo..=w_hi).contains(&p[0]))
        .collect();
    assert!(inside.len() > 100 && inside.len() + 2 >= points.len());
    assert!(points[0][0] <= 0.5 + 1e-12 && points[points.len() - 1][0] >= 0.8);

    let mut report = String::new();
    let mut failures = Vec::new();
    for (col, name) in [(1, "a1 DOF 1"), (2, "a1 DOF 2"), (3, "mean DOF 1")] {
        let line: Vec<(f64, f64)> = peer.iter().map(|p| (p[0] / W1, p[col] / GAP)).collect();
        let mut d: Vec<(f64, f64)> = inside
            .iter()
            .map(|p| (distance_to_polyline(&line, (p[0] / W1, p[col] / GAP)), p[0]))
            .collect();
        d.sort_by(|a, b| b.0.total_cmp(&a.0));
        let median = d[d.len() / 2].0;
        let _ = writeln!(
            report,
            "{name}: largest distance {:.2e} at W = {:.5} rad/s, median {median:.2e}",
            d[0].0, d[0].1
        );
        if d[0].0 > 3e-4 || median > 1e-5 {
            failures.push(name);
        }
    }

    // The jump frequencies against the peer's folds, in order along the curve (nlmodes goes up in
    // W, the peer down: the peer's list reversed; a largest W turns back either way).
    let mut ours: Vec<(f64, bool)> = curve["folds"]
        .as_array()
        .unwrap()
        .iter()
        .map(|f| (f[1].as_f64().unwrap(), f[2] == "TurnsBack"))
        .collect();
    let theirs: Vec<(f64, bool)> = peer_folds(&peer.iter().map(|p| p[0]).collect::<Vec<_>>())
        .into_iter()
        .rev()
        .collect();
    let _ = writeln!(report, "folds: nlmodes {ours:?}, NLvib {theirs:?}");
    assert_eq!(ours.len(), 2, "{report}");
    assert_eq!(theirs.len(), 2, "{report}");
    for ((w, back), (wp, backp)) in ours.drain(..).zip(&theirs) {
        assert_eq!(back, *backp, "{report}");
        if (w - wp).abs() > 3e-4 * W1 {
            failures.push("fold frequency");
        }
    }

    // The peak of a1 (largest point of each curve).
    let peak = |v: &[[f64; 4]]| {
        v.iter()
            .copied()
            .fold([0.0; 4], |m, p| if p[1] > m[1] { p } else { m })
    };
    let (ours, theirs) = (peak(&points), peak(&peer));
    let _ = writeln!(
        report,
        "peak a1: nlmodes {:.6} at {:.6} rad/s, NLvib {:.6} at {:.6} rad/s",
        ours[1], ours[0], theirs[1], theirs[0]
    );
    if (ours[1] - theirs[1]).abs() > 3e-4 * GAP {
        failures.push("peak");
    }
    println!("{report}");
    assert!(failures.is_empty(), "{failures:?} off the peer:\n{report}");
}
