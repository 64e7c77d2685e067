//! Where the distributed stages get K and M: assembled over the ranks from the mesh (the
//! model at rest), or assembled serially on rank 0 and scattered by rows (the rotating blade's
//! stiffness at speed K(Omega), whose prestress and stress stiffening `nlmodes_fem::rotation`
//! computes on one process).

use nlmodes_fem::{DofMap, Isotropic, Mesh};
use sprs::CsMat;

use crate::assembly::assemble;
use crate::bridge::scatter_matrix;
use crate::error::Result;
use crate::layout::Layout;
use crate::petsc::Matrix;

/// The source of K (N/m) and M (kg) over the free DOFs.
#[derive(Clone, Copy)]
pub enum Operators<'a> {
    /// Assembled over the ranks from the mesh and this material (each rank its elements).
    Assembled(&'a Isotropic),
    /// K and M held by rank 0 (`Some` there, `None` on the other ranks), sent by rows.
    FromRoot(Option<(&'a CsMat<f64>, &'a CsMat<f64>)>),
}

impl Operators<'_> {
    /// K and M in the PETSc numbering of `layout` (collective).
    pub fn build(&self, mesh: &Mesh, dofs: &DofMap, layout: &Layout) -> Result<(Matrix, Matrix)> {
        match self {
            Self::Assembled(material) => assemble(mesh, material, dofs, layout),
            Self::FromRoot(km) => Ok((
                scatter_matrix(km.map(|(k, _)| k), layout)?,
                scatter_matrix(km.map(|(_, m)| m), layout)?,
            )),
        }
    }
}
