//! The errors of the distributed path.

use thiserror::Error;

/// An error of a distributed stage. Every rank that sees one ends the whole job
/// ([`crate::abort_if_parallel`]): a collective operation would otherwise wait for it forever.
#[derive(Debug, Error)]
pub enum DistributedError {
    /// Launched by an MPI launcher (`mpirun`) but this nlmodes was built without the `mpi`
    /// feature (PETSc, SLEPc, MUMPS).
    #[error(
        "nlmodes was launched by mpirun ({variable} is set) but was built without MPI support \
         (cargo feature `mpi` off): rebuild with the default features after scripts/deps, or \
         run it without mpirun"
    )]
    NotBuilt { variable: String },
    /// MPI could not be initialized (the library is missing or the launch is broken).
    #[error("MPI could not be initialized ({0})")]
    MpiInit(String),
    /// A PETSc or SLEPc call returned an error code (its traceback is on stderr).
    #[error("{call} failed with PETSc error code {code} (PETSc's traceback above, on stderr)")]
    Petsc { call: &'static str, code: i32 },
    /// The model or a request does not fit the distributed path.
    #[error("{0}")]
    Invalid(String),
    /// The eigensolver delivered fewer pairs than asked.
    #[error(
        "SLEPc converged {converged} of the {wanted} eigenpairs of {what} (Krylov-Schur, \
         shift-invert at {sigma:e} rad^2/s^2) in {iterations} restarts; raise -eps_max_it or \
         ask for fewer modes"
    )]
    NotConverged {
        what: String,
        wanted: usize,
        converged: usize,
        sigma: f64,
        iterations: usize,
    },
    /// An error of the FE model (element with a bad Jacobian, invalid material, ...).
    #[error(transparent)]
    Fem(#[from] nlmodes_fem::FemError),
    /// An error of the reduction's dense algebra.
    #[error(transparent)]
    Modal(#[from] nlmodes_modal::ModalError),
}

/// Result of the distributed path.
pub type Result<T> = std::result::Result<T, DistributedError>;
