//! The stability column of `nlmodes backbone` against exact Floquet multipliers (issues 24 and
//! 38): three systems with a rigid stop whose one-impact nonlinear modes are known exactly
//! (`crates/nnm/tests/oracle/impact.rs`: the free linear flow between impacts, the
//! elastic-impact saltation matrix at each; independent of the harmonic-balance solver).
//!
//! * the 2-DOF chain M = I, K = [[2, -1], [-1, 2]], stop on DOF 2 at gap 1, master DOF 1;
//! * a chain with a mass ratio of 3, M = diag(1, 3), the stop on DOF 1, master DOF 2;
//! * a 3-DOF system with a non-diagonal M and a contact row along no coordinate
//!   (a = (0.2, 0, 1), gap 0.5), master DOF 3.
//!
//! Each is written as a reduced-model directory the way an external model comes, with modes far
//! above the harmonics resolved (issue 38): a contact node needs three coordinates, and the
//! 2-DOF systems complete theirs with two stiff coordinates that couple to nothing (unit masses
//! at rho w1 and 1.1 rho w1, rho = 10, 100, 1000); the 3-DOF system's node is the system itself
//! (radial a / |a|, gap 0.5 / |a|) and gets the same two coordinates as interior DOFs. A
//! decoupled coordinate changes no orbit and no multiplier but adds its own pair exp(+-i w_p T)
//! on the unit circle: the monodromy is block-diagonal, so the exact multipliers are the
//! unpadded system's (checked below against the oracle of the padded system at a few points).
//! A fourth variant couples one stiff coordinate (unit mass at 30 w1) to the contact
//! coordinate by a mass term mu = 0.03 and a spring kappa = 0.01 (a share of about 1e-3 of the
//! contact row's inverse mass), the node completed by one decoupled coordinate at 1000 w1; its
//! exact multipliers are those of the padded system itself (the oracle on the system and the weak
//! coordinate; the decoupled one changes nothing but its own pair).
//!
//! Criterion (the issue's): at every main-branch point after grazing whose exact one-impact orbit
//! exists and that lies more than 1 % in w from an exact change of stability (the exact
//! instability measure sampled at 201 frequencies across +-1 % of the point, the point's own
//! frequency among them, so that no transition, however narrow, around the point is missed),
//! the column agrees with the exact multipliers (|mu| > 1 + 1e-6 is unstable) or says
//! `undetermined`; none wrong, and undetermined at no more than 10 % of them, the points within
//! 1 % of an internal resonance w_p = m w of the weakly coupled coordinate left out of that
//! count (not of the first): the exact family is cut there and its multipliers diverge, as at
//! grazing (|mu| = 19-92 within 0.15 % of w_p / 27 on the mass-ratio chain), and no N-harmonic
//! orbit represents the resonant mode. Every variant runs
//! `nlmodes backbone DIR` with every setting at its default (N = 10, q_max = 35); the systems
//! padded at 1000 w1 and the weakly padded ones also run the issue's command (`--q-start 0.1
//! --q-max 30 --harmonics 40 --samples 512`).

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

/// The coordinates added to a system.
#[derive(Clone, Copy, Debug)]
enum Padding {
    /// Two unit masses at rho w1 and 1.1 rho w1 coupled to nothing.
    Decoupled(f64),
    /// A unit mass at 30 w1 coupled to the contact coordinate by M = mu and a spring kappa, and a
    /// decoupled one at 1000 w1.
    Weak,
}

const WEAK_RHO: f64 = 30.0;
const WEAK_MASS_COUPLING: f64 = 0.03;
const WEAK_SPRING: f64 = 0.01;

impl Padding {
    fn label(self) -> String {
        match self {
            Padding::Decoupled(rho) => format!("decoupled_{rho}"),
            Padding::Weak => "weak".into(),
        }
    }
}

/// M, K of `spec` padded by `pad` (the system's DOFs first), and the contact coordinate the
/// weakly coupled one is attached to.
fn padded(spec: &Spec, pad: Padding, w1: f64) -> (Vec<Vec<f64>>, Vec<Vec<f64>>) {
    let n0 = spec.a.len();
    let n = n0 + 2;
    let mut m = vec![vec![0.0; n]; n];
    let mut k = vec![vec![0.0; n]; n];
    for i in 0..n0 {
        for j in 0..n0 {
            m[i][j] = spec.m[i][j];
            k[i][j] = spec.k[i][j];
        }
    }
    let (p, q) = (n0, n0 + 1);
    m[p][p] = 1.0;
    m[q][q] = 1.0;
    match pad {
        Padding::Decoupled(rho) => {
            k[p][p] = (rho * w1).powi(2);
            k[q][q] = (1.1 * rho * w1).powi(2);
        }
        Padding::Weak => {
            let c = contact_coordinate(spec);
            k[p][p] = (WEAK_RHO * w1).powi(2) + WEAK_SPRING;
            k[c][c] += WEAK_SPRING;
            k[c][p] = -WEAK_SPRING;
            k[p][c] = -WEAK_SPRING;
            m[c][p] = WEAK_MASS_COUPLING;
            m[p][c] = WEAK_MASS_COUPLING;
            k[q][q] = (1000.0 * w1).powi(2);
        }
    }
    (m, k)
}

/// The coordinate with the largest entry of the contact row.
fn contact_coordinate(spec: &Spec) -> usize {
    (0..spec.a.len())
        .max_by(|&i, &j| spec.a[i].abs().total_cmp(&spec.a[j].abs()))
        .unwrap()
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

/// The reduced-model directory of `spec` padded by `pad`.
fn model_dir(spec: &Spec, pad: Padding, w1: f64, dir: &Path) {
    std::fs::create_dir_all(dir).unwrap();
    let n0 = spec.a.len();
    let (m, k) = padded(spec, pad, w1);
    write_symmetric(&dir.join("M.mtx"), &m);
    write_symmetric(&dir.join("K.mtx"), &k);
    // The node: the contact coordinate and the pads, or the three coordinates of the system.
    let (dofs, radial, gap) = if n0 < 3 {
        let c = contact_coordinate(spec);
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
    let a: Vec<f64> = spec.a.iter().copied().chain([0.0, 0.0]).collect();
    let hz: Vec<f64> = ImpactChain::new(&m, &k, &a, spec.gap, spec.master)
        .linear_omegas()
        .iter()
        .map(|w| w / (2.0 * std::f64::consts::PI))
        .collect();
    let model = serde_json::json!({
        "format": "nlmodes-reduced-model",
        "format_version": 1,
        "units": "SI: m, kg, s; K in N/m, M in kg",
        "n": m.len(),
        "contact_nodes": [{"dofs": dofs, "position": [1.0, 0.0, 0.0], "radial": radial, "gap": gap}],
        "rotor_axis": {"point": [0.0, 0.0, 0.0], "direction": [0.0, 0.0, 1.0]},
        "master": {"dof": spec.master, "description": "the exact system's master"},
        "linear_frequencies_hz": hz,
    });
    std::fs::write(dir.join("model.json"), model.to_string()).unwrap();
}

/// The exact one-impact model of `spec` with the weakly coupled coordinate (the decoupled one
/// at 1000 w1 left out: it changes no multiplier but its own pair).
fn weakly_padded_exact(spec: &Spec, w1: f64) -> ImpactChain {
    let n = spec.a.len() + 1;
    let (m, k) = padded(spec, Padding::Weak, w1);
    let cut =
        |a: &[Vec<f64>]| -> Vec<Vec<f64>> { a[..n].iter().map(|r| r[..n].to_vec()).collect() };
    let a: Vec<f64> = spec.a.iter().copied().chain([0.0]).collect();
    ImpactChain::new(&cut(&m), &cut(&k), &a, spec.gap, spec.master)
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

/// Whether the exact instability measure changes sign within +-1 % of `w` (201 samples and `w`
/// itself; frequencies without an admissible orbit skipped).
fn near_transition(exact: &ImpactChain, w: f64) -> bool {
    let measure = |x: f64| {
        exact
            .orbit_at_omega(x)
            .filter(|o| o.admissible)
            .map(|o| exact.instability(&o) > 0.0)
    };
    let mut grid: Vec<f64> = (0..=200)
        .map(|i| w * (0.99 + 0.02 * i as f64 / 200.0))
        .collect();
    grid.push(w);
    grid.sort_by(f64::total_cmp);
    let signs: Vec<bool> = grid.iter().filter_map(|&x| measure(x)).collect();
    signs.windows(2).any(|s| s[0] != s[1])
}

/// Whether `w` lies within 1 % of an internal resonance w_p = m w of the weakly coupled
/// coordinate (w_p its mode's frequency): the exact one-impact family is cut there (the impulse
/// vanishes, the multipliers diverge as at grazing: |mu| = 92 at 0.07 % from one).
fn near_resonance(w_p: Option<f64>, w: f64) -> bool {
    w_p.is_some_and(|w_p| {
        let m = (w_p / w).round();
        m >= 1.0 && (w - w_p / m).abs() <= 0.01 * w
    })
}

struct Tally {
    agree: usize,
    wrong: usize,
    undetermined: usize,
    /// Of `undetermined`, those within 1 % of an internal resonance of the weak coordinate.
    undetermined_at_resonance: usize,
    table: String,
}

/// Runs the command on `spec` padded by `pad` and compares its column with `reference`.
fn check(spec: &Spec, pad: Padding, root: &Path, args: &[&str]) -> Tally {
    let plain = ImpactChain::new(&spec.m, &spec.k, &spec.a, spec.gap, spec.master);
    let w1 = plain.grazing_omega();
    let dir = root.join(format!("{}_{}_{}", spec.name, pad.label(), args.len()));
    model_dir(spec, pad, w1, &dir.join("model"));
    // Decoupled pads: the padded system's multipliers are the plain ones plus the pads' pairs.
    let reference = match pad {
        Padding::Decoupled(_) => plain,
        Padding::Weak => weakly_padded_exact(spec, w1),
    };
    let reference = &reference;
    // The weakly coupled coordinate's mode: the padded system's mode above 10 w1.
    let w_weak = match pad {
        Padding::Decoupled(_) => None,
        Padding::Weak => reference
            .linear_omegas()
            .iter()
            .copied()
            .find(|&w| w > 10.0 * w1),
    };
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
        "{} {pad:?}: {}",
        spec.name,
        String::from_utf8_lossy(&out.stderr)
    );
    let mut tally = Tally {
        agree: 0,
        wrong: 0,
        undetermined: 0,
        undetermined_at_resonance: 0,
        table: format!("{} {} {args:?}\n", spec.name, pad.label()),
    };
    for (w, word, kind) in points(&dir.join("out/backbone.csv")) {
        if kind != "main" || w <= w1 * (1.0 + 1e-9) {
            continue;
        }
        let Some(orbit) = reference.orbit_at_omega(w).filter(|o| o.admissible) else {
            continue;
        };
        if near_transition(reference, w) {
            continue;
        }
        let mu = reference.max_multiplier_modulus(&orbit);
        let exact_word = if mu > 1.0 + 1e-6 {
            "unstable"
        } else {
            "stable"
        };
        let resonance = near_resonance(w_weak, w);
        let mark = match word.as_str() {
            "undetermined" => {
                tally.undetermined += 1;
                tally.undetermined_at_resonance += usize::from(resonance);
                ""
            }
            w if w == exact_word => {
                tally.agree += 1;
                ""
            }
            _ => {
                tally.wrong += 1;
                "  WRONG"
            }
        };
        let _ = writeln!(
            tally.table,
            "  w/w1 {:.4}: {word:>12}, exact max|mu| {mu:.4}{mark}{}",
            w / w1,
            if resonance { "  (resonance)" } else { "" }
        );
    }
    tally
}

fn root() -> PathBuf {
    let dir = std::env::temp_dir().join(format!("nlmodes-stability-cli-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    dir
}

/// The decoupled pads add their own pairs and change nothing else: the oracle of the padded
/// system against the plain one at a few frequencies on the branch.
#[test]
fn decoupled_coordinates_change_no_exact_multiplier() {
    for spec in specs() {
        let plain = ImpactChain::new(&spec.m, &spec.k, &spec.a, spec.gap, spec.master);
        let w1 = plain.grazing_omega();
        for rho in [10.0, 100.0, 1000.0] {
            let (m, k) = padded(&spec, Padding::Decoupled(rho), w1);
            let a: Vec<f64> = spec.a.iter().copied().chain([0.0, 0.0]).collect();
            let exact = ImpactChain::new(&m, &k, &a, spec.gap, spec.master);
            for ratio in [1.02, 1.1, 1.25, 1.35] {
                let (Some(o), Some(p)) = (
                    plain.orbit_at_omega(ratio * w1),
                    exact.orbit_at_omega(ratio * w1),
                ) else {
                    continue;
                };
                // Every multiplier of the plain system is one of the padded system's (the
                // trivial pair, a Jordan block at +1 that round-off splits by ~1e-8, left out),
                // and the others lie on the unit circle.
                let near_one = |m: &faer::c64| (m - faer::c64::new(1.0, 0.0)).norm() < 1e-6;
                let mut padded_mu = exact.multipliers(&p);
                for mu in plain.multipliers(&o).iter().filter(|m| !near_one(m)) {
                    let (i, d) = padded_mu
                        .iter()
                        .enumerate()
                        .map(|(i, m)| (i, (m - mu).norm()))
                        .min_by(|a, b| a.1.total_cmp(&b.1))
                        .unwrap();
                    assert!(
                        d <= 1e-9 * mu.norm().max(1.0),
                        "{} rho {rho} w/w1 {ratio}: {mu} not among {padded_mu:?}",
                        spec.name
                    );
                    padded_mu.swap_remove(i);
                }
                assert!(
                    padded_mu
                        .iter()
                        .all(|m| near_one(m) || (m.norm() - 1.0).abs() < 1e-9),
                    "{} rho {rho} w/w1 {ratio}: {padded_mu:?}",
                    spec.name
                );
            }
        }
    }
}

#[test]
fn stability_column_at_the_defaults_against_exact_multipliers() {
    let root = root();
    let mut failures = Vec::new();
    let issue: &[&str] = &[
        "--q-start",
        "0.1",
        "--q-max",
        "30",
        "--harmonics",
        "40",
        "--samples",
        "512",
    ];
    let mut runs: Vec<(Padding, &[&str])> =
        vec![(Padding::Decoupled(1000.0), issue), (Padding::Weak, issue)];
    for pad in [
        Padding::Decoupled(10.0),
        Padding::Decoupled(100.0),
        Padding::Decoupled(1000.0),
        Padding::Weak,
    ] {
        runs.push((pad, &[]));
    }
    for (pad, args) in runs {
        for spec in specs() {
            let t = check(&spec, pad, &root, args);
            let compared = t.agree + t.wrong + t.undetermined;
            let what = format!("{} {} {args:?}", spec.name, pad.label());
            println!(
                "{}{what}: {compared} compared: {} agree, {} wrong, {} undetermined ({} within 1 % \
                 of an internal resonance of the weak coordinate)",
                t.table, t.agree, t.wrong, t.undetermined, t.undetermined_at_resonance
            );
            let budget = t.undetermined - t.undetermined_at_resonance;
            if compared < 15 || t.wrong > 0 || 10 * budget > compared {
                failures.push(format!(
                    "{what}: {compared} compared, {} wrong, {} undetermined",
                    t.wrong, t.undetermined
                ));
            }
        }
    }
    let _ = std::fs::remove_dir_all(&root);
    assert!(failures.is_empty(), "{failures:?}");
}
