//! The full-model solves of the blade at speed (DESIGN §9, docs/ROTATION.md) on this process
//! or over the ranks of an MPI job (issue 40; docs/LARGE_MODELS.md, "Over MPI"): the Newton
//! steps of the centrifugal static solves (the `speed` stage's prestress, the Campbell stage's
//! march), the lowest modes of K(Omega) (the Ritz basis of the Campbell diagram and its direct
//! check) and the Craig-Bampton reductions of K(Omega) (the model at speed, the parametric
//! model's basis). [`FullSolver`] holds the choice: the serial path's solvers unchanged, or the
//! matrices rank 0 assembles by `nlmodes_fem::rotation` sent by rows to MUMPS and the block
//! eigensolver over the ranks (`crate::reduce::reduce_mpi` tasks).

use std::path::Path;

use anyhow::Result;
use nlmodes_fem::rotation::{LinearSolveError, LinearSolver};
use nlmodes_fem::{DofMap, Isotropic, Mesh};
use nlmodes_modal::{Modes, ReducedModel};
use nlmodes_sparse::CholeskySolver;
use sprs::CsMat;

use crate::mesh::fe_model::FeModel;
use crate::reduce::reduce_mpi::{lead, Delivered, FeSource, RootData, Task};
use crate::reduce::ReduceSettings;

/// Where the full model's solves at speed run.
pub enum FullSolver {
    /// On this process (the serial path): the METIS-ordered sparse Cholesky, its ordering and
    /// symbolic analysis reused while the pattern stays ([`CholeskySolver`]).
    Here(CholeskySolver),
    /// Under mpirun, on rank 0: every solve a task of all the ranks.
    OverRanks(OverRanks),
}

impl Default for FullSolver {
    /// The serial path's solver.
    fn default() -> Self {
        Self::Here(CholeskySolver::default())
    }
}

/// The model the ranks solve: where they read it, and rank 0's copy of its mesh and DOF map
/// (the solver outlives no borrow: 0.2 GB at 1M DOFs, against the 7.5 GB factor it spreads).
pub struct OverRanks {
    source: FeSource,
    mesh: Mesh,
    dofs: DofMap,
}

impl FullSolver {
    /// The solver of the clamped model `fe` read from `mesh_file` with `material`: over the
    /// ranks under mpirun, else on this process.
    pub fn of(fe: &FeModel, mesh_file: &Path, material: &Isotropic) -> Self {
        if !crate::reduce::reduce_mpi::distributed() {
            return Self::default();
        }
        Self::OverRanks(OverRanks {
            source: FeSource::new(mesh_file, &fe.clamp, material),
            mesh: fe.mesh.clone(),
            dofs: fe.dofs.clone(),
        })
    }

    /// The `n` lowest modes of (`k`, `m`) on the free DOFs (N/m, kg): shift-invert at 0, here
    /// on the factor of `k` (the analysis of the last factorization reused) with the progress
    /// spinner `spinner`, or over the ranks (`k` and `m` sent by rows, block Lanczos on MUMPS).
    pub fn lowest_modes(
        &mut self,
        k: &CsMat<f64>,
        m: &CsMat<f64>,
        n: usize,
        spinner: &str,
    ) -> Result<Modes> {
        match self {
            Self::Here(cholesky) => {
                let factor = cholesky.factorize(k, "K(Omega)")?;
                Ok(crate::ui::with_solve_spinner(spinner, |opts| {
                    nlmodes_modal::eigs_shift_invert_factored(k, m, 0.0, factor, n, opts)
                })?)
            }
            Self::OverRanks(r) => {
                let task = Task::Modes {
                    fe: r.source.clone(),
                    modes: n,
                    sigma: 0.0,
                    from_root: true,
                };
                let root = RootData {
                    k: Some(k),
                    m: Some(m),
                    rhs: None,
                };
                match lead(&task, &r.mesh, &r.dofs, root)? {
                    Delivered::Modes(modes) => Ok(modes),
                    _ => anyhow::bail!("a modes task delivered something else"),
                }
            }
        }
    }

    /// The Craig-Bampton reduction of `fe` (its K the stiffness at speed) with `settings`: the
    /// serial `crate::reduce::reduce`, or over the ranks with K and M sent by rows.
    pub fn reduce(
        &self,
        fe: &FeModel,
        settings: &ReduceSettings,
    ) -> Result<(ReducedModel, Option<Vec<f64>>)> {
        let Self::OverRanks(r) = self else {
            return crate::reduce::reduce(fe, settings);
        };
        let side = crate::reduce::MeshSide {
            mesh: &fe.mesh,
            dofs: &fe.dofs,
            clamp: &fe.clamp,
        };
        let root = RootData {
            k: Some(&fe.k),
            m: Some(&fe.m),
            rhs: None,
        };
        crate::reduce::reduce_distributed(&side, r.source.clone(), settings, root)
    }
}

impl LinearSolver for FullSolver {
    /// A Newton step: by the Cholesky here, or by MUMPS over the ranks (the tangent and the
    /// right-hand side sent by rows, one analysis and factorization per step). A solve that
    /// fails over the ranks ends the job at once (the Newton solve's cutbacks would start new
    /// tasks while the other ranks may still wait in the failed one); a non-finite solution
    /// is reported as the serial solver's failures are.
    fn solve(&mut self, a: &CsMat<f64>, b: &[f64]) -> Result<Vec<f64>, LinearSolveError> {
        let r = match self {
            Self::Here(cholesky) => return cholesky.solve(a, b),
            Self::OverRanks(r) => r,
        };
        let task = Task::StaticSolve {
            fe: r.source.clone(),
        };
        let root = RootData {
            k: Some(a),
            m: None,
            rhs: Some(b),
        };
        let failure = match lead(&task, &r.mesh, &r.dofs, root) {
            Ok(Delivered::Solution(x)) if x.iter().all(|v| v.is_finite()) => return Ok(x),
            Ok(Delivered::Solution(_)) => {
                return Err(LinearSolveError(
                    "the MUMPS solve over the ranks gave a non-finite solution".into(),
                ))
            }
            Ok(_) => anyhow::anyhow!("a static-solve task delivered something else"),
            Err(e) => e.context("a Newton step's solve over the ranks"),
        };
        eprintln!("error (MPI rank 0): {failure:#}");
        nlmodes_distributed::abort_if_parallel(crate::exit::code_of(&failure).into());
        // One rank only: nothing waits for this one, the Newton solve reports the failure.
        Err(LinearSolveError(format!("{failure:#}")))
    }

    /// Here, on the Cholesky's last factor; over the ranks none is kept (each MUMPS task
    /// factors its own matrix), so the Newton solves take full steps.
    fn solve_with_last_factor(&mut self, b: &[f64]) -> Option<Result<Vec<f64>, LinearSolveError>> {
        match self {
            Self::Here(cholesky) => cholesky.solve_with_last_factor(b),
            Self::OverRanks(_) => None,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Without mpirun the solver is the serial path's: its Newton steps and its modes are those
    /// of `CholeskySolver` and the shift-invert solve on its factor, bit for bit.
    #[test]
    fn without_mpirun_the_solver_is_the_serial_cholesky() {
        let fe = crate::campbell::campbell_march::fixtures::beam([4, 1, 1]);
        let material = crate::campbell::campbell_march::fixtures::steel();
        let mut solver = FullSolver::of(&fe, Path::new("beam.msh"), &material);
        assert!(matches!(solver, FullSolver::Here(_)));
        let b: Vec<f64> = (0..fe.k.rows()).map(|i| (i as f64).sin()).collect();
        let x = solver.solve(&fe.k, &b).unwrap();
        let y = CholeskySolver::default().solve(&fe.k, &b).unwrap();
        assert_eq!(x, y);
        let modes = solver.lowest_modes(&fe.k, &fe.m, 3, "test").unwrap();
        let mut cholesky = CholeskySolver::default();
        let factor = cholesky.factorize(&fe.k, "K").unwrap();
        let opts = nlmodes_modal::EigenOptions::default();
        let direct =
            nlmodes_modal::eigs_shift_invert_factored(&fe.k, &fe.m, 0.0, factor, 3, &opts).unwrap();
        assert_eq!(modes.eigenvalues, direct.eigenvalues);
        assert_eq!(modes.vectors, direct.vectors);
    }
}
