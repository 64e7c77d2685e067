//! Bridges between the serial data (sprs matrices and vectors in the free-DOF numbering of
//! [`nlmodes_fem::DofMap`]) and the distributed ones, for stages whose operators are still
//! assembled serially on every rank (the rotating blade's K(Omega) of the prestress and the
//! Campbell diagram): each rank copies its own rows into PETSc and gets the solution back.

use sprs::CsMat;

use crate::collective::gather_to_root;
use crate::error::{DistributedError, Result};
use crate::ffi;
use crate::layout::Layout;
use crate::petsc::{check, comm, int, Matrix, Vector};

/// A distributed copy of the symmetric free-DOF matrix `a` (CSC or CSR: a symmetric matrix's
/// columns are its rows): each rank inserts its own rows.
pub fn distributed_matrix(a: &CsMat<f64>, layout: &Layout) -> Result<Matrix> {
    let n = layout.row_of_free.len();
    if a.rows() != n || a.cols() != n {
        return Err(DistributedError::Invalid(format!(
            "a {}x{} matrix for a layout of {n} free DOFs",
            a.rows(),
            a.cols()
        )));
    }
    let owned = layout.owned();
    let (mut diagonal, mut off_diagonal) = (Vec::new(), Vec::new());
    for row in owned.clone() {
        let line = a.outer_view(layout.free_of_row[row]).expect("row in range");
        let d = line
            .indices()
            .iter()
            .filter(|&&f| owned.contains(&layout.row_of_free[f]))
            .count();
        diagonal.push(int(d)?);
        off_diagonal.push(int(line.nnz() - d)?);
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
    for row in owned {
        let line = a.outer_view(layout.free_of_row[row]).expect("row in range");
        let cols = line
            .indices()
            .iter()
            .map(|&f| int(layout.row_of_free[f]))
            .collect::<Result<Vec<_>>>()?;
        let r = int(row)?;
        check(
            unsafe {
                ffi::MatSetValues(
                    m.0,
                    1,
                    &r,
                    int(cols.len())?,
                    cols.as_ptr(),
                    line.data().as_ptr(),
                    ffi::InsertMode::INSERT_VALUES,
                )
            },
            "MatSetValues",
        )?;
    }
    m.assemble()?;
    m.set_option(ffi::MatOption::MAT_SYMMETRIC)?;
    Ok(m)
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
