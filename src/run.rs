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
use crate::{backbone, gmsh, post, reduce, ui};

/// FNV-1a, 64 bit: a stable hash of stage inputs (stable across Rust versions, unlike `DefaultHasher`).
pub fn fnv1a(parts: &[&[u8]]) -> String {
    let mut h: u64 = 0xcbf29ce484222325;
    for p in parts {
        for &b in p.iter().chain(&[0xff]) {
            h ^= b as u64;
            h = h.wrapping_mul(0x100000001b3);
        }
    }
    format!("{h:016x}")
}

/// Paths of a case's results.
pub struct Layout {
    pub root: PathBuf,
}

impl Layout {
    pub fn mesh(&self) -> PathBuf {
        self.root.join("mesh").join("mesh.msh")
    }
    pub fn modes(&self) -> PathBuf {
        self.root.join("modes")
    }
    pub fn model(&self) -> PathBuf {
        self.root.join("model")
    }
    pub fn backbone(&self) -> PathBuf {
        self.root.join("backbone")
    }
    fn stamp(&self, stage: &str) -> PathBuf {
        self.root.join(".stamps").join(stage)
    }
}

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
    Post,
}

/// Run the case; `only` runs that stage (and whatever it needs that is out of date); `force` reruns
/// the `only` stage even when it is up to date, or every stage when `only` is not given (the stages
/// an `--only` stage depends on still rerun only when out of date).
pub fn run(case_path: &Path, only: Option<Only>, force: bool) -> Result<()> {
    let case = Case::load(case_path)?;
    let layout = Layout {
        root: case.out_dir(),
    };
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
    let mut fe: Option<FeModel> = None;
    let fe_model = |fe: &mut Option<FeModel>| -> Result<()> {
        if fe.is_none() {
            *fe = Some(FeModel::build(
                &layout.mesh(),
                &material,
                &case.model.clamp,
            )?);
        }
        Ok(())
    };

    // modes
    let modes_hash = fnv1a(&[fe_hash.as_bytes(), &json(&case.model.linear_modes)]);
    let modes_out = [
        layout.modes().join("frequencies.csv"),
        layout.modes().join("modes.vtu"),
    ];
    if wants(Only::Modes)
        && (forced(Only::Modes) || !up_to_date(&layout, "modes", &modes_hash, &modes_out))
    {
        fe_model(&mut fe)?;
        let fe = fe.as_ref().context("FE model")?;
        let m = fe.modes(case.model.linear_modes, 0.0)?;
        crate::fe_model::write_modes(fe, &m, &layout.modes())?;
        ui::say(&crate::fe_model::frequency_table(&m));
        stamp(&layout, "modes", &modes_hash)?;
    } else if wants(Only::Modes) {
        tracing::info!("stage modes: up to date");
    }

    // reduce
    let reduce_hash = fnv1a(&[fe_hash.as_bytes(), &json(&case.model)]);
    let model_out = [layout.model().join("model.json")];
    let needs_model = wants(Only::Reduce) || wants(Only::Backbone) || wants(Only::Post);
    if needs_model
        && (forced(Only::Reduce) || !up_to_date(&layout, "reduce", &reduce_hash, &model_out))
    {
        fe_model(&mut fe)?;
        let fe = fe.as_ref().context("FE model")?;
        let settings = reduce::ReduceSettings {
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
                MasterChoice::Auto(s) => anyhow::bail!(
                    "[model] master = \"{s}\": expected \"auto\" or a reduced DOF index"
                ),
            },
        };
        let (mut model, _) = reduce::reduce(fe, &settings)?;
        reduce::write_model(&mut model, &layout.model(), &layout.mesh())?;
        let full = crate::fe_model::read_frequencies(&layout.modes().join("frequencies.csv"));
        if let Some(full) = full {
            ui::say(&reduce::comparison_table(
                &full,
                &model.linear_frequencies_hz,
            ));
        }
        stamp(&layout, "reduce", &reduce_hash)?;
    } else if needs_model {
        tracing::info!("stage reduce: up to date");
    }
    drop(fe);

    // backbone
    let bb_hash = fnv1a(&[
        reduce_hash.as_bytes(),
        &json(&case.nnm),
        &json(&case.continuation),
        &json(&case.algorithm),
    ]);
    let bb_out = [
        layout.backbone().join("backbone.json"),
        layout.backbone().join("kept.json"),
    ];
    let needs_bb = wants(Only::Backbone) || wants(Only::Post);
    if needs_bb && (forced(Only::Backbone) || !up_to_date(&layout, "backbone", &bb_hash, &bb_out)) {
        let model = backbone::load_model(&layout.model())?;
        let system = backbone::system_of(&model, None)?;
        backbone::check_reaches_contact(&system, &case.continuation)?;
        let hs = nlmodes_nnm::HarmonicSettings::new(case.nnm.harmonics, case.nnm.samples)?;
        let b = backbone::trace(&system, hs, &case.algorithm, &case.continuation)?;
        backbone::write(&b, &layout.backbone())?;
        let kept = backbone::kept_points(&system, hs, &case.algorithm, &b, &case.nnm.keep)?;
        nlmodes_output::write_json(&layout.backbone().join("kept.json"), &kept)?;
        ui::say(&backbone::summary(&b));
        stamp(&layout, "backbone", &bb_hash)?;
    } else if needs_bb {
        tracing::info!("stage backbone: up to date");
    }

    // post
    if wants(Only::Post) {
        post::post(&case, &layout)?;
    }
    tracing::info!(
        "case {} done in {:.1} s; results in {}",
        case.name(),
        total.elapsed().as_secs_f64(),
        layout.root.display()
    );
    Ok(())
}
