//! The files a user keeps (issue 15), on the coarse blade: the XDMF/HDF5 series and modes.vtu read
//! back by independent readers (meshio always; ParaView's pvpython where ParaView is installed), the
//! report's mode-shape pictures, and `nlmodes backbone --settings` honouring the file's q range.
//!
//! One `nlmodes run` of a coarse case serves every test of this file (run once, shared).

use std::path::{Path, PathBuf};
use std::process::{Command, Output};
use std::sync::OnceLock;

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

fn text(o: &Output) -> String {
    format!(
        "{}{}",
        String::from_utf8_lossy(&o.stdout),
        String::from_utf8_lossy(&o.stderr)
    )
}

/// Contact nodes on the blade's tip edge (meshes/blade.geo, n_contact).
const CONTACT_NODES: usize = 24;
/// Frames per period of the coarse case.
const FRAMES: usize = 6;
/// Algorithm 1's tolerance on Powell's measure, units of g0 (cases' default epsilon).
const EPSILON: f64 = 1e-3;

/// The coarse blade (about 8k DOFs) run once: its results folder.
fn results() -> &'static Path {
    static RUN: OnceLock<(tempfile::TempDir, PathBuf)> = OnceLock::new();
    let (_, res) = RUN.get_or_init(|| {
        let tmp = tempfile::tempdir().unwrap();
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
linear_modes = 4
[nnm]
harmonics = 10
samples = 128
keep = [12.0]
frames = {FRAMES}
[continuation]
q_start = 0.5
q_max = 12.5
"#,
            results = tmp.path().join("results").display(),
            geo = root().join("meshes/blade.geo").display(),
        );
        let path = tmp.path().join("coarse.toml");
        std::fs::write(&path, case).unwrap();
        let out = Command::new(env!("CARGO_BIN_EXE_nlmodes"))
            .args(["run", path.to_str().unwrap()])
            .output()
            .unwrap();
        assert!(out.status.success(), "nlmodes run failed:\n{}", text(&out));
        let res = tmp.path().join("results/coarse");
        (tmp, res)
    });
    res
}

/// The kept orbit of the coarse case, as kept.json holds it.
fn kept_orbit(res: &Path) -> serde_json::Value {
    let kept: serde_json::Value =
        serde_json::from_slice(&std::fs::read(res.join("backbone/kept.json")).unwrap()).unwrap();
    kept[0].clone()
}

fn f64s(v: &serde_json::Value) -> Vec<f64> {
    v.as_array()
        .unwrap()
        .iter()
        .map(|x| x.as_f64().unwrap())
        .collect()
}

/// Full nodal displacement (3 per node, m) of the kept orbit at t = 0 computed here from the
/// reduced model: u(0) = sum_n u_n (cosine series at t = 0), recovered and expanded.
fn displacement_at_zero(res: &Path, orbit: &serde_json::Value) -> Vec<f64> {
    let model = nlmodes_modal::ReducedModel::read(&res.join("model")).unwrap();
    let coefficients: Vec<Vec<f64>> = orbit["coefficients"]
        .as_array()
        .unwrap()
        .iter()
        .map(f64s)
        .collect();
    let n = coefficients[0].len();
    let u: Vec<f64> = (0..n)
        .map(|i| coefficients.iter().map(|c| c[i]).sum())
        .collect();
    let r = model.recovery.as_ref().unwrap();
    let free: Vec<f64> = (0..r.nrows())
        .map(|i| (0..n).map(|j| r[(i, j)] * u[j]).sum())
        .collect();
    model.mesh.as_ref().unwrap().expand_to_full(&free).unwrap()
}

/// The reduce stage stores the recovery basis compactly (`model/recovery.q24`: 24-bit fixed
/// point per column, mid-edge rows predicted, `nlmodes_modal` recovery_codec). Its rounding, at most s_j / 2 on column j
/// (s_j = max |R_j| / (2^23 - 1), read from the file's column table), moves the displacement of
/// the kept orbit at t = 0 by at most sum_j |q_j| s_j / 2 (a worst case: the roundings add up
/// with no cancellation). This bound must stay below 1e-5 of the largest |u|: 100 times below
/// what a picture or a colour map resolves (a pixel of a 1000 px view, one of 256 colour levels,
/// 1e-3 .. 4e-3 of the range). Measured: 1.6e-6 on this coarse blade.
#[test]
fn compact_recovery_rounding_is_below_the_output_precision() {
    let res = results();
    let model_dir = res.join("model");
    assert!(!model_dir.join("recovery.f64").exists());
    let json: serde_json::Value =
        serde_json::from_slice(&std::fs::read(model_dir.join("model.json")).unwrap()).unwrap();
    assert_eq!(json["recovery"]["file"], "recovery.q24");
    let bytes = std::fs::read(model_dir.join("recovery.q24")).unwrap();
    assert_eq!(&bytes[..8], b"NLMRCV02");
    let word = |i: usize| <[u8; 8]>::try_from(&bytes[i..i + 8]).unwrap();
    // Header: magic, rows, columns, predicted rows, prediction table length; then per column
    // (scale, stream length).
    let (rows, cols) = (
        u64::from_le_bytes(word(8)) as usize,
        u64::from_le_bytes(word(16)) as usize,
    );
    let predicted = u64::from_le_bytes(word(24)) as usize;
    // TET10: every free mid-edge DOF is predicted from its edge's vertices (most of the rows).
    assert!(
        predicted > rows / 2 && predicted < rows,
        "{predicted} of {rows} rows predicted"
    );
    let scales: Vec<f64> = (0..cols)
        .map(|j| f64::from_le_bytes(word(40 + 16 * j)))
        .collect();
    assert!(
        scales.iter().all(|s| s.is_finite() && *s > 0.0),
        "{scales:?}"
    );
    let orbit = kept_orbit(res);
    let coefficients: Vec<Vec<f64>> = orbit["coefficients"]
        .as_array()
        .unwrap()
        .iter()
        .map(f64s)
        .collect();
    let q: Vec<f64> = (0..cols)
        .map(|j| coefficients.iter().map(|c| c[j]).sum())
        .collect();
    let bound: f64 = q.iter().zip(&scales).map(|(q, s)| q.abs() * s / 2.0).sum();
    let u0 = max_norm(&displacement_at_zero(res, &orbit));
    assert!(
        bound <= 1e-5 * u0,
        "rounding bound {bound:e} m against max |u| {u0:e} m"
    );
    // The reduced model reads back with the basis decoded (every entry finite, checked on read).
    let model = nlmodes_modal::ReducedModel::read(&model_dir).unwrap();
    assert_eq!(model.recovery.as_ref().unwrap().ncols(), cols);
}

fn max_norm(u: &[f64]) -> f64 {
    u.chunks_exact(3)
        .map(|d| (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt())
        .fold(0.0, f64::max)
}

/// The XDMF series of the kept amplitude (coarse case).
fn series(res: &Path) -> PathBuf {
    res.join("amplitude_q12.0/mode_q12.0.xdmf")
}

#[test]
fn xdmf_series_and_modes_read_back_with_meshio() {
    let res = results();
    let mesh = nlmodes_fem::read_msh(&res.join("mesh/mesh.msh")).unwrap();
    let orbit = kept_orbit(res);
    let omega = orbit["omega"].as_f64().unwrap();
    let period = 2.0 * std::f64::consts::PI / omega;
    let xdmf = series(res);
    let py = Command::new("/usr/bin/python3")
        .arg(root().join("scripts/check_vtu.py"))
        .arg("--series")
        .arg(&xdmf)
        .output()
        .expect(
            "/usr/bin/python3 with python3-meshio and python3-h5py is needed (scripts/deps \
             installs them)",
        );
    assert!(py.status.success(), "meshio check failed: {}", text(&py));
    let s: serde_json::Value = serde_json::from_slice(&py.stdout).unwrap();
    // Same mesh in every frame: the FE mesh's nodes and TET10 cells.
    assert_eq!(s["points"].as_u64().unwrap() as usize, mesh.n_nodes());
    assert_eq!(s["cells"].as_u64().unwrap() as usize, mesh.n_elements());
    assert_eq!(s["cell_type"], "tetra10");
    assert_eq!(s["contact_nodes"].as_u64().unwrap() as usize, CONTACT_NODES);
    // Times in seconds: t_f = f T / frames (written at round-trip precision).
    let times = f64s(&s["times"]);
    assert_eq!(times.len(), FRAMES);
    for (f, t) in times.iter().enumerate() {
        let expected = f as f64 / FRAMES as f64 * period;
        assert!(
            (t - expected).abs() <= 1e-12 * period,
            "frame {f}: time {t} s, expected {expected} s"
        );
    }
    let note = std::fs::read_to_string(&xdmf).unwrap();
    assert!(
        note.contains("time values in seconds") && note.contains(&format!("{period:.9e} s")),
        "the XDMF must state the unit and the period:\n{note}"
    );
    // One mesh, and the frames at t and T - t (the orbit is even in time) share their
    // displacement: FRAMES / 2 + 1 arrays for FRAMES frames.
    let stored = |field: &str| {
        let mut d: Vec<&str> = note
            .match_indices(&format!("/fields/{field}/"))
            .map(|(i, _)| &note[i..i + field.len() + 12])
            .collect();
        d.sort();
        d.dedup();
        d.len()
    };
    assert_eq!(stored("displacement_m"), FRAMES / 2 + 1, "{note}");
    assert_eq!(stored("contact_node"), 1);
    assert_eq!(note.matches(".h5:/mesh/points<").count(), FRAMES);
    // The displacement of frame FRAMES - 1 is that of frame 1, as the maximum shows.
    let maxima = f64s(&s["max_displacement"]);
    assert_eq!(maxima[1], maxima[FRAMES - 1]);
    // Displacement of frame 0 against the model's own reconstruction; the file holds Float32
    // (relative rounding 6e-8 per value), so 1e-6 relative on the largest magnitude.
    let u0 = max_norm(&displacement_at_zero(res, &orbit));
    let in_file = f64s(&s["max_displacement"])[0];
    assert!(
        (in_file - u0).abs() <= 1e-6 * u0,
        "largest |u| at t = 0: {in_file} m in the file, {u0} m from the model"
    );
    // Contact fields: at q/g0 = 12 some node touches (force > 0, gap closed to Algorithm 1's
    // tolerance epsilon g0, plus Float32 rounding) and some is open (gap < 0).
    let g0 = 2.0e-4;
    let force_max = s["force_max"].as_f64().unwrap();
    let samples: Vec<f64> = orbit["contact_force"]
        .as_array()
        .unwrap()
        .iter()
        .flat_map(f64s)
        .collect();
    let sample_max = samples.iter().copied().fold(0.0, f64::max);
    assert!(force_max > 0.0 && force_max <= sample_max * (1.0 + 1e-6));
    assert!(
        s["gap_max"].as_f64().unwrap() <= EPSILON * g0 + 1e-6 * g0,
        "{s}"
    );
    assert!(s["gap_min"].as_f64().unwrap() < 0.0, "{s}");

    // modes.vtu: every mode by name.
    let py = Command::new("/usr/bin/python3")
        .arg(root().join("scripts/check_vtu.py"))
        .arg(res.join("modes/modes.vtu"))
        .args(["mode_01", "mode_02", "mode_03", "mode_04"])
        .output()
        .unwrap();
    assert!(py.status.success(), "meshio check failed: {}", text(&py));
}

/// Every `.xdmf` file under `dir`, sorted.
fn xdmf_files(dir: &Path) -> Vec<PathBuf> {
    let mut out = Vec::new();
    for entry in std::fs::read_dir(dir).unwrap() {
        let path = entry.unwrap().path();
        if path.is_dir() {
            out.extend(xdmf_files(&path));
        } else if path.extension().is_some_and(|e| e == "xdmf") {
            out.push(path);
        }
    }
    out.sort();
    out
}

/// Every series, with every XDMF reader ParaView offers for it (XdmfReader, Xdmf3ReaderS,
/// Xdmf3ReaderT in ParaView 5.11), read at every time step as the GUI reads it
/// (tests/paraview_readers.py): all points and cells, every field as stored in the HDF5 file,
/// where ParaView is installed (`scripts/test` installs it); elsewhere the test says so and
/// passes.
#[test]
fn every_paraview_reader_reads_every_series() {
    let Ok(pv) = which("pvpython") else {
        eprintln!("pvpython not found: ParaView check skipped (apt-get install paraview python3-paraview)");
        return;
    };
    let res = results();
    let files = xdmf_files(res);
    assert!(files.contains(&series(res)), "{files:?}");
    let out = Command::new(pv)
        .arg(root().join("tests/paraview_readers.py"))
        .args(&files)
        .env_remove("DISPLAY")
        .output()
        .unwrap();
    assert!(out.status.success(), "pvpython failed: {}", text(&out));
    let stdout = String::from_utf8_lossy(&out.stdout);
    let line = stdout
        .lines()
        .find_map(|l| l.strip_prefix("RESULT "))
        .unwrap_or_else(|| panic!("no result from pvpython: {}", text(&out)));
    let v: serde_json::Value = serde_json::from_str(line).unwrap();
    let mesh = nlmodes_fem::read_msh(&res.join("mesh/mesh.msh")).unwrap();
    for file in &files {
        let entry = &v[file.to_str().unwrap()];
        let mut readers: Vec<&str> = entry["readers"]
            .as_array()
            .unwrap()
            .iter()
            .map(|r| r.as_str().unwrap())
            .collect();
        readers.sort_unstable();
        assert_eq!(
            readers,
            ["Xdmf3ReaderS", "Xdmf3ReaderT", "XdmfReader"],
            "{file:?}"
        );
        let xml_times = f64s(&entry["xml_times"]);
        for reader in readers {
            let read = &entry["read"][reader];
            let what = format!("{reader} on {}", file.display());
            // Every frame's time (frames at t and T - t are distinct times).
            let mut want = xml_times.clone();
            want.sort_by(f64::total_cmp);
            assert_eq!(f64s(&read["times"]), want, "{what}");
            for (f, fr) in read["frames"].as_array().unwrap().iter().enumerate() {
                let at = format!("{what}, frame {f}");
                assert_eq!(fr["points"].as_u64(), Some(mesh.n_nodes() as u64), "{at}");
                assert_eq!(fr["cells"].as_u64(), Some(mesh.n_elements() as u64), "{at}");
                // VTK_QUADRATIC_TETRA, in the node order stored.
                assert_eq!(fr["cell_type"], 24, "{at}");
                assert_eq!(fr["first_cell_as_stored"], true, "{at}");
                assert_eq!(fr["points_as_stored"], true, "{at}");
                let fields = [
                    "contact_force_n",
                    "contact_node",
                    "displacement_m",
                    "radial_gap_m",
                ];
                assert_eq!(fr["fields"], serde_json::json!(fields), "{at}");
                assert_eq!(fr["fields_as_stored"], serde_json::json!(fields), "{at}");
                assert_eq!(fr["contact"].as_u64(), Some(CONTACT_NODES as u64), "{at}");
                assert_eq!(fr["nan_off_contact"], true, "{at}");
                assert_eq!(fr["finite_on_contact"], true, "{at}");
            }
        }
    }
    // The kept orbit's series: FRAMES frames over one period, frame 0 the orbit at t = 0.
    let entry = &v[series(res).to_str().unwrap()];
    let omega = kept_orbit(res)["omega"].as_f64().unwrap();
    let period = 2.0 * std::f64::consts::PI / omega;
    let times = f64s(&entry["xml_times"]);
    assert_eq!(times.len(), FRAMES);
    assert!((times[FRAMES / 2] - 0.5 * period).abs() <= 1e-12 * period);
    let u0 = max_norm(&displacement_at_zero(res, &kept_orbit(res)));
    for reader in ["Xdmf3ReaderS", "Xdmf3ReaderT", "XdmfReader"] {
        let m = entry["read"][reader]["frames"][0]["max_u"]
            .as_f64()
            .unwrap();
        assert!((m - u0).abs() <= 1e-6 * u0, "{reader}: {m} vs {u0}");
    }
}

fn which(name: &str) -> Result<PathBuf, ()> {
    std::env::var_os("PATH")
        .and_then(|p| {
            std::env::split_paths(&p)
                .map(|d| d.join(name))
                .find(|c| c.is_file())
        })
        .ok_or(())
}

/// The report shows the mode shapes (Fig. 5) and the linear modes: the pictures exist, are
/// linked from report.md and show a colour-mapped blade. Share of coloured pixels: the blade
/// panels take 10-30 % of these pictures (measured on the default and coarse blades: 15-25 %);
/// the colour bar alone is about 1 %, a picture without the blade would be under 3 %.
#[test]
fn report_pictures_show_the_blade() {
    let res = results();
    let report = std::fs::read_to_string(res.join("report.md")).unwrap();
    for name in ["figures/shape_q12.0.png", "figures/linear_modes.png"] {
        assert!(
            report.contains(&format!("]({name})")),
            "report.md does not show {name}"
        );
        let (w, h, share) = nlmodes_output::plot::png_color_share(&res.join(name)).unwrap();
        assert!(w >= 800 && h >= 600, "{name}: {w} x {h} px");
        assert!(
            (0.05..=0.6).contains(&share),
            "{name}: coloured pixel share {share:.3}"
        );
    }
}

/// Every picture report.md shows exists, Fig. 3a and its diagnostics among them.
#[test]
fn report_pictures_exist() {
    let res = results();
    let report = std::fs::read_to_string(res.join("report.md")).unwrap();
    let pictures: Vec<&str> = report
        .split("](")
        .skip(1)
        .filter_map(|rest| rest.split(')').next())
        .filter(|link| link.ends_with(".png"))
        .collect();
    for want in [
        "backbone.png",
        "backbone_diagnostics.png",
        "frequency_energy.png",
    ] {
        assert!(pictures.contains(&want), "report.md does not show {want}");
    }
    for p in pictures {
        assert!(
            res.join(p).is_file(),
            "report.md shows {p}, which is missing"
        );
    }
}

/// `nlmodes backbone --settings FILE` uses the file's q_start / q_max unless a flag is given.
#[test]
fn backbone_settings_file_sets_the_amplitude_range() {
    let res = results();
    let dir = tempfile::tempdir().unwrap();
    let settings = dir.path().join("settings.toml");
    std::fs::write(&settings, "[continuation]\nq_start = 0.5\nq_max = 7.0\n").unwrap();
    let largest_q = |extra: &[&str], out: &Path| -> f64 {
        let o = Command::new(env!("CARGO_BIN_EXE_nlmodes"))
            .args(["--quiet", "backbone"])
            .arg(res.join("model"))
            .arg("--settings")
            .arg(&settings)
            .args(extra)
            .arg("-o")
            .arg(out)
            .output()
            .unwrap();
        assert!(o.status.success(), "{}", text(&o));
        let v: serde_json::Value =
            serde_json::from_slice(&std::fs::read(out.join("backbone.json")).unwrap()).unwrap();
        let g0 = v["gap_reference"].as_f64().unwrap();
        v["points"]
            .as_array()
            .unwrap()
            .iter()
            .map(|p| p["q"].as_f64().unwrap() / g0)
            .fold(0.0, f64::max)
    };
    let from_file = largest_q(&[], &dir.path().join("a"));
    // The continuation stops at q_max or one step (max_step = 1 gap) before it; grazing is at
    // q/g0 = 6 on this blade, so q_max = 7 from the file and 9 from the flag.
    assert!(
        (6.0..=7.0 + 1e-9).contains(&from_file),
        "q_max = 7 from the file, largest q/g0 {from_file}"
    );
    let from_flag = largest_q(&["--q-max", "9"], &dir.path().join("b"));
    assert!(
        (8.0..=9.0 + 1e-9).contains(&from_flag),
        "--q-max 9 on the command line, largest q/g0 {from_flag}"
    );
}
