//! Whether nlmodes runs under an MPI launcher, and the MPI + PETSc/SLEPc session.

/// The environment variables an MPI launcher sets in every process it starts: Open MPI's
/// `mpirun` (`OMPI_COMM_WORLD_SIZE`), PMIx launchers (`PMIX_RANK`, Slurm's `srun --mpi=pmix`)
/// and MPICH/Hydra or Slurm PMI-2 (`PMI_SIZE`).
const LAUNCH_VARIABLES: [&str; 3] = ["OMPI_COMM_WORLD_SIZE", "PMIX_RANK", "PMI_SIZE"];

/// The launcher variable that is set, if nlmodes was started by an MPI launcher.
pub fn launch_variable() -> Option<&'static str> {
    LAUNCH_VARIABLES
        .iter()
        .copied()
        .find(|v| std::env::var_os(v).is_some())
}

/// This process's place in the job.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct World {
    /// Rank of this process, 0 ..= size - 1.
    pub rank: usize,
    /// Number of processes.
    pub size: usize,
}

impl World {
    /// Whether this process writes the results (rank 0).
    pub fn is_root(&self) -> bool {
        self.rank == 0
    }
}
