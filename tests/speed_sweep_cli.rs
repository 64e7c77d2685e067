//! `nlmodes forced PARAMETRIC_DIR --speed-sweep` and `--speed RPM` (issue 39, items 1 and 2)
//! on a small parametric model written here: two 3-DOF nodes on springs (one chain per
//! direction), the first node a contact node 0.3 m from the rotor axis, turning with
//! K(Omega) = K0 + S Omega^2 M (S = 1.2), so that every frequency follows the Southwell law
//! w_k(Omega)^2 = w_k0^2 + S Omega^2 exactly and the Campbell curve of mode 0 crosses engine
//! order e at Omega_c = w_00 / sqrt(e^2 - S) in closed form; the contact node grows outward by
//! c Omega^2 (the running gap 1 mm - c Omega^2). The spline in Omega^2 of the parametric model
//! is exact for this affine K and growth, so the model is the closed form at every speed.
//!
//! Checked: bad input refused first, naming the file, the key and the value (an engine order
//! below 1, a speed range outside the model's range, an engine order without a crossing, a
//! speed outside the range; in a case file: an engine order below 1, a speed range outside
//! `[rotation] campbell_range`, `[speed_sweep]` without `[rotation]`); the linear sweep's
//! crossing at the closed form's (1e-9) and its peak within the half-power half-width of it;
//! the sweep into contact: the speeds where it touches, the largest contact force, a fold
//! where the run-up jumps, every point's stability; `--speed` at the closed-form frequency.
//! Cost: a few seconds.

use std::path::{Path, PathBuf};
use std::process::Command;

use faer::Mat;
use nlmodes_modal::{
    ContactNode, MasterCoordinate, ParametricContact, ParametricModel, RecoveryStorage,
    ReducedModel, RotorAxis,
};

/// Southwell coefficient, cold gap (m), growth per Omega^2 (m s^2), sample speeds (rad/s).
const S: f64 = 1.2;
const GAP: f64 = 1e-3;
const GROWTH: f64 = 1.875e-9;
const SPEEDS: [f64; 5] = [0.0, 100.0, 200.0, 300.0, 400.0];
const REFERENCE: f64 = 200.0;
const RPM: f64 = std::f64::consts::PI / 30.0;

fn mass() -> Mat<f64> {
    Mat::from_fn(6, 6, |i, j| {
        if i == j {
            [1.0, 1.0, 1.0, 2.0, 2.0, 2.0][i]
        } else {
            0.0
        }
    })
}

/// K(Omega): per direction d a chain ground - node 0 - node 1 with springs (4, 2) x 1e6
/// x (1, 1.3, 1.7)[d] N/m, plus S Omega^2 M.
fn stiffness(omega: f64) -> Mat<f64> {
    let mut k = Mat::<f64>::zeros(6, 6);
    for d in 0..3 {
        let f = [1.0, 1.3, 1.7][d];
        let (k1, k2) = (4e6 * f, 2e6 * f);
        k[(d, d)] = k1 + k2;
        k[(d + 3, d + 3)] = k2;
        k[(d, d + 3)] = -k2;
        k[(d + 3, d)] = -k2;
    }
    let m = mass();
    Mat::from_fn(6, 6, |i, j| k[(i, j)] + S * omega * omega * m[(i, j)])
}

/// w_0 at rest (rad/s): the x chain's first mode, lambda^2 - 7e6 lambda + 4e12 = 0.
fn w00() -> f64 {
    ((7e6 - (49e12_f64 - 16e12).sqrt()) / 2.0).sqrt()
}

const X0: [f64; 3] = [0.3, 0.0, 0.1];

fn growth(omega: f64) -> [f64; 3] {
    [GROWTH * omega * omega, 0.0, 0.0]
}

fn write_model(dir: &Path) {
    let u = growth(REFERENCE);
    let reference = ReducedModel {
        k: stiffness(REFERENCE),
        m: mass(),
        contact_nodes: vec![ContactNode {
            mesh_node: None,
            dofs: [0, 1, 2],
            position: [X0[0] + u[0], X0[1], X0[2]],
            radial: [1.0, 0.0, 0.0],
            gap: GAP - u[0],
        }],
        rotor_axis: RotorAxis::new([0.0, 0.0, 0.0], [0.0, 0.0, 1.0]).unwrap(),
        master: MasterCoordinate {
            dof: 0,
            description: "x of the contact node".into(),
        },
        linear_frequencies_hz: nlmodes_modal::reduced_model::linear_frequencies_hz(
            &stiffness(REFERENCE),
            &mass(),
            6,
        )
        .unwrap(),
        recovery: None,
        mesh: None,
    };
    let contact = vec![ParametricContact {
        mesh_node: None,
        undeformed_position: X0,
        cold_gap: GAP,
        displacement_m: SPEEDS.iter().map(|&w| growth(w)).collect(),
    }];
    let k = SPEEDS.iter().map(|&w| stiffness(w)).collect();
    let model =
        ParametricModel::new(reference, REFERENCE, SPEEDS.to_vec(), k, contact, "linear").unwrap();
    model.write(dir, &RecoveryStorage::Float64).unwrap();
}

fn nlmodes(args: &[&str]) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_nlmodes"))
        .arg("--quiet")
        .args(args)
        .output()
        .expect("cannot start nlmodes")
}

fn settings(dir: &Path, name: &str, text: &str) -> PathBuf {
    let p = dir.join(name);
    std::fs::write(&p, text).unwrap();
    p
}

/// Exit status 2 with every `want` in the message.
fn refused(args: &[&str], want: &[&str]) {
    let out = nlmodes(args);
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{args:?}: {err}");
    for w in want {
        assert!(err.contains(w), "{args:?}: `{w}` not in: {err}");
    }
}

fn json(path: &Path) -> serde_json::Value {
    serde_json::from_str(&std::fs::read_to_string(path).unwrap()).unwrap()
}

struct Dirs {
    root: PathBuf,
    model: PathBuf,
}

impl Dirs {
    fn new() -> Self {
        let root = std::env::temp_dir().join(format!("nlmodes-speed-sweep-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&root);
        std::fs::create_dir_all(&root).unwrap();
        let model = root.join("parametric");
        write_model(&model);
        Self { root, model }
    }

    fn sweep(&self, name: &str, text: &str) -> (std::process::Output, PathBuf) {
        let s = settings(&self.root, &format!("{name}.toml"), text);
        let out = self.root.join(name);
        let output = nlmodes(&[
            "forced",
            self.model.to_str().unwrap(),
            "--speed-sweep",
            "--settings",
            s.to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
        ]);
        (output, out)
    }
}

#[test]
fn speed_sweeps_from_the_command() {
    let d = Dirs::new();
    bad_sweep_settings(&d);
    bad_case_tables(&d);
    linear_sweep(&d);
    contact_sweep(&d);
    casing_at_a_speed(&d);
    forced_at_a_speed(&d);
    let _ = std::fs::remove_dir_all(&d.root);
}

fn bad_sweep_settings(d: &Dirs) {
    let model = d.model.to_str().unwrap();
    let out = d.root.join("refused");
    let out = out.to_str().unwrap();
    for (name, text, want) in [
        (
            "eo0",
            "[speed_sweep]\nengine_orders = [0]\n",
            vec!["eo0.toml: speed_sweep.engine_orders = 0: expected integers 1 <= EO"],
        ),
        (
            "range",
            "[speed_sweep]\nspeed_range = [1000.0, 5000.0]\n",
            vec![
                "range.toml: speed_sweep.speed_range = [1000.0, 5000.0]: expected a range within",
                "parametric.json",
            ],
        ),
        (
            "nocross",
            "[speed_sweep]\nengine_orders = [2]\n",
            vec!["nocross.toml: speed_sweep.engine_orders = 2: expected an engine order whose line crosses mode 0"],
        ),
        (
            "lobes0",
            "[speed_sweep.casing]\nlobes = 0\namplitudes = [0.5, 0.2]\n",
            vec![
                "lobes0.toml: speed_sweep.casing.lobes = 0: expected an integer 1 <= n",
                "lobes0.toml: speed_sweep.casing.amplitudes = [0.5, 0.2]: expected [from, to]",
            ],
        ),
        (
            "casing_speed",
            "[speed_sweep.casing]\nspeed = 5000.0\n",
            vec!["casing_speed.toml: speed_sweep.casing.speed = 5000.0: expected a speed > 0 within"],
        ),
    ] {
        let s = settings(&d.root, &format!("{name}.toml"), text);
        let args = ["forced", model, "--speed-sweep", "--settings", s.to_str().unwrap(), "--out", out];
        refused(&args, &want);
        assert!(!Path::new(out).join("speed_sweep.csv").exists());
    }
    refused(
        &["forced", model, "--speed", "5000", "--out", out],
        &["--speed = 5000: expected a speed within the range of the parametric model"],
    );
}

/// A case is refused before its first stage (no mesh made).
fn bad_case_tables(d: &Dirs) {
    let geo = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("meshes/blade.geo");
    let head = format!(
        "name = \"c\"\nresults_dir = \"{}\"\n[mesh]\ngeo = \"{}\"\n",
        d.root.join("results").display(),
        geo.display()
    );
    let rotation = "[rotation]\ncampbell_range = [0.0, 10000.0]\n";
    for (name, text, want) in [
        (
            "case_eo",
            format!("{head}{rotation}[speed_sweep]\nengine_orders = [0, 3]\n"),
            "case_eo.toml: speed_sweep.engine_orders = 0: expected integers 1 <= EO",
        ),
        (
            "case_range",
            format!("{head}{rotation}[speed_sweep]\nspeed_range = [5000.0, 12000.0]\n"),
            "case_range.toml: speed_sweep.speed_range = [5000.0, 12000.0]: expected a range \
             within rotation.campbell_range = [0, 10000] rpm",
        ),
        (
            "case_alone",
            format!("{head}[speed_sweep]\nengine_orders = [3]\n"),
            "case_alone.toml: speed_sweep: needs a [rotation] table",
        ),
    ] {
        let s = settings(&d.root, &format!("{name}.toml"), &text);
        refused(&["run", s.to_str().unwrap()], &[want]);
    }
    assert!(!d.root.join("results/c/mesh").exists());
}

const LINEAR: &str = "[forced]\nlevels = [1.0]\nlevel_unit = \"N\"\ndamping_ratio = 0.01\n\
                      harmonics = 3\n[speed_sweep]\nengine_orders = [3]\nwindow = [0.95, 1.05]\n";

/// Without contact (1 N: about 0.06 of the gap at the peak): the crossing at the closed
/// form's to 1e-9 (bisection to 1e-12 on an exact model), the peak within the half-power
/// half-width zeta Omega_c e^2 / (e^2 - S) of it, no contact, every column in the CSV.
fn linear_sweep(d: &Dirs) {
    let (out, dir) = d.sweep("linear", LINEAR);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let j = json(&dir.join("speed_sweep.json"));
    let sweep = &j["sweeps"][0];
    let e = 3.0;
    let crossing = w00() / (e * e - S).sqrt() / RPM;
    let found = sweep["crossing_rpm"].as_f64().unwrap();
    let peak = sweep["peak_rpm"].as_f64().unwrap();
    let half = 0.01 * crossing * e * e / (e * e - S);
    println!(
        "crossing {found:.6} rpm (closed form {crossing:.6}), peak {peak:.4} ({:+.3} half-widths)",
        (peak - crossing) / half
    );
    assert!((found - crossing).abs() < 1e-9 * crossing);
    assert!((peak - crossing).abs() < half);
    assert_eq!(sweep["contact_rpm"].as_array().unwrap().len(), 0);
    assert_eq!(sweep["complete"], true);
    let csv = std::fs::read_to_string(dir.join("speed_sweep.csv")).unwrap();
    let header = csv.lines().next().unwrap();
    for col in [
        "speed_rpm",
        "excitation_hz",
        "detuning",
        "running_gap_m",
        "q1_over_g0",
        "max_contact_force_N",
        "stability",
        "fold",
    ] {
        assert!(header.contains(col), "{col} not in {header}");
    }
    assert!(dir.join("speed_sweep.png").is_file());
}

/// Into contact (3 x the grazing force at the crossing's speed, 1 % damping, the penalty law at
/// 10 x the static contact stiffness: at the default 1000 x the curve bends where the orbit
/// leaves contact on the lower branch more sharply than the secant continuation follows, a
/// limit docs/ROTATION.md states): the run-up touches over an interval starting below the
/// crossing, with a contact force; the hardening contact bends the response toward higher
/// speeds, where it folds back (a `turns_back` fold above the crossing); every point has a
/// verdict and some are unstable (between the folds).
fn contact_sweep(d: &Dirs) {
    let text = LINEAR
        .replace(
            "levels = [1.0]\nlevel_unit = \"N\"",
            "levels = [3.0]\nlevel_unit = \"grazing\"",
        )
        .replace("window = [0.95, 1.05]", "window = [0.9, 1.2]")
        .replace("harmonics = 3\n", "harmonics = 3\npenalty_factor = 10.0\n");
    let (out, dir) = d.sweep("contact", &text);
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success(),
        "{stdout}{}",
        String::from_utf8_lossy(&out.stderr)
    );
    println!("{stdout}");
    let sweep = &json(&dir.join("speed_sweep.json"))["sweeps"][0];
    let crossing = sweep["crossing_rpm"].as_f64().unwrap();
    let touches = sweep["contact_rpm"].as_array().unwrap();
    assert!(!touches.is_empty());
    let first = touches[0].as_array().unwrap()[0].as_f64().unwrap();
    assert!(
        first < crossing,
        "contact from {first} rpm, crossing {crossing}"
    );
    assert!(sweep["max_contact_force_n"].as_f64().unwrap() > 0.0);
    let folds = sweep["folds"].as_array().unwrap();
    assert!(
        folds
            .iter()
            .any(|f| f["kind"] == "turns_back" && f["speed_rpm"].as_f64().unwrap() > crossing),
        "{folds:?}"
    );
    let [stable, unstable, undetermined] =
        [0, 1, 2].map(|i| sweep["stability"][i].as_u64().unwrap());
    assert_eq!(
        stable + unstable + undetermined,
        sweep["points"].as_u64().unwrap()
    );
    assert!(unstable > 0);
    // N converged by retracing (the default): the first trace at [forced] harmonics = 3, each
    // trace's check at 2N recorded, the sweep's N that of its last trace and of every CSV row
    // but the raised points'.
    let retraces = sweep["retraces"].as_array().unwrap();
    assert_eq!(retraces[0]["harmonics"], 3);
    let n = sweep["harmonics"].as_u64().unwrap();
    assert_eq!(retraces.last().unwrap()["harmonics"].as_u64(), Some(n));
    assert!(sweep["harmonics_note"]
        .as_str()
        .unwrap()
        .starts_with(&format!("N = {n} ")));
    let csv = std::fs::read_to_string(dir.join("speed_sweep.csv")).unwrap();
    let col = csv
        .lines()
        .next()
        .unwrap()
        .split(',')
        .position(|h| h == "harmonics");
    // Points raised above the last trace's N (where its check still moved) carry theirs.
    let raised = sweep["raised"]["raised"].as_array().map_or(0, |r| r.len());
    let ns: Vec<u64> = (csv.lines().skip(1))
        .map(|l| l.split(',').nth(col.unwrap()).unwrap().parse().unwrap())
        .collect();
    assert!(
        ns.iter().all(|&h| h == n || (h > n && h % n == 0)),
        "{ns:?}"
    );
    assert_eq!(ns.iter().filter(|&&h| h != n).count(), raised, "{ns:?}");
}

/// `[speed_sweep.casing]` (issue 39, item 6) at 2000 rpm, a 2-lobed casing, no load (the
/// penalty law at 10 x the static contact stiffness, N = 6): the onset is the contact node's
/// running gap in closed form, 1 mm - c Omega^2, to 1e-9 (the spline of the parametric model
/// is exact here); below it the node never touches and stays at rest (its first harmonic 0),
/// above it it touches with a contact force; W is twice the speed; every point carries a
/// verdict and the grid's amplitudes are all there. (That the orbits are those of the moving
/// gap is `crates/forced/tests/distortion.rs`'s check against exact orbits.)
fn casing_at_a_speed(d: &Dirs) {
    let text = format!(
        "{}[speed_sweep.casing]\nlobes = 2\namplitudes = [0.0, 1.5]\npoints = 7\n\
         speed = 2000.0\n",
        LINEAR.replace("harmonics = 3\n", "harmonics = 6\npenalty_factor = 10.0\n")
    );
    let (out, dir) = d.sweep("casing", &text);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let c = json(&dir.join("casing.json"));
    let omega = 2000.0 * RPM;
    let gap = GAP - GROWTH * omega * omega;
    let onset = c["onset_m"].as_f64().unwrap();
    assert!((onset - gap).abs() < 1e-9 * gap, "{onset} vs {gap}");
    let w = c["lobe_passing_hz"].as_f64().unwrap();
    assert!((w - 2.0 * omega / std::f64::consts::TAU).abs() < 1e-12 * w);
    assert_eq!(c["complete"], true);
    let csv = std::fs::read_to_string(dir.join("casing.csv")).unwrap();
    let mut lines = csv.lines();
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    let col = |n: &str| header.iter().position(|h| *h == n).unwrap();
    let rows: Vec<Vec<String>> = lines
        .map(|l| l.split(',').map(String::from).collect())
        .collect();
    let num = |r: &Vec<String>, n: &str| r[col(n)].parse::<f64>().unwrap();
    // The 7 amplitudes of the grid (in mean running gaps, here the node's gap) and the onset,
    // among the points (a step halved adds points between them).
    let deltas: Vec<f64> = rows.iter().map(|r| num(r, "amplitude_m")).collect();
    for want in (0..7).map(|i| 0.25 * gap * i as f64).chain([gap]) {
        let found = deltas.iter().any(|d| (d - want).abs() <= 1e-12 * gap);
        assert!(found, "{want} not among {deltas:?}");
    }
    for r in &rows {
        let (delta, force) = (num(r, "amplitude_m"), num(r, "max_contact_force_N"));
        assert!(!r[col("stability")].is_empty());
        if delta < gap * (1.0 - 1e-9) {
            assert_eq!(num(r, "nodes_in_contact"), 0.0, "{r:?}");
            assert_eq!(num(r, "q1_m"), 0.0, "{r:?}");
        } else if delta >= 1.25 * gap {
            assert!(force > 0.0, "{r:?}");
        }
    }
    assert!(dir.join("casing.png").is_file());
}

/// `--speed`: the forced study at 2000 rpm on the model there, around mode 0 at the
/// closed-form frequency sqrt(w_00^2 + S Omega^2).
fn forced_at_a_speed(d: &Dirs) {
    let s = settings(
        &d.root,
        "at.toml",
        "[forced]\nlevels = [0.5]\nharmonics = 3\n",
    );
    let out = d.root.join("at");
    let o = nlmodes(&[
        "forced",
        d.model.to_str().unwrap(),
        "--speed",
        "2000",
        "--settings",
        s.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let omega = 2000.0 * RPM;
    let w = (w00() * w00() + S * omega * omega).sqrt();
    let frf = json(&out.join("frf.json"));
    let found = frf["omega_mode_rad_s"].as_f64().unwrap();
    assert!((found - w).abs() < 1e-9 * w, "{found} vs {w}");
}
