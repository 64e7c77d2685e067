//! Output helpers of the binary (re-exports of nlmodes-output once it lands).

use anyhow::{Context, Result};
use std::io::Write;
use std::path::Path;

/// Write `bytes` to `path` through a temporary file in the same directory and a rename.
pub fn write_atomic(path: &Path, bytes: &[u8]) -> Result<()> {
    let dir = path.parent().unwrap_or(Path::new("."));
    let name = path.file_name().context("output path has no file name")?;
    let tmp = dir.join(format!(".{}.tmp-{}", name.to_string_lossy(), std::process::id()));
    let r = (|| -> std::io::Result<()> {
        let mut f = std::fs::File::create(&tmp)?;
        f.write_all(bytes)?;
        f.sync_all()?;
        std::fs::rename(&tmp, path)
    })();
    if r.is_err() {
        let _ = std::fs::remove_file(&tmp);
    }
    r.with_context(|| format!("cannot write {}", path.display()))
}

/// Write a VTU of the mesh with point vector fields (3 values per node).
pub fn write_mesh_vtu(mesh: &nlmodes_fem::Mesh, path: &Path, fields: &[(String, Vec<f64>)]) -> Result<()> {
    use std::fmt::Write as _;
    let npe = mesh.kind.nodes_per_element();
    let (vtk_type, order): (u8, &[usize]) = if npe == 10 {
        (24, &[0, 1, 2, 3, 4, 5, 6, 7, 9, 8])
    } else {
        (10, &[0, 1, 2, 3])
    };
    let mut s = String::new();
    let _ = writeln!(s, "<?xml version=\"1.0\"?>\n<VTKFile type=\"UnstructuredGrid\" version=\"1.0\" byte_order=\"LittleEndian\">\n<UnstructuredGrid>\n<Piece NumberOfPoints=\"{}\" NumberOfCells=\"{}\">", mesh.n_nodes(), mesh.n_elements());
    s.push_str("<PointData>\n");
    for (name, v) in fields {
        anyhow::ensure!(v.iter().all(|x| x.is_finite()), "field {name} has non-finite values");
        let _ = writeln!(s, "<DataArray type=\"Float64\" Name=\"{name}\" NumberOfComponents=\"3\" format=\"ascii\">");
        for x in v {
            let _ = write!(s, "{x:e} ");
        }
        s.push_str("\n</DataArray>\n");
    }
    s.push_str("</PointData>\n<Points>\n<DataArray type=\"Float64\" NumberOfComponents=\"3\" format=\"ascii\">\n");
    for p in &mesh.nodes {
        let _ = writeln!(s, "{:e} {:e} {:e}", p[0], p[1], p[2]);
    }
    s.push_str("</DataArray>\n</Points>\n<Cells>\n<DataArray type=\"Int64\" Name=\"connectivity\" format=\"ascii\">\n");
    for e in 0..mesh.n_elements() {
        let el = mesh.element(e);
        for &i in order {
            let _ = write!(s, "{} ", el[i]);
        }
        s.push('\n');
    }
    s.push_str("</DataArray>\n<DataArray type=\"Int64\" Name=\"offsets\" format=\"ascii\">\n");
    for e in 0..mesh.n_elements() {
        let _ = write!(s, "{} ", (e + 1) * npe);
    }
    s.push_str("\n</DataArray>\n<DataArray type=\"UInt8\" Name=\"types\" format=\"ascii\">\n");
    for _ in 0..mesh.n_elements() {
        let _ = write!(s, "{vtk_type} ");
    }
    s.push_str("\n</DataArray>\n</Cells>\n</Piece>\n</UnstructuredGrid>\n</VTKFile>\n");
    write_atomic(path, s.as_bytes())
}
