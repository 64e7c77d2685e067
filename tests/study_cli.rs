//! `nlmodes study` end to end (issue 40, item 2; docs/STUDIES.md): a study of four small runs on
//! the coarse blade (two damping ratios x two force levels) through Snakemake with `--cores 2`.
//!
//! * The shared stages ran once: one mesh, one reduction, one backbone job for the four runs,
//!   one forced job per run; each run's folder holds the shared mesh as a link to the one file.
//! * The gathered table is checked value by value against the same four runs made one by one
//!   with the plain `nlmodes run`, read from their own files by this test: the first linear
//!   frequency, the backbone's reach, each level's peak q1/g0 and its W/w1 and frequency, and
//!   the number of points of each forced curve (a discrete check: the continuation took the
//!   same steps). Tolerance 1e-7 relative: the same run is reproducible to a few 1e-9 only,
//!   since the reduced model is: gmsh's mesh depends on its argument list and environment
//!   (under Snakemake and under `nlmodes run` node coordinates can differ in their last digit)
//!   and the reduction on the thread count; `nlmodes reduce` of two such meshes of this blade
//!   with 1 and 2 threads gave first frequencies 6e-10 to 2.8e-9 apart, and the peaks moved by
//!   up to 8.5e-10. 1e-7 keeps a margin of 35 over that, and is 2e4 times below the smallest
//!   difference between two runs of the study (2.2e-3: the peaks of level 0.5 at the two
//!   damping ratios), so a run gathered from another run's results fails.
//! * A bad study (unknown key, empty list, wrong type, out-of-range value) is refused before
//!   anything runs, naming the file, the key and the value (exit 2).
//!
//! Needs `snakemake` (scripts/deps installs it). Cost: 23 s on 2 cores (60 s with the machine
//! loaded by other builds): the study, then the four single runs two at a time.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

mod common;

use common::{nlmodes, nlmodes_ok as ok};

/// The coarse blade (about 8k DOFs), a short backbone and a cheap forced study.
fn base_case(results: &Path) -> String {
    let geo = Path::new(env!("CARGO_MANIFEST_DIR")).join("meshes/blade.geo");
    format!(
        r#"results_dir = "{results}"
[mesh]
geo = "{geo}"
[mesh.parameters]
mesh_size = 0.012
[model]
fixed_interface_modes = 20
linear_modes = 6
full_check = "off"
[nnm]
harmonics = 6
samples = 64
keep = [3.0]
frames = 6
[continuation]
q_max = 8.0
[stability]
enabled = false
[forced]
harmonics = 6
range = [0.95, 1.15]
levels = [2.0]
penalty_factor = 10
stability = false
exact_curve = false
keep_peaks = false
"#,
        results = results.display(),
        geo = geo.display()
    )
}

/// A CSV file as rows of column -> text.
fn read_csv(path: &Path) -> Vec<BTreeMap<String, String>> {
    let text = std::fs::read_to_string(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    let mut lines = text.lines();
    let header: Vec<String> = lines
        .next()
        .unwrap()
        .split(',')
        .map(str::to_string)
        .collect();
    lines
        .map(|l| {
            header
                .iter()
                .cloned()
                .zip(l.split(',').map(str::to_string))
                .collect()
        })
        .collect()
}

fn num(row: &BTreeMap<String, String>, col: &str) -> f64 {
    row.get(col)
        .and_then(|v| v.parse().ok())
        .unwrap_or_else(|| panic!("no number in column {col}: {row:?}"))
}

/// What the test reads from one run's own files.
struct Single {
    f1_hz: f64,
    reach: [f64; 3],
    /// (level, peak q1/g0, W/w, frequency Hz, points of the curve).
    peaks: Vec<(f64, f64, f64, f64, usize)>,
}

fn read_single(dir: &Path) -> Single {
    let model: serde_json::Value =
        serde_json::from_slice(&std::fs::read(dir.join("model/model.json")).unwrap()).unwrap();
    let backbone = read_csv(&dir.join("backbone/backbone.csv"));
    let top = backbone
        .iter()
        .filter(|r| matches!(r["branch_kind"].as_str(), "linear" | "main"))
        .max_by(|a, b| num(a, "q_over_g0").total_cmp(&num(b, "q_over_g0")))
        .unwrap();
    let frf = read_csv(&dir.join("forced/frf.csv"));
    let mut levels: Vec<f64> = frf.iter().map(|r| num(r, "level")).collect();
    levels.dedup();
    let peaks = levels
        .iter()
        .map(|&l| {
            let rows: Vec<_> = frf.iter().filter(|r| num(r, "level") == l).collect();
            let p = rows
                .iter()
                .max_by(|a, b| num(a, "q1_over_g0").total_cmp(&num(b, "q1_over_g0")))
                .unwrap();
            let cols = ["q1_over_g0", "omega_ratio", "frequency_hz"].map(|c| num(p, c));
            (l, cols[0], cols[1], cols[2], rows.len())
        })
        .collect();
    Single {
        f1_hz: model["linear_frequencies_hz"][0].as_f64().unwrap(),
        reach: ["q_over_g0", "omega_ratio", "frequency_hz"].map(|c| num(top, c)),
        peaks,
    }
}

fn close(what: &str, study: f64, single: f64) {
    // The module doc: a run is reproducible to a few 1e-9 (mesh and reduction round-off).
    let tol = 1e-7;
    assert!(
        (study - single).abs() <= tol * single.abs().max(1e-300),
        "{what}: study {study} against the single run {single}"
    );
}

fn entries(dir: &Path) -> usize {
    std::fs::read_dir(dir).map_or(0, |d| d.count())
}

#[cfg(unix)]
fn same_file(a: &Path, b: &Path) -> bool {
    use std::os::unix::fs::MetadataExt;
    let (a, b) = (std::fs::metadata(a).unwrap(), std::fs::metadata(b).unwrap());
    (a.dev(), a.ino()) == (b.dev(), b.ino())
}

/// The shared stages ran once: one job each, one status each; one forced job per run; the
/// runs' meshes are links to the one file.
fn check_sharing(dir: &Path) {
    for (stage, jobs) in [("mesh", 1), ("reduce", 1), ("backbone", 1), ("forced", 4)] {
        assert_eq!(
            entries(&dir.join("stages").join(stage)),
            jobs,
            "{stage} jobs"
        );
        let prefix = format!("{stage}-");
        let statuses = std::fs::read_dir(dir.join("status"))
            .unwrap()
            .filter(|e| {
                e.as_ref()
                    .unwrap()
                    .file_name()
                    .to_string_lossy()
                    .starts_with(&prefix)
            })
            .count();
        assert_eq!(statuses, jobs, "{stage} jobs that ran");
    }
    #[cfg(unix)]
    assert!(same_file(
        &dir.join("runs/r001/mesh/mesh.msh"),
        &dir.join("runs/r004/mesh/mesh.msh")
    ));
    for f in [
        "report.md",
        "figures/peak_vs_forced.damping_ratio.png",
        "runs/r004/report.md",
    ] {
        assert!(dir.join(f).exists(), "{f} missing");
    }
}

/// The runs (damping ratio, level) made one by one with `nlmodes run`, two at a time: each
/// run's folder and what this test reads from it.
fn single_runs(tmp: &Path, results: &Path, runs: &[(f64, f64)]) -> Vec<(PathBuf, Single)> {
    let one = |k: usize, (z, l): (f64, f64)| {
        let name = format!("single{}", k + 1);
        let case = tmp.join(format!("{name}.toml"));
        let text = base_case(results).replace(
            "levels = [2.0]",
            &format!("levels = [{l:?}]\ndamping_ratio = {z:?}"),
        );
        std::fs::write(&case, format!("name = \"{name}\"\n{text}")).unwrap();
        ok(&["run", case.to_str().unwrap()]);
        let out = results.join(&name);
        (out.clone(), read_single(&out))
    };
    std::thread::scope(|s| {
        let handles: Vec<_> = (0..2)
            .map(|half| {
                s.spawn(move || {
                    (half..runs.len())
                        .step_by(2)
                        .map(|k| (k, one(k, runs[k])))
                        .collect::<Vec<_>>()
                })
            })
            .collect();
        let mut all: Vec<_> = handles
            .into_iter()
            .flat_map(|h| h.join().unwrap())
            .collect();
        all.sort_by_key(|(k, _)| *k);
        all.into_iter().map(|(_, r)| r).collect()
    })
}

/// One row of study.csv against the same run made alone.
fn check_row(row: &BTreeMap<String, String>, (z, l): (f64, f64), single: &Single, dir: &Path) {
    let run = &row["run"];
    assert_eq!(row["status"], "complete", "{run}");
    assert_eq!(
        (num(row, "forced.damping_ratio"), num(row, "forced.levels")),
        (z, l),
        "{run}"
    );
    close("f1_hz", num(row, "f1_hz"), single.f1_hz);
    for (i, c) in ["q_over_g0", "omega_ratio", "frequency_hz"]
        .iter()
        .enumerate()
    {
        let column = format!("backbone_reach_{c}");
        close(
            &format!("{run} {column}"),
            num(row, &column),
            single.reach[i],
        );
    }
    assert_eq!(single.peaks.len(), 1);
    let (level, q, w, f, points) = single.peaks[0];
    assert_eq!(level, l);
    for (what, value) in [("q1_over_g0", q), ("omega_ratio", w), ("frequency_hz", f)] {
        let column = format!("peak_{what}_level_{l}");
        close(&format!("{run} {column}"), num(row, &column), value);
    }
    let other = if l == 0.5 { 2.0 } else { 0.5 };
    assert!(
        row[&format!("peak_q1_over_g0_level_{other}")].is_empty(),
        "{run}: one level"
    );
    let in_study = read_csv(&dir.join("runs").join(run).join("forced/frf.csv"));
    assert_eq!(in_study.len(), points, "{run}: points of the curve");
}

#[test]
fn a_study_shares_its_stages_and_gathers_the_runs_made_one_by_one() {
    let tmp = tempfile::tempdir().unwrap();
    let results = tmp.path().join("results");
    std::fs::write(tmp.path().join("base.toml"), base_case(&results)).unwrap();
    let study = tmp.path().join("small.toml");
    std::fs::write(
        &study,
        "[study]\ncase = \"base.toml\"\n[study.parameters]\n\"forced.damping_ratio\" = [0.01, 0.03]\n\"forced.levels\" = [[0.5], [2.0]]\n",
    )
    .unwrap();
    ok(&["study", study.to_str().unwrap(), "--cores", "2"]);
    let dir = results.join("small");
    check_sharing(&dir);

    let table = read_csv(&dir.join("study.csv"));
    let expected = [(0.01, 0.5), (0.01, 2.0), (0.03, 0.5), (0.03, 2.0)];
    assert_eq!(table.len(), expected.len());
    let singles = single_runs(tmp.path(), &results, &expected);
    let study_mesh = std::fs::read(dir.join("runs/r001/mesh/mesh.msh")).unwrap();
    for ((row, &run), (out, single)) in table.iter().zip(&expected).zip(&singles) {
        check_row(row, run, single, &dir);
        let same_mesh = std::fs::read(out.join("mesh/mesh.msh")).unwrap() == study_mesh;
        let column = format!("peak_q1_over_g0_level_{}", run.1);
        eprintln!(
            "{}: peak q1/g0 {} (alone) against {} (study); same mesh bytes: {same_mesh}",
            row["run"], single.peaks[0].1, row[&column]
        );
    }
}

#[test]
fn a_bad_study_is_refused_before_anything_runs() {
    let tmp = tempfile::tempdir().unwrap();
    let results = tmp.path().join("results");
    std::fs::write(tmp.path().join("base.toml"), base_case(&results)).unwrap();
    let cases = [
        ("\"forced.dampng_ratio\" = [0.01]", "study.parameters.\"forced.dampng_ratio\"[0] = 0.01: unknown field `dampng_ratio`"),
        ("\"forced.levels\" = []", "study.parameters.\"forced.levels\" = \"[]\": expected a non-empty list of values"),
        ("\"model.gap\" = [2e-4, \"wide\"]", "study.parameters.\"model.gap\"[1] = \"wide\": invalid type: string \"wide\", expected f64"),
        ("\"forced.damping_ratio\" = [0.01, -0.2]", "forced.damping_ratio = -0.2: expected"),
    ];
    for (line, want) in cases {
        let study = tmp.path().join("bad.toml");
        std::fs::write(
            &study,
            format!("[study]\ncase = \"base.toml\"\n[study.parameters]\n{line}\n"),
        )
        .unwrap();
        let out = nlmodes(&["study", study.to_str().unwrap(), "--cores", "2"]);
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{line}: {err}");
        assert!(
            err.contains("bad.toml") && err.contains(want),
            "{line}: expected `{want}` in:\n{err}"
        );
        assert!(!results.exists(), "{line}: nothing may be written");
    }
    // A study named as a case's results folder would mix its files into the case's.
    std::fs::create_dir_all(results.join("clash/.stamps")).unwrap();
    let study = tmp.path().join("clash.toml");
    let text = "[study]\ncase = \"base.toml\"\n[study.parameters]\n\"model.gap\" = [2e-4]\n";
    std::fs::write(&study, text).unwrap();
    let out = nlmodes(&["study", study.to_str().unwrap()]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{err}");
    assert!(
        err.contains("study.name = \"clash\"") && err.contains("holds the results of a case"),
        "{err}"
    );
    assert_eq!(
        std::fs::read_dir(results.join("clash")).unwrap().count(),
        1,
        "nothing written"
    );
}
