//! The MPI and PETSc/SLEPc session: started once in `main` when an MPI launcher started
//! nlmodes, finalized when its guard drops, and ended for every rank by [`abort`] on an error.

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
    let (universe, _) = mpi::initialize_with_threading(mpi::Threading::Funneled)
        .ok_or_else(|| DistributedError::MpiInit("MPI was already initialized".into()))?;
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

/// Ends every rank of the job with `code` (MPI_Abort), when a session runs with more than one
/// rank; returns otherwise (the caller then exits normally).
pub fn abort_if_parallel(code: i32) {
    if world().is_some_and(|w| w.size > 1) {
        mpi::topology::SimpleCommunicator::world().abort(code);
    }
}
