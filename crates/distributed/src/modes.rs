//! The full model's modes over MPI (`nlmodes modes` under mpirun): distributed assembly and
//! SLEPc, the vectors gathered on rank 0 in the free-DOF numbering of the serial path.

use faer::Mat;
use nlmodes_fem::{DofMap, Isotropic, Mesh};
use nlmodes_modal::Modes;

use crate::assembly::assemble;
use crate::collective::gather_to_root;
use crate::error::{DistributedError, Result};
use crate::layout::Layout;
use crate::pencil::{nearest_modes, Pencil};
use crate::session::world;

/// The `nev` modes of the free model nearest `sigma` (rad^2/s^2), on rank 0 (`None` on the
/// other ranks; collective).
pub fn full_modes(
    mesh: &Mesh,
    material: &Isotropic,
    dofs: &DofMap,
    nev: usize,
    sigma: f64,
) -> Result<Option<Modes>> {
    let world = world().ok_or_else(|| DistributedError::Invalid("no MPI session".into()))?;
    let layout = Layout::new(mesh, dofs, world)?;
    let (k, m) = assemble(mesh, material, dofs, &layout)?;
    let what = format!("the full model ({} free DOFs)", dofs.n_free());
    let pencil = Pencil::whole(&k, &m, layout.serial_free_index())?;
    let (solver, local) = nearest_modes(&pencil, nev, sigma, &what)?;
    drop(pencil);
    drop((solver, k, m));
    let frees: Vec<u64> = layout
        .owned()
        .map(|r| layout.free_of_row[r] as u64)
        .collect();
    let order = gather_to_root(&frees)?;
    let mut vectors = order
        .as_ref()
        .map(|_| Mat::<f64>::zeros(dofs.n_free(), nev));
    for j in 0..nev {
        let col: Vec<f64> = (0..local.vectors.nrows())
            .map(|r| local.vectors[(r, j)])
            .collect();
        if let (Some(values), Some(out), Some(order)) =
            (gather_to_root(&col)?, vectors.as_mut(), order.as_ref())
        {
            for (&f, v) in order.iter().zip(values) {
                out[(f as usize, j)] = v;
            }
        }
    }
    Ok(vectors.map(|vectors| Modes {
        eigenvalues: local.eigenvalues,
        vectors,
        residuals: local.residuals,
    }))
}
