//! `nlmodes reduce` over MPI (issue 40): `mpirun -n 1` and `-n 2` on the coarse blade
//! (meshes/blade.geo, mesh_size 0.012, 8004 free DOFs, 20 fixed-interface modes) give the
//! serial reduced model, and a failing or killed rank ends the whole job with an error.
//!
//! Tolerances: the reduced frequencies to 1e-8 relative and K_r, M_r to 1e-8 of their largest
//! entry, after aligning the signs of the modal basis vectors. Both paths converge the
//! fixed-interface modes to relative residuals near 1e-10 (serial block Lanczos; SLEPc with
//! -eps_tol 1e-10), so their shapes agree to about 1e-10 / (relative eigenvalue gap) and the
//! reduced matrices, linear in them, to ~1e-9; the projections and factorizations differ only
//! by round-off (1e-13). Every mpirun has a timeout: a hang fails the test.

mod common;

use std::path::Path;
use std::process::{Command, Output, Stdio};
use std::time::{Duration, Instant};

use nlmodes_modal::ReducedModel;

/// Longest an mpirun of the coarse blade may take (it takes seconds; minutes on a loaded
/// 2-core machine).
const MPIRUN_TIMEOUT: Duration = Duration::from_secs(300);

/// Longest the job may take to end once a rank is killed (about a second: Open MPI's runtime
/// notices the death at once and ends the other ranks).
const KILLED_JOB_ENDS: Duration = Duration::from_secs(60);

/// `mpirun -n ranks nlmodes --quiet args...`, killed after `timeout`; None when it timed out.
fn mpirun(ranks: usize, args: &[&str], timeout: Duration) -> Option<Output> {
    let child = mpirun_command(ranks, args)
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("cannot start mpirun (Open MPI: scripts/deps installs openmpi-bin)");
    wait_with_timeout(child, timeout)
}

fn mpirun_command(ranks: usize, args: &[&str]) -> Command {
    let mut cmd = Command::new("mpirun");
    cmd.args(["-n", &ranks.to_string(), "--oversubscribe"])
        // CI and this machine run as root; one BLAS and rayon thread per rank on 2 cores.
        .env("OMPI_ALLOW_RUN_AS_ROOT", "1")
        .env("OMPI_ALLOW_RUN_AS_ROOT_CONFIRM", "1")
        // No cross-memory attach between the ranks: a container without CAP_SYS_PTRACE (CI)
        // refuses it ("Read -1, expected ..., errno = 1", open-mpi/ompi#4948).
        .env("OMPI_MCA_btl_vader_single_copy_mechanism", "none")
        .env("OPENBLAS_NUM_THREADS", "1")
        .env("RAYON_NUM_THREADS", "1")
        .arg(env!("CARGO_BIN_EXE_nlmodes"))
        .arg("--quiet")
        .args(args);
    cmd
}

/// Waits for `child`, killing it after `timeout` (then None).
fn wait_with_timeout(mut child: std::process::Child, timeout: Duration) -> Option<Output> {
    let start = Instant::now();
    loop {
        if child.try_wait().expect("waiting for mpirun").is_some() {
            return Some(child.wait_with_output().expect("mpirun output"));
        }
        if start.elapsed() > timeout {
            let _ = child.kill();
            let _ = child.wait();
            return None;
        }
        std::thread::sleep(Duration::from_millis(100));
    }
}

fn reduce_args<'a>(mesh: &'a str, out: &'a str, compare: &'a str) -> Vec<&'a str> {
    vec![
        "reduce",
        mesh,
        "--modes",
        "20",
        "--compare",
        compare,
        "-o",
        out,
    ]
}

/// Largest |a - b| over the largest |a|.
fn relative_difference(a: &faer::Mat<f64>, b: &faer::Mat<f64>) -> f64 {
    let mut diff: f64 = 0.0;
    let mut scale: f64 = 0.0;
    for j in 0..a.ncols() {
        for i in 0..a.nrows() {
            diff = diff.max((a[(i, j)] - b[(i, j)]).abs());
            scale = scale.max(a[(i, j)].abs());
        }
    }
    diff / scale
}

/// `b` with the signs of its modal basis vectors (coordinates n_b..) aligned on `a`'s: the
/// sign of each mode's mass coupling with the boundary coordinates.
fn sign_aligned(a: &ReducedModel, b: &ReducedModel) -> (faer::Mat<f64>, faer::Mat<f64>) {
    let n_b = 3 * a.contact_nodes.len();
    let n = a.k.nrows();
    let sign: Vec<f64> = (0..n)
        .map(|j| {
            if j < n_b {
                return 1.0;
            }
            let c: f64 = (0..n_b).map(|i| a.m[(i, j)] * b.m[(i, j)]).sum();
            if c < 0.0 {
                -1.0
            } else {
                1.0
            }
        })
        .collect();
    let flip = |x: &faer::Mat<f64>| faer::Mat::from_fn(n, n, |i, j| sign[i] * sign[j] * x[(i, j)]);
    (flip(&b.k), flip(&b.m))
}

fn assert_same_model(serial: &Path, mpi: &Path, ranks: usize) {
    let s = ReducedModel::read(serial).expect("serial model");
    let p = ReducedModel::read(mpi).expect("MPI model");
    assert_eq!(s.k.nrows(), p.k.nrows(), "reduced order, {ranks} rank(s)");
    assert_eq!(s.master.dof, p.master.dof, "master coordinate");
    let worst = s
        .linear_frequencies_hz
        .iter()
        .zip(&p.linear_frequencies_hz)
        .map(|(a, b)| ((a - b) / a).abs())
        .fold(0.0, f64::max);
    let (k, m) = sign_aligned(&s, &p);
    let (dk, dm) = (relative_difference(&s.k, &k), relative_difference(&s.m, &m));
    eprintln!(
        "{ranks} rank(s): frequencies {worst:.1e} relative, K_r {dk:.1e}, M_r {dm:.1e} of \
         their largest entry"
    );
    assert!(
        worst < 1e-8,
        "frequencies differ by {worst:e} ({ranks} ranks)"
    );
    assert!(dk < 1e-8, "K_r differs by {dk:e} ({ranks} ranks)");
    assert!(dm < 1e-8, "M_r differs by {dm:e} ({ranks} ranks)");
}

#[test]
fn mpirun_with_one_and_two_ranks_gives_the_serial_reduced_model() {
    let dir = tempfile::tempdir().unwrap();
    let serial = common::coarse_blade_model(dir.path());
    let mesh = dir.path().join("coarse.msh");
    let mesh = mesh.to_str().unwrap();
    for ranks in [1, 2] {
        let out = dir.path().join(format!("model-{ranks}"));
        let args = reduce_args(mesh, out.to_str().unwrap(), "0");
        let output = mpirun(ranks, &args, MPIRUN_TIMEOUT)
            .unwrap_or_else(|| panic!("mpirun -n {ranks} did not end in {MPIRUN_TIMEOUT:?}"));
        assert!(
            output.status.success(),
            "mpirun -n {ranks}: {}",
            String::from_utf8_lossy(&output.stderr)
        );
        assert_same_model(&serial, &out, ranks);
    }
}

#[test]
fn bad_input_under_mpirun_ends_every_rank_with_exit_status_2() {
    let dir = tempfile::tempdir().unwrap();
    let mesh = dir.path().join("coarse.msh");
    common::nlmodes_ok(&[
        "mesh",
        common::blade_geo().to_str().unwrap(),
        "-o",
        mesh.to_str().unwrap(),
        "--set",
        "mesh_size=0.012",
    ]);
    let out = dir.path().join("model");
    let mut args = reduce_args(mesh.to_str().unwrap(), out.to_str().unwrap(), "0");
    args.extend(["--contact", "no_such_group"]);
    let output = mpirun(2, &args, MPIRUN_TIMEOUT).expect("mpirun -n 2 hung on bad input");
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert_eq!(output.status.code(), Some(2), "{stderr}");
    assert!(stderr.contains("no_such_group"), "{stderr}");
    assert!(!out.exists(), "no model directory after a failure");
}

/// The process ids of mpirun's children with `OMPI_COMM_WORLD_RANK=rank`.
fn rank_pids(mpirun: u32, rank: usize) -> Vec<u32> {
    let wanted = format!("OMPI_COMM_WORLD_RANK={rank}");
    std::fs::read_dir("/proc")
        .unwrap()
        .filter_map(|e| e.ok()?.file_name().to_str()?.parse::<u32>().ok())
        .filter(|pid| {
            let stat = std::fs::read_to_string(format!("/proc/{pid}/stat")).unwrap_or_default();
            let ppid = stat
                .rsplit(')')
                .next()
                .and_then(|s| s.split_whitespace().nth(1))
                .and_then(|s| s.parse::<u32>().ok());
            ppid == Some(mpirun)
                && std::fs::read(format!("/proc/{pid}/environ"))
                    .unwrap_or_default()
                    .split(|&b| b == 0)
                    .any(|v| v == wanted.as_bytes())
        })
        .collect()
}

/// Rank 1 killed (SIGKILL) inside the distributed reduction: the job ends with an error within
/// [`KILLED_JOB_ENDS`] (a hang fails the test), mpirun names the killed rank, rank 0 is gone and no
/// model is written. "Inside" is certain, not timed: the kill follows the first log line of
/// the reduction's task (`partition and assembly`, logged by a rank once both assembled their
/// part), after which the ranks still factorize, solve the eigenproblems and the full-model
/// check together.
#[test]
fn a_rank_killed_mid_run_ends_the_others_with_an_error() {
    let dir = tempfile::tempdir().unwrap();
    let mesh = dir.path().join("coarse.msh");
    common::nlmodes_ok(&[
        "mesh",
        common::blade_geo().to_str().unwrap(),
        "-o",
        mesh.to_str().unwrap(),
        "--set",
        "mesh_size=0.012",
    ]);
    let out = dir.path().join("model");
    // The full-model check too: a second factorization and eigen-solve after the first line.
    let mut args = reduce_args(mesh.to_str().unwrap(), out.to_str().unwrap(), "10");
    args.extend(["--full-check", "on"]);
    let mut child = mpirun_command(2, &args)
        // The steps' log lines despite --quiet (RUST_LOG takes precedence).
        .env("RUST_LOG", "info")
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .expect("cannot start mpirun");
    let (inside, stderr) = watch_stderr(&mut child, "partition and assembly");
    let in_task = inside.recv_timeout(MPIRUN_TIMEOUT);
    let victim = rank_pids(child.id(), 1);
    let rank0 = rank_pids(child.id(), 0);
    if in_task.is_err() || victim.len() != 1 {
        let _ = child.kill();
        panic!(
            "the reduction's task never started ({victim:?}): {}",
            stderr.join().unwrap()
        );
    }
    let killed = Command::new("kill")
        .args(["-KILL", &victim[0].to_string()])
        .status()
        .unwrap();
    assert!(killed.success(), "rank 1 had already ended");
    let start = Instant::now();
    let status = loop {
        if let Some(status) = child.try_wait().unwrap() {
            break status;
        }
        if start.elapsed() > KILLED_JOB_ENDS {
            let _ = child.kill();
            panic!("the other rank hung: {}", stderr.join().unwrap());
        }
        std::thread::sleep(Duration::from_millis(100));
    };
    let stderr = stderr.join().unwrap();
    assert!(!status.success(), "mpirun reported success: {stderr}");
    // mpirun's report is a help message, which Open MPI 4.1 loses now and then
    // (open-mpi/ompi#8356: "... read past end of buffer in file util/show_help.c").
    let report_lost = stderr.contains("show_help.c");
    assert!(
        report_lost
            || stderr.contains("signal 9")
            || stderr.contains("Killed")
            || stderr.contains("killed"),
        "mpirun names the killed rank: {stderr}"
    );
    for pid in rank0 {
        assert!(
            !Path::new(&format!("/proc/{pid}")).exists()
                || std::fs::read_to_string(format!("/proc/{pid}/stat"))
                    .is_ok_and(|s| s.contains(") Z ")),
            "rank 0 (pid {pid}) still runs"
        );
    }
    assert!(!out.join("model.json").exists(), "no model after a failure");
}

/// Rank 1 failing inside the reduction's task, by an error and by a panic (the test hook
/// `NLMODES_TEST_TASK_FAILURE` of src/reduce_mpi.rs; rank 0 is then inside the task's
/// collectives): the job ends within the timeout (a hang fails the test) with the error's exit
/// status (1) or a panic's (101), the message of rank 1, and no model. (Not MPI_Abort's own
/// report: Open MPI 4.1 loses it now and then, "ORTE_ERROR_LOG: Data unpack would read past
/// end of buffer in file util/show_help.c", open-mpi/ompi#8356.) The panic's case checks the
/// hook `main` installs (`crew::abort_on_panic`): without it the test fails.
#[test]
fn a_rank_failing_inside_a_task_ends_the_job_with_its_message() {
    let dir = tempfile::tempdir().unwrap();
    let mesh = dir.path().join("coarse.msh");
    common::nlmodes_ok(&[
        "mesh",
        common::blade_geo().to_str().unwrap(),
        "-o",
        mesh.to_str().unwrap(),
        "--set",
        "mesh_size=0.012",
    ]);
    for (failure, status, message) in [
        (
            "error",
            1,
            "error (MPI rank 1): NLMODES_TEST_TASK_FAILURE=error",
        ),
        (
            "panic",
            101,
            "NLMODES_TEST_TASK_FAILURE=panic: a panic inside the task",
        ),
    ] {
        let out = dir.path().join(format!("model_{failure}"));
        let args = reduce_args(mesh.to_str().unwrap(), out.to_str().unwrap(), "0");
        let child = mpirun_command(2, &args)
            .env("NLMODES_TEST_TASK_FAILURE", failure)
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .expect("cannot start mpirun");
        let output = wait_with_timeout(child, MPIRUN_TIMEOUT).expect("the job hung");
        let stderr = String::from_utf8_lossy(&output.stderr);
        assert_eq!(output.status.code(), Some(status), "{failure}: {stderr}");
        assert!(stderr.contains(message), "{failure}: {stderr}");
        assert!(!out.join("model.json").exists(), "no model after a failure");
    }
}

/// Reads `child`'s stderr on a thread: a message on the receiver once a line contains `marker`,
/// and the whole text when the thread is joined (at the end of the stream).
fn watch_stderr(
    child: &mut std::process::Child,
    marker: &'static str,
) -> (
    std::sync::mpsc::Receiver<()>,
    std::thread::JoinHandle<String>,
) {
    use std::io::BufRead;
    let pipe = child.stderr.take().expect("stderr piped");
    let (tx, rx) = std::sync::mpsc::channel();
    let reader = std::thread::spawn(move || {
        let mut text = String::new();
        for line in std::io::BufReader::new(pipe).lines().map_while(Result::ok) {
            if line.contains(marker) {
                let _ = tx.send(());
            }
            text.push_str(&line);
            text.push('\n');
        }
        text
    });
    (rx, reader)
}

/// The eigenvalues of a `frequencies.csv` (column 3, rad^2/s^2).
fn eigenvalues_csv(path: &Path) -> Vec<f64> {
    std::fs::read_to_string(path)
        .unwrap_or_else(|e| panic!("{}: {e}", path.display()))
        .lines()
        .skip(1)
        .map(|l| l.split(',').nth(2).unwrap().parse().unwrap())
        .collect()
}

#[test]
fn mpirun_modes_with_two_ranks_gives_the_serial_frequencies() {
    let dir = tempfile::tempdir().unwrap();
    let mesh = dir.path().join("coarse.msh");
    let mesh_s = mesh.to_str().unwrap();
    let geo = common::blade_geo();
    common::nlmodes_ok(&[
        "mesh",
        geo.to_str().unwrap(),
        "-o",
        mesh_s,
        "--set",
        "mesh_size=0.012",
    ]);
    let (serial, mpi) = (dir.path().join("serial"), dir.path().join("mpi"));
    let args = |out: &Path| {
        ["modes", mesh_s, "--fix", "root", "--modes", "10", "-o"]
            .iter()
            .map(|s| s.to_string())
            .chain([out.to_str().unwrap().to_string()])
            .collect::<Vec<_>>()
    };
    let serial_args = args(&serial);
    common::nlmodes_ok(&serial_args.iter().map(String::as_str).collect::<Vec<_>>());
    let mpi_args = args(&mpi);
    let output = mpirun(
        2,
        &mpi_args.iter().map(String::as_str).collect::<Vec<_>>(),
        MPIRUN_TIMEOUT,
    )
    .expect("mpirun -n 2 modes did not end");
    assert!(
        output.status.success(),
        "{}",
        String::from_utf8_lossy(&output.stderr)
    );
    let (s, p) = (
        eigenvalues_csv(&serial.join("frequencies.csv")),
        eigenvalues_csv(&mpi.join("frequencies.csv")),
    );
    assert_eq!(s.len(), 10);
    assert_eq!(p.len(), 10);
    // Both solvers converge to relative residuals of 1e-10 or less: eigenvalue errors of the
    // order of the squared residual times the spectral spread, far below 1e-8.
    for (a, b) in s.iter().zip(&p) {
        assert!(
            ((a - b) / a).abs() < 1e-8,
            "eigenvalue {a} (serial) vs {b} (MPI)"
        );
    }
    assert!(mpi.join("modes.vtu").exists());
}

/// The coarse blade case (meshes/blade.geo at mesh_size 0.012, 8004 free DOFs, 20
/// fixed-interface modes, 6 full-model modes) writing into `results`, with a short backbone
/// (just past grazing at q/g0 = 6.0) and `extra` lines appended.
fn coarse_case(dir: &Path, name: &str, results: &Path, extra: &str) -> std::path::PathBuf {
    let geo = common::blade_geo();
    let case = format!(
        "name = \"coarse\"\nresults_dir = \"{}\"\n[mesh]\ngeo = \"{}\"\norder = 2\n\
         [mesh.parameters]\nmesh_size = 0.012\n[model]\nfixed_interface_modes = 20\n\
         linear_modes = 6\n[nnm]\nharmonics = 10\nsamples = 128\nkeep = [3.0]\nframes = 6\n\
         [continuation]\nq_start = 0.5\nq_max = 7.0\n{extra}",
        results.display(),
        geo.display()
    );
    let path = dir.join(name);
    std::fs::write(&path, case).unwrap();
    path
}

/// `mpirun -n 2 nlmodes run`: rank 0 runs the pipeline and the other rank takes part in its
/// modes and reduce stages (docs/LARGE_MODELS.md, "Over MPI"). Against the serial run of the
/// same case: the reduced model as in `assert_same_model` (tolerances at the top of this file),
/// the full model's 6 eigenvalues to 1e-8 relative (both converged to residuals of 1e-10 or
/// less, measured 1.8e-10 at most), the later stages done on rank 0 (backbone, report), and
/// their summary printed once.
#[test]
fn mpirun_run_distributes_modes_and_reduce_and_gives_the_serial_results() {
    let dir = tempfile::tempdir().unwrap();
    let (serial, mpi) = (dir.path().join("serial"), dir.path().join("mpi"));
    let forced_off = "[forced]\nenabled = false\n";
    let serial_case = coarse_case(dir.path(), "serial.toml", &serial, forced_off);
    let mpi_case = coarse_case(dir.path(), "mpi.toml", &mpi, forced_off);
    common::nlmodes_ok(&["run", serial_case.to_str().unwrap()]);
    let output = mpirun(2, &["run", mpi_case.to_str().unwrap()], MPIRUN_TIMEOUT)
        .expect("mpirun -n 2 nlmodes run did not end");
    let stdout = String::from_utf8_lossy(&output.stdout);
    assert!(
        output.status.success(),
        "{stdout}\n{}",
        String::from_utf8_lossy(&output.stderr)
    );
    let (serial, mpi) = (serial.join("coarse"), mpi.join("coarse"));
    assert_same_model(&serial.join("model"), &mpi.join("model"), 2);
    let (s, p) = (
        eigenvalues_csv(&serial.join("modes/frequencies.csv")),
        eigenvalues_csv(&mpi.join("modes/frequencies.csv")),
    );
    assert_eq!((s.len(), p.len()), (6, 6));
    for (a, b) in s.iter().zip(&p) {
        assert!(
            ((a - b) / a).abs() < 1e-8,
            "eigenvalue {a} (serial) vs {b} (MPI)"
        );
    }
    for file in ["modes/modes.vtu", "backbone/backbone.csv", "report.md"] {
        assert!(mpi.join(file).exists(), "{file} missing after mpirun");
    }
    assert_eq!(
        stdout.matches("grazing at q/g0").count(),
        1,
        "the backbone's summary once:\n{stdout}"
    );
}

/// `mpirun -n 2 nlmodes run --only reduce` of a case with a group load (`[forced] load =
/// "group"`): its static correction joins the basis over MPI as in the serial run (the model
/// as in `assert_same_model`, the one more coordinate), and F.mtx = T^T f agrees to 1e-8 of its
/// largest entry (linear in the basis) once the signs of the modal coordinates are aligned.
#[test]
fn mpirun_run_reduces_with_a_static_correction_like_the_serial_run() {
    let dir = tempfile::tempdir().unwrap();
    let (serial, mpi) = (dir.path().join("serial"), dir.path().join("mpi"));
    let load =
        "[forced]\nload = \"group\"\nload_group = \"tip\"\nload_direction = [0.0, 2.0, 0.0]\n";
    let serial_case = coarse_case(dir.path(), "serial.toml", &serial, load);
    let mpi_case = coarse_case(dir.path(), "mpi.toml", &mpi, load);
    common::nlmodes_ok(&["run", serial_case.to_str().unwrap(), "--only", "reduce"]);
    let args = ["run", mpi_case.to_str().unwrap(), "--only", "reduce"];
    let output = mpirun(2, &args, MPIRUN_TIMEOUT).expect("mpirun -n 2 did not end");
    assert!(
        output.status.success(),
        "{}",
        String::from_utf8_lossy(&output.stderr)
    );
    let (serial, mpi) = (serial.join("coarse/model"), mpi.join("coarse/model"));
    assert_same_model(&serial, &mpi, 2);
    let (s, p) = (
        ReducedModel::read(&serial).unwrap(),
        ReducedModel::read(&mpi).unwrap(),
    );
    assert_eq!(
        s.k.nrows(),
        3 * s.contact_nodes.len() + 21,
        "one correction"
    );
    let read = |d: &Path| {
        nlmodes_modal::matrix_market_general::read_dense_general(&d.join("F.mtx")).unwrap()
    };
    let (fs, fp) = (read(&serial), read(&mpi));
    let n_b = 3 * s.contact_nodes.len();
    let scale = (0..fs.nrows()).fold(0.0f64, |a, i| a.max(fs[(i, 0)].abs()));
    for i in 0..fs.nrows() {
        // The sign of modal coordinate i, from its mass coupling with the boundary.
        let sign = if i < n_b {
            1.0
        } else {
            let c: f64 = (0..n_b).map(|r| s.m[(r, i)] * p.m[(r, i)]).sum();
            c.signum()
        };
        let d = (fs[(i, 0)] - sign * fp[(i, 0)]).abs() / scale;
        assert!(d < 1e-8, "F.mtx row {i}: {} vs {}", fs[(i, 0)], fp[(i, 0)]);
    }
}

/// Every number of a JSON value with its path.
fn json_numbers(v: &serde_json::Value, path: String, out: &mut Vec<(String, f64)>) {
    match v {
        serde_json::Value::Object(map) => {
            for (k, x) in map {
                json_numbers(x, format!("{path}/{k}"), out);
            }
        }
        serde_json::Value::Array(items) => {
            for (i, x) in items.iter().enumerate() {
                json_numbers(x, format!("{path}[{i}]"), out);
            }
        }
        serde_json::Value::Number(n) => out.push((path, n.as_f64().unwrap())),
        _ => {}
    }
}

/// The columns ending in `_hz` of a CSV file, row by row.
fn hz_columns(path: &Path) -> Vec<f64> {
    let text = std::fs::read_to_string(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    let mut lines = text.lines();
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    lines
        .flat_map(|l| {
            l.split(',')
                .zip(&header)
                .filter(|(_, h)| h.ends_with("_hz"))
                .map(|(v, _)| v.parse::<f64>().unwrap())
                .collect::<Vec<_>>()
        })
        .collect()
}

/// The blade at speed under `mpirun -n 2 nlmodes run` (`--only speed`, then `--only
/// campbell`): the prestress's Newton steps (MUMPS on each tangent), the reduction of K(Omega),
/// the Campbell march's Newton steps, its basis modes, its direct check and the parametric
/// model's reduction run over the ranks on the matrices rank 0 assembles and sends by rows
/// (`src/rotation_mpi.rs`). Against the serial run: every number of prestress.json (Newton
/// residuals excepted) to 1e-9 relative (both direct solves are accurate to cond(K_T) eps,
/// about 1e-11 here, and Newton stops at the same iteration), the model at speed as in
/// `assert_same_model`, the Campbell frequencies to 1e-8 relative (the basis modes of both
/// paths converge to residuals of 1e-10; Ritz values are second order in them), and the
/// parametric model's lowest 6 frequencies and running gaps at every sample and midway
/// between, to 1e-8 relative (its basis spans the same vectors up to the modes' 1e-10).
#[test]
fn mpirun_run_distributes_the_blade_at_speed_like_the_serial_run() {
    let dir = tempfile::tempdir().unwrap();
    let (serial, mpi) = (dir.path().join("serial"), dir.path().join("mpi"));
    let rotation = "[forced]\nenabled = false\n[rotation]\noperating_speed = 8000.0\n\
                    campbell_range = [0.0, 10000.0]\ncampbell_speeds = 6\ncampbell_modes = 4\n\
                    engine_orders = [2, 3]\nmap_amplitudes = [5.0]\n";
    let serial_case = coarse_case(dir.path(), "serial.toml", &serial, rotation);
    let mpi_case = coarse_case(dir.path(), "mpi.toml", &mpi, rotation);
    for only in ["speed", "campbell"] {
        common::nlmodes_ok(&["run", serial_case.to_str().unwrap(), "--only", only]);
        let args = ["run", mpi_case.to_str().unwrap(), "--only", only];
        let output = mpirun(2, &args, MPIRUN_TIMEOUT).expect("mpirun -n 2 did not end");
        assert!(
            output.status.success(),
            "--only {only}: {}",
            String::from_utf8_lossy(&output.stderr)
        );
    }
    let (serial, mpi) = (serial.join("coarse"), mpi.join("coarse"));
    let numbers = |root: &Path| {
        let text = std::fs::read_to_string(root.join("speed/prestress.json")).unwrap();
        let mut out = Vec::new();
        json_numbers(
            &serde_json::from_str(&text).unwrap(),
            String::new(),
            &mut out,
        );
        out
    };
    let (s, p) = (numbers(&serial), numbers(&mpi));
    assert_eq!(s.len(), p.len());
    for ((key, a), (_, b)) in s.iter().zip(&p) {
        if key.contains("newton") || *a == 0.0 {
            continue;
        }
        assert!(
            ((a - b) / a).abs() < 1e-9,
            "prestress.json {key}: {a} vs {b}"
        );
    }
    assert_same_model(&serial.join("speed/model"), &mpi.join("speed/model"), 2);
    let (s, p) = (
        hz_columns(&serial.join("campbell/campbell.csv")),
        hz_columns(&mpi.join("campbell/campbell.csv")),
    );
    assert!(!s.is_empty() && s.len() == p.len());
    for (a, b) in s.iter().zip(&p) {
        assert!(
            ((a - b) / a).abs() < 1e-8,
            "Campbell frequency {a} vs {b} Hz"
        );
    }
    assert_same_parametric_model(&serial.join("parametric"), &mpi.join("parametric"));
}

/// The parametric models of `serial` and `mpi` (directories) agree at the sample speeds and
/// midway between: the lowest 6 frequencies and the contact nodes' running gaps to 1e-8
/// relative (tolerance of the test above).
fn assert_same_parametric_model(serial: &Path, mpi: &Path) {
    let read = |dir: &Path| nlmodes_modal::ParametricModel::read(dir).unwrap();
    let (s, p) = (read(serial), read(mpi));
    assert_eq!(s.speeds(), p.speeds());
    let samples = s.speeds();
    let midway = samples.windows(2).map(|w| 0.5 * (w[0] + w[1]));
    let (mut worst_hz, mut worst_gap) = (0.0_f64, 0.0_f64);
    for omega in samples.iter().copied().chain(midway) {
        let (a, b) = (s.at(omega).unwrap(), p.at(omega).unwrap());
        let hz = |m: &ReducedModel| {
            nlmodes_modal::reduced_model::linear_frequencies_hz(&m.k, &m.m, 6).unwrap()
        };
        let (fa, fb) = (hz(&a), hz(&b));
        assert_eq!(fa.len(), 6);
        for (x, y) in fa.iter().zip(&fb) {
            worst_hz = worst_hz.max(((x - y) / x).abs());
            assert!(
                ((x - y) / x).abs() < 1e-8,
                "parametric model at {omega} rad/s: {x} vs {y} Hz"
            );
        }
        assert_eq!(a.contact_nodes.len(), b.contact_nodes.len());
        for (x, y) in a.contact_nodes.iter().zip(&b.contact_nodes) {
            worst_gap = worst_gap.max(((x.gap - y.gap) / x.gap).abs());
            assert!(
                ((x.gap - y.gap) / x.gap).abs() < 1e-8,
                "parametric model at {omega} rad/s: running gap {} vs {} m",
                x.gap,
                y.gap
            );
        }
    }
    println!(
        "parametric model: frequencies within {worst_hz:.1e}, running gaps within {worst_gap:.1e}"
    );
}
