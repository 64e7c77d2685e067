//! The bad-input corpus of issues 14 and 37: `tests/bad_inputs/make_corpus.py` writes damaged
//! meshes, case and settings files, reduced models, forced-study settings and inputs (C.mtx,
//! F.mtx, `--backbone`, the orbit mesh), `[rotation]` tables, command lines and output paths (at
//! least 240) from one coarse blade mesh and its reduced model, built once here; every case must
//! exit with its expected code (2 bad input, 3 stopped early; README "Exit codes") and a message
//! matching its pattern, and leave behind no file it must not (no `.tmp`, no `frf.csv` of a
//! refused forced study) and keep the files it must.
//!
//! Cost: the coarse mesh and reduction take about 2 s; each case fails in milliseconds (the
//! `reduce` cases after a coarse assembly, the forced inputs after reading the coarse model, the
//! one stopped-early backbone after 2 points); about 40 s in all on 2 busy cores.

use std::path::{Path, PathBuf};
use std::process::Command;

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

/// Runs nlmodes quietly; panics with its output when it fails.
fn nlmodes_ok(args: &[&str]) {
    let out = Command::new(env!("CARGO_BIN_EXE_nlmodes"))
        .arg("--quiet")
        .args(args)
        .output()
        .expect("cannot start nlmodes");
    assert!(
        out.status.success(),
        "nlmodes {args:?} failed:\n{}{}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
}

/// The good inputs every damaged one is made from: the coarse blade (as in the end-to-end test)
/// and its Craig-Bampton model with 20 fixed-interface modes.
fn good_inputs(dir: &Path) -> (PathBuf, PathBuf) {
    let mesh = dir.join("coarse.msh");
    let model = dir.join("model");
    let geo = root().join("meshes/blade.geo");
    nlmodes_ok(&[
        "mesh",
        geo.to_str().unwrap(),
        "-o",
        mesh.to_str().unwrap(),
        "--set",
        "mesh_size=0.012",
    ]);
    nlmodes_ok(&[
        "reduce",
        mesh.to_str().unwrap(),
        "--modes",
        "20",
        "--compare",
        "0",
        "-o",
        model.to_str().unwrap(),
    ]);
    (mesh, model)
}

#[derive(serde::Deserialize)]
struct Case {
    name: String,
    cls: String,
    args: Vec<String>,
    code: i32,
    pattern: String,
    absent: Vec<String>,
    present: Vec<String>,
}

/// Paths matching a glob whose only wildcard is a trailing `*` in the file name (or none).
fn existing(pattern: &str) -> Vec<PathBuf> {
    let p = Path::new(pattern);
    let name = p.file_name().map(|n| n.to_string_lossy().into_owned());
    match name {
        Some(n) if n.contains('*') => {
            let prefix = n.trim_end_matches('*');
            let dir = p.parent().unwrap_or(Path::new("."));
            std::fs::read_dir(dir)
                .map(|entries| {
                    entries
                        .filter_map(|e| e.ok())
                        .filter(|e| e.file_name().to_string_lossy().starts_with(prefix))
                        .map(|e| e.path())
                        .collect()
                })
                .unwrap_or_default()
        }
        _ if p.exists() => vec![p.to_path_buf()],
        _ => Vec::new(),
    }
}

/// What is wrong with one case's run, if anything.
fn run_case(case: &Case) -> Option<String> {
    let out = Command::new(env!("CARGO_BIN_EXE_nlmodes"))
        .args(&case.args)
        .env_remove("RUST_LOG")
        .output()
        .expect("cannot start nlmodes");
    let text = format!(
        "{}{}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
    let mut wrong = Vec::new();
    if out.status.code() != Some(case.code) {
        wrong.push(format!(
            "exit {:?}, expected {}",
            out.status.code(),
            case.code
        ));
    }
    let re = regex::Regex::new(&case.pattern).expect("the corpus patterns are valid");
    if !re.is_match(&text) {
        wrong.push(format!("message does not match /{}/", case.pattern));
    }
    for a in &case.absent {
        for p in existing(a) {
            wrong.push(format!("{} must not exist", p.display()));
        }
    }
    for p in &case.present {
        if !Path::new(p).exists() {
            wrong.push(format!("{p} must exist (partial results kept)"));
        }
    }
    (!wrong.is_empty()).then(|| {
        format!(
            "{} [{}] nlmodes {}: {}\n{}",
            case.name,
            case.cls,
            case.args.join(" "),
            wrong.join("; "),
            text.trim_end()
        )
    })
}

#[test]
fn every_bad_input_is_refused_with_its_code_and_message() {
    let tmp = tempfile::tempdir().unwrap();
    let (mesh, model) = good_inputs(tmp.path());
    let corpus = tmp.path().join("corpus");
    let script = root().join("tests/bad_inputs/make_corpus.py");
    let made = Command::new("python3")
        .arg(&script)
        .arg("--out")
        .arg(&corpus)
        .arg("--mesh")
        .arg(&mesh)
        .arg("--model")
        .arg(&model)
        .arg("--geo")
        .arg(root().join("meshes/blade.geo"))
        .output()
        .expect("python3 runs the corpus generator");
    assert!(
        made.status.success(),
        "{} failed:\n{}",
        script.display(),
        String::from_utf8_lossy(&made.stderr)
    );
    eprintln!("{}", String::from_utf8_lossy(&made.stdout));
    let manifest = std::fs::read(corpus.join("manifest.json")).unwrap();
    let cases: Vec<Case> = serde_json::from_slice(&manifest).unwrap();
    assert!(cases.len() >= 240, "only {} cases", cases.len());
    for class in [
        "case file",
        "settings file",
        "CLI argument",
        "output path",
        "mesh",
        "reduced model",
        "forced settings",
        "forced inputs",
        "stopped early",
    ] {
        assert!(
            cases.iter().any(|c| c.cls == class),
            "no case of class {class}"
        );
    }
    let failures: Vec<String> = cases.iter().filter_map(run_case).collect();
    assert!(
        failures.is_empty(),
        "{} of {} cases failed:\n\n{}",
        failures.len(),
        cases.len(),
        failures.join("\n\n")
    );
}

/// Processes whose parent is `pid` (from /proc/*/stat), with their state letter.
fn children_of(pid: u32) -> Vec<(u32, char)> {
    let mut out = Vec::new();
    for entry in std::fs::read_dir("/proc").unwrap().flatten() {
        let Ok(child) = entry.file_name().to_string_lossy().parse::<u32>() else {
            continue;
        };
        if let Some((state, ppid)) = process_state(child) {
            if ppid == pid {
                out.push((child, state));
            }
        }
    }
    out
}

/// (state, parent pid) of a process, from the fields after the `(comm)` of /proc/PID/stat.
fn process_state(pid: u32) -> Option<(char, u32)> {
    let stat = std::fs::read_to_string(format!("/proc/{pid}/stat")).ok()?;
    let rest = &stat[stat.rfind(')')? + 2..];
    let mut fields = rest.split_whitespace();
    let state = fields.next()?.chars().next()?;
    let ppid = fields.next()?.parse().ok()?;
    Some((state, ppid))
}

/// Issue 14, item 4: SIGKILL of nlmodes while gmsh meshes leaves no gmsh running
/// (PR_SET_PDEATHSIG), and no file but a temporary that `nlmodes run` cleans.
#[test]
fn gmsh_dies_with_a_killed_nlmodes() {
    let tmp = tempfile::tempdir().unwrap();
    let out = tmp.path().join("fine.msh");
    let geo = root().join("meshes/blade.geo");
    let mut nlmodes = Command::new(env!("CARGO_BIN_EXE_nlmodes"))
        .args(["--quiet", "mesh", geo.to_str().unwrap(), "-o"])
        .arg(&out)
        .args(["--set", "mesh_size=0.0015"])
        .spawn()
        .unwrap();
    let start = std::time::Instant::now();
    let gmsh = loop {
        let running: Vec<u32> = children_of(nlmodes.id())
            .into_iter()
            .filter(|&(_, s)| s != 'Z')
            .map(|(p, _)| p)
            .collect();
        if let Some(&p) = running.first() {
            break p;
        }
        assert!(
            start.elapsed().as_secs() < 20 && nlmodes.try_wait().unwrap().is_none(),
            "gmsh never started under nlmodes"
        );
        std::thread::sleep(std::time::Duration::from_millis(20));
    };
    // Let gmsh work a little, then SIGKILL nlmodes (no chance to clean up).
    std::thread::sleep(std::time::Duration::from_millis(300));
    nlmodes.kill().unwrap();
    nlmodes.wait().unwrap();
    let start = std::time::Instant::now();
    let alive = loop {
        let alive = matches!(process_state(gmsh), Some((s, _)) if s != 'Z' && s != 'X');
        if !alive || start.elapsed().as_secs() >= 5 {
            break alive;
        }
        std::thread::sleep(std::time::Duration::from_millis(20));
    };
    if alive {
        // SAFETY: kill(2) on the pid of the gmsh this test started.
        unsafe { libc::kill(gmsh as libc::pid_t, libc::SIGKILL) };
    }
    assert!(!alive, "gmsh (pid {gmsh}) survived the SIGKILL of nlmodes");
    assert!(!out.exists(), "a mesh was written by a killed run");
    // What gmsh may have left is a temporary that every `nlmodes run` removes on start.
    nlmodes_output::remove_stale_temporaries(tmp.path()).unwrap();
    let rest: Vec<String> = std::fs::read_dir(tmp.path())
        .unwrap()
        .flatten()
        .map(|e| e.file_name().to_string_lossy().into_owned())
        .collect();
    assert!(rest.is_empty(), "{rest:?} left after cleaning");
}
