//! The few MPI collectives the distributed stages need besides PETSc's (rsmpi, `mpi` crate).

use mpi::datatype::{Equivalence, PartitionMut};
use mpi::topology::SimpleCommunicator;
use mpi::traits::*;

use crate::error::{DistributedError, Result};

fn world() -> SimpleCommunicator {
    SimpleCommunicator::world()
}

/// Sums `values` over the ranks, in place, on every rank.
pub fn sum_all(values: &mut [f64]) {
    let send = values.to_vec();
    world().all_reduce_into(&send[..], values, mpi::collective::SystemOperation::sum());
}

/// The maximum of `value` over the ranks.
pub fn max_all(value: f64) -> f64 {
    let mut out = 0.0;
    world().all_reduce_into(&value, &mut out, mpi::collective::SystemOperation::max());
    out
}

/// Rank 0's `values` on every rank (the length must be the same everywhere).
pub fn broadcast<T: Equivalence>(values: &mut [T]) {
    world().process_at_rank(0).broadcast_into(values);
}

/// Every rank's `local` values, concatenated in rank order, on rank 0; `None` elsewhere.
pub fn gather_to_root<T: Equivalence + Copy + Default>(local: &[T]) -> Result<Option<Vec<T>>> {
    let comm = world();
    let root = comm.process_at_rank(0);
    let count = i32::try_from(local.len()).map_err(|_| {
        DistributedError::Invalid(format!(
            "{} values to gather from one rank: more than MPI's 32-bit counts",
            local.len()
        ))
    })?;
    if comm.rank() != 0 {
        root.gather_into(&count);
        root.gather_varcount_into(local);
        return Ok(None);
    }
    let mut counts = vec![0i32; comm.size() as usize];
    root.gather_into_root(&count, &mut counts[..]);
    let displs: Vec<i32> = counts
        .iter()
        .scan(0i32, |acc, &c| {
            let d = *acc;
            *acc += c;
            Some(d)
        })
        .collect();
    let total: usize = counts.iter().map(|&c| c as usize).sum();
    let mut all = vec![T::default(); total];
    {
        let mut partition = PartitionMut::new(&mut all[..], &counts[..], &displs[..]);
        root.gather_varcount_into_root(local, &mut partition);
    }
    Ok(Some(all))
}

/// Every rank's `local` values, concatenated in rank order, on every rank.
pub fn gather_to_all<T: Equivalence + Copy + Default>(local: &[T]) -> Vec<T> {
    let comm = world();
    let count = local.len() as i32;
    let mut counts = vec![0i32; comm.size() as usize];
    comm.all_gather_into(&count, &mut counts[..]);
    let displs: Vec<i32> = counts
        .iter()
        .scan(0i32, |acc, &c| {
            let d = *acc;
            *acc += c;
            Some(d)
        })
        .collect();
    let total: usize = counts.iter().map(|&c| c as usize).sum();
    let mut all = vec![T::default(); total];
    {
        let mut partition = PartitionMut::new(&mut all[..], &counts[..], &displs[..]);
        comm.all_gather_varcount_into(local, &mut partition);
    }
    all
}
