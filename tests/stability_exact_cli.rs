//! The stability column of `nlmodes backbone` at its defaults against exact Floquet multipliers
//! (issue 24): three systems with a rigid stop whose one-impact nonlinear modes are known exactly
//! (`crates/nnm/tests/oracle/impact.rs`: the free linear flow between impacts, the
//! elastic-impact saltation matrix at each; independent of the harmonic-balance solver).
//!
//! * the 2-DOF chain M = I, K = [[2, -1], [-1, 2]], stop on DOF 2 at gap 1, master DOF 1;
//! * a chain with a mass ratio of 3, M = diag(1, 3), the stop on DOF 1, master DOF 2;
//! * a 3-DOF system with a non-diagonal M and a contact row along no coordinate
//!   (a = (0.2, 0, 1), gap 0.5), master DOF 3.
//!
//! Each goes through the command a user runs: `nlmodes backbone DIR --harmonics 40 --samples 512
//! --q-max 20`, every other setting at its default (the issue's command), and `nlmodes backbone
//! DIR` with every setting at its default (N = 10, q_max = 35). A reduced-model
//! directory needs a contact node of three coordinates: the 2-DOF chains get two decoupled unit
//! masses at w = 5 w1 (above the modes traced and below (N + 1) w / 2, so that every mode is
//! resolved, as the event-based monodromy requires; they only add multipliers on the unit circle)
//! as the node's y and z; the 3-DOF system is the node itself (radial a / |a|, gap
//! 0.5 / |a|).
//!
//! Criterion (the issue's): at every main-branch point after grazing whose exact one-impact orbit
//! exists and that lies more than 1 % in w from an exact change of stability, the column agrees
//! with the exact multipliers (|mu| > 1 + 1e-6 is unstable) or says `undetermined`; undetermined
//! at no more than 10 % of them.

#[path = "../crates/nnm/tests/oracle/mod.rs"]
mod oracle;

use oracle::impact::ImpactChain;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

struct Spec {
    name: &'static str,
    m: Vec<Vec<f64>>,
    k: Vec<Vec<f64>>,
    /// The contact row and gap of the system (before padding).
    a: Vec<f64>,
    gap: f64,
    master: usize,
}

fn specs() -> Vec<Spec> {
    vec![
        Spec {
            name: "chain",
            m: vec![vec![1.0, 0.0], vec![0.0, 1.0]],
            k: vec![vec![2.0, -1.0], vec![-1.0, 2.0]],
            a: vec![0.0, 1.0],
            gap: 1.0,
            master: 0,
        },
        Spec {
            name: "mass_ratio",
            m: vec![vec![1.0, 0.0], vec![0.0, 3.0]],
            k: vec![vec![2.0, -1.0], vec![-1.0, 2.0]],
            a: vec![1.0, 0.0],
            gap: 1.0,
            master: 1,
        },
        Spec {
            name: "three_dof",
            m: vec![
                vec![2.0, 0.3, 0.0],
                vec![0.3, 1.0, 0.2],
                vec![0.0, 0.2, 1.5],
            ],
            k: vec![
                vec![3.0, -1.0, 0.0],
                vec![-1.0, 2.5, -1.0],
                vec![0.0, -1.0, 1.2],
            ],
            a: vec![0.2, 0.0, 1.0],
            gap: 0.5,
            master: 2,
        },
    ]
}

fn write_symmetric(path: &Path, a: &[Vec<f64>]) {
    let n = a.len();
    let mut s = format!(
        "%%MatrixMarket matrix coordinate real symmetric\n{n} {n} {}\n",
        n * (n + 1) / 2
    );
    for j in 0..n {
        for (i, row) in a.iter().enumerate().skip(j) {
            let _ = writeln!(s, "{} {} {:.17e}", i + 1, j + 1, row[j]);
        }
    }
    std::fs::write(path, s).unwrap();
}

/// The reduced-model directory of `spec` (padded to a 3-coordinate contact node).
fn model_dir(spec: &Spec, exact: &ImpactChain, dir: &Path) {
    std::fs::create_dir_all(dir).unwrap();
    let n0 = spec.a.len();
    let pad = if n0 >= 3 { 0 } else { 2 };
    let n = n0 + pad;
    let grow = |a: &[Vec<f64>], diag: f64| -> Vec<Vec<f64>> {
        (0..n)
            .map(|i| {
                (0..n)
                    .map(|j| match (i < n0, j < n0) {
                        (true, true) => a[i][j],
                        _ if i == j => diag,
                        _ => 0.0,
                    })
                    .collect()
            })
            .collect()
    };
    write_symmetric(&dir.join("M.mtx"), &grow(&spec.m, 1.0));
    let w_pad = 5.0 * exact.linear_omegas()[0];
    write_symmetric(&dir.join("K.mtx"), &grow(&spec.k, w_pad * w_pad));
    // The node: the contact coordinate and the pads, or the three coordinates of the system.
    let (dofs, radial, gap) = if pad > 0 {
        let c = spec.a.iter().position(|&v| v != 0.0).unwrap();
        (
            vec![c, n0, n0 + 1],
            vec![1.0, 0.0, 0.0],
            spec.gap / spec.a[c],
        )
    } else {
        let norm = spec.a.iter().map(|v| v * v).sum::<f64>().sqrt();
        (
            vec![0, 1, 2],
            spec.a.iter().map(|v| v / norm).collect(),
            spec.gap / norm,
        )
    };
    let mut hz: Vec<f64> = exact
        .linear_omegas()
        .iter()
        .copied()
        .chain(std::iter::repeat_n(w_pad, pad))
        .map(|w| w / (2.0 * std::f64::consts::PI))
        .collect();
    hz.sort_by(f64::total_cmp);
    let model = serde_json::json!({
        "format": "nlmodes-reduced-model",
        "format_version": 1,
        "units": "SI: m, kg, s; K in N/m, M in kg",
        "n": n,
        "contact_nodes": [{"dofs": dofs, "position": [1.0, 0.0, 0.0], "radial": radial, "gap": gap}],
        "rotor_axis": {"point": [0.0, 0.0, 0.0], "direction": [0.0, 0.0, 1.0]},
        "master": {"dof": spec.master, "description": "the exact system's master"},
        "linear_frequencies_hz": hz,
    });
    std::fs::write(dir.join("model.json"), model.to_string()).unwrap();
}

/// (w rad/s, stability word, branch kind) of every point of backbone.csv.
fn points(csv: &Path) -> Vec<(f64, String, String)> {
    let text = std::fs::read_to_string(csv).unwrap();
    let mut lines = text.lines();
    let head: Vec<&str> = lines.next().unwrap().split(',').collect();
    let col = |name: &str| head.iter().position(|h| *h == name).unwrap();
    let (w, st, kind) = (col("omega_rad_s"), col("stability"), col("branch_kind"));
    lines
        .map(|l| {
            let f: Vec<&str> = l.split(',').collect();
            (
                f[w].parse().unwrap(),
                f[st].to_string(),
                f[kind].to_string(),
            )
        })
        .collect()
}

/// Agreeing, wrong and undetermined points of one system run with `args`, and the table.
fn check(spec: &Spec, root: &Path, args: &[&str]) -> (usize, usize, usize, String) {
    let exact = ImpactChain::new(&spec.m, &spec.k, &spec.a, spec.gap, spec.master);
    let dir = root.join(spec.name);
    model_dir(spec, &exact, &dir.join("model"));
    let _ = std::fs::remove_dir_all(dir.join("out"));
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_nlmodes"))
        .args(["--quiet", "backbone"])
        .arg(dir.join("model"))
        .args(args)
        .arg("-o")
        .arg(dir.join("out"))
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}: {}",
        spec.name,
        String::from_utf8_lossy(&out.stderr)
    );
    let w1 = exact.grazing_omega();
    let transitions: Vec<f64> = exact
        .stability_transitions(w1 * (1.0 + 1e-6), 2.0 * w1, 800)
        .iter()
        .map(|t| t.omega)
        .collect();
    let (mut agree, mut wrong, mut undetermined) = (0, 0, 0);
    let mut table = format!("{}: exact changes of stability at w/w1 = ", spec.name);
    for t in &transitions {
        let _ = write!(table, "{:.4} ", t / w1);
    }
    table.push('\n');
    for (w, word, kind) in points(&dir.join("out/backbone.csv")) {
        if kind != "main" || w <= w1 * (1.0 + 1e-9) {
            continue;
        }
        let Some(orbit) = exact.orbit_at_omega(w).filter(|o| o.admissible) else {
            continue;
        };
        if transitions.iter().any(|t| (w - t).abs() <= 0.01 * t) {
            continue;
        }
        let mu = exact.max_multiplier_modulus(&orbit);
        let exact_word = if mu > 1.0 + 1e-6 {
            "unstable"
        } else {
            "stable"
        };
        let mark = match word.as_str() {
            "undetermined" => {
                undetermined += 1;
                ""
            }
            w if w == exact_word => {
                agree += 1;
                ""
            }
            _ => {
                wrong += 1;
                "  WRONG"
            }
        };
        let _ = writeln!(
            table,
            "  w/w1 {:.4}: {word:>12}, exact max|mu| {mu:.4}{mark}",
            w / w1
        );
    }
    (agree, wrong, undetermined, table)
}

fn root() -> PathBuf {
    let dir = std::env::temp_dir().join(format!("nlmodes-stability-cli-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    dir
}

#[test]
fn stability_column_at_the_defaults_against_exact_multipliers() {
    let root = root();
    let mut failures = Vec::new();
    let issue: &[&str] = &["--harmonics", "40", "--samples", "512", "--q-max", "20"];
    for args in [issue, &[]] {
        for spec in specs() {
            let (agree, wrong, undetermined, table) = check(&spec, &root, args);
            let compared = agree + wrong + undetermined;
            let what = format!("{} {args:?}", spec.name);
            println!(
                "{table}{what}: {compared} compared: {agree} agree, {wrong} wrong, \
                 {undetermined} undetermined"
            );
            if compared < 15 || wrong > 0 || 10 * undetermined > compared {
                failures.push(format!(
                    "{what}: {compared} compared, {wrong} wrong, {undetermined} undetermined"
                ));
            }
        }
    }
    let _ = std::fs::remove_dir_all(&root);
    assert!(failures.is_empty(), "{failures:?}");
}
