//! The finite-element stages over MPI (issue 40; docs/LARGE_MODELS.md, "Over MPI"). Under
//! mpirun, rank 0 runs the command as the serial path does (reads and checks the input, runs
//! the stages, prints, writes every file) and hands each distributed computation to the other
//! ranks as a [`Task`] through `nlmodes_distributed::crew`; the other ranks [`serve`]: they
//! read the mesh the task names, compute their part with rank 0, and wait for the next task
//! until rank 0 ends. Only rank 0 prints and writes.
//!
//! The model at rest is assembled over the ranks; the operators of the blade at speed (the
//! prestress's Newton tangents, K(Omega) and M of the reductions at speed and of the Campbell
//! diagram's eigen-solves) are assembled on rank 0 by `nlmodes_fem::rotation` and sent to the
//! ranks by rows ([`RootData`]; `crate::rotation::rotation_mpi`).

use anyhow::{Context, Result};
use nlmodes_fem::{DofMap, Isotropic, Mesh};
use nlmodes_modal::Modes;
use serde::{Deserialize, Serialize};
use sprs::CsMat;
use std::path::{Path, PathBuf};

use crate::mesh::fe_model::read_mesh;

/// Where every rank finds the FE model: the mesh file (on a file system all ranks see), the
/// Dirichlet specifications and the material.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct FeSource {
    pub mesh: PathBuf,
    pub clamp: Vec<String>,
    /// Young's modulus (Pa), Poisson's ratio, density (kg/m^3).
    pub material: [f64; 3],
}

impl FeSource {
    pub fn new(mesh: &Path, clamp: &[String], material: &Isotropic) -> Self {
        Self {
            mesh: mesh.to_path_buf(),
            clamp: clamp.to_vec(),
            material: [material.young, material.poisson, material.density],
        }
    }

    fn material(&self) -> Result<Isotropic> {
        let [e, nu, rho] = self.material;
        Ok(Isotropic::new(e, nu, rho)?)
    }
}

/// A distributed computation, run by every rank.
#[derive(Debug, Serialize, Deserialize)]
pub enum Task {
    /// The Craig-Bampton reduction (`nlmodes_distributed::craig_bampton`) onto `boundary` (free
    /// DOFs), with `modes` fixed-interface modes, the first `check_modes` full-model modes and
    /// the static corrections of `loads` (free DOFs, N); of K and M sent by rank 0 when
    /// `from_root` (the model at speed), else assembled over the ranks.
    Reduce {
        fe: FeSource,
        boundary: Vec<usize>,
        modes: usize,
        check_modes: usize,
        loads: Vec<Vec<f64>>,
        from_root: bool,
    },
    /// The full model's `modes` modes nearest `sigma` (rad^2/s^2); of K and M sent by rank 0
    /// when `from_root` (K(Omega) of the Campbell diagram), else assembled over the ranks.
    Modes {
        fe: FeSource,
        modes: usize,
        sigma: f64,
        from_root: bool,
    },
    /// x = A^-1 b for the matrix A (free DOFs) and the vector b that rank 0 sends: a Newton
    /// step of the prestress, by MUMPS.
    StaticSolve { fe: FeSource },
}

/// What rank 0 sends with a task: K (or the matrix of a static solve), M and the right-hand
/// side, assembled on rank 0 (`None` on the other ranks, and for what the task does not use).
#[derive(Clone, Copy, Default)]
pub struct RootData<'a> {
    pub k: Option<&'a CsMat<f64>>,
    pub m: Option<&'a CsMat<f64>>,
    pub rhs: Option<&'a [f64]>,
}

/// What a task delivers on rank 0.
pub enum Delivered {
    Reduction(Box<nlmodes_distributed::Reduction>),
    Modes(Modes),
    Solution(Vec<f64>),
}

impl Task {
    fn fe(&self) -> &FeSource {
        match self {
            Self::Reduce { fe, .. } | Self::Modes { fe, .. } | Self::StaticSolve { fe } => fe,
        }
    }

    /// This rank's part of the task on the mesh of [`Task::fe`] (read already): the result on
    /// rank 0, `None` on the others.
    fn run_on(&self, mesh: &Mesh, dofs: &DofMap, root: RootData) -> Result<Option<Delivered>> {
        let material = self.fe().material()?;
        let operators = |from_root: bool| {
            if from_root {
                nlmodes_distributed::Operators::FromRoot(root.k.zip(root.m))
            } else {
                nlmodes_distributed::Operators::Assembled(&material)
            }
        };
        Ok(match self {
            Self::Reduce {
                boundary,
                modes,
                check_modes,
                loads,
                from_root,
                ..
            } => {
                let input = nlmodes_distributed::ReductionInput {
                    mesh,
                    operators: operators(*from_root),
                    dofs,
                    boundary,
                    n_modes: *modes,
                    check_modes: *check_modes,
                    loads,
                };
                nlmodes_distributed::craig_bampton(&input)?
                    .map(|r| Delivered::Reduction(Box::new(r)))
            }
            Self::Modes {
                modes,
                sigma,
                from_root,
                ..
            } => nlmodes_distributed::full_modes(mesh, operators(*from_root), dofs, *modes, *sigma)
                .with_context(|| {
                    format!("computing {modes} modes of the {}-DOF model", dofs.n_free())
                })?
                .map(Delivered::Modes),
            Self::StaticSolve { .. } => {
                nlmodes_distributed::solve_from_root(mesh, dofs, root.k, root.rhs)
                    .with_context(|| format!("a static solve of {} DOFs", dofs.n_free()))?
                    .map(Delivered::Solution)
            }
        })
    }
}

/// The ranks other than 0: the tasks of rank 0, one after the other, until it releases them.
pub fn serve() -> Result<()> {
    let mut last: Option<(PathBuf, Vec<String>, Mesh, DofMap)> = None;
    while let Some(bytes) = nlmodes_distributed::crew::next_task()? {
        let task: Task =
            serde_json::from_slice(&bytes).context("a task from rank 0 that cannot be read")?;
        let fe = task.fe();
        // The mesh of the previous task is kept (the tasks of one `nlmodes run` share it).
        if !last
            .as_ref()
            .is_some_and(|(path, clamp, ..)| *path == fe.mesh && *clamp == fe.clamp)
        {
            // The previous mesh is freed before the next is read.
            drop(last.take());
            let (mesh, dofs) = read_mesh(&fe.mesh, &fe.clamp)?;
            last = Some((fe.mesh.clone(), fe.clamp.clone(), mesh, dofs));
        }
        let (_, _, mesh, dofs) = last.as_ref().expect("read above");
        injected_failure()?;
        task.run_on(mesh, dofs, RootData::default())?;
    }
    Ok(())
}

/// The environment variable of the test hook [`injected_failure`].
const TEST_FAILURE_VARIABLE: &str = "NLMODES_TEST_TASK_FAILURE";

/// A test hook (tests/mpi_reduce.rs): with `NLMODES_TEST_TASK_FAILURE=error` (or `=panic`) in
/// its environment, a serving rank fails at the start of each task as a rank meeting an error
/// (or a bug) inside a task would, while rank 0 has gone on into the task's collectives:
/// the job must end with the message, not hang. Any other value is ignored.
fn injected_failure() -> Result<()> {
    match std::env::var(TEST_FAILURE_VARIABLE).as_deref() {
        Ok("error") => anyhow::bail!("{TEST_FAILURE_VARIABLE}=error: a failure inside the task"),
        Ok("panic") => panic!("{TEST_FAILURE_VARIABLE}=panic: a panic inside the task"),
        _ => Ok(()),
    }
}

/// Rank 0: hands `task` to the other ranks and computes its part with them, on the mesh of
/// [`Task::fe`] already read, with the matrices it sends (`root`).
pub fn lead(task: &Task, mesh: &Mesh, dofs: &DofMap, root: RootData) -> Result<Delivered> {
    let bytes = serde_json::to_vec(task).context("encoding a task for the other ranks")?;
    let assignment = nlmodes_distributed::crew::assign(&bytes)?;
    let delivered = task
        .run_on(mesh, dofs, root)?
        .context("rank 0 receives the result of every task")?;
    assignment.done();
    Ok(delivered)
}

/// The full model's `modes` modes nearest `sigma` over the ranks (rank 0: `nlmodes modes`
/// and the modes stage of `nlmodes run` under mpirun).
pub fn full_modes(fe: FeSource, modes: usize, sigma: f64) -> Result<(Mesh, DofMap, Modes)> {
    let (mesh, dofs) = read_mesh(&fe.mesh, &fe.clamp)?;
    let task = Task::Modes {
        fe,
        modes,
        sigma,
        from_root: false,
    };
    match lead(&task, &mesh, &dofs, RootData::default())? {
        Delivered::Modes(m) => Ok((mesh, dofs, m)),
        _ => anyhow::bail!("a modes task delivered something else"),
    }
}

/// `nlmodes modes` under mpirun and its stage in `nlmodes run`: the modes by SLEPc over the
/// ranks, written to `out` (`frequencies.csv`, `modes.vtu`) and printed by rank 0.
pub fn write_full_modes(source: FeSource, modes: usize, sigma: f64, out: &Path) -> Result<()> {
    let stage = crate::ui::Stage::start("modes");
    let (mesh, dofs, m) = full_modes(source, modes, sigma)?;
    let worst = m.residuals.iter().cloned().fold(0.0, f64::max);
    stage.done(&format!(
        "{} modes, largest relative residual {worst:.2e}",
        m.len()
    ));
    crate::mesh::fe_model::write_modes_of(&mesh, &dofs, &m, out)?;
    crate::ui::say(&crate::mesh::fe_model::frequency_table(&m));
    Ok(())
}

/// Whether this process runs under mpirun (the distributed path).
pub fn distributed() -> bool {
    nlmodes_distributed::world().is_some()
}
