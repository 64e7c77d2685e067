//! `nlmodes forced` end to end on the coarse blade (issue 22): the command a user runs, its
//! files, and two physical checks that do not depend on the solver's own numbers:
//!
//! * below grazing (level 0.5 x grazing) the curve is linear and its peak is the resonant
//!   amplitude the level was defined from, 0.5 q_graze, within 1 % (the single-mode estimate
//!   |phi_m| |phi . f| / (2 zeta w^2) leaves out the other modes' quasi-static share, measured
//!   1e-3, and the continuation samples the peak);
//! * past grazing (level 3) the contact clips the response: the peak lies between grazing and
//!   the linear peak 3 q_graze, with contact forces, and the curve folds (hardening).
//!
//! Cost: mesh + reduction 2 s, the forced run about 12 s (N = 8, two levels, stability).

use std::path::PathBuf;
use std::process::Command;

mod common;

use common::{nlmodes, nlmodes_ok as ok};

/// Column `name` of frf.csv for the rows of `level`.
fn column(csv: &str, level: f64, name: &str) -> Vec<String> {
    let mut lines = csv.lines();
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    let at = header
        .iter()
        .position(|h| *h == name)
        .unwrap_or_else(|| panic!("no column {name}"));
    lines
        .map(|l| l.split(',').map(str::to_string).collect::<Vec<_>>())
        .filter(|r| r[0].parse::<f64>().unwrap() == level)
        .map(|r| r[at].clone())
        .collect()
}

fn numbers(v: &[String]) -> Vec<f64> {
    v.iter().map(|s| s.parse().unwrap()).collect()
}

#[test]
fn forced_command_writes_a_curve_that_is_linear_below_grazing_and_clipped_above() {
    let dir = tempfile::tempdir().unwrap();
    let model = common::coarse_blade_model(dir.path());
    let settings = dir.path().join("forced.toml");
    std::fs::write(
        &settings,
        "[forced]\nharmonics = 8\nrange = [0.95, 1.15]\nlevels = [0.5, 3.0]\npenalty_factor = 10\n",
    )
    .unwrap();
    let out = dir.path().join("frf");
    ok(&[
        "forced",
        model.to_str().unwrap(),
        "--settings",
        settings.to_str().unwrap(),
        "-o",
        out.to_str().unwrap(),
    ]);
    for f in [
        "frf.csv",
        "frf.json",
        "frf.svg",
        "frf.png",
        "frf_max.svg",
        "frf_max.png",
    ] {
        assert!(out.join(f).exists(), "{f} missing");
    }
    let json: serde_json::Value =
        serde_json::from_slice(&std::fs::read(out.join("frf.json")).unwrap()).unwrap();
    let q_graze =
        json["grazing_amplitude_m"].as_f64().unwrap() / json["gap_reference_m"].as_f64().unwrap();
    let csv = std::fs::read_to_string(out.join("frf.csv")).unwrap();

    let low = numbers(&column(&csv, 0.5, "q1_over_g0"));
    let low_peak = low.iter().copied().fold(0.0, f64::max);
    let force = numbers(&column(&csv, 0.5, "max_contact_force_N"));
    assert!(force.iter().all(|&f| f == 0.0), "contact below grazing");
    assert!(
        (low_peak / (0.5 * q_graze) - 1.0).abs() < 1e-2,
        "linear peak {low_peak} vs {}",
        0.5 * q_graze
    );

    let high = numbers(&column(&csv, 3.0, "q1_over_g0"));
    let high_peak = high.iter().copied().fold(0.0, f64::max);
    assert!(
        high_peak > q_graze && high_peak < 3.0 * q_graze,
        "peak {high_peak}, grazing {q_graze}"
    );
    let force = numbers(&column(&csv, 3.0, "max_contact_force_N"));
    assert!(force.iter().any(|&f| f > 0.0), "no contact at 3 x grazing");
    let folds = column(&csv, 3.0, "fold");
    assert!(
        folds.iter().any(|f| f == "TurnsBack"),
        "no fold at the peak"
    );
    for word in column(&csv, 3.0, "stability") {
        assert!(
            ["stable", "unstable", "undetermined"].contains(&word.as_str()),
            "{word}"
        );
    }
    assert_eq!(json["curves"][1]["termination"], "complete");
    peak_orbits_for_paraview(&out, &csv, &json);
}

/// The peak orbit of each level as a ParaView series (`keep_peaks`, default on): read back by
/// meshio (another reader), 24 frames at t = f T / 24 with T = 2 pi / W of the curve's peak row
/// of frf.csv; the contact forces on the mesh are those of the orbit: none below grazing, some
/// at 3 x grazing, never above the curve's largest force.
fn peak_orbits_for_paraview(out: &std::path::Path, csv: &str, json: &serde_json::Value) {
    for (level, contact) in [(0.5, false), (3.0, true)] {
        let xdmf = out.join(format!("orbits/level_{level}_peak.xdmf"));
        let py = Command::new("/usr/bin/python3")
            .arg(PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("scripts/check_vtu.py"))
            .arg("--series")
            .arg(&xdmf)
            .output()
            .expect("/usr/bin/python3 with meshio and h5py (scripts/deps installs them)");
        assert!(
            py.status.success(),
            "{}",
            String::from_utf8_lossy(&py.stderr)
        );
        let s: serde_json::Value = serde_json::from_slice(&py.stdout).unwrap();
        let q1 = numbers(&column(csv, level, "q1_over_g0"));
        let w = numbers(&column(csv, level, "omega_rad_s"));
        let peak = (0..q1.len())
            .max_by(|&a, &b| q1[a].total_cmp(&q1[b]))
            .unwrap();
        let period = 2.0 * std::f64::consts::PI / w[peak];
        let times: Vec<f64> = numbers(
            &s["times"]
                .as_array()
                .unwrap()
                .iter()
                .map(|v| v.to_string())
                .collect::<Vec<_>>(),
        );
        assert_eq!(times.len(), 24);
        for (f, t) in times.iter().enumerate() {
            assert!(
                (t - f as f64 / 24.0 * period).abs() <= 1e-12 * period,
                "frame {f}: {t}"
            );
        }
        let force_max = s["force_max"].as_f64().unwrap();
        let curve_max = numbers(&column(csv, level, "max_contact_force_N"))[peak];
        assert_eq!(force_max > 0.0, contact, "level {level}: {force_max} N");
        assert!(
            force_max <= curve_max * (1.0 + 1e-6),
            "{force_max} vs {curve_max}"
        );
        assert!(s["gap_min"].as_f64().unwrap() < 0.0, "{s}");
    }
    assert!(json["curves"].as_array().unwrap().len() == 2);
}

/// Issue 24: progress and log lines written to a pipe or a file carry no ANSI colour codes.
#[test]
fn logs_redirected_to_a_file_carry_no_colour_codes() {
    let dir = tempfile::tempdir().unwrap();
    let geo = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("tests/data/beam.geo");
    let out = Command::new(env!("CARGO_BIN_EXE_nlmodes"))
        .args(["mesh", geo.to_str().unwrap(), "-o"])
        .arg(dir.path().join("beam.msh"))
        .env_remove("NO_COLOR")
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let log = String::from_utf8_lossy(&out.stderr);
    assert!(log.contains("stage mesh"), "no log line: {log}");
    assert!(
        !log.contains('\u{1b}'),
        "colour codes in a redirected log: {log:?}"
    );
}

/// The `forced` stage of `nlmodes run`: after the backbone, before the report (which shows it);
/// up to date on a rerun; a change of `[forced]` reruns it and nothing upstream.
#[test]
fn forced_stage_of_a_case_reruns_only_when_its_inputs_change() {
    let dir = tempfile::tempdir().unwrap();
    let geo = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("meshes/blade.geo");
    let case = |levels: &str| {
        format!(
            "name = \"coarse\"\nresults_dir = \"{}\"\n[mesh]\ngeo = \"{}\"\n[mesh.parameters]\n\
             mesh_size = 0.012\n[model]\nfixed_interface_modes = 20\nlinear_modes = 6\n\
             full_check = \"off\"\n[nnm]\nkeep = [3.0]\nframes = 4\n[continuation]\nq_max = 8.0\n\
             [forced]\nenabled = true\nharmonics = 8\nrange = [0.95, 1.15]\nlevels = {levels}\n\
             penalty_factor = 10\nstability = false\n",
            dir.path().join("results").display(),
            geo.display()
        )
    };
    let path = dir.path().join("coarse.toml");
    std::fs::write(&path, case("[0.5]")).unwrap();
    let run = || {
        let out = Command::new(env!("CARGO_BIN_EXE_nlmodes"))
            .args(["run", path.to_str().unwrap()])
            .output()
            .unwrap();
        let log = format!(
            "{}{}",
            String::from_utf8_lossy(&out.stdout),
            String::from_utf8_lossy(&out.stderr)
        );
        assert!(out.status.success(), "{log}");
        log
    };
    let first = run();
    assert!(first.contains("stage forced: started"), "{first}");
    let res = dir.path().join("results/coarse");
    let report = std::fs::read_to_string(res.join("report.md")).unwrap();
    assert!(
        report.contains("## Forced response") && report.contains("forced/frf.png"),
        "no forced section"
    );
    assert!(res.join("forced/frf.csv").exists() && res.join("forced/frf.png").exists());
    let again = run();
    assert!(again.contains("stage forced: up to date"), "{again}");
    std::fs::write(&path, case("[0.5, 0.8]")).unwrap();
    let changed = run();
    assert!(changed.contains("stage forced: started"), "{changed}");
    assert!(changed.contains("stage backbone: up to date"), "{changed}");
}

/// `[forced] damping_matrix = true` reads C.mtx of the reduced-model directory: a C.mtx equal
/// to alpha M + beta K gives the curve of `rayleigh = [alpha, beta]` (to the printed digits of
/// the CSV's first harmonic, 1e-9 relative: the same C up to the file's round trip); a C.mtx of
/// the wrong size is refused naming the file.
#[test]
fn a_damping_matrix_file_gives_the_curve_of_the_same_rayleigh_damping() {
    let dir = tempfile::tempdir().unwrap();
    let model = common::coarse_blade_model(dir.path());
    let reduced = nlmodes_modal::ReducedModel::read(&model).unwrap();
    let (alpha, beta) = (2.0, 4e-6);
    let n = reduced.m.nrows();
    let c = faer::Mat::from_fn(n, n, |i, j| {
        alpha * reduced.m[(i, j)] + beta * reduced.k[(i, j)]
    });
    nlmodes_modal::matrix_market::write_symmetric_dense(&model.join("C.mtx"), c.as_ref(), "C")
        .unwrap();
    let common = "harmonics = 4\nrange = [0.97, 1.03]\nlevels = [0.5]\nstability = false\n";
    let run = |damping: &str, tag: &str| {
        let settings = dir.path().join(format!("{tag}.toml"));
        std::fs::write(&settings, format!("[forced]\n{common}{damping}")).unwrap();
        let out = dir.path().join(tag);
        ok(&[
            "forced",
            model.to_str().unwrap(),
            "--settings",
            settings.to_str().unwrap(),
            "-o",
            out.to_str().unwrap(),
        ]);
        numbers(&column(
            &std::fs::read_to_string(out.join("frf.csv")).unwrap(),
            0.5,
            "q1_over_g0",
        ))
    };
    let from_file = run("damping_matrix = true\n", "file");
    let rayleigh = run(&format!("rayleigh = [{alpha}, {beta}]\n"), "rayleigh");
    assert_eq!(from_file.len(), rayleigh.len());
    for (a, b) in from_file.iter().zip(&rayleigh) {
        assert!((a - b).abs() <= 1e-9 * b.abs(), "{a} vs {b}");
    }
    // A C.mtx of another order.
    let small = faer::Mat::<f64>::identity(3, 3);
    nlmodes_modal::matrix_market::write_symmetric_dense(&model.join("C.mtx"), small.as_ref(), "C")
        .unwrap();
    let settings = dir.path().join("bad.toml");
    std::fs::write(
        &settings,
        format!("[forced]\n{common}damping_matrix = true\n"),
    )
    .unwrap();
    let out = nlmodes(&[
        "forced",
        model.to_str().unwrap(),
        "--settings",
        settings.to_str().unwrap(),
        "-o",
        dir.path().join("bad").to_str().unwrap(),
    ]);
    assert_eq!(
        out.status.code(),
        Some(2),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("damping") && err.contains('3'), "{err}");
}

/// `load = "file"`: F.mtx of the model directory. One column holding the master's unit force is
/// the `load = "master"` curve exactly; a (cosine, sine) pair (0, e_master) is the same force a
/// quarter period later, so the amplitudes are equal (to 1e-9) and the response phase at the
/// first point (linear regime) is shifted by pi / 2; an F.mtx of the wrong order is refused
/// (exit 2) naming the file and the model's order.
#[test]
fn a_load_file_gives_the_master_load_and_its_quarter_period_shift() {
    let dir = tempfile::tempdir().unwrap();
    let model = common::coarse_blade_model(dir.path());
    let reduced = nlmodes_modal::ReducedModel::read(&model).unwrap();
    let (n, master) = (reduced.m.nrows(), reduced.master.dof);
    let write_f = |cols: usize, value_at: &dyn Fn(usize, usize) -> f64, rows: usize| {
        let mut s =
            format!("%%MatrixMarket matrix array real general\n% test load\n{rows} {cols}\n");
        for j in 0..cols {
            for i in 0..rows {
                s += &format!("{:e}\n", value_at(i, j));
            }
        }
        std::fs::write(model.join("F.mtx"), s).unwrap();
    };
    let common = "harmonics = 4\nrange = [0.97, 1.03]\nlevels = [0.5]\nstability = false\n";
    let run = |load: &str, tag: &str| -> std::process::Output {
        let settings = dir.path().join(format!("{tag}.toml"));
        std::fs::write(&settings, format!("[forced]\n{common}{load}")).unwrap();
        nlmodes(&[
            "forced",
            model.to_str().unwrap(),
            "--settings",
            settings.to_str().unwrap(),
            "-o",
            dir.path().join(tag).to_str().unwrap(),
        ])
    };
    let csv = |tag: &str| std::fs::read_to_string(dir.path().join(tag).join("frf.csv")).unwrap();
    assert!(run("load = \"master\"\n", "master").status.success());
    write_f(1, &|i, _| f64::from(u8::from(i == master)), n);
    assert!(run("load = \"file\"\n", "file").status.success());
    assert_eq!(
        csv("file"),
        csv("master"),
        "F.mtx with the master's unit force"
    );
    write_f(2, &|i, j| f64::from(u8::from(i == master && j == 1)), n);
    assert!(run("load = \"file\"\n", "sine").status.success());
    let amp = |tag: &str| numbers(&column(&csv(tag), 0.5, "q1_over_g0"));
    let (a, b) = (amp("master"), amp("sine"));
    assert_eq!(a.len(), b.len());
    for (x, y) in a.iter().zip(&b) {
        assert!((x - y).abs() <= 1e-9 * x.abs(), "{x} vs {y}");
    }
    let phase = |tag: &str| numbers(&column(&csv(tag), 0.5, "master_phase_h1_rad"))[0];
    let shift = (phase("sine") - phase("master")).rem_euclid(2.0 * std::f64::consts::PI);
    assert!(
        (shift - std::f64::consts::FRAC_PI_2).abs() < 1e-9,
        "phase shift {shift}"
    );
    write_f(1, &|_, _| 1.0, n + 1);
    let out = run("load = \"file\"\n", "bad");
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{err}");
    assert!(
        err.contains("F.mtx") && err.contains(&format!("order n = {n}")),
        "{err}"
    );
}

/// `[forced] load = "group"` (issue 22, item 3): 1 N along a direction shared by the nodes of the
/// tip face, a group whose nodes are mostly interior to the Craig-Bampton partition. The reduce
/// stage adds the load's static correction to the basis and writes T^T f as F.mtx. Checked
/// against the full FE model assembled here (independently of the stage), with q from
/// K_r q = F.mtx:
/// * at the contact nodes (boundary coordinates, physical DOFs) the static displacement is the
///   full model's K^-1 f to 1e-8: Craig-Bampton condenses the boundary statically exactly,
///   with or without the correction;
/// * over the whole blade, recovered by the model's stored basis (24-bit fixed point, 6e-8 of
///   each column's largest entry, which bounds this comparison), within 1e-6 with the
///   correction's coordinate and off by more than 1e-4 without it (the check can fail): the
///   interior static response is what the correction makes exact (3.9e-14 in the unstored
///   algebra, `crates/modal/tests/craig_bampton.rs`);
/// * a group the mesh does not have is refused before the reduction, naming it.
#[test]
fn a_group_load_is_exact_in_the_static_limit() {
    let dir = tempfile::tempdir().unwrap();
    let geo = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("meshes/blade.geo");
    let case = |group: &str| {
        format!(
            "name = \"grp\"\nresults_dir = \"{}\"\n[mesh]\ngeo = \"{}\"\n[mesh.parameters]\n\
             mesh_size = 0.012\n[model]\nfixed_interface_modes = 20\nlinear_modes = 6\n\
             full_check = \"off\"\n[forced]\nload = \"group\"\nload_group = \"{group}\"\n\
             load_direction = [0.0, 2.0, 0.0]\n",
            dir.path().join("results").display(),
            geo.display()
        )
    };
    let path = dir.path().join("grp.toml");
    std::fs::write(&path, case("tip")).unwrap();
    ok(&["run", path.to_str().unwrap(), "--only", "reduce"]);
    let res = dir.path().join("results/grp");
    let model = nlmodes_modal::ReducedModel::read(&res.join("model")).unwrap();
    let fr =
        nlmodes_modal::matrix_market_general::read_dense_general(&res.join("model/F.mtx")).unwrap();
    let nr = model.k.nrows();
    assert_eq!((fr.nrows(), fr.ncols()), (nr, 1));
    assert_eq!(
        nr,
        3 * model.contact_nodes.len() + 20 + 1,
        "one correction coordinate"
    );
    // The full model and its static response to the same load.
    let mesh = std::sync::Arc::new(nlmodes_fem::read_msh(&res.join("mesh/mesh.msh")).unwrap());
    let fe = common::fe_system(mesh.clone(), &common::titanium(), &["root"]);
    let group = mesh.group("tip").unwrap();
    let free: Vec<usize> = group
        .nodes
        .iter()
        .copied()
        .filter(|&n| (0..3).all(|c| fe.dofs.free_index(3 * n + c).is_some()))
        .collect();
    let mut f = vec![0.0; fe.k.rows()];
    for &n in &free {
        f[fe.dofs.free_index(3 * n + 1).unwrap()] = 1.0 / free.len() as f64;
    }
    let ([c_with, e_with], [c_without, e_without]) =
        common::reduced_static_errors(&model, &fr, &fe, &f);
    println!(
        "static displacement: contact nodes {c_with:.1e} with the correction, {c_without:.1e} \
         without; whole blade {e_with:.1e} with, {e_without:.1e} without"
    );
    assert!(
        c_with < 1e-8 && c_without < 1e-8,
        "{c_with:e} {c_without:e}"
    );
    assert!(e_with < 1e-6, "{e_with:e}");
    assert!(e_without > 1e-4, "{e_without:e}");
    // A group the mesh does not have.
    std::fs::write(&path, case("no_such_group")).unwrap();
    let out = nlmodes(&["run", path.to_str().unwrap(), "--only", "reduce"]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{err}");
    assert!(
        err.contains("forced.load_group = \"no_such_group\""),
        "{err}"
    );
}
