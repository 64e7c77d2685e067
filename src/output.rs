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
