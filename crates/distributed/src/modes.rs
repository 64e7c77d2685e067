//! The full model's modes over MPI (`nlmodes modes` under mpirun, the modes stage of `nlmodes
//! run`, the Campbell diagram's modes at a speed): K and M assembled over the ranks or sent by
//! rank 0 ([`Operators`]), the pairs of [`crate::pencil::nearest_modes`], the vectors gathered
//! on rank 0 in the free-DOF numbering of the serial path.

use nlmodes_fem::{DofMap, Mesh};
use nlmodes_modal::Modes;

use crate::bridge::gather_columns;
use crate::error::{DistributedError, Result};
use crate::layout::Layout;
use crate::operators::Operators;
use crate::pencil::{nearest_modes, Pencil};
use crate::session::world;

/// The `nev` modes of the free model nearest `sigma` (rad^2/s^2), on rank 0 (`None` on the
/// other ranks; collective).
pub fn full_modes(
    mesh: &Mesh,
    operators: Operators,
    dofs: &DofMap,
    nev: usize,
    sigma: f64,
) -> Result<Option<Modes>> {
    let world = world().ok_or_else(|| DistributedError::Invalid("no MPI session".into()))?;
    let layout = Layout::new(mesh, dofs, world)?;
    let (k, m) = operators.build(mesh, dofs, &layout)?;
    let what = format!("the full model ({} free DOFs)", dofs.n_free());
    let pencil = Pencil::whole(&k, &m, layout.serial_free_index())?;
    let (solver, local) = nearest_modes(&pencil, nev, sigma, &what)?;
    drop(pencil);
    drop((solver, k, m));
    let vectors = gather_columns(&local.vectors, &layout)?;
    Ok(vectors.map(|vectors| Modes {
        eigenvalues: local.eigenvalues,
        vectors,
        residuals: local.residuals,
    }))
}
