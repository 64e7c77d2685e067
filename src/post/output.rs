//! Output glue of the binary over nlmodes-output: atomic files, VTU of the FE mesh.

use anyhow::Result;
use nlmodes_output::{Field, Precision, VtuEncoding, VtuMesh, VtuWriter};
use std::path::Path;

/// Write `bytes` to `path` through a temporary file in the same directory and a rename.
pub fn write_atomic(path: &Path, bytes: &[u8]) -> Result<()> {
    Ok(nlmodes_output::write_atomic(path, bytes)?)
}

/// The FE mesh as a VTU mesh (gmsh node order; the writer reorders TET10 for VTK).
pub fn vtu_mesh(mesh: &nlmodes_fem::Mesh) -> VtuMesh<'_> {
    VtuMesh {
        points: &mesh.nodes,
        connectivity: &mesh.connectivity,
        nodes_per_cell: mesh.kind.nodes_per_element(),
    }
}

/// Write a VTU of the mesh with point vector fields (3 values per node), zlib-compressed, points
/// and fields in Float32 (relative rounding 6e-8: enough to draw mode shapes; the exact values
/// are recomputed from the model, never read back from the VTU).
pub fn write_mesh_vtu(
    mesh: &nlmodes_fem::Mesh,
    path: &Path,
    fields: &[(String, Vec<f64>)],
) -> Result<()> {
    let f: Vec<Field> = fields
        .iter()
        .map(|(n, d)| Field::vector(n, d).f32())
        .collect();
    let writer = VtuWriter::new(path, &vtu_mesh(mesh), VtuEncoding::Zlib, Precision::F32)?;
    Ok(writer.write(path, &f, &[])?)
}

/// The rows of the recovery basis (free DOFs of `reference`) that `recovery.q24` predicts from
/// two others: for each TET10 edge of the mesh in `msh`, component c of its mid-edge node from
/// component c of the edge's two vertices (all three free; each mid-edge DOF once). Vertices are
/// never mid-edge nodes, so no predicted row is a parent. None for a TET4 mesh.
pub fn mid_edge_predictions(
    msh: &Path,
    reference: &nlmodes_modal::MeshReference,
) -> Result<Vec<[usize; 3]>> {
    let mesh = nlmodes_fem::read_msh(msh)?;
    let npc = mesh.kind.nodes_per_element();
    if npc != 10 || 3 * mesh.n_nodes() != reference.n_full_dofs {
        return Ok(Vec::new());
    }
    let mut free = vec![usize::MAX; reference.n_full_dofs];
    for (row, dof) in reference.free_to_full().into_iter().enumerate() {
        free[dof] = row;
    }
    // gmsh TET10 edge nodes 4..9: (0,1) (1,2) (0,2) (0,3) (2,3) (1,3).
    const EDGES: [(usize, usize); 6] = [(0, 1), (1, 2), (0, 2), (0, 3), (2, 3), (1, 3)];
    let mut seen = vec![false; reference.n_full_dofs];
    let mut predictions = Vec::new();
    for cell in mesh.connectivity.chunks_exact(10) {
        for (k, &(a, b)) in EDGES.iter().enumerate() {
            let (m, a, b) = (cell[4 + k], cell[a], cell[b]);
            for c in 0..3 {
                let (dm, da, db) = (3 * m + c, 3 * a + c, 3 * b + c);
                let rows = [free[dm], free[da], free[db]];
                if !seen[dm] && rows.iter().all(|&r| r != usize::MAX) {
                    seen[dm] = true;
                    predictions.push(rows);
                }
            }
        }
    }
    Ok(predictions)
}
