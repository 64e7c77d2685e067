//! VTK XML UnstructuredGrid (`.vtu`) writer for TET4 / TET10 meshes, for ParaView.
//!
//! Format: VTK XML file version 1.0, `LittleEndian`, `header_type="UInt64"`. Two encodings:
//! * [`VtuEncoding::Base64`] (default): every DataArray is `format="binary"`, i.e. inline base64
//!   of an 8-byte little-endian byte count followed by the raw little-endian values, encoded in
//!   one base64 stream. Exact, about 4/3 of the binary size, still a valid text/XML file.
//! * [`VtuEncoding::Ascii`]: `format="ascii"`, numbers at full round-trip precision.
//!
//! Arrays: `Points` Float64 (3 components), `connectivity` Int64, `offsets` Int64, `types` UInt8,
//! fields Float64 with `NumberOfComponents` = [`Field::components`].
//!
//! Node order: meshes come in gmsh order. gmsh TET10 (type 11) has edge nodes 4:(0,1) 5:(1,2)
//! 6:(0,2) 7:(0,3) 8:(2,3) 9:(1,3); `VTK_QUADRATIC_TETRA` (24) wants 8:(1,3) 9:(2,3), so nodes 8
//! and 9 (0-based) are swapped when writing. TET4 (gmsh 4) is `VTK_TETRA` (10) in the same order.

use std::fmt::Write as _;
use std::path::Path;

use crate::atomic::write_atomic;
use crate::base64;
use crate::finite::check_finite;
use crate::number::fmt_f64;
use crate::xml::escape;
use crate::OutputError;

/// VTK cell type of a 4-node tetrahedron.
pub const VTK_TETRA: u8 = 10;
/// VTK cell type of a 10-node (quadratic) tetrahedron.
pub const VTK_QUADRATIC_TETRA: u8 = 24;

/// A tetrahedral mesh in gmsh node order.
#[derive(Debug, Clone, Copy)]
pub struct VtuMesh<'a> {
    /// Node coordinates (m).
    pub points: &'a [[f64; 3]],
    /// 0-based node indices, `nodes_per_cell` per cell, in gmsh order.
    pub connectivity: &'a [usize],
    /// 4 (TET4) or 10 (TET10).
    pub nodes_per_cell: usize,
}

impl VtuMesh<'_> {
    /// Number of cells (`connectivity.len() / nodes_per_cell`; 0 for an invalid `nodes_per_cell`).
    pub fn cell_count(&self) -> usize {
        self.connectivity
            .len()
            .checked_div(self.nodes_per_cell)
            .unwrap_or(0)
    }
}

/// A named data field, `components` values per point (or per cell), point-major:
/// `data[i * components + c]`. 1 component: scalar; 3: vector (ParaView can warp by it).
#[derive(Debug, Clone, Copy)]
pub struct Field<'a> {
    /// Name shown in ParaView; unique among the point (resp. cell) fields of a file.
    pub name: &'a str,
    /// Values per point or cell, >= 1.
    pub components: usize,
    /// `components * count` finite values.
    pub data: &'a [f64],
}

impl<'a> Field<'a> {
    /// A scalar field.
    pub fn scalar(name: &'a str, data: &'a [f64]) -> Self {
        Field {
            name,
            components: 1,
            data,
        }
    }

    /// A 3-vector field, `data[3 i + c]`.
    pub fn vector(name: &'a str, data: &'a [f64]) -> Self {
        Field {
            name,
            components: 3,
            data,
        }
    }
}

/// How DataArrays are encoded (see the module documentation).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum VtuEncoding {
    /// Inline base64 of raw little-endian values (`format="binary"`).
    #[default]
    Base64,
    /// Decimal text (`format="ascii"`).
    Ascii,
}

/// Writes `mesh` with point fields to `path` (base64 encoding), atomically.
pub fn write_vtu(path: &Path, mesh: &VtuMesh, point_fields: &[Field]) -> Result<(), OutputError> {
    write_vtu_with(path, mesh, point_fields, &[], VtuEncoding::Base64)
}

/// Writes `mesh` with point and cell fields to `path` in the given encoding, atomically.
pub fn write_vtu_with(
    path: &Path,
    mesh: &VtuMesh,
    point_fields: &[Field],
    cell_fields: &[Field],
    encoding: VtuEncoding,
) -> Result<(), OutputError> {
    let doc = vtu_document(path, mesh, point_fields, cell_fields, encoding)?;
    write_atomic(path, doc.as_bytes())
}

/// The VTU document as a string, after checking the input; `target` only names the file in
/// error messages.
pub fn vtu_document(
    target: &Path,
    mesh: &VtuMesh,
    point_fields: &[Field],
    cell_fields: &[Field],
    encoding: VtuEncoding,
) -> Result<String, OutputError> {
    let file = target.display().to_string();
    let cell_type = check_mesh(&file, mesh)?;
    let n_points = mesh.points.len();
    let n_cells = mesh.cell_count();
    check_fields(&file, "point", point_fields, n_points)?;
    check_fields(&file, "cell", cell_fields, n_cells)?;

    let npc = mesh.nodes_per_cell;
    let mut connectivity: Vec<i64> = Vec::with_capacity(mesh.connectivity.len());
    for cell in mesh.connectivity.chunks_exact(npc) {
        let start = connectivity.len();
        connectivity.extend(cell.iter().map(|&n| n as i64));
        if npc == 10 {
            connectivity.swap(start + 8, start + 9);
        }
    }
    let offsets: Vec<i64> = (1..=n_cells).map(|c| (c * npc) as i64).collect();
    let types = vec![cell_type; n_cells];
    let coords: Vec<f64> = mesh.points.iter().flatten().copied().collect();

    let mut s = String::with_capacity(64 + 40 * (coords.len() + connectivity.len()));
    s.push_str("<?xml version=\"1.0\"?>\n");
    s.push_str(
        "<VTKFile type=\"UnstructuredGrid\" version=\"1.0\" byte_order=\"LittleEndian\" \
         header_type=\"UInt64\">\n",
    );
    s.push_str("  <UnstructuredGrid>\n");
    let _ = writeln!(
        s,
        "    <Piece NumberOfPoints=\"{n_points}\" NumberOfCells=\"{n_cells}\">"
    );
    s.push_str("      <Points>\n");
    push_array(
        &mut s,
        encoding,
        "Float64",
        "Points",
        3,
        &Values::F64(&coords),
    );
    s.push_str("      </Points>\n");
    s.push_str("      <Cells>\n");
    push_array(
        &mut s,
        encoding,
        "Int64",
        "connectivity",
        1,
        &Values::I64(&connectivity),
    );
    push_array(
        &mut s,
        encoding,
        "Int64",
        "offsets",
        1,
        &Values::I64(&offsets),
    );
    push_array(&mut s, encoding, "UInt8", "types", 1, &Values::U8(&types));
    s.push_str("      </Cells>\n");
    push_field_block(&mut s, encoding, "PointData", point_fields);
    push_field_block(&mut s, encoding, "CellData", cell_fields);
    s.push_str("    </Piece>\n  </UnstructuredGrid>\n</VTKFile>\n");
    Ok(s)
}

/// Validates the mesh and returns its VTK cell type.
fn check_mesh(file: &str, mesh: &VtuMesh) -> Result<u8, OutputError> {
    let cell_type = match mesh.nodes_per_cell {
        4 => VTK_TETRA,
        10 => VTK_QUADRATIC_TETRA,
        n => {
            return Err(OutputError::invalid(
                format!("mesh for {file}"),
                format!("{n} nodes per cell; expected 4 (TET4) or 10 (TET10)"),
            ))
        }
    };
    if mesh.connectivity.len() % mesh.nodes_per_cell != 0 {
        return Err(OutputError::invalid(
            format!("mesh for {file}"),
            format!(
                "connectivity length {} is not a multiple of {} nodes per cell",
                mesh.connectivity.len(),
                mesh.nodes_per_cell
            ),
        ));
    }
    let n_points = mesh.points.len();
    if let Some(pos) = mesh.connectivity.iter().position(|&n| n >= n_points) {
        return Err(OutputError::invalid(
            format!("mesh for {file}"),
            format!(
                "cell {} refers to node index {}, but there are only {n_points} points",
                pos / mesh.nodes_per_cell,
                mesh.connectivity[pos]
            ),
        ));
    }
    for (i, p) in mesh.points.iter().enumerate() {
        if let Some(c) = p.iter().position(|v| !v.is_finite()) {
            return Err(OutputError::NonFinite {
                what: format!("point coordinates of {file}"),
                index: 3 * i + c,
                value: p[c],
            });
        }
    }
    Ok(cell_type)
}

fn check_fields(file: &str, kind: &str, fields: &[Field], count: usize) -> Result<(), OutputError> {
    for (k, f) in fields.iter().enumerate() {
        let what = format!("{kind} field `{}` of {file}", f.name);
        if f.name.trim().is_empty() {
            return Err(OutputError::invalid(
                format!("{kind} field #{k} of {file}"),
                "empty name",
            ));
        }
        if fields[..k].iter().any(|g| g.name == f.name) {
            return Err(OutputError::invalid(what, "duplicate name"));
        }
        if f.components == 0 {
            return Err(OutputError::invalid(what, "0 components; expected >= 1"));
        }
        if f.data.len() != f.components * count {
            return Err(OutputError::invalid(
                what,
                format!(
                    "{} values; expected {} components x {count} {kind}s = {}",
                    f.data.len(),
                    f.components,
                    f.components * count
                ),
            ));
        }
        check_finite(&what, f.data)?;
    }
    Ok(())
}

enum Values<'a> {
    F64(&'a [f64]),
    I64(&'a [i64]),
    U8(&'a [u8]),
}

impl Values<'_> {
    fn len(&self) -> usize {
        match self {
            Values::F64(v) => v.len(),
            Values::I64(v) => v.len(),
            Values::U8(v) => v.len(),
        }
    }

    fn to_le_bytes(&self) -> Vec<u8> {
        match self {
            Values::F64(v) => v.iter().flat_map(|x| x.to_le_bytes()).collect(),
            Values::I64(v) => v.iter().flat_map(|x| x.to_le_bytes()).collect(),
            Values::U8(v) => v.to_vec(),
        }
    }

    fn text(&self, i: usize) -> String {
        match self {
            Values::F64(v) => fmt_f64(v[i]),
            Values::I64(v) => v[i].to_string(),
            Values::U8(v) => v[i].to_string(),
        }
    }
}

fn push_field_block(s: &mut String, encoding: VtuEncoding, tag: &str, fields: &[Field]) {
    if fields.is_empty() {
        return;
    }
    let scalar = fields.iter().find(|f| f.components == 1).map(|f| f.name);
    let vector = fields.iter().find(|f| f.components == 3).map(|f| f.name);
    let _ = write!(s, "      <{tag}");
    if let Some(n) = scalar {
        let _ = write!(s, " Scalars=\"{}\"", escape(n));
    }
    if let Some(n) = vector {
        let _ = write!(s, " Vectors=\"{}\"", escape(n));
    }
    s.push_str(">\n");
    for f in fields {
        push_array(
            s,
            encoding,
            "Float64",
            f.name,
            f.components,
            &Values::F64(f.data),
        );
    }
    let _ = writeln!(s, "      </{tag}>");
}

fn push_array(
    s: &mut String,
    encoding: VtuEncoding,
    vtk_type: &str,
    name: &str,
    components: usize,
    values: &Values,
) {
    let format = match encoding {
        VtuEncoding::Base64 => "binary",
        VtuEncoding::Ascii => "ascii",
    };
    let _ = write!(
        s,
        "        <DataArray type=\"{vtk_type}\" Name=\"{}\" NumberOfComponents=\"{components}\" \
         format=\"{format}\">\n          ",
        escape(name)
    );
    match encoding {
        VtuEncoding::Base64 => {
            let data = values.to_le_bytes();
            let mut raw = Vec::with_capacity(8 + data.len());
            raw.extend_from_slice(&(data.len() as u64).to_le_bytes());
            raw.extend_from_slice(&data);
            base64::encode_into(&raw, s);
        }
        VtuEncoding::Ascii => {
            for i in 0..values.len() {
                if i > 0 {
                    s.push(if i % (6 * components.max(1)) == 0 {
                        '\n'
                    } else {
                        ' '
                    });
                }
                s.push_str(&values.text(i));
            }
        }
    }
    s.push_str("\n        </DataArray>\n");
}

#[cfg(test)]
mod tests;
