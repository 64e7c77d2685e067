//! One job of a study's workflow: `nlmodes study-job STUDY_DIR JOB` (what each Snakemake job
//! runs; docs/STUDIES.md). A stage job starts its folder `stages/<kind>/<key>/` from the
//! folders of the jobs it needs (hard links: every nlmodes output is written to a temporary
//! file and renamed, so a stage writing into its own folder never changes a shared file), then
//! runs its one stage there as `nlmodes run` would (`crate::stage::run_if_needed`: the stages
//! upstream are up to date by their stamps). A run job makes `runs/<id>/` afresh from all its
//! stages' jobs, checks that every stage is up to date there, and runs the post-processing
//! (`nlmodes run --only post`). Each job leaves `status/<job>.json`: complete, stopped early,
//! bad input or failed, with the message and the time it took.

use anyhow::{Context, Result};
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};

use crate::case::Case;
use crate::forced::forced_stage::ForcedStage;
use crate::layout::Layout;
use crate::stage::{run_if_needed, up_to_date, Only, Stage};
use crate::study::study_plan::{material_of, CaseStages, Job, JobKind, Plan};

/// `status/<job>.json`.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct JobStatus {
    pub job: String,
    /// `complete`, `stopped_early` (exit code 3: partial results kept), `bad_input`, `failed`.
    pub status: String,
    pub message: String,
    /// Wall time, s.
    pub seconds: f64,
}

impl JobStatus {
    /// The status file of job `id`.
    pub fn path(dir: &Path, id: &str) -> PathBuf {
        dir.join("status").join(format!("{id}.json"))
    }

    /// The status of job `id`, if it ran.
    pub fn read(dir: &Path, id: &str) -> Option<Self> {
        crate::post::results::read_json(&Self::path(dir, id)).ok()
    }
}

/// Runs job `id` of the study in `dir` and records its status.
pub fn run(dir: &Path, id: &str) -> Result<()> {
    let plan = Plan::read(dir)?;
    let job = plan.job(id)?.clone();
    let started = std::time::Instant::now();
    tracing::info!(
        "study {}: job {id} ({} runs share it)",
        plan.study,
        job.runs.len()
    );
    let result = execute(dir, &plan, id, &job);
    let status = match &result {
        Ok(()) => "complete",
        Err(e) => match crate::exit::code_of(e) {
            crate::exit::STOPPED_EARLY => "stopped_early",
            crate::exit::BAD_INPUT => "bad_input",
            _ => "failed",
        },
    };
    let record = JobStatus {
        job: id.to_string(),
        status: status.into(),
        message: result
            .as_ref()
            .err()
            .map(|e| format!("{e:#}"))
            .unwrap_or_default(),
        seconds: started.elapsed().as_secs_f64(),
    };
    let path = JobStatus::path(dir, id);
    std::fs::create_dir_all(dir.join("status"))?;
    nlmodes_output::write_json(&path, &record)?;
    result
}

/// Starts the job's folder from its needs' folders, then runs it.
fn execute(dir: &Path, plan: &Plan, id: &str, job: &Job) -> Result<()> {
    let own = dir.join(&job.dir);
    if job.kind == JobKind::Run && own.exists() {
        // A run's folder is only ever made of its jobs' results and its post-processing.
        std::fs::remove_dir_all(&own).with_context(|| format!("cannot clear {}", own.display()))?;
    }
    std::fs::create_dir_all(&own).with_context(|| format!("cannot create {}", own.display()))?;
    for need in &job.needs {
        let from = dir.join(&plan.job(need)?.dir);
        let n = link_tree(&from, &own)?;
        tracing::debug!("{n} files of job {need} linked into {}", own.display());
    }
    let case_path = dir.join("cases").join(format!("{}.toml", job.run));
    let mut case = Case::load(&case_path)?;
    if job.kind != JobKind::Run {
        case.results_dir = own.parent().map(Path::to_path_buf).unwrap_or_default();
        case.name = own.file_name().map(|n| n.to_string_lossy().into_owned());
    }
    let layout = Layout::new(case.out_dir());
    anyhow::ensure!(
        same_dir(&layout.root, &own),
        "the case {} writes to {}, not to {}: the study's folder moved (rerun `nlmodes study`)",
        case_path.display(),
        layout.root.display(),
        own.display()
    );
    let material = material_of(&case)?;
    let stages = CaseStages::new(&case, &layout, &material)?;
    match job.kind {
        JobKind::Run => finish_run(&stages, plan.post, &case_path),
        JobKind::Forced => {
            let forced = forced_stage(&stages, id)?;
            run_if_needed(&forced, false)
        }
        JobKind::Modes if !stages.modes.wanted() => {
            tracing::info!(
                "stage modes: skipped ([model] full_check = \"{}\")",
                case.model.full_check
            );
            Ok(())
        }
        _ => {
            let jobs = stages.jobs();
            let stage = jobs.iter().find(|j| j.id == id).and_then(|j| j.stage).with_context(|| {
                format!("job {id} is not a stage of run {} (its case changed: rerun `nlmodes study`)", job.run)
            })?;
            run_if_needed(stage, false)
        }
    }
}

/// Whether two paths name the same existing directory.
fn same_dir(a: &Path, b: &Path) -> bool {
    matches!((a.canonicalize(), b.canonicalize()), (Ok(x), Ok(y)) if x == y)
}

/// The forced stage of the case, checked to be job `id`.
fn forced_stage<'a>(stages: &CaseStages<'a>, id: &str) -> Result<ForcedStage<'a>> {
    let planned = stages
        .jobs()
        .into_iter()
        .any(|j| j.kind == JobKind::Forced && j.id == id);
    anyhow::ensure!(
        planned,
        "job {id} is not the forced stage of its case (rerun `nlmodes study`)"
    );
    Ok(ForcedStage::new(
        stages.case,
        stages.layout,
        stages.reduce.hash(),
        "at rest",
    ))
}

/// A run's folder, made of its stages' results: every stage must be up to date there (else a
/// stage would be computed again outside its job); then the post-processing of `nlmodes run`.
fn finish_run(stages: &CaseStages, post: bool, case_path: &Path) -> Result<()> {
    let mut stale = Vec::new();
    for j in stages.jobs() {
        let fresh = match (j.kind, j.stage) {
            (JobKind::Modes, _) if !stages.modes.wanted() => true,
            (JobKind::Forced, _) => up_to_date(&forced_stage(stages, &j.id)?),
            (_, Some(stage)) => up_to_date(stage),
            (_, None) => true,
        };
        if !fresh {
            stale.push(j.id);
        }
    }
    anyhow::ensure!(
        stale.is_empty(),
        "stages not up to date in {} after linking their jobs' results: {} (rerun `nlmodes study`)",
        stages.layout.root.display(),
        stale.join(", ")
    );
    if post {
        crate::run::run(case_path, Some(Only::Post), false)?;
    }
    Ok(())
}

/// Links every file under `from` into `to` (same relative paths; hard links, a copy where the
/// file system refuses them), replacing what is there; temporary files are left out. Returns
/// how many files.
pub fn link_tree(from: &Path, to: &Path) -> Result<usize> {
    let mut count = 0;
    let entries =
        std::fs::read_dir(from).with_context(|| format!("cannot read {}", from.display()))?;
    for entry in entries {
        let entry = entry?;
        let (path, target) = (entry.path(), to.join(entry.file_name()));
        let kind = entry.file_type()?;
        let name = entry.file_name().to_string_lossy().into_owned();
        if kind.is_dir() {
            std::fs::create_dir_all(&target)?;
            count += link_tree(&path, &target)?;
        } else if kind.is_file() && !(name.starts_with('.') && name.contains(".tmp-")) {
            if target.symlink_metadata().is_ok() {
                std::fs::remove_file(&target)
                    .with_context(|| format!("cannot replace {}", target.display()))?;
            }
            if std::fs::hard_link(&path, &target).is_err() {
                std::fs::copy(&path, &target).with_context(|| {
                    format!("cannot copy {} to {}", path.display(), target.display())
                })?;
            }
            count += 1;
        }
    }
    Ok(count)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Linked files share the source's bytes; an atomic rewrite in the copy leaves the source
    /// as it was (the property every job relies on); temporaries are not linked.
    #[test]
    fn linked_trees_share_files_until_one_is_rewritten() {
        let tmp = tempfile::tempdir().unwrap();
        let (a, b) = (tmp.path().join("a"), tmp.path().join("b"));
        std::fs::create_dir_all(a.join(".stamps")).unwrap();
        std::fs::create_dir_all(a.join("model")).unwrap();
        std::fs::write(a.join(".stamps/mesh"), "abc").unwrap();
        std::fs::write(a.join("model/K.mtx"), "K").unwrap();
        std::fs::write(a.join("model/.K.mtx.tmp-1-2"), "partial").unwrap();
        std::fs::create_dir_all(&b).unwrap();
        std::fs::write(b.join("other"), "keep").unwrap();
        assert_eq!(link_tree(&a, &b).unwrap(), 2);
        assert_eq!(
            std::fs::read_to_string(b.join(".stamps/mesh")).unwrap(),
            "abc"
        );
        assert!(!b.join("model/.K.mtx.tmp-1-2").exists());
        assert_eq!(std::fs::read_to_string(b.join("other")).unwrap(), "keep");
        nlmodes_output::write_atomic(b.join("model/K.mtx"), b"K2").unwrap();
        assert_eq!(std::fs::read_to_string(a.join("model/K.mtx")).unwrap(), "K");
        assert_eq!(link_tree(&a, &b).unwrap(), 2, "linking again replaces");
        assert_eq!(std::fs::read_to_string(b.join("model/K.mtx")).unwrap(), "K");
    }
}
