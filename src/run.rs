//! `nlmodes run CASE.toml`: every stage of the study, each rerun only when its inputs changed.
//!
//! Make-like semantics with content hashes instead of time stamps: each stage's inputs (the
//! relevant case keys, and the hash of the stage it depends on, or the .geo file's bytes for the
//! mesh) are hashed; the hash is stored in `results/<case>/.stamps/<stage>` after the stage
//! succeeded, and the stage is skipped when the stored hash equals the new one and its outputs exist.

use anyhow::{Context, Result};
use nlmodes_fem::Isotropic;
use std::path::{Path, PathBuf};

use crate::case::{Case, MasterChoice};
use crate::fe_model::FeModel;
use crate::layout::Layout;
use crate::stage_hash::fnv1a;
use crate::{backbone, gmsh, post, reduce, ui};

/// A stage is up to date when its stamp holds `hash` and every output exists.
fn up_to_date(layout: &Layout, stage: &str, hash: &str, outputs: &[PathBuf]) -> bool {
    let stored = std::fs::read_to_string(layout.stamp(stage)).unwrap_or_default();
    stored.trim() == hash && outputs.iter().all(|p| p.exists())
}

fn stamp(layout: &Layout, stage: &str, hash: &str) -> Result<()> {
    let p = layout.stamp(stage);
    std::fs::create_dir_all(p.parent().unwrap_or(Path::new(".")))?;
    crate::output::write_atomic(&p, hash.as_bytes())
}

fn json<T: serde::Serialize>(v: &T) -> Vec<u8> {
    serde_json::to_vec(v).unwrap_or_default()
}

/// Which stages to run.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum Only {
    Mesh,
    Modes,
    Reduce,
    Backbone,
    Forced,
    /// The prestress and the reduced model at the operating speed (`[rotation]`).
    Speed,
    /// The Campbell diagram (`[rotation]`).
    Campbell,
    Post,
}

/// Run the case; `only` runs that stage (and whatever it needs that is out of date); `force` reruns
/// the `only` stage even when it is up to date, or every stage when `only` is not given (the stages
/// an `--only` stage depends on still rerun only when out of date).
pub fn run(case_path: &Path, only: Option<Only>, force: bool) -> Result<()> {
    // Every key, cross-key rule and the output location, before the first stage (issue 14).
    let case = Case::load(case_path)?;
    crate::validate::check_case(&case, case_path)?;
    let layout = Layout::new(case.out_dir());
    std::fs::create_dir_all(&layout.root)
        .with_context(|| format!("cannot create {}", layout.root.display()))?;
    tracing::info!("case {} -> {}", case_path.display(), layout.root.display());
    let stale = nlmodes_output::remove_stale_temporaries(&layout.root)?;
    if stale > 0 {
        tracing::info!("removed {stale} temporary files left by an interrupted run");
    }
    let wants = |s: Only| only.is_none_or(|o| o == s);
    let forced = |s: Only| force && wants(s);
    let total = std::time::Instant::now();

    // mesh
    let geo_bytes = std::fs::read(&case.mesh.geo)
        .with_context(|| format!("cannot read the geometry {}", case.mesh.geo.display()))?;
    let mesh_hash = fnv1a(&[
        &geo_bytes,
        &json(&case.mesh.parameters),
        &json(&case.mesh.order),
    ]);
    if forced(Only::Mesh) || !up_to_date(&layout, "mesh", &mesh_hash, &[layout.mesh()]) {
        let st = ui::Stage::start("mesh");
        gmsh::mesh(
            &case.mesh.geo,
            &case.mesh.parameters,
            case.mesh.order,
            &layout.mesh(),
        )?;
        stamp(&layout, "mesh", &mesh_hash)?;
        st.done(&format!("wrote {}", layout.mesh().display()));
    } else {
        tracing::info!("stage mesh: up to date");
    }
    if only == Some(Only::Mesh) {
        return Ok(());
    }

    let material = Isotropic::new(
        case.material.young,
        case.material.poisson,
        case.material.density,
    )
    .context("[material] of the case file")?;
    let fe_hash = fnv1a(&[
        mesh_hash.as_bytes(),
        &json(&case.material),
        &json(&case.model.clamp),
    ]);

    // modes: the full model's clamped modes, in a child process (`nlmodes modes`) so that its
    // eigensolver runs on the second core while this process reduces the model. A process, not a
    // thread: ARPACK keeps its state in Fortran SAVE variables and is not re-entrant.
    let modes_hash = fnv1a(&[fe_hash.as_bytes(), &json(&case.model.linear_modes)]);
    let modes_out = [
        layout.modes().join("frequencies.csv"),
        layout.modes().join("modes.vtu"),
    ];
    let mut modes_child = None;
    if wants(Only::Modes) && !full_check_wanted(&case, &layout) {
        tracing::info!(
            "stage modes: skipped ([model] full_check = \"{}\", about {} DOFs)",
            case.model.full_check,
            3 * crate::reduce::msh_node_count(&layout.mesh()).unwrap_or(0)
        );
    } else if wants(Only::Modes)
        && (forced(Only::Modes) || !up_to_date(&layout, "modes", &modes_hash, &modes_out))
    {
        modes_child = Some(ModesChild::spawn(&case, &layout)?);
    } else if wants(Only::Modes) {
        tracing::info!("stage modes: up to date");
    }
    // Waits for the modes and stamps them; on every path out of this function the child is
    // waited for (or killed, on error), never left running.
    let finish_modes = |child: Option<ModesChild>| -> Result<()> {
        if let Some(child) = child {
            child.wait()?;
            stamp(&layout, "modes", &modes_hash)?;
        }
        Ok(())
    };

    // reduce
    let reduce_hash = fnv1a(&[fe_hash.as_bytes(), &json(&case.model)]);
    let model_out = [layout.model().join("model.json")];
    let needs_model = wants(Only::Reduce) || wants(Only::Backbone) || wants(Only::Post);
    if needs_model
        && (forced(Only::Reduce) || !up_to_date(&layout, "reduce", &reduce_hash, &model_out))
    {
        let reduced = reduce_stage(&case, &layout, &material);
        let reduced = match reduced {
            Ok(model) => model,
            Err(e) => {
                if let Some(child) = modes_child.take() {
                    child.kill();
                    // The killed child may have left its temporary files.
                    let _ = nlmodes_output::remove_stale_temporaries(&layout.modes());
                }
                return Err(e);
            }
        };
        finish_modes(modes_child.take())?;
        let full = crate::fe_model::read_frequencies(&layout.modes().join("frequencies.csv"));
        if let Some(full) = full {
            ui::say(&reduce::comparison_table(
                &full,
                &reduced.linear_frequencies_hz,
            ));
        }
        stamp(&layout, "reduce", &reduce_hash)?;
    } else if needs_model {
        tracing::info!("stage reduce: up to date");
    }
    finish_modes(modes_child.take())?;

    // speed (issue 23): the prestress and the reduced model at the operating speed, then at
    // each map speed
    let speeds: Vec<crate::speed_stage::SpeedStage> = case
        .rotation
        .as_ref()
        .map(|r| {
            std::iter::once(r.operating_speed)
                .chain(r.extra_map_speeds())
                .map(|rpm| crate::speed_stage::SpeedStage::at(&case, r, &layout, &fe_hash, rpm))
                .collect()
        })
        .unwrap_or_default();
    for stage in &speeds {
        if wants(Only::Speed) || wants(Only::Backbone) || wants(Only::Post) {
            stage.run_if_needed(&material, forced(Only::Speed))?;
        }
    }
    if let Some(r) = &case.rotation {
        if wants(Only::Campbell) || wants(Only::Post) {
            crate::campbell_stage::CampbellStage::new(&case, r, &layout, &fe_hash)
                .run_if_needed(&material, forced(Only::Campbell))?;
        }
    }

    // backbone and post, for each mode the case traces
    let needs_bb = wants(Only::Backbone) || wants(Only::Post);
    let modes = case.continuation.modes_to_trace();
    let several = modes.len() > 1;
    let mut stopped = None;
    // The modes whose backbone is there to post-process (not stopped early in this run).
    let mut traced = Vec::new();
    for &mode in &modes {
        let (lay, stage) = if several {
            (layout.for_mode(mode), format!("backbone_mode{}", mode + 1))
        } else {
            (layout.clone(), "backbone".to_string())
        };
        if several {
            tracing::info!("mode {}: results in {}", mode + 1, lay.root.display());
        }
        let cont = nlmodes_nnm::ContinuationSettings {
            mode,
            ..case.continuation.clone()
        };
        let bb_hash = fnv1a(&[
            reduce_hash.as_bytes(),
            &json(&case.nnm),
            &json(&cont),
            &json(&case.algorithm),
            &json(&case.stability),
        ]);
        let bb_out = [
            lay.backbone().join("backbone.json"),
            lay.backbone().join("kept.json"),
        ];
        if needs_bb && (forced(Only::Backbone) || !up_to_date(&lay, &stage, &bb_hash, &bb_out)) {
            // A backbone stopped before q_max keeps its results but no stamp (exit code 3); the
            // other modes are still traced.
            match backbone_stage(&case, &cont, &lay) {
                Ok(()) => stamp(&lay, &stage, &bb_hash)?,
                Err(e) if e.is::<crate::exit::StoppedEarly>() => {
                    tracing::warn!("{e}");
                    stopped.get_or_insert(e);
                    continue;
                }
                Err(e) => return Err(e),
            }
        } else if needs_bb {
            tracing::info!("stage {stage}: up to date");
        }
        traced.push((mode, lay));
    }
    for stage in &speeds {
        if wants(Only::Backbone) || wants(Only::Post) {
            crate::speed_stage::backbone_at_speed(
                &case,
                stage,
                forced(Only::Backbone),
                wants(Only::Post),
            )?;
        }
    }
    // forced (issue 22): after the backbone it is crowned by, before the report that shows it
    if case.forced.enabled && (wants(Only::Forced) || wants(Only::Post)) {
        let stage = crate::forced_stage::ForcedStage::new(&case, &layout, &reduce_hash);
        match stage.run_if_needed(forced(Only::Forced)) {
            Err(e) if e.is::<crate::exit::StoppedEarly>() => {
                tracing::warn!("{e}");
                stopped.get_or_insert(e);
            }
            other => other?,
        }
    }
    if let Some(r) = &case.rotation {
        if wants(Only::Campbell) || wants(Only::Post) {
            crate::campbell_stage::draw(&case, r, &layout)?;
        }
    }
    for (_, lay) in &traced {
        if wants(Only::Post) {
            post::post(&case, lay)?;
        }
    }
    if several && wants(Only::Post) {
        post::several_modes(&case, &layout, &modes)?;
    }
    if let Some(e) = stopped {
        return Err(e);
    }
    tracing::info!(
        "case {} done in {:.1} s; results in {}",
        case.name(),
        total.elapsed().as_secs_f64(),
        layout.root.display()
    );
    Ok(())
}

/// Whether the full model's modes are computed (`[model] full_check`); `auto` counts the DOFs as
/// 3 x the mesh's nodes (read from its header: the model is not assembled yet).
fn full_check_wanted(case: &Case, layout: &Layout) -> bool {
    let check = crate::reduce::FullCheck::parse(&case.model.full_check)
        .unwrap_or(crate::reduce::FullCheck::Auto);
    let dofs = crate::reduce::msh_node_count(&layout.mesh()).map_or(0, |n| 3 * n);
    check.wanted(dofs)
}

/// The reduce stage: builds the FE model if needed, reduces it and writes the reduced model.
fn reduce_stage(
    case: &Case,
    layout: &Layout,
    material: &Isotropic,
) -> Result<nlmodes_modal::ReducedModel> {
    let fe = FeModel::build(&layout.mesh(), material, &case.model.clamp)?;
    let (mut model, _) = reduce::reduce(&fe, &reduce_settings(case)?)?;
    reduce::write_model(&mut model, &layout.model(), &layout.mesh())?;
    Ok(model)
}

/// The reduction settings of `[model]` (at rest; the speed stage adds the running contact).
pub fn reduce_settings(case: &Case) -> Result<reduce::ReduceSettings<'_>> {
    Ok(reduce::ReduceSettings {
        contact_group: &case.model.contact_group,
        axis: nlmodes_modal::RotorAxis::new(
            case.model.rotor_axis_point,
            case.model.rotor_axis_direction,
        )?,
        gap: case.model.gap,
        modes: case.model.fixed_interface_modes,
        master: match &case.model.master {
            MasterChoice::Index(i) => Some(*i),
            MasterChoice::Auto(s) if s == "auto" => None,
            MasterChoice::Auto(s) => {
                anyhow::bail!("[model] master = \"{s}\": expected \"auto\" or a reduced DOF index")
            }
        },
        // The full model's modes come from the modes stage, alongside.
        check_modes: 0,
        running: None,
    })
}

/// The modes stage running as `nlmodes --quiet modes ...` in a child process.
struct ModesChild {
    child: std::process::Child,
    stage: ui::Stage,
}

impl ModesChild {
    fn spawn(case: &Case, layout: &Layout) -> Result<Self> {
        let exe = std::env::current_exe().context("cannot locate the nlmodes executable")?;
        let mut cmd = std::process::Command::new(&exe);
        cmd.arg("--quiet")
            .arg("modes")
            .arg(layout.mesh())
            .arg("--young")
            .arg(format!("{:e}", case.material.young))
            .arg("--poisson")
            .arg(format!("{:e}", case.material.poisson))
            .arg("--density")
            .arg(format!("{:e}", case.material.density))
            .arg("--modes")
            .arg(case.model.linear_modes.to_string())
            .arg("--out")
            .arg(layout.modes());
        for f in &case.model.clamp {
            cmd.arg("--fix").arg(f);
        }
        // RUST_LOG would override --quiet and could fill the pipe read only at the end.
        cmd.env_remove("RUST_LOG")
            .stdout(std::process::Stdio::piped())
            .stderr(std::process::Stdio::piped());
        let stage = ui::Stage::start("modes");
        tracing::info!(
            "stage modes: {} clamped modes of the full model, in a child process alongside the reduction",
            case.model.linear_modes
        );
        let child = crate::child::die_with_parent(&mut cmd)
            .spawn()
            .with_context(|| format!("cannot start {} modes", exe.display()))?;
        Ok(Self { child, stage })
    }

    /// Waits for the child; its frequency table goes to stdout, its errors into ours.
    fn wait(self) -> Result<()> {
        let out = self
            .child
            .wait_with_output()
            .context("waiting for the modes stage")?;
        let stderr = String::from_utf8_lossy(&out.stderr);
        if !out.status.success() {
            anyhow::bail!("stage modes failed ({}): {}", out.status, stderr.trim());
        }
        if !stderr.trim().is_empty() {
            tracing::warn!("stage modes: {}", stderr.trim());
        }
        ui::say(String::from_utf8_lossy(&out.stdout).trim_end());
        self.stage.done("modes.vtu and frequencies.csv written");
        Ok(())
    }

    fn kill(mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

/// The backbone stage of one mode: trace, stability, kept orbits, truncation estimates, files.
pub fn backbone_stage(
    case: &Case,
    cont: &nlmodes_nnm::ContinuationSettings,
    layout: &Layout,
) -> Result<()> {
    let model = backbone::load_model(&layout.model())?;
    let system = backbone::system_of(&model, None)?;
    backbone::check_reaches_contact(&system, cont)?;
    let hs = nlmodes_nnm::HarmonicSettings::new(case.nnm.harmonics, case.nnm.samples)?;
    let mut b = backbone::trace(&system, hs, &case.algorithm, cont)?;
    backbone::stability(&system, &mut b, &case.stability)?;
    let mut kept = backbone::kept_points(&system, hs, &case.algorithm, &b, &case.nnm.keep)?;
    backbone::truncation(
        &system,
        hs,
        &case.algorithm,
        &mut b,
        &mut kept,
        case.nnm.truncation_every,
        case.nnm.truncation_tolerance,
    )?;
    backbone::write(&b, &layout.backbone())?;
    nlmodes_output::write_json(&layout.backbone().join("kept.json"), &kept)?;
    ui::say(&backbone::summary(&b, &case.algorithm));
    backbone::stopped_early(&b, &layout.backbone())
}
