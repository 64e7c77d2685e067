//! Distributed assembly of the free-DOF stiffness K (N/m) and consistent mass M (kg): each rank
//! computes the element matrices of its elements ([`Layout::elements`], in parallel with rayon)
//! and adds them with MatSetValues; the entries of rows owned by another rank travel at
//! MatAssemblyEnd. The element matrices are those of the serial assembly
//! (`nlmodes_fem::element::element_matrices`, docs/DESIGN.md section 3).

use nlmodes_fem::element::element_matrices;
use nlmodes_fem::{DofMap, Isotropic, Mesh, NodeAdjacency};
use rayon::prelude::*;

use crate::error::Result;
use crate::ffi;
use crate::layout::Layout;
use crate::petsc::{check, comm, int, Matrix};

/// Elements whose matrices are computed in one parallel batch before they are added.
const BATCH: usize = 1024;

/// K and M over the free DOFs in the PETSc numbering of `layout` (MPIAIJ, preallocated exactly
/// from the node adjacency, flagged symmetric).
pub fn assemble(
    mesh: &Mesh,
    material: &Isotropic,
    dofs: &DofMap,
    layout: &Layout,
) -> Result<(Matrix, Matrix)> {
    material.validate()?;
    mesh.validate()?;
    let adjacency = NodeAdjacency::new(mesh);
    let (diagonal, off_diagonal) = preallocation(&adjacency, dofs, layout)?;
    drop(adjacency);
    let k = preallocated(layout, &diagonal, &off_diagonal)?;
    let m = preallocated(layout, &diagonal, &off_diagonal)?;
    add_elements(mesh, material, dofs, layout, &k, &m)?;
    for a in [&k, &m] {
        a.assemble()?;
        a.set_option(ffi::MatOption::MAT_SYMMETRIC)?;
    }
    Ok((k, m))
}

/// Nonzeros of each owned row in the columns this rank owns and in the others.
fn preallocation(
    adjacency: &NodeAdjacency,
    dofs: &DofMap,
    layout: &Layout,
) -> Result<(Vec<ffi::PetscInt>, Vec<ffi::PetscInt>)> {
    let owned = layout.owned();
    let mut diagonal = Vec::with_capacity(owned.len());
    let mut off_diagonal = Vec::with_capacity(owned.len());
    for row in owned.clone() {
        let node = dofs.global_of_free(layout.free_of_row[row]) / 3;
        let (mut d, mut o) = (0usize, 0usize);
        for &neighbour in adjacency.neighbours(node) {
            for c in 0..3 {
                match layout.row_of_dof(dofs, 3 * neighbour + c) {
                    Some(col) if owned.contains(&col) => d += 1,
                    Some(_) => o += 1,
                    None => {}
                }
            }
        }
        diagonal.push(int(d)?);
        off_diagonal.push(int(o)?);
    }
    Ok((diagonal, off_diagonal))
}

/// An empty AIJ matrix over the free DOFs with this preallocation.
fn preallocated(
    layout: &Layout,
    diagonal: &[ffi::PetscInt],
    off_diagonal: &[ffi::PetscInt],
) -> Result<Matrix> {
    let n = int(layout.row_of_free.len())?;
    let local = int(layout.owned().len())?;
    let mut a = std::ptr::null_mut();
    check(unsafe { ffi::MatCreate(comm(), &mut a) }, "MatCreate")?;
    let a = Matrix(a);
    check(
        unsafe { ffi::MatSetSizes(a.0, local, local, n, n) },
        "MatSetSizes",
    )?;
    check(
        unsafe { ffi::MatSetType(a.0, c"aij".as_ptr()) },
        "MatSetType",
    )?;
    check(
        unsafe { ffi::MatSeqAIJSetPreallocation(a.0, 0, diagonal.as_ptr()) },
        "MatSeqAIJSetPreallocation",
    )?;
    check(
        unsafe {
            ffi::MatMPIAIJSetPreallocation(a.0, 0, diagonal.as_ptr(), 0, off_diagonal.as_ptr())
        },
        "MatMPIAIJSetPreallocation",
    )?;
    Ok(a)
}

/// Computes the element matrices of this rank's elements batch by batch and adds them to K
/// and M; the first failing element (in mesh order among this rank's) is reported.
fn add_elements(
    mesh: &Mesh,
    material: &Isotropic,
    dofs: &DofMap,
    layout: &Layout,
    k: &Matrix,
    m: &Matrix,
) -> Result<()> {
    let npe = mesh.kind.nodes_per_element();
    let n_e = 3 * npe;
    let block = n_e * n_e;
    let mut k_buf = vec![0.0; BATCH * block];
    let mut m_buf = vec![0.0; BATCH * block];
    let mut rows = vec![0 as ffi::PetscInt; n_e];
    for batch in layout.elements.chunks(BATCH) {
        let failure = k_buf[..batch.len() * block]
            .par_chunks_mut(block)
            .zip(m_buf[..batch.len() * block].par_chunks_mut(block))
            .zip(batch.par_iter())
            .filter_map(|((ke, me), &e)| {
                let mut coords = [[0.0; 3]; 10];
                mesh.element_coords_into(e, &mut coords);
                element_matrices(
                    mesh.kind,
                    &coords[..npe],
                    material,
                    mesh.element_tag(e),
                    ke,
                    me,
                )
                .err()
                .map(|err| (e, err))
            })
            .min_by_key(|(e, _)| *e);
        if let Some((_, err)) = failure {
            return Err(err.into());
        }
        for (i, &e) in batch.iter().enumerate() {
            for (l, &node) in mesh.element(e).iter().enumerate() {
                for c in 0..3 {
                    // A negative index makes MatSetValues skip the row/column (fixed DOF).
                    rows[3 * l + c] = match layout.row_of_dof(dofs, 3 * node + c) {
                        Some(r) => r as ffi::PetscInt,
                        None => -1,
                    };
                }
            }
            for (a, buf) in [(k, &k_buf), (m, &m_buf)] {
                check(
                    unsafe {
                        ffi::MatSetValues(
                            a.0,
                            n_e as ffi::PetscInt,
                            rows.as_ptr(),
                            n_e as ffi::PetscInt,
                            rows.as_ptr(),
                            buf[i * block..(i + 1) * block].as_ptr(),
                            ffi::InsertMode::ADD_VALUES,
                        )
                    },
                    "MatSetValues",
                )?;
            }
        }
    }
    Ok(())
}
