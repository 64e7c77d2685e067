//! `nlmodes run CASE.toml`: the study as the list of its stages, each a file of its own that
//! implements [`Stage`] (its inputs' hash, its outputs, its work) and reruns only when its inputs
//! changed (`crate::stage`). In order: mesh, reduce (the full model's modes then run beside the
//! stages up to forced), the Campbell diagram and the prestress and reduced model at each speed
//! (`[rotation]`), the backbone of each traced mode and at each speed, the forced response
//! (`[forced]`, at rest and at the operating speed), the speed sweeps (`[speed_sweep]`), the
//! interaction map, post and report.

use anyhow::{Context, Result};
use nlmodes_fem::Isotropic;

use crate::backbone::backbone_stage::BackboneStage;
use crate::campbell::campbell_stage::CampbellStage;
use crate::case::Case;
use crate::forced::forced_stage::ForcedStage;
use crate::layout::Layout;
use crate::mesh::mesh_stage::MeshStage;
use crate::post;
use crate::reduce::reduce_stage::{ModelRequest, ModesStage, ReduceStage};
use crate::rotation::speed_stage::SpeedStage;
use crate::speed_sweep::forced_speed_stage::SpeedSweepStage;
use crate::stage::{run_if_needed, Stage};

pub use crate::stage::Only;

/// What `--only` and `--force` select.
struct Selection {
    only: Option<Only>,
    force: bool,
}

impl Selection {
    fn wants(&self, s: Only) -> bool {
        self.only.is_none_or(|o| o == s)
    }

    fn wants_any(&self, s: &[Only]) -> bool {
        s.iter().any(|&o| self.wants(o))
    }

    /// `--force` reruns the `--only` stage (every stage without `--only`); the stages it depends
    /// on still rerun only when out of date.
    fn force(&self, s: Only) -> bool {
        self.force && self.wants(s)
    }

    /// Runs `stage` (when out of date) if it is selected or one of the stages `needed_by` is.
    fn run(&self, stage: &dyn Stage, needed_by: &[Only]) -> Result<()> {
        if self.wants(stage.only()) || self.wants_any(needed_by) {
            run_if_needed(stage, self.force(stage.only()))?;
        }
        Ok(())
    }
}

/// The first stage that stopped early (`StoppedEarly`, exit code 3): the others still run, and
/// the run ends with it.
#[derive(Default)]
struct Stops(Option<anyhow::Error>);

impl Stops {
    /// `Ok(true)` when the stage completed, `Ok(false)` when it stopped early; other errors pass.
    fn absorb(&mut self, r: Result<()>) -> Result<bool> {
        match r {
            Ok(()) => Ok(true),
            Err(e) if e.is::<crate::exit::StoppedEarly>() => {
                tracing::warn!("{e}");
                self.0.get_or_insert(e);
                Ok(false)
            }
            Err(e) => Err(e),
        }
    }

    fn finish(self) -> Result<()> {
        self.0.map_or(Ok(()), Err)
    }
}

/// Run the case; `only` runs that stage (and whatever it needs that is out of date); `force` reruns
/// the `only` stage even when it is up to date, or every stage when `only` is not given.
pub fn run(case_path: &std::path::Path, only: Option<Only>, force: bool) -> Result<()> {
    // Every key, cross-key rule and the output location, before the first stage (issue 14).
    let case = Case::load(case_path)?;
    crate::validate::check_case(&case, case_path)?;
    let layout = prepare(&case, case_path)?;
    let sel = Selection { only, force };
    let total = std::time::Instant::now();

    let mesh = MeshStage::new(&case, &layout)?;
    run_if_needed(&mesh, sel.force(Only::Mesh))?;
    if only == Some(Only::Mesh) {
        return Ok(());
    }
    let material = Isotropic::new(
        case.material.young,
        case.material.poisson,
        case.material.density,
    )
    .context("[material] of the case file")?;
    let fe_hash = crate::reduce::reduce_stage::fe_hash(&case, mesh.hash());
    let reduce = ReduceStage::new(&case, &layout, &material, &fe_hash);
    let modes = ModesStage::new(&case, &layout, &fe_hash);
    // The full model's modes run in a child process beside the stages below, until forced.
    let pending_modes = crate::reduce::reduce_stage::modes_and_reduce(
        &modes,
        &reduce,
        ModelRequest {
            modes: sel.wants(Only::Modes),
            force_modes: sel.force(Only::Modes),
            reduce: sel.wants_any(&[Only::Reduce, Only::Backbone, Only::Post]),
            force_reduce: sel.force(Only::Reduce),
        },
    )?;
    // The Campbell stage before the speed stages: they start their static solves from its
    // march's states (`crate::rotation::static_states`).
    let mut campbell_hash = None;
    if let Some(r) = &case.rotation {
        let campbell = CampbellStage::new(&case, r, &material, &layout, &fe_hash);
        sel.run(&campbell, &[Only::SpeedSweep, Only::Post])?;
        campbell_hash = Some(campbell.hash().to_string());
    }
    let speeds = speed_stages(&case, &material, &layout, &fe_hash);
    for stage in &speeds {
        sel.run(stage, &[Only::Backbone, Only::Forced, Only::Post])?;
    }
    let mut stops = Stops::default();
    let mut traced = Vec::new();
    for stage in backbone_stages(&case, &layout, reduce.hash()) {
        if stops.absorb(sel.run(&stage, &[Only::Post]))? {
            traced.push(stage.results().clone());
        }
    }
    let mut speed_posts = Vec::new();
    for speed in &speeds {
        let stage = speed_backbone_stage(&case, speed);
        if stops.absorb(sel.run(&stage, &[Only::Post]))? && sel.wants(Only::Post) {
            speed_posts.push(stage.results().clone());
        }
    }
    // The modes child ran beside the single-threaded backbones; the forced stages use both
    // cores (their levels in parallel), so the child ends first.
    pending_modes.finish()?;
    let last = LastStages::of(
        &case,
        &layout,
        reduce.hash(),
        &speeds,
        campbell_hash.as_deref(),
    );
    for result in side_by_side(&sel, &last.list()) {
        stops.absorb(result)?;
    }
    for results in &speed_posts {
        post::post(&case, results)?;
    }
    if let Some(r) = &case.rotation {
        if sel.wants_any(&[Only::Campbell, Only::Post]) {
            crate::campbell::campbell_stage::draw(&case, r, &layout)?;
        }
    }
    if sel.wants(Only::Post) {
        for lay in &traced {
            post::post(&case, lay)?;
        }
        let modes = case.continuation.modes_to_trace();
        if modes.len() > 1 {
            post::several_modes(&case, &layout, &modes)?;
        }
    }
    stops.finish()?;
    tracing::info!(
        "case {} done in {:.1} s; results in {}",
        case.name(),
        total.elapsed().as_secs_f64(),
        layout.root.display()
    );
    Ok(())
}

/// The stages after the backbones: the forced response (issue 22) after the backbone it is
/// crowned by, at rest and at the operating speed (issue 39, item 1), and the speed sweeps (item
/// 2) on the Campbell stage's parametric model; they run side by side ([`side_by_side`]).
struct LastStages<'a> {
    forced: Option<(ForcedStage<'a>, Option<ForcedStage<'a>>)>,
    sweeps: Option<SpeedSweepStage<'a>>,
}

impl<'a> LastStages<'a> {
    fn of(
        case: &'a Case,
        layout: &'a Layout,
        reduce_hash: &str,
        speeds: &'a [SpeedStage<'a>],
        campbell_hash: Option<&str>,
    ) -> Self {
        let forced = case.forced.enabled.then(|| {
            let at_rest = ForcedStage::new(case, layout, reduce_hash, "at rest");
            let at_speed = speeds.first().map(|operating| {
                let label = format!("at {} rpm", operating.speed_rpm());
                ForcedStage::new(case, operating.layout(), operating.hash(), &label)
            });
            (at_rest, at_speed)
        });
        let sweeps = match (&case.rotation, &case.speed_sweep, campbell_hash) {
            (Some(r), Some(sweep), Some(hash)) if sweep.enabled => {
                Some(SpeedSweepStage::new(case, r, sweep, layout, hash))
            }
            _ => None,
        };
        Self { forced, sweeps }
    }

    /// In the order their results are absorbed: at rest, at speed, the sweeps.
    fn list(&self) -> Vec<&(dyn Stage + Sync)> {
        let mut out: Vec<&(dyn Stage + Sync)> = Vec::new();
        if let Some((at_rest, at_speed)) = &self.forced {
            out.push(at_rest);
            out.extend(at_speed.iter().map(|s| s as &(dyn Stage + Sync)));
        }
        out.extend(self.sweeps.iter().map(|s| s as &(dyn Stage + Sync)));
        out
    }
}

/// Runs `stages` at the same time, each on a thread of its own (`Selection::run`), and returns
/// their results in their order: the forced stages at rest and at the operating speed and the
/// speed sweeps, which need nothing of each other. Each forced stage runs its levels on a pool
/// of its own (`crate::forced::run`). Measured on the default blade (docs/BENCHMARKS.md,
/// session 22): the forced stages alone already keep both cores busy, so this saves little
/// there (the block is CPU-bound); it fills the cores where one stage's tail is serial. Their
/// outputs are in different folders and the forced stages' log lines carry their span
/// ("forced{at=..}").
fn side_by_side(sel: &Selection, stages: &[&(dyn Stage + Sync)]) -> Vec<Result<()>> {
    std::thread::scope(|s| {
        let handles: Vec<_> = stages
            .iter()
            .map(|&stage| s.spawn(move || sel.run(stage, &[Only::Post])))
            .collect();
        handles
            .into_iter()
            .map(|h| h.join().unwrap_or_else(|p| std::panic::resume_unwind(p)))
            .collect()
    })
}

/// The results folder, created, with the temporary files of an interrupted run removed.
fn prepare(case: &Case, case_path: &std::path::Path) -> Result<Layout> {
    let layout = Layout::new(case.out_dir());
    std::fs::create_dir_all(&layout.root)
        .with_context(|| format!("cannot create {}", layout.root.display()))?;
    tracing::info!("case {} -> {}", case_path.display(), layout.root.display());
    let stale = nlmodes_output::remove_stale_temporaries(&layout.root)?;
    if stale > 0 {
        tracing::info!("removed {stale} temporary files left by an interrupted run");
    }
    Ok(layout)
}

/// The speed stages of `[rotation]`: the operating speed, then each map speed.
pub(crate) fn speed_stages<'a>(
    case: &'a Case,
    material: &'a Isotropic,
    layout: &Layout,
    fe_hash: &str,
) -> Vec<SpeedStage<'a>> {
    let Some(r) = &case.rotation else {
        return Vec::new();
    };
    std::iter::once(r.operating_speed)
        .chain(r.extra_map_speeds())
        .map(|rpm| SpeedStage::at(case, r, material, layout, fe_hash, rpm))
        .collect()
}

/// The backbone stage of each traced mode at rest (`mode_<k>/` and stamp `backbone_mode<k>`
/// when the case traces several).
pub(crate) fn backbone_stages<'a>(
    case: &'a Case,
    layout: &Layout,
    reduce_hash: &str,
) -> Vec<BackboneStage<'a>> {
    let modes = case.continuation.modes_to_trace();
    let several = modes.len() > 1;
    modes
        .iter()
        .map(|&mode| {
            let (lay, name) = if several {
                tracing::info!(
                    "mode {}: results in {}",
                    mode + 1,
                    layout.for_mode(mode).root.display()
                );
                (layout.for_mode(mode), format!("backbone_mode{}", mode + 1))
            } else {
                (layout.clone(), "backbone".to_string())
            };
            BackboneStage::new(case, mode, lay, reduce_hash, name)
        })
        .collect()
}

/// The backbone stage at a speed of `[rotation]`: the first traced mode on that speed's reduced
/// model, in its folder.
pub(crate) fn speed_backbone_stage<'a>(case: &'a Case, speed: &SpeedStage) -> BackboneStage<'a> {
    let mode = case.continuation.modes_to_trace()[0];
    BackboneStage::new(
        case,
        mode,
        speed.layout().clone(),
        speed.hash(),
        "backbone".into(),
    )
}
