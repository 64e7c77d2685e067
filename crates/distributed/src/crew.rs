//! Rank 0 leads, the other ranks serve: under mpirun, rank 0 runs the command as the serial
//! path does (reads and checks the input, runs the stages, prints, writes every file) and hands
//! each distributed computation to the other ranks as a task (opaque bytes here: the binary
//! encodes what to compute); they wait for it, run their part of it together with rank 0 and
//! wait for the next, until rank 0 releases them at its end. docs/LARGE_MODELS.md, "Over MPI".
//!
//! Errors end every rank and never hang: a rank that fails inside a task may leave the others
//! in a collective, so it ends the job ([`abort_if_parallel`]); rank 0 failing between tasks
//! releases the others (they end with status 0) and ends with its own status, so that mpirun
//! returns it without MPI_Abort's banner; a panic ends the job as an error inside a task does
//! ([`abort_on_panic`]). Waiting ranks sleep between probes (about 0 CPU)
//! instead of spinning in a blocking receive: the serial stages of rank 0 (gmsh, the backbone)
//! keep the cores.

use std::sync::atomic::{AtomicBool, AtomicU8, Ordering};
use std::time::Duration;

use mpi::point_to_point::{Destination, MatchedReceiveVec, Source};
use mpi::topology::{Communicator, SimpleCommunicator};

use crate::error::{DistributedError, Result};
use crate::session::world;

/// The tag of the task messages (distinct from PETSc's, which uses its own communicators).
const TASK_TAG: i32 = 4040;
/// Sleep between two probes of a waiting rank.
const PROBE_INTERVAL: Duration = Duration::from_millis(20);

/// Rank 0's state: 0 not leading (every rank runs the same code), 1 leading, 2 released.
static LEADING: AtomicU8 = AtomicU8::new(0);
/// Whether rank 0 is inside a task (the others may wait for it in a collective).
static BUSY: AtomicBool = AtomicBool::new(false);

const NOT_LEADING: u8 = 0;
const LEADS: u8 = 1;
const RELEASED: u8 = 2;

/// Rank 0 starts leading: from now on it sends the others their tasks ([`assign`]).
pub fn lead() {
    let _ = LEADING.compare_exchange(NOT_LEADING, LEADS, Ordering::SeqCst, Ordering::SeqCst);
}

/// A task rank 0 handed out: [`Assignment::done`] when rank 0's part of it succeeded. Dropped
/// without it (an error inside the task), the other ranks may be stuck in a collective and
/// the job is ended by [`abort_if_parallel`].
#[must_use = "call done() once rank 0's part of the task succeeded"]
pub struct Assignment(());

impl Assignment {
    /// Rank 0's part of the task is over; the others wait for the next one.
    pub fn done(self) {
        BUSY.store(false, Ordering::SeqCst);
    }
}

/// Rank 0: sends `task` to every other rank, which then runs it with rank 0. Only while
/// leading ([`lead`]) and not released.
pub fn assign(task: &[u8]) -> Result<Assignment> {
    if LEADING.load(Ordering::SeqCst) != LEADS {
        return Err(DistributedError::Invalid(
            "a distributed task outside the leading rank's run (nlmodes_distributed::crew)".into(),
        ));
    }
    if task.is_empty() {
        return Err(DistributedError::Invalid("an empty task".into()));
    }
    BUSY.store(true, Ordering::SeqCst);
    let comm = SimpleCommunicator::world();
    for rank in 1..comm.size() {
        comm.process_at_rank(rank).send_with_tag(task, TASK_TAG);
    }
    Ok(Assignment(()))
}

/// Rank 0 at its end: releases the waiting ranks (an empty message each), unless a task is
/// still running (an error inside it: [`abort_if_parallel`] ends the job then). Does nothing
/// on the other ranks, without a session or when not leading.
pub fn release() {
    if BUSY.load(Ordering::SeqCst)
        || LEADING
            .compare_exchange(LEADS, RELEASED, Ordering::SeqCst, Ordering::SeqCst)
            .is_err()
    {
        return;
    }
    let comm = SimpleCommunicator::world();
    let empty: [u8; 0] = [];
    for rank in 1..comm.size() {
        comm.process_at_rank(rank)
            .send_with_tag(&empty[..], TASK_TAG);
    }
}

/// A serving rank: the next task from rank 0, `None` when released. Sleeps between probes.
pub fn next_task() -> Result<Option<Vec<u8>>> {
    if world().is_none_or(|w| w.is_root()) {
        return Err(DistributedError::Invalid(
            "only the ranks other than 0 wait for tasks".into(),
        ));
    }
    let comm = SimpleCommunicator::world();
    let root = comm.process_at_rank(0);
    loop {
        if let Some(probed) = root.immediate_matched_probe_with_tag(TASK_TAG) {
            let (bytes, _) = probed.matched_receive_vec::<u8>();
            return Ok((!bytes.is_empty()).then_some(bytes));
        }
        std::thread::sleep(PROBE_INTERVAL);
    }
}

/// Ends every rank of the job with `code` (MPI_Abort) when a session runs with more than one
/// rank and the others may be waiting for this one in a collective; returns otherwise (the
/// caller then exits with `code`): on rank 0 once it released the others ([`release`]).
pub fn abort_if_parallel(code: i32) {
    let released = LEADING.load(Ordering::SeqCst) == RELEASED;
    if world().is_some_and(|w| w.size > 1) && !released {
        SimpleCommunicator::world().abort(code);
    }
}

/// From now on a panic on this rank, once its message is printed, ends the job like an error
/// ([`abort_if_parallel`], status 101 as Rust's panics): unwinding would reach MPI_Finalize,
/// which waits for ranks that may be waiting for this one in a collective. Every rank calls it
/// after [`crate::start`]; nothing happens without a session of more than one rank.
pub fn abort_on_panic() {
    if world().is_none_or(|w| w.size <= 1) {
        return;
    }
    let previous = std::panic::take_hook();
    std::panic::set_hook(Box::new(move |info| {
        previous(info);
        abort_if_parallel(PANIC_STATUS);
    }));
}

/// The exit status of a Rust panic.
const PANIC_STATUS: i32 = 101;
