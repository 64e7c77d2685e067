//! `nlmodes study STUDY.toml` (issue 40, item 2; docs/STUDIES.md): a parameter study as a
//! Snakemake workflow. The study file (`crate::study::study_file`) names the case keys to vary and
//! their values; every combination is a run. The command checks the whole study first (bad
//! input: exit 2, nothing written), writes `<results_dir>/<study>/`: each run's case in
//! `cases/`, the jobs in `plan.json` (`crate::study::study_plan`: one per distinct stage, shared by
//! the runs with the same inputs to it), the `Snakefile` and SLURM profiles
//! (`crate::study::study_snakefile`); then runs Snakemake here with `--cores N` (unless
//! `--write-only`: then the same workflow runs anywhere Snakemake does, e.g. on a SLURM
//! cluster). Its last job gathers the runs into `study.csv`, figures and `report.md`
//! (`crate::study::study_report`). A failed job does not stop the others (`--keep-going`); the runs
//! that completed are still gathered, and the command exits 3 when every failed job stopped
//! early (exit code 3 of `nlmodes run`), 1 otherwise.

pub(crate) mod study_file;
pub(crate) mod study_gather;
pub(crate) mod study_job;
pub(crate) mod study_plan;
pub(crate) mod study_report;
pub(crate) mod study_snakefile;

use anyhow::{Context, Result};
use std::path::{Path, PathBuf};
use std::process::Command;

use crate::case::Case;
use crate::exit::{bad_input, StoppedEarly};
use crate::study::study_file::Study;
use crate::study::study_job::JobStatus;
use crate::study::study_plan::{job_counts, Plan};

/// How `nlmodes study` runs the workflow.
pub struct Options {
    /// Cores for Snakemake's local run (`--cores`).
    pub cores: usize,
    /// Write the workflow without running it.
    pub write_only: bool,
    /// More arguments for Snakemake.
    pub snakemake_args: Vec<String>,
}

/// The oldest Snakemake whose workflows and profiles the study writes (`--slurm` needs 7.19;
/// Debian 12 has 7.21).
const SNAKEMAKE_MAJOR: u32 = 7;

/// `nlmodes study`.
pub fn study(path: &Path, opts: &Options) -> Result<()> {
    let study = Study::load(path)?;
    if opts.cores == 0 {
        return Err(bad_input("--cores 0: expected at least 1"));
    }
    crate::validate::check_output_dir(
        &study.dir,
        &format!("{}: the study's folder", path.display()),
    )?;
    if study.dir.join(".stamps").exists() {
        return Err(bad_input(format!(
            "{}: study.name = {:?}: {} holds the results of a case (`nlmodes run`): expected \
             another name for the study",
            path.display(),
            study.name,
            study.dir.display()
        )));
    }
    let snakemake = if opts.write_only {
        None
    } else {
        Some(find_snakemake()?)
    };
    let plan = write_workflow(&study)?;
    crate::ui::say(&sharing(&plan));
    let Some(snakemake) = snakemake else {
        crate::ui::say(&format!(
            "workflow written to {0}; run it there with `snakemake --cores N`, or on SLURM with \
             `snakemake --profile profiles/slurm` (docs/STUDIES.md)",
            study.dir.display()
        ));
        return Ok(());
    };
    let mut cmd = Command::new(&snakemake);
    cmd.arg("--snakefile")
        .arg(study.dir.join("Snakefile"))
        .arg("--directory")
        .arg(&study.dir)
        .arg("--cores")
        .arg(opts.cores.to_string())
        .args(["--keep-going", "--rerun-incomplete"]);
    if crate::ui::quiet() {
        cmd.args(["--quiet", "all"]);
    }
    cmd.args(&opts.snakemake_args)
        .stdin(std::process::Stdio::null());
    tracing::info!("running {cmd:?}");
    // Not killed with nlmodes (a SIGKILL would leave its lock): Ctrl-C reaches both.
    let status = cmd
        .status()
        .with_context(|| format!("cannot run {}", snakemake.display()))?;
    if status.success() {
        return Ok(());
    }
    tracing::warn!("snakemake failed ({status}): gathering the runs that completed");
    crate::study::study_report::write_gathered(&study.dir)?;
    Err(failure(&study.dir, &plan, status))
}

/// The `snakemake` on PATH, at least version 7; missing, it is a system failure naming the
/// package.
fn find_snakemake() -> Result<PathBuf> {
    let missing = |why: String| {
        anyhow::anyhow!(
            "{why}: `nlmodes study` runs its workflow with Snakemake {SNAKEMAKE_MAJOR} or later \
             (Debian: apt-get install snakemake, as scripts/deps does), or writes it only with \
             --write-only"
        )
    };
    let out = Command::new("snakemake")
        .arg("--version")
        .output()
        .map_err(|e| missing(format!("cannot run snakemake ({e})")))?;
    let version = String::from_utf8_lossy(&out.stdout).trim().to_string();
    let major: Option<u32> = version.split('.').next().and_then(|m| m.parse().ok());
    if !out.status.success() || major.is_none_or(|m| m < SNAKEMAKE_MAJOR) {
        return Err(missing(format!("snakemake --version says `{version}`")));
    }
    tracing::info!("snakemake {version}");
    Ok(PathBuf::from("snakemake"))
}

/// Writes the study folder: each run's case, plan.json, the Snakefile, the profiles, a copy of
/// the study file. The cases are read back as `nlmodes run` and each job read them, and must
/// be the cases checked.
fn write_workflow(study: &Study) -> Result<Plan> {
    let dir = &study.dir;
    let cases_dir = dir.join("cases");
    if cases_dir.exists() {
        // Only this command writes there: the runs of an earlier version of the study go.
        std::fs::remove_dir_all(&cases_dir)?;
    }
    std::fs::create_dir_all(&cases_dir)?;
    std::fs::create_dir_all(dir.join("logs").join("slurm"))?;
    let mut cases = Vec::new();
    for run in &study.runs {
        let path = cases_dir.join(format!("{}.toml", run.id));
        let text = format!(
            "# Run {} of the study {} ({}), written by `nlmodes study`: every key of its case.\n\n{}",
            crate::study::study_file::describe(&run.id, &study.parameters, &run.values),
            study.name,
            study.path.display(),
            toml::to_string(&run.case).context("writing a run's case as TOML")?
        );
        crate::post::output::write_atomic(&path, text.as_bytes())?;
        let back = Case::load(&path)?;
        anyhow::ensure!(
            serde_json::to_value(&back)? == serde_json::to_value(&run.case)?,
            "the case written to {} does not read back the same",
            path.display()
        );
        cases.push(back);
    }
    let plan = crate::study::study_plan::plan(study, &cases)?;
    nlmodes_output::write_json(&dir.join("plan.json"), &plan)?;
    let exe = std::env::current_exe().context("cannot locate the nlmodes executable")?;
    let snakefile = crate::study::study_snakefile::snakefile(&study.name, &study.path, &exe);
    crate::post::output::write_atomic(&dir.join("Snakefile"), snakefile.as_bytes())?;
    for (file, text) in crate::study::study_snakefile::profiles() {
        let path = dir.join(file);
        std::fs::create_dir_all(path.parent().unwrap_or(dir))?;
        crate::post::output::write_atomic(&path, text.as_bytes())?;
    }
    let copy = std::fs::read(&study.path)?;
    crate::post::output::write_atomic(&dir.join("study.toml"), &copy)?;
    Ok(plan)
}

/// One line per stage: its jobs and the runs they serve.
fn sharing(plan: &Plan) -> String {
    let mut s = format!(
        "study {}: {} runs; jobs per stage (runs served):",
        plan.study,
        plan.runs.len()
    );
    for (kind, (jobs, served)) in job_counts(plan) {
        s += &format!(" {} {jobs} ({served})", kind.name());
    }
    s
}

/// The error of a failed workflow: its failed jobs, as stopped early when every one did.
fn failure(dir: &Path, plan: &Plan, status: std::process::ExitStatus) -> anyhow::Error {
    let statuses: Vec<JobStatus> = plan
        .jobs
        .keys()
        .filter_map(|id| JobStatus::read(dir, id))
        .filter(|s| s.status != "complete")
        .collect();
    let list: Vec<String> = statuses
        .iter()
        .map(|s| format!("{} {} (logs/{}.log)", s.job, s.status, s.job))
        .collect();
    let message = format!(
        "snakemake failed ({status}); jobs not complete: {}; the runs that completed are in {}",
        if list.is_empty() {
            "none recorded (see snakemake's output)".into()
        } else {
            list.join(", ")
        },
        dir.join("study.csv").display()
    );
    if !statuses.is_empty() && statuses.iter().all(|s| s.status == "stopped_early") {
        anyhow::Error::new(StoppedEarly(message))
    } else {
        anyhow::anyhow!(message)
    }
}
