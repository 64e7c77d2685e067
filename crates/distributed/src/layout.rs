//! Which rank owns which node, element and row: a METIS partition of the mesh (computed on
//! rank 0, broadcast), and the PETSc numbering of the free DOFs in which every rank owns one
//! contiguous range of rows.

use nlmodes_fem::{DofMap, Mesh};

use crate::collective::broadcast;
use crate::error::{DistributedError, Result};
use crate::launch::World;

/// The distribution of a mesh and its free DOFs over the ranks.
pub struct Layout {
    /// This process.
    pub world: World,
    /// PETSc row of each free DOF (free numbering of [`DofMap`]).
    pub row_of_free: Vec<usize>,
    /// Free DOF of each PETSc row.
    pub free_of_row: Vec<usize>,
    /// First PETSc row of each rank, and the number of free DOFs last (size + 1 entries).
    pub starts: Vec<usize>,
    /// The elements this rank assembles (ascending).
    pub elements: Vec<usize>,
}

impl Layout {
    /// Partitions `mesh` into `world.size` parts (METIS_PartMeshNodal: elements and nodes) and
    /// numbers the free DOFs part after part, ascending within a part.
    pub fn new(mesh: &Mesh, dofs: &DofMap, world: World) -> Result<Self> {
        let (element_part, node_part) = partition(mesh, world)?;
        let n_free = dofs.n_free();
        let mut counts = vec![0usize; world.size];
        for f in 0..n_free {
            counts[node_part[dofs.global_of_free(f) / 3] as usize] += 1;
        }
        let mut starts = vec![0usize; world.size + 1];
        for p in 0..world.size {
            starts[p + 1] = starts[p] + counts[p];
        }
        let mut next = starts.clone();
        let mut row_of_free = vec![0usize; n_free];
        let mut free_of_row = vec![0usize; n_free];
        for (f, row) in row_of_free.iter_mut().enumerate() {
            let p = node_part[dofs.global_of_free(f) / 3] as usize;
            *row = next[p];
            free_of_row[next[p]] = f;
            next[p] += 1;
        }
        let elements = (0..mesh.n_elements())
            .filter(|&e| element_part[e] as usize == world.rank)
            .collect();
        Ok(Self {
            world,
            row_of_free,
            free_of_row,
            starts,
            elements,
        })
    }

    /// The rows this rank owns.
    pub fn owned(&self) -> std::ops::Range<usize> {
        self.starts[self.world.rank]..self.starts[self.world.rank + 1]
    }

    /// The free DOF (serial numbering) of each row this rank owns.
    pub fn serial_free_index(&self) -> Vec<usize> {
        self.owned().map(|r| self.free_of_row[r]).collect()
    }

    /// The PETSc row of global DOF `dof` (3 node + component), `None` if it is fixed.
    pub fn row_of_dof(&self, dofs: &DofMap, dof: usize) -> Option<usize> {
        dofs.free_index(dof).map(|f| self.row_of_free[f])
    }
}

/// The part of every element and every node: all in part 0 for one rank, else METIS's nodal
/// partition on rank 0 broadcast to the others (one partition, whatever METIS's seed).
fn partition(mesh: &Mesh, world: World) -> Result<(Vec<i32>, Vec<i32>)> {
    let (ne, nn) = (mesh.n_elements(), mesh.n_nodes());
    if world.size == 1 {
        return Ok((vec![0; ne], vec![0; nn]));
    }
    let mut element_part = vec![0i32; ne];
    let mut node_part = vec![0i32; nn];
    let mut status = [0i32];
    if world.is_root() {
        status[0] = metis_nodal(mesh, world.size, &mut element_part, &mut node_part);
    }
    broadcast(&mut status[..]);
    if status[0] != metis_sys::rstatus_et_METIS_OK {
        return Err(DistributedError::Invalid(format!(
            "METIS could not partition the mesh ({ne} elements, {nn} nodes) into {} parts \
             (status {})",
            world.size, status[0]
        )));
    }
    broadcast(&mut element_part[..]);
    broadcast(&mut node_part[..]);
    Ok((element_part, node_part))
}

/// METIS_PartMeshNodal into `parts` parts; returns METIS's status.
fn metis_nodal(mesh: &Mesh, parts: usize, element_part: &mut [i32], node_part: &mut [i32]) -> i32 {
    let npe = mesh.kind.nodes_per_element();
    let mut ne = mesh.n_elements() as i32;
    let mut nn = mesh.n_nodes() as i32;
    let mut eptr: Vec<i32> = (0..=mesh.n_elements()).map(|e| (e * npe) as i32).collect();
    let mut eind: Vec<i32> = mesh.connectivity.iter().map(|&v| v as i32).collect();
    let mut nparts = parts as i32;
    let mut options = [0i32; metis_sys::METIS_NOPTIONS as usize];
    let mut objval = 0i32;
    // SAFETY: arrays of the sizes METIS documents (eptr ne + 1, eind ne npe, parts ne and nn).
    unsafe {
        metis_sys::METIS_SetDefaultOptions(options.as_mut_ptr());
        options[metis_sys::moptions_et_METIS_OPTION_NUMBERING as usize] = 0;
        metis_sys::METIS_PartMeshNodal(
            &mut ne,
            &mut nn,
            eptr.as_mut_ptr(),
            eind.as_mut_ptr(),
            std::ptr::null_mut(),
            std::ptr::null_mut(),
            &mut nparts,
            std::ptr::null_mut(),
            options.as_mut_ptr(),
            &mut objval,
            element_part.as_mut_ptr(),
            node_part.as_mut_ptr(),
        )
    }
}
