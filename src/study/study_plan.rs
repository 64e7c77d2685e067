//! The jobs of a study (docs/STUDIES.md): every make-like stage of every run (the stages of
//! `nlmodes run`, `crate::run`), keyed by the hash of its inputs. Runs whose inputs to a stage
//! are the same share one job: one mesh for every run that meshes the same .geo with the same
//! parameters, one reduction, one backbone, ... A stage's hash already holds the hashes of the
//! stages it starts from, so equal keys mean equal upstream results. The forced stage's own
//! hash reads the backbone's bytes, unknown before it runs: its key holds the backbone job's
//! key instead. Written as `plan.json`, which the workflow (`crate::study::study_snakefile`) and each
//! job (`crate::study::study_job`) read.

use anyhow::{Context, Result};
use nlmodes_fem::Isotropic;
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;
use std::path::Path;

use crate::backbone::backbone_stage::BackboneStage;
use crate::campbell::campbell_stage::CampbellStage;
use crate::case::Case;
use crate::layout::Layout;
use crate::mesh::mesh_stage::MeshStage;
use crate::reduce::reduce_stage::{ModesStage, ReduceStage};
use crate::rotation::speed_stage::SpeedStage;
use crate::stage::{json, Stage};
use crate::stage_hash::fnv1a;
use crate::study::study_file::Study;

/// What a job computes: one stage of `nlmodes run`, or `Run`: a run's results folder
/// assembled from its stages' jobs, and its post-processing.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum JobKind {
    Mesh,
    Modes,
    Reduce,
    Speed,
    Campbell,
    Backbone,
    Forced,
    Run,
}

impl JobKind {
    pub const ALL: [JobKind; 8] = [
        JobKind::Mesh,
        JobKind::Modes,
        JobKind::Reduce,
        JobKind::Speed,
        JobKind::Campbell,
        JobKind::Backbone,
        JobKind::Forced,
        JobKind::Run,
    ];

    /// The rule's name in the Snakefile and the first part of a job id.
    pub fn name(self) -> &'static str {
        match self {
            JobKind::Mesh => "mesh",
            JobKind::Modes => "modes",
            JobKind::Reduce => "reduce",
            JobKind::Speed => "speed",
            JobKind::Campbell => "campbell",
            JobKind::Backbone => "backbone",
            JobKind::Forced => "forced",
            JobKind::Run => "run",
        }
    }
}

/// A job id: `<kind>-<key>` (`reduce-3fa9...`, `run-r004`).
pub fn job_id(kind: JobKind, key: &str) -> String {
    format!("{}-{key}", kind.name())
}

/// One job of the plan.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Job {
    pub kind: JobKind,
    /// The run whose case it runs the stage of (the first of `runs`).
    pub run: String,
    /// The jobs whose results it starts from.
    pub needs: Vec<String>,
    /// Its results folder, relative to the study folder: `stages/<kind>/<key>`, `runs/<id>`.
    pub dir: String,
    /// Where in a case's folder its stage writes, for the stages that have a place of their
    /// own: `speed`, `speeds/4000rpm` (speed; backbone at a speed), `mode_2` (backbone of one
    /// of several modes); empty otherwise.
    pub place: String,
    /// Every run that shares it.
    pub runs: Vec<String>,
}

/// One run of the plan: its parameter values and its jobs.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct PlanRun {
    pub id: String,
    /// One value per parameter, in the order of `Plan::parameters`.
    pub values: Vec<serde_json::Value>,
    /// Its stages' jobs (its `run-<id>` job aside).
    pub jobs: Vec<String>,
}

/// `plan.json`.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct Plan {
    pub format: String,
    pub format_version: u32,
    pub study: String,
    /// The study file, absolute.
    pub study_file: String,
    pub post: bool,
    /// The varied case keys.
    pub parameters: Vec<String>,
    pub runs: Vec<PlanRun>,
    pub jobs: BTreeMap<String, Job>,
}

pub const PLAN_FORMAT: &str = "nlmodes-study-plan";

impl Plan {
    /// Reads `<dir>/plan.json`.
    pub fn read(dir: &Path) -> Result<Self> {
        let path = dir.join("plan.json");
        let plan: Plan = crate::post::results::read_json(&path)
            .with_context(|| format!("reading the study plan {}", path.display()))?;
        anyhow::ensure!(
            plan.format == PLAN_FORMAT && plan.format_version == 1,
            "{} is not a study plan of this nlmodes (format {} {})",
            path.display(),
            plan.format,
            plan.format_version
        );
        Ok(plan)
    }

    /// The job `id`, or an error naming the plan.
    pub fn job(&self, id: &str) -> Result<&Job> {
        self.jobs.get(id).with_context(|| {
            format!(
                "no job {id} in the plan of study {} (rerun `nlmodes study`)",
                self.study
            )
        })
    }
}

/// The stages of one case in one results folder, as `nlmodes run` builds them.
pub struct CaseStages<'a> {
    pub case: &'a Case,
    pub layout: &'a Layout,
    pub mesh: MeshStage<'a>,
    pub modes: ModesStage<'a>,
    pub reduce: ReduceStage<'a>,
    pub speeds: Vec<SpeedStage<'a>>,
    pub campbell: Option<CampbellStage<'a>>,
    /// At rest, one per traced mode.
    pub backbones: Vec<BackboneStage<'a>>,
    /// One per speed of `speeds`.
    pub speed_backbones: Vec<BackboneStage<'a>>,
}

/// One stage of a case as a job: its id, kind, the jobs it starts from, the stage (none for
/// `forced`, whose stage reads the backbone when it is built: `study_job` builds it).
pub struct StageJob<'s> {
    pub id: String,
    pub kind: JobKind,
    /// See [`Job::place`].
    pub place: String,
    pub needs: Vec<String>,
    pub stage: Option<&'s dyn Stage>,
}

impl<'a> CaseStages<'a> {
    /// Reads the .geo file (the mesh stage hashes its bytes).
    pub fn new(case: &'a Case, layout: &'a Layout, material: &'a Isotropic) -> Result<Self> {
        let mesh = MeshStage::new(case, layout)?;
        let fe_hash = crate::reduce::reduce_stage::fe_hash(case, mesh.hash());
        let reduce = ReduceStage::new(case, layout, material, &fe_hash);
        let speeds = crate::run::speed_stages(case, material, layout, &fe_hash);
        let speed_backbones = speeds
            .iter()
            .map(|s| crate::run::speed_backbone_stage(case, s))
            .collect();
        Ok(Self {
            case,
            layout,
            modes: ModesStage::new(case, layout, &fe_hash),
            backbones: crate::run::backbone_stages(case, layout, reduce.hash()),
            campbell: case
                .rotation
                .as_ref()
                .map(|r| CampbellStage::new(case, r, material, layout, &fe_hash)),
            mesh,
            reduce,
            speeds,
            speed_backbones,
        })
    }

    /// Where a stage writes, relative to the case's folder (`speed`, `mode_2`, ...).
    fn place(&self, stage: &dyn Stage) -> String {
        let root = &stage.layout().root;
        root.strip_prefix(&self.layout.root)
            .map_or_else(|_| root.display().to_string(), |p| p.display().to_string())
    }

    /// A job of a stage whose key is its hash and its place.
    fn placed<'s>(&'s self, kind: JobKind, stage: &'s dyn Stage, needs: &str) -> StageJob<'s> {
        let place = self.place(stage);
        let key = fnv1a(&[stage.hash().as_bytes(), place.as_bytes()]);
        StageJob {
            id: job_id(kind, &key),
            kind,
            place,
            needs: vec![needs.to_string()],
            stage: Some(stage),
        }
    }

    /// Every stage of the case as a job, upstream first.
    pub fn jobs(&self) -> Vec<StageJob<'_>> {
        use JobKind::*;
        let mesh = job_id(Mesh, self.mesh.hash());
        let reduce = job_id(Reduce, self.reduce.hash());
        let on_mesh = || vec![mesh.clone()];
        let modes = job_id(Modes, self.modes.hash());
        let mut out = vec![
            stage_job(Mesh, &self.mesh, mesh.clone(), Vec::new()),
            stage_job(Modes, &self.modes, modes, on_mesh()),
            stage_job(Reduce, &self.reduce, reduce.clone(), on_mesh()),
        ];
        let speeds: Vec<StageJob> = self
            .speeds
            .iter()
            .map(|s| self.placed(Speed, s, &mesh))
            .collect();
        let speed_ids: Vec<String> = speeds.iter().map(|s| s.id.clone()).collect();
        out.extend(speeds);
        if let Some(c) = &self.campbell {
            out.push(stage_job(
                Campbell,
                c,
                job_id(Campbell, c.hash()),
                on_mesh(),
            ));
        }
        let backbones: Vec<StageJob> = self
            .backbones
            .iter()
            .map(|b| self.placed(Backbone, b, &reduce))
            .collect();
        let forced = self.forced_job(&reduce, &backbones);
        out.extend(backbones);
        for (b, speed) in self.speed_backbones.iter().zip(&speed_ids) {
            out.push(self.placed(Backbone, b, speed));
        }
        out.extend(forced);
        out
    }

    /// The forced stage's job: on the reduced model, crowned by the backbone of its mode when
    /// the case traces it (`crate::forced::forced_stage`); keyed by the reduction's hash, the
    /// `[forced]` table and that backbone's job.
    fn forced_job(&self, reduce: &str, backbones: &[StageJob]) -> Option<StageJob<'static>> {
        let case = self.case;
        if !case.forced.enabled {
            return None;
        }
        let traced = case.continuation.modes_to_trace();
        let backbone = traced
            .iter()
            .position(|&m| m == case.forced.mode)
            .map(|i| backbones[i].id.clone());
        let key = fnv1a(&[
            self.reduce.hash().as_bytes(),
            &json(&case.forced),
            backbone.as_deref().unwrap_or_default().as_bytes(),
        ]);
        Some(StageJob {
            id: job_id(JobKind::Forced, &key),
            kind: JobKind::Forced,
            place: String::new(),
            needs: std::iter::once(reduce.to_string())
                .chain(backbone)
                .collect(),
            stage: None,
        })
    }
}

fn stage_job(kind: JobKind, stage: &dyn Stage, id: String, needs: Vec<String>) -> StageJob<'_> {
    StageJob {
        id,
        kind,
        place: String::new(),
        needs,
        stage: Some(stage),
    }
}

/// The material of a case (checked by `validate::check_case` before).
pub fn material_of(case: &Case) -> Result<Isotropic> {
    let m = &case.material;
    Isotropic::new(m.young, m.poisson, m.density).context("[material] of the case")
}

/// The plan of a checked study whose runs' cases are `cases` (as read back from their files).
pub fn plan(study: &Study, cases: &[Case]) -> Result<Plan> {
    let mut jobs: BTreeMap<String, Job> = BTreeMap::new();
    let mut runs = Vec::new();
    for (run, case) in study.runs.iter().zip(cases) {
        let layout = Layout::new(case.out_dir());
        let material = material_of(case)?;
        let stages = CaseStages::new(case, &layout, &material)?;
        let mut own = Vec::new();
        for j in stages.jobs() {
            let key = j.id.split_once('-').map_or("", |(_, k)| k);
            let dir = format!("stages/{}/{key}", j.kind.name());
            let job = jobs.entry(j.id.clone()).or_insert_with(|| Job {
                kind: j.kind,
                run: run.id.clone(),
                needs: j.needs.clone(),
                dir,
                place: j.place.clone(),
                runs: Vec::new(),
            });
            anyhow::ensure!(
                job.needs == j.needs,
                "job {} of run {} starts from {:?} but from {:?} in run {}",
                j.id,
                run.id,
                j.needs,
                job.needs,
                job.run
            );
            job.runs.push(run.id.clone());
            own.push(j.id);
        }
        jobs.insert(
            job_id(JobKind::Run, &run.id),
            Job {
                kind: JobKind::Run,
                run: run.id.clone(),
                needs: own.clone(),
                dir: format!("runs/{}", run.id),
                place: String::new(),
                runs: vec![run.id.clone()],
            },
        );
        let values = run
            .values
            .iter()
            .map(serde_json::to_value)
            .collect::<Result<_, _>>()?;
        runs.push(PlanRun {
            id: run.id.clone(),
            values,
            jobs: own,
        });
    }
    Ok(Plan {
        format: PLAN_FORMAT.into(),
        format_version: 1,
        study: study.name.clone(),
        study_file: crate::study::study_file::absolute(&study.path)?
            .display()
            .to_string(),
        post: study.post,
        parameters: study.parameters.iter().map(|p| p.key.clone()).collect(),
        runs,
        jobs,
    })
}

/// How many jobs of each kind, and how many runs they serve: the sharing a study gets.
pub fn job_counts(plan: &Plan) -> BTreeMap<JobKind, (usize, usize)> {
    let mut out = BTreeMap::new();
    for job in plan.jobs.values() {
        let e = out.entry(job.kind).or_insert((0, 0));
        e.0 += 1;
        e.1 += job.runs.len();
    }
    out
}
