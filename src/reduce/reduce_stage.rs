//! The `modes` and `reduce` stages of `nlmodes run`. `modes`: the full model's clamped modes,
//! in a child process (`nlmodes modes`) so that its eigensolver runs on the second core while
//! this process traces the backbone (a process, not a thread: ARPACK keeps its state in Fortran
//! SAVE variables and is not re-entrant). `reduce`: the FE model's Craig-Bampton reduction onto
//! the contact nodes, written as `model/`. Both rerun when the mesh, `[material]` or the clamp
//! change; `modes` also with `linear_modes`, `reduce` with any `[model]` key. Under mpirun both
//! run over the ranks (`crate::reduce::reduce_mpi`), the modes in this process after the reduction.

use anyhow::{Context, Result};
use nlmodes_fem::Isotropic;
use std::path::PathBuf;

use crate::case::{Case, MasterChoice};
use crate::forced::forced_settings::ForcedLoadKind;
use crate::layout::Layout;
use crate::mesh::fe_model::FeModel;
use crate::reduce;
use crate::stage::{json, stamp, up_to_date, Only, Stage};
use crate::stage_hash::fnv1a;
use crate::ui;

/// The hash of the FE model (mesh, material, clamp): the input of every stage that assembles it.
pub fn fe_hash(case: &Case, mesh_hash: &str) -> String {
    fnv1a(&[
        mesh_hash.as_bytes(),
        &json(&case.material),
        &json(&case.model.clamp),
    ])
}

/// The modes stage.
pub struct ModesStage<'a> {
    case: &'a Case,
    layout: &'a Layout,
    hash: String,
}

impl<'a> ModesStage<'a> {
    pub fn new(case: &'a Case, layout: &'a Layout, fe_hash: &str) -> Self {
        let hash = fnv1a(&[fe_hash.as_bytes(), &json(&case.model.linear_modes)]);
        Self { case, layout, hash }
    }

    /// Whether `[model] full_check` asks for the full model's modes; `auto` counts the DOFs as
    /// 3 x the mesh's nodes (read from its header: the model is not assembled yet).
    pub fn wanted(&self) -> bool {
        let check = reduce::FullCheck::parse(&self.case.model.full_check)
            .unwrap_or(reduce::FullCheck::Auto);
        let dofs = reduce::msh_node_count(&self.layout.mesh()).map_or(0, |n| 3 * n);
        check.wanted(dofs)
    }

    /// Starts the stage in a child process.
    fn spawn(&self) -> Result<ModesChild> {
        ModesChild::spawn(self.case, self.layout)
    }
}

impl Stage for ModesStage<'_> {
    fn name(&self) -> String {
        "modes".into()
    }
    fn only(&self) -> Only {
        Only::Modes
    }
    fn hash(&self) -> &str {
        &self.hash
    }
    fn layout(&self) -> &Layout {
        self.layout
    }
    fn outputs(&self) -> Vec<PathBuf> {
        let d = self.layout.modes();
        vec![d.join("frequencies.csv"), d.join("modes.vtu")]
    }
    fn work(&self) -> Result<()> {
        if crate::reduce::reduce_mpi::distributed() {
            return self.over_mpi();
        }
        self.spawn()?.wait()
    }
}

impl ModesStage<'_> {
    /// Under mpirun: the modes over the ranks, in this process (the other ranks wait for
    /// rank 0's tasks: a child `nlmodes` would not be part of the MPI job).
    fn over_mpi(&self) -> Result<()> {
        let m = &self.case.material;
        let source = crate::reduce::reduce_mpi::FeSource {
            mesh: self.layout.mesh(),
            clamp: self.case.model.clamp.clone(),
            material: [m.young, m.poisson, m.density],
        };
        tracing::info!(
            "stage modes: {} clamped modes of the full model, over MPI",
            self.case.model.linear_modes
        );
        crate::reduce::reduce_mpi::write_full_modes(
            source,
            self.case.model.linear_modes,
            0.0,
            &self.layout.modes(),
        )
    }
}

/// The reduce stage.
pub struct ReduceStage<'a> {
    case: &'a Case,
    layout: &'a Layout,
    material: &'a Isotropic,
    hash: String,
}

impl<'a> ReduceStage<'a> {
    pub fn new(case: &'a Case, layout: &'a Layout, material: &'a Isotropic, fe_hash: &str) -> Self {
        let f = &case.forced;
        let load = match (f.enabled, f.load) {
            (true, ForcedLoadKind::Group) => Some(json(&(&f.load_group, f.load_direction))),
            (true, ForcedLoadKind::Pressure) => Some(json(&("pressure", &f.load_group))),
            _ => None,
        };
        // Without a full-model load the inputs are those of every earlier version (same stamps).
        let hash = match &load {
            None => fnv1a(&[fe_hash.as_bytes(), &json(&case.model)]),
            Some(l) => fnv1a(&[fe_hash.as_bytes(), &json(&case.model), l]),
        };
        Self {
            case,
            layout,
            material,
            hash,
        }
    }

    /// Builds the FE model, reduces it and writes `model/` (with `F.mtx`, the reduced load, and
    /// the load's static correction in the basis when `[forced] load = "group"` or
    /// `"pressure"`). Under mpirun the reduction runs over the ranks (`reduce_mpi`).
    fn reduce(&self) -> Result<nlmodes_modal::ReducedModel> {
        let mut settings = reduce_settings(self.case)?;
        let (mut model, full_load) = if crate::reduce::reduce_mpi::distributed() {
            let clamp = &self.case.model.clamp;
            let (mesh, dofs) = crate::mesh::fe_model::read_mesh(&self.layout.mesh(), clamp)?;
            let full_load = self.full_load(&mesh, &dofs, &mut settings)?;
            let side = reduce::MeshSide {
                mesh: &mesh,
                dofs: &dofs,
                clamp,
            };
            let source =
                crate::reduce::reduce_mpi::FeSource::new(&self.layout.mesh(), clamp, self.material);
            (
                reduce::reduce_distributed(
                    &side,
                    source,
                    &settings,
                    crate::reduce::reduce_mpi::RootData::default(),
                )?
                .0,
                full_load,
            )
        } else {
            let fe = FeModel::build(&self.layout.mesh(), self.material, &self.case.model.clamp)?;
            let full_load = self.full_load(&fe.mesh, &fe.dofs, &mut settings)?;
            (reduce::reduce(&fe, &settings)?.0, full_load)
        };
        let reduced_loads = settings
            .loads
            .iter()
            .map(|load| reduced_load(&model, load))
            .collect::<Result<Vec<_>>>()?;
        reduce::write_model(&mut model, &self.layout.model(), &self.layout.mesh())?;
        let path = self.layout.model().join("F.mtx");
        match (reduced_loads.first(), &full_load) {
            (Some(fr), Some(load)) => {
                let col = faer::Mat::from_fn(fr.len(), 1, |i, _| fr[i]);
                nlmodes_modal::matrix_market_general::write_dense_general(
                    &path,
                    col.as_ref(),
                    &load.description,
                )?;
            }
            _ if path.exists() => std::fs::remove_file(&path)?,
            _ => {}
        }
        Ok(model)
    }

    /// The full-model load of `[forced]` (group or pressure), if any, added to the settings'
    /// static-correction loads.
    fn full_load(
        &self,
        mesh: &nlmodes_fem::Mesh,
        dofs: &nlmodes_fem::DofMap,
        settings: &mut reduce::ReduceSettings,
    ) -> Result<Option<crate::forced::forced_settings::FullLoad>> {
        let f = &self.case.forced;
        let full_load = if f.enabled {
            crate::forced::forced_settings::full_load(f, mesh, dofs)?
        } else {
            None
        };
        if let Some(load) = &full_load {
            tracing::info!("stage reduce: {}", load.description);
            settings.loads = vec![load.f.clone()];
        }
        Ok(full_load)
    }

    /// The full model's frequencies (modes stage) against the reduced model's, when both exist.
    fn compare(&self, reduced_hz: &[f64]) {
        let full =
            crate::mesh::fe_model::read_frequencies(&self.layout.modes().join("frequencies.csv"));
        if let Some(full) = full {
            ui::say(&reduce::comparison_table(&full, reduced_hz));
        }
    }
}

impl Stage for ReduceStage<'_> {
    fn name(&self) -> String {
        "reduce".into()
    }
    fn only(&self) -> Only {
        Only::Reduce
    }
    fn hash(&self) -> &str {
        &self.hash
    }
    fn layout(&self) -> &Layout {
        self.layout
    }
    fn outputs(&self) -> Vec<PathBuf> {
        vec![self.layout.model().join("model.json")]
    }
    fn work(&self) -> Result<()> {
        self.reduce().map(|_| ())
    }
}

/// T^T f: the load `f` (free DOFs) on the reduced coordinates, by the model's recovery basis.
fn reduced_load(model: &nlmodes_modal::ReducedModel, f: &[f64]) -> Result<Vec<f64>> {
    let r = model
        .recovery
        .as_ref()
        .context("the reduced model has no recovery basis")?;
    anyhow::ensure!(
        r.nrows() == f.len(),
        "load of {} values for {} free DOFs",
        f.len(),
        r.nrows()
    );
    Ok((0..r.ncols())
        .map(|j| (0..r.nrows()).map(|i| r[(i, j)] * f[i]).sum())
        .collect())
}

/// What to run of the two stages and whether to force them.
pub struct ModelRequest {
    pub modes: bool,
    pub force_modes: bool,
    pub reduce: bool,
    pub force_reduce: bool,
}

/// Runs the reduce stage, then starts the modes stage in a child process that runs beside the
/// stages after it (the backbone's continuation is single-threaded, so the second core is free;
/// started beside the reduction instead, the two shared the cores and the reduction took 8.1 s
/// instead of 7.1 s). [`PendingModes::finish`] waits for it; dropping it unfinished (an error
/// on the way) kills it, so it is never left running. Under mpirun both run over the ranks in
/// this process, the modes after the reduction (`reduce_mpi`).
pub fn modes_and_reduce<'s>(
    modes: &'s ModesStage<'s>,
    red: &'s ReduceStage<'s>,
    want: ModelRequest,
) -> Result<PendingModes<'s>> {
    let mut reduced = None;
    if want.reduce && (want.force_reduce || !up_to_date(red)) {
        // On a thread of its own, as every stage (`crate::stage::on_own_thread`).
        let model = crate::stage::on_own_thread(|| red.reduce())?;
        stamp(red)?;
        reduced = Some(model.linear_frequencies_hz);
    } else if want.reduce {
        tracing::info!("stage reduce: up to date");
    }
    let mut child = None;
    if want.modes && !modes.wanted() {
        tracing::info!(
            "stage modes: skipped ([model] full_check = \"{}\", about {} DOFs)",
            modes.case.model.full_check,
            3 * reduce::msh_node_count(&modes.layout.mesh()).unwrap_or(0)
        );
    } else if want.modes && (want.force_modes || !up_to_date(modes)) {
        if crate::reduce::reduce_mpi::distributed() {
            crate::stage::on_own_thread(|| modes.over_mpi())?;
            stamp(modes)?;
        } else {
            child = Some(modes.spawn()?);
        }
    } else if want.modes {
        tracing::info!("stage modes: up to date");
    }
    Ok(PendingModes {
        modes,
        red,
        child,
        reduced,
    })
}

/// The modes stage running beside the later stages, and the reduced model's frequencies to
/// compare with its result.
pub struct PendingModes<'s> {
    modes: &'s ModesStage<'s>,
    red: &'s ReduceStage<'s>,
    child: Option<ModesChild>,
    /// The reduced model's linear frequencies (Hz), when the reduction ran in this call.
    reduced: Option<Vec<f64>>,
}

impl PendingModes<'_> {
    /// Waits for the modes stage, stamps it, and prints the full-against-reduced frequency
    /// table when the reduction ran.
    pub fn finish(mut self) -> Result<()> {
        if let Some(c) = self.child.take() {
            c.wait()?;
            stamp(self.modes)?;
        }
        if let Some(reduced) = self.reduced.take() {
            self.red.compare(&reduced);
        }
        Ok(())
    }
}

impl Drop for PendingModes<'_> {
    fn drop(&mut self) {
        if let Some(c) = self.child.take() {
            c.kill();
            // The killed child may have left its temporary files.
            let _ = nlmodes_output::remove_stale_temporaries(&self.modes.layout.modes());
        }
    }
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
        loads: Vec::new(),
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
            "stage modes: {} clamped modes of the full model, in a child process beside the stages that follow",
            case.model.linear_modes
        );
        crate::child::at_lower_priority(&mut cmd);
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
