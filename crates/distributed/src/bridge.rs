//! Bridges between the serial data (sprs matrices and vectors in the free-DOF numbering of
//! [`nlmodes_fem::DofMap`]) and the distributed ones, for operators assembled serially (the
//! rotating blade's K(Omega) and tangents of the prestress, the Campbell diagram and the
//! reduction at speed): held by every rank ([`distributed_matrix`]) or by rank 0 only, which
//! sends each rank its rows ([`scatter_matrix`]); the solution comes back to rank 0
//! ([`gather_free`], [`gather_columns`]).

use mpi::point_to_point::{Destination, Source};
use mpi::topology::{Communicator, SimpleCommunicator};
use sprs::CsMat;

use crate::collective::gather_to_root;
use crate::error::{DistributedError, Result};
use crate::ffi;
use crate::layout::Layout;
use crate::petsc::{check, comm, int, Matrix, Vector};

/// The tag of the messages of [`scatter_matrix`] and [`scatter_vector`] (MPI keeps the order
/// of messages between two ranks with the same tag).
const SCATTER_TAG: i32 = 4041;

/// The rows of one rank of a symmetric free-DOF matrix, in the PETSc numbering of a layout:
/// the length of each row, then its columns and values one row after the other.
struct RowBlock {
    lengths: Vec<ffi::PetscInt>,
    columns: Vec<ffi::PetscInt>,
    values: Vec<f64>,
}

/// The rows of rank `rank` of `a` (CSC or CSR: a symmetric matrix's columns are its rows).
fn row_block(a: &CsMat<f64>, layout: &Layout, rank: usize) -> Result<RowBlock> {
    let n = layout.row_of_free.len();
    if a.rows() != n || a.cols() != n {
        return Err(DistributedError::Invalid(format!(
            "a {}x{} matrix for a layout of {n} free DOFs",
            a.rows(),
            a.cols()
        )));
    }
    let rows = layout.starts[rank]..layout.starts[rank + 1];
    let mut block = RowBlock {
        lengths: Vec::with_capacity(rows.len()),
        columns: Vec::new(),
        values: Vec::new(),
    };
    for row in rows {
        let line = a.outer_view(layout.free_of_row[row]).expect("row in range");
        block.lengths.push(int(line.nnz())?);
        for (&f, &v) in line.indices().iter().zip(line.data()) {
            block.columns.push(int(layout.row_of_free[f])?);
            block.values.push(v);
        }
    }
    Ok(block)
}

/// The distributed matrix whose own rows on this rank are `block` (exact preallocation),
/// flagged symmetric.
fn matrix_of_rows(block: &RowBlock, layout: &Layout) -> Result<Matrix> {
    let n = layout.row_of_free.len();
    let owned = layout.owned();
    let (mut diagonal, mut off_diagonal) = (Vec::new(), Vec::new());
    let mut start = 0;
    for &len in &block.lengths {
        let line = &block.columns[start..start + len as usize];
        let d = line
            .iter()
            .filter(|&&c| owned.contains(&(c as usize)))
            .count();
        diagonal.push(int(d)?);
        off_diagonal.push(len - int(d)?);
        start += len as usize;
    }
    let mut m = std::ptr::null_mut();
    check(
        unsafe {
            ffi::MatCreateAIJ(
                comm(),
                int(owned.len())?,
                int(owned.len())?,
                int(n)?,
                int(n)?,
                0,
                diagonal.as_ptr(),
                0,
                off_diagonal.as_ptr(),
                &mut m,
            )
        },
        "MatCreateAIJ",
    )?;
    let m = Matrix(m);
    let mut start = 0;
    for (row, &len) in owned.zip(&block.lengths) {
        let end = start + len as usize;
        let r = int(row)?;
        check(
            unsafe {
                ffi::MatSetValues(
                    m.0,
                    1,
                    &r,
                    len,
                    block.columns[start..end].as_ptr(),
                    block.values[start..end].as_ptr(),
                    ffi::InsertMode::INSERT_VALUES,
                )
            },
            "MatSetValues",
        )?;
        start = end;
    }
    m.assemble()?;
    m.set_option(ffi::MatOption::MAT_SYMMETRIC)?;
    Ok(m)
}

/// A distributed copy of the symmetric free-DOF matrix `a`, which every rank holds (CSC or
/// CSR: a symmetric matrix's columns are its rows): each rank inserts its own rows.
pub fn distributed_matrix(a: &CsMat<f64>, layout: &Layout) -> Result<Matrix> {
    matrix_of_rows(&row_block(a, layout, layout.world.rank)?, layout)
}

/// A distributed copy of the symmetric free-DOF matrix `a`, which only rank 0 holds (`Some`
/// there, `None` on the others; collective): rank 0 sends each rank its rows (three messages),
/// so that no other rank holds more than its own.
pub fn scatter_matrix(a: Option<&CsMat<f64>>, layout: &Layout) -> Result<Matrix> {
    let comm = SimpleCommunicator::world();
    let block = if layout.world.is_root() {
        let a = a.ok_or_else(|| {
            DistributedError::Invalid("rank 0 scatters a matrix it does not have".into())
        })?;
        for rank in 1..layout.world.size {
            let block = row_block(a, layout, rank)?;
            let to = comm.process_at_rank(rank as i32);
            to.send_with_tag(&block.lengths[..], SCATTER_TAG);
            to.send_with_tag(&block.columns[..], SCATTER_TAG);
            to.send_with_tag(&block.values[..], SCATTER_TAG);
        }
        row_block(a, layout, 0)?
    } else {
        let from = comm.process_at_rank(0);
        let (lengths, _) = from.receive_vec_with_tag(SCATTER_TAG);
        let (columns, _) = from.receive_vec_with_tag(SCATTER_TAG);
        let (values, _) = from.receive_vec_with_tag(SCATTER_TAG);
        RowBlock {
            lengths,
            columns,
            values,
        }
    };
    matrix_of_rows(&block, layout)
}

/// A distributed vector with the rows of `a` holding the entries of `free` (the free-DOF
/// numbering), which only rank 0 holds (`Some` there; collective, as [`scatter_matrix`]).
pub fn scatter_vector(a: &Matrix, free: Option<&[f64]>, layout: &Layout) -> Result<Vector> {
    let comm = SimpleCommunicator::world();
    let local = if layout.world.is_root() {
        let free = free.ok_or_else(|| {
            DistributedError::Invalid("rank 0 scatters a vector it does not have".into())
        })?;
        let rows_of = |rank: usize| -> Vec<f64> {
            (layout.starts[rank]..layout.starts[rank + 1])
                .map(|r| free[layout.free_of_row[r]])
                .collect()
        };
        for rank in 1..layout.world.size {
            comm.process_at_rank(rank as i32)
                .send_with_tag(&rows_of(rank)[..], SCATTER_TAG);
        }
        rows_of(0)
    } else {
        comm.process_at_rank(0).receive_vec_with_tag(SCATTER_TAG).0
    };
    let v = a.row_vector()?;
    v.set_local(&local)?;
    Ok(v)
}

/// A distributed vector with the rows of `a` holding this rank's entries of `free` (a vector
/// in the free-DOF numbering, the same on every rank).
pub fn distributed_vector(a: &Matrix, free: &[f64], layout: &Layout) -> Result<Vector> {
    let v = a.row_vector()?;
    let local: Vec<f64> = layout
        .owned()
        .map(|r| free[layout.free_of_row[r]])
        .collect();
    v.set_local(&local)?;
    Ok(v)
}

/// The whole vector in the free-DOF numbering on rank 0 (`None` on the others).
pub fn gather_free(v: &Vector, layout: &Layout) -> Result<Option<Vec<f64>>> {
    let local = v.local()?;
    let frees: Vec<u64> = layout
        .owned()
        .map(|r| layout.free_of_row[r] as u64)
        .collect();
    let (order, values) = (gather_to_root(&frees)?, gather_to_root(&local)?);
    Ok(order.zip(values).map(|(order, values)| {
        let mut out = vec![0.0; order.len()];
        for (f, v) in order.into_iter().zip(values) {
            out[f as usize] = v;
        }
        out
    }))
}

/// The columns of `local` (this rank's own rows of distributed vectors) on rank 0 as whole
/// vectors in the free-DOF numbering (`None` on the others; collective, one column at a time).
pub fn gather_columns(local: &faer::Mat<f64>, layout: &Layout) -> Result<Option<faer::Mat<f64>>> {
    let frees: Vec<u64> = layout
        .owned()
        .map(|r| layout.free_of_row[r] as u64)
        .collect();
    let order = gather_to_root(&frees)?;
    let n = layout.row_of_free.len();
    let mut whole = order
        .as_ref()
        .map(|_| faer::Mat::<f64>::zeros(n, local.ncols()));
    for j in 0..local.ncols() {
        let col: Vec<f64> = local.col(j).iter().copied().collect();
        if let (Some(values), Some(out), Some(order)) =
            (gather_to_root(&col)?, whole.as_mut(), order.as_ref())
        {
            for (&f, v) in order.iter().zip(values) {
                out[(f as usize, j)] = v;
            }
        }
    }
    Ok(whole)
}
