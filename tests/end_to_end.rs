//! The blade study end to end (issue 5) on a coarse mesh: `nlmodes run` from the .geo to the
//! figures, then checks of the physics (backbone flat below grazing, stiffening after it, contact
//! growing with amplitude), of the VTU files by an independent reader (meshio), of the make-like
//! reruns, and of the errors on bad input.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

fn nlmodes(args: &[&str], env: &[(&str, &str)]) -> Output {
    let mut cmd = Command::new(env!("CARGO_BIN_EXE_nlmodes"));
    cmd.args(args).env("RUST_LOG", "info");
    for (k, v) in env {
        cmd.env(k, v);
    }
    cmd.output().expect("cannot start nlmodes")
}

fn text(o: &Output) -> String {
    format!(
        "{}{}",
        String::from_utf8_lossy(&o.stdout),
        String::from_utf8_lossy(&o.stderr)
    )
}

/// A coarse version of cases/blade.toml (about 8k DOFs) writing into `dir`.
fn coarse_case(dir: &Path, extra: &str) -> PathBuf {
    let geo = root().join("meshes/blade.geo");
    let case = format!(
        r#"name = "coarse"
results_dir = "{results}"
[mesh]
geo = "{geo}"
order = 2
[mesh.parameters]
mesh_size = 0.012
[model]
fixed_interface_modes = 20
linear_modes = 6
[nnm]
harmonics = 10
samples = 128
keep = [3.0, 12.0]
frames = 6
[continuation]
q_start = 0.5
q_max = 14.0
{extra}
[forced]
# The forced stage has its own end-to-end test (tests/forced_cli.rs).
enabled = false
"#,
        results = dir.join("results").display(),
        geo = geo.display(),
    );
    let path = dir.join("coarse.toml");
    std::fs::write(&path, case).unwrap();
    path
}

struct Row {
    q: f64,
    ratio: f64,
    touching: usize,
    share: f64,
    fold: bool,
    jump: bool,
    /// On the main branch (or its linear part), not on a tongue.
    main: bool,
}

fn read_backbone(path: &Path) -> Vec<Row> {
    let text = std::fs::read_to_string(path).unwrap();
    let mut lines = text.lines();
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    let col = |name: &str| header.iter().position(|h| *h == name).unwrap();
    let (iq, ir, it, is, ifo, ij) = (
        col("q_over_g0"),
        col("omega_ratio"),
        col("nodes_in_contact"),
        col("max_contact_fraction"),
        col("fold"),
        col("jump"),
    );
    let kind = col("branch_kind");
    lines
        .map(|l| {
            let f: Vec<&str> = l.split(',').collect();
            Row {
                q: f[iq].parse().unwrap(),
                ratio: f[ir].parse().unwrap(),
                touching: f[it].parse().unwrap(),
                share: f[is].parse().unwrap(),
                fold: f[ifo] == "1",
                jump: f[ij] == "1",
                main: matches!(f[kind], "main" | "linear"),
            }
        })
        .collect()
}

fn grazing(dir: &Path) -> f64 {
    let v: serde_json::Value =
        serde_json::from_slice(&std::fs::read(dir.join("backbone/backbone.json")).unwrap())
            .unwrap();
    v["grazing_amplitude"].as_f64().unwrap() / v["gap_reference"].as_f64().unwrap()
}

#[test]
fn coarse_blade_study_end_to_end() {
    let tmp = tempfile::tempdir().unwrap();
    let case = coarse_case(tmp.path(), "");
    let out = nlmodes(&["run", case.to_str().unwrap()], &[]);
    assert!(out.status.success(), "nlmodes run failed:\n{}", text(&out));
    let res = tmp.path().join("results/coarse");

    // Physics of the backbone (Fig. 3a), on the stretch before the first fold or jump.
    let rows = read_backbone(&res.join("backbone/backbone.csv"));
    let qg = grazing(&res);
    assert!(
        qg > 0.5 && qg < 14.0,
        "grazing amplitude {qg} outside the range"
    );
    let below: Vec<&Row> = rows.iter().filter(|r| r.q < qg * (1.0 - 1e-6)).collect();
    assert!(below.len() >= 2, "too few points below grazing");
    // Below grazing the orbit is the linear mode: w = w1 up to the accuracy with which a
    // frequency of this reduced model can be computed at all. A backward-stable symmetric
    // eigensolver gets lambda to eps lambda_max, so w1 / w1 is known to (1/2) eps lambda_max /
    // lambda_1 (about 7e-9 here: the constraint modes make lambda_max / lambda_1 ~ 6e7); the
    // solver's w and the reference w1 each carry that error, hence eps lambda_max / lambda_1.
    // (The 1e-10 of issue 4 holds on well-conditioned systems: crates/nnm/tests/nnm_oracles.rs.)
    let model = nlmodes_modal::ReducedModel::read(&res.join("model")).unwrap();
    let (values, _) =
        nlmodes_modal::dense_generalized_eigen(model.k.as_ref(), model.m.as_ref()).unwrap();
    let tol = f64::EPSILON * values[values.len() - 1] / values[0];
    assert!(
        tol < 1e-7,
        "reduced model unexpectedly ill-conditioned: tol {tol:e}"
    );
    for r in &below {
        assert!(
            (r.ratio - 1.0).abs() < tol,
            "q/g0 = {}: w/w1 = {} below grazing (tolerance {tol:e})",
            r.q,
            r.ratio
        );
        assert_eq!(r.touching, 0);
    }
    // The main branch only: a tongue's rows follow the point it was detected at.
    let first_stretch: Vec<&Row> = rows
        .iter()
        .filter(|r| r.main)
        .take_while(|r| !r.fold && !r.jump)
        .filter(|r| r.q > qg * 1.05)
        .collect();
    assert!(
        first_stretch.len() >= 3,
        "too few points after grazing before a fold or jump"
    );
    for w in first_stretch.windows(2) {
        assert!(w[1].q > w[0].q, "q not increasing on the first stretch");
        // Stiffening: the frequency grows with amplitude after contact (1e-9 allows the solver
        // tolerance on nearly flat stretches right after grazing).
        assert!(
            w[1].ratio >= w[0].ratio - 1e-9,
            "w/w1 decreases: {} -> {}",
            w[0].ratio,
            w[1].ratio
        );
        assert!(w[1].ratio > 1.0);
    }
    // Contact grows with amplitude: more nodes and a longer contact at the end of the stretch.
    let (a, b) = (first_stretch[0], first_stretch[first_stretch.len() - 1]);
    assert!(
        b.touching >= a.touching && b.touching >= 1,
        "{} -> {}",
        a.touching,
        b.touching
    );
    assert!(
        b.share > a.share,
        "contact share {} -> {}",
        a.share,
        b.share
    );
    assert!(b.ratio > a.ratio);

    // Outputs of every stage.
    for f in [
        "report.md",
        "backbone.png",
        "backbone.svg",
        "manifold.csv",
        "manifold_displacement.png",
        "modes/frequencies.csv",
        "modes/modes.vtu",
        "model/K.mtx",
        "model/model.json",
    ] {
        assert!(res.join(f).is_file(), "missing {f}");
    }
    // The report states how Algorithm 1 converged: the count of points above epsilon (1e-4, the
    // default) is the backbone's.
    let report = std::fs::read_to_string(res.join("report.md")).unwrap();
    let csv = std::fs::read_to_string(res.join("backbone/backbone.csv")).unwrap();
    let header: Vec<&str> = csv.lines().next().unwrap().split(',').collect();
    let ig = header.iter().position(|h| *h == "powell_measure").unwrap();
    let above = csv
        .lines()
        .skip(1)
        .filter(|l| l.split(',').nth(ig).unwrap().parse::<f64>().unwrap() > 1e-4)
        .count();
    let stated = if above == 0 {
        "Every point reached it.".to_string()
    } else {
        format!(
            "{above} of {} points stalled above it",
            csv.lines().count() - 1
        )
    };
    assert!(
        report.contains("is at most epsilon = 1e-4.") && report.contains(&stated),
        "report.md does not say `{stated}`"
    );
    let kept = res.join("amplitude_q12.0");
    for f in [
        "radial_q12.0.csv",
        "radial_q12.0.png",
        "contact_map_q12.0.png",
        "mode_q12.0.xdmf",
        "mode_q12.0.h5",
    ] {
        assert!(kept.join(f).is_file(), "missing {f}");
    }
    // Fig. 4 from the exact orbit of the massless contact boundary next to the kept point: the
    // rigid stop holds every contact node at or below g0 (to round-off), and some node sits on
    // it; the exact backbone beside the harmonic balance's.
    assert!(res.join("backbone/backbone_boundary.csv").is_file());
    // Its pieces stay on the traced mode: inside a piece (its two ends are where it turns into a
    // tongue) the starting mode's fundamental holds more of the energy than any other component,
    // and no piece is listed twice.
    let exact_json: serde_json::Value = serde_json::from_slice(
        &std::fs::read(res.join("backbone/backbone_boundary.json")).unwrap(),
    )
    .unwrap();
    let mut spans = Vec::new();
    for piece in exact_json["pieces"].as_array().expect("pieces") {
        let pts = piece["points"].as_array().expect("points");
        let share = |p: &serde_json::Value, k: &str| p[k].as_f64().unwrap();
        for p in &pts[1..pts.len() - 1] {
            assert!(
                share(p, "primary_share") >= share(p, "secondary_share"),
                "an exact orbit inside a piece is off the traced mode: {p}"
            );
        }
        let q: Vec<f64> = pts.iter().map(|p| p["q"].as_f64().unwrap().abs()).collect();
        let span = (
            q.iter().copied().fold(f64::INFINITY, f64::min),
            q.iter().copied().fold(0.0, f64::max),
        );
        assert!(!spans.contains(&span), "piece listed twice: {span:?}");
        spans.push(span);
    }
    let exact = std::fs::read_to_string(kept.join("radial_boundary_q12.0.csv"))
        .expect("radial_boundary_q12.0.csv");
    let highest = exact
        .lines()
        .skip(1)
        .flat_map(|l| l.split(',').skip(1).map(|v| v.parse::<f64>().unwrap()))
        .fold(f64::NEG_INFINITY, f64::max);
    assert!(
        (highest - 1.0).abs() < 1e-9,
        "the exact orbit's contact nodes reach {highest} g0, not the stop at 1"
    );
    assert!(report.contains("radial_boundary_q12.0.png"));
    // Converged orbits (docs/STABILITY.md Sec. 9.4): every main-branch point in contact has
    // one or is named in the report; each converged one was checked at the next N (two levels
    // or more: N, 2N and, by default, 4N; or one where 2N adds no mode, its change then 0) and
    // its last change is within the tolerances.
    let bj: serde_json::Value =
        serde_json::from_slice(&std::fs::read(res.join("backbone/backbone.json")).unwrap())
            .unwrap();
    let mut with_orbit = 0;
    for p in bj["points"].as_array().unwrap() {
        let Some(c) = p.get("converged") else {
            continue;
        };
        with_orbit += 1;
        if c["stop"] == "converged" {
            let levels = c["levels"].as_array().unwrap();
            let dw = c["omega_change"].as_f64().unwrap();
            let ds = c["share_change"].as_f64().unwrap();
            assert!(dw <= 1e-3 && ds <= 0.02, "{c}");
            assert!(levels.len() >= 2 || (dw == 0.0 && ds == 0.0), "{c}");
        }
    }
    assert!(with_orbit > 0, "no converged orbit computed");
    assert!(
        report.contains("Converged orbits"),
        "report: no converged-orbit paragraph"
    );
    // The ParaView files through an independent reader (meshio): cell type, VTK edge-node order,
    // fields (the XDMF series: every frame).
    for args in [
        vec![
            "--series".to_string(),
            kept.join("mode_q12.0.xdmf").display().to_string(),
        ],
        vec![
            res.join("modes/modes.vtu").display().to_string(),
            "mode_01".to_string(),
        ],
    ] {
        let py = Command::new("/usr/bin/python3")
            .arg(root().join("scripts/check_vtu.py"))
            .args(&args)
            .output()
            .expect("/usr/bin/python3 with python3-meshio is needed (scripts/deps installs it)");
        assert!(py.status.success(), "meshio check failed: {}", text(&py));
    }
    // No temporary file left behind.
    let leftovers: Vec<_> = walk(&res)
        .into_iter()
        .filter(|p| {
            p.file_name()
                .is_some_and(|n| n.to_string_lossy().contains(".tmp"))
        })
        .collect();
    assert!(leftovers.is_empty(), "temporary files left: {leftovers:?}");

    // Make-like rerun: nothing to do, then only the nonlinear stages after changing q_max.
    let model_time = std::fs::metadata(res.join("model/K.mtx"))
        .unwrap()
        .modified()
        .unwrap();
    let out = nlmodes(&["run", case.to_str().unwrap()], &[]);
    assert!(out.status.success(), "{}", text(&out));
    for stage in ["mesh", "modes", "reduce", "backbone"] {
        assert!(
            text(&out).contains(&format!("stage {stage}: up to date")),
            "{}",
            text(&out)
        );
    }
    let case2 = coarse_case(tmp.path(), "max_points = 999");
    let out = nlmodes(&["run", case2.to_str().unwrap()], &[]);
    assert!(out.status.success(), "{}", text(&out));
    assert!(
        text(&out).contains("stage reduce: up to date"),
        "{}",
        text(&out)
    );
    assert!(
        text(&out).contains("stage backbone: started"),
        "{}",
        text(&out)
    );
    assert_eq!(
        std::fs::metadata(res.join("model/K.mtx"))
            .unwrap()
            .modified()
            .unwrap(),
        model_time
    );
    // `--only backbone --force` reruns the backbone only: the stages it needs are up to date.
    let out = nlmodes(
        &[
            "run",
            case2.to_str().unwrap(),
            "--only",
            "backbone",
            "--force",
        ],
        &[],
    );
    assert!(out.status.success(), "{}", text(&out));
    for stage in ["mesh", "reduce"] {
        assert!(
            text(&out).contains(&format!("stage {stage}: up to date")),
            "--force reran {stage}: {}",
            text(&out)
        );
    }
    assert!(
        text(&out).contains("stage backbone: started"),
        "{}",
        text(&out)
    );
    assert!(!text(&out).contains("stage post"), "{}", text(&out));

    // A run killed while writing leaves no half-written file; the next run completes.
    interrupted_run_leaves_no_half_written_file(&case2, &res);
}

/// Every final (non-temporary) file under `dir` is complete: JSON parses, CSV has a header and
/// a row, VTU and PVD end with their closing tag, PNG ends with the IEND chunk.
fn assert_complete_outputs(dir: &Path) {
    for p in walk(dir) {
        let name = p.file_name().unwrap().to_string_lossy().into_owned();
        if name.contains(".tmp-") {
            continue;
        }
        let bytes = std::fs::read(&p).unwrap();
        let tail = String::from_utf8_lossy(&bytes[bytes.len().saturating_sub(64)..]).into_owned();
        let ok = match p.extension().and_then(|e| e.to_str()) {
            Some("json") => serde_json::from_slice::<serde_json::Value>(&bytes).is_ok(),
            Some("csv") => String::from_utf8_lossy(&bytes).lines().count() >= 2,
            Some("vtu") | Some("pvd") => tail.trim_end().ends_with("</VTKFile>"),
            Some("png") => bytes.len() > 12 && &bytes[bytes.len() - 8..bytes.len() - 4] == b"IEND",
            _ => true,
        };
        assert!(ok, "{} is incomplete", p.display());
    }
}

/// Kills `nlmodes run --only post --force` while it is writing (a temporary file exists), then
/// checks that no final file is half-written and that the next run cleans up and completes.
fn interrupted_run_leaves_no_half_written_file(case: &Path, res: &Path) {
    let has_temporary = |dir: &Path| {
        walk(dir)
            .iter()
            .any(|p| p.file_name().unwrap().to_string_lossy().contains(".tmp-"))
    };
    let mut caught = false;
    for _attempt in 0..10 {
        let mut child = Command::new(env!("CARGO_BIN_EXE_nlmodes"))
            .args([
                "run",
                case.to_str().unwrap(),
                "--only",
                "post",
                "--force",
                "--quiet",
            ])
            .stdout(std::process::Stdio::null())
            .stderr(std::process::Stdio::null())
            .spawn()
            .unwrap();
        loop {
            if has_temporary(res) {
                child.kill().unwrap();
                child.wait().unwrap();
                caught = true;
                break;
            }
            if child.try_wait().unwrap().is_some() {
                break;
            }
            std::thread::sleep(std::time::Duration::from_micros(200));
        }
        if caught {
            break;
        }
    }
    assert!(
        caught,
        "never caught the post stage while it was writing a file"
    );
    assert_complete_outputs(res);
    let out = nlmodes(&["run", case.to_str().unwrap()], &[]);
    assert!(out.status.success(), "{}", text(&out));
    assert!(!has_temporary(res), "temporary files survived the rerun");
    assert_complete_outputs(res);
}

fn walk(dir: &Path) -> Vec<PathBuf> {
    let mut out = Vec::new();
    if let Ok(rd) = std::fs::read_dir(dir) {
        for e in rd.flatten() {
            let p = e.path();
            if p.is_dir() {
                out.extend(walk(&p));
            } else {
                out.push(p);
            }
        }
    }
    out
}

#[test]
fn bad_inputs_give_clear_errors() {
    let tmp = tempfile::tempdir().unwrap();
    // gmsh missing
    let case = coarse_case(tmp.path(), "");
    let out = nlmodes(
        &["run", case.to_str().unwrap(), "--only", "mesh"],
        &[("NLMODES_GMSH", "/nonexistent/gmsh")],
    );
    assert!(!out.status.success());
    assert!(text(&out).contains("gmsh not found"), "{}", text(&out));
    // a parameter the .geo does not define
    let geo = root().join("meshes/blade.geo");
    let out = nlmodes(
        &[
            "mesh",
            geo.to_str().unwrap(),
            "-o",
            tmp.path().join("x.msh").to_str().unwrap(),
            "--set",
            "wingspan=3",
        ],
        &[],
    );
    assert!(!out.status.success());
    assert!(
        text(&out).contains("`wingspan` is not defined"),
        "{}",
        text(&out)
    );
    // an unknown key in the case file
    let bad = tmp.path().join("bad.toml");
    std::fs::write(&bad, "[nnm]\nharmonix = 3\n").unwrap();
    let out = nlmodes(&["run", bad.to_str().unwrap()], &[]);
    assert!(!out.status.success());
    assert!(text(&out).contains("harmonix"), "{}", text(&out));
    // a missing group, and an amplitude range below grazing only (reuses the coarse mesh)
    let nogroup = coarse_case(tmp.path(), "");
    let s = std::fs::read_to_string(&nogroup)
        .unwrap()
        .replace("[model]\n", "[model]\ncontact_group = \"tip_rim\"\n");
    std::fs::write(&nogroup, s).unwrap();
    let out = nlmodes(&["run", nogroup.to_str().unwrap()], &[]);
    assert!(!out.status.success());
    assert!(
        text(&out).contains("tip_rim") && text(&out).contains("tip_edge"),
        "{}",
        text(&out)
    );
    let low = coarse_case(tmp.path(), "").to_str().unwrap().to_string();
    let s = std::fs::read_to_string(&low)
        .unwrap()
        .replace("q_max = 14.0", "q_max = 1.0")
        .replace("keep = [3.0, 12.0]", "keep = [0.8]");
    std::fs::write(&low, s).unwrap();
    let out = nlmodes(&["run", &low], &[]);
    assert!(!out.status.success());
    assert!(text(&out).contains("stays below grazing"), "{}", text(&out));
}
