//! The MPI and PETSc/SLEPc session: started once in `main` when an MPI launcher started
//! nlmodes, finalized when its guard drops, and ended for every rank by
//! [`crate::crew::abort_if_parallel`] on an error.

use std::sync::OnceLock;

use mpi::topology::Communicator;

use crate::error::{DistributedError, Result};
use crate::ffi;
use crate::launch::{launch_variable, World};
use crate::petsc::check;

static WORLD: OnceLock<World> = OnceLock::new();

/// The running MPI session. Dropping it finalizes SLEPc/PETSc, then MPI.
pub struct Session {
    world: World,
    // Dropped after `Drop::drop` has finalized PETSc: MPI_Finalize.
    _universe: mpi::environment::Universe,
}

/// Starts MPI and PETSc/SLEPc if an MPI launcher started this process; `None` otherwise (the
/// serial path, untouched). PETSc reads its options from `PETSC_OPTIONS` and `~/.petscrc`
/// (`-eps_view`, `-log_view`, `-mat_mumps_icntl_*`, ...): the command line belongs to nlmodes.
pub fn start() -> Result<Option<Session>> {
    if launch_variable().is_none() {
        return Ok(None);
    }
    // `nlmodes run` runs each stage on a thread of its own, one after the other: MPI calls
    // come from several threads, never at the same time (MPI_THREAD_SERIALIZED).
    let (universe, provided) = mpi::initialize_with_threading(mpi::Threading::Serialized)
        .ok_or_else(|| DistributedError::MpiInit("MPI was already initialized".into()))?;
    if provided < mpi::Threading::Serialized {
        return Err(DistributedError::MpiInit(format!(
            "the MPI library provides thread level {provided:?}, MPI_THREAD_SERIALIZED is needed"
        )));
    }
    let comm = universe.world();
    let world = World {
        rank: comm.rank() as usize,
        size: comm.size() as usize,
    };
    // SAFETY: MPI is initialized on this thread; PETSc then uses MPI_COMM_WORLD.
    check(
        unsafe { ffi::SlepcInitializeNoArguments() },
        "SlepcInitialize",
    )?;
    let _ = WORLD.set(world);
    tracing::info!(
        "MPI: rank {} of {} (PETSc, SLEPc, MUMPS)",
        world.rank,
        world.size
    );
    Ok(Some(Session {
        world,
        _universe: universe,
    }))
}

impl Session {
    /// This process's place in the job.
    pub fn world(&self) -> World {
        self.world
    }
}

impl Drop for Session {
    fn drop(&mut self) {
        // SAFETY: PETSc was initialized by `start`; nothing PETSc is alive after `run`.
        unsafe {
            ffi::SlepcFinalize();
        }
    }
}

/// The job's world while a session runs; `None` on the serial path.
pub fn world() -> Option<World> {
    WORLD.get().copied()
}
