//! VTK XML UnstructuredGrid (`.vtu`) writer for TET4 / TET10 meshes, for ParaView.
//!
//! Format: VTK XML file version 1.0, `LittleEndian`, `header_type="UInt64"`. Three encodings:
//! * [`VtuEncoding::Zlib`] (default of [`write_vtu`]): every DataArray is `format="binary"` and
//!   zlib-compressed as VTK's `vtkZLibDataCompressor` does it (`compressor` attribute of the
//!   `VTKFile` element): the raw little-endian values are cut into blocks of
//!   [`ZLIB_BLOCK_SIZE`] bytes, each compressed into a zlib stream; the array is the base64 of
//!   the UInt64 header `[blocks, block size, size of the last partial block (0 if none),
//!   compressed size of each block]` followed by the base64 of the concatenated compressed
//!   blocks (two base64 streams, as VTK reads them). Cell connectivity and offsets are Int32
//!   when the mesh has fewer than 2^31 points.
//! * [`VtuEncoding::Base64`]: `format="binary"` uncompressed, i.e. inline base64 of an 8-byte
//!   little-endian byte count followed by the raw little-endian values, in one base64 stream.
//! * [`VtuEncoding::Ascii`]: `format="ascii"`, numbers at full round-trip precision.
//!
//! Arrays: `Points` Float64 or Float32 ([`VtuWriter::new`]), `connectivity` and `offsets` Int64
//! (Int32 with zlib, see above), `types` UInt8, fields Float64 or Float32 ([`Field::precision`])
//! with `NumberOfComponents` = [`Field::components`]. A field marked [`Field::partial`] may hold
//! NaN where it is not defined (VTK's and ParaView's convention: NaN is drawn in the "NaN
//! color" and left out of ranges); all other values must be finite.
//!
//! Node order: meshes come in gmsh order. gmsh TET10 (type 11) has edge nodes 4:(0,1) 5:(1,2)
//! 6:(0,2) 7:(0,3) 8:(2,3) 9:(1,3); `VTK_QUADRATIC_TETRA` (24) wants 8:(1,3) 9:(2,3), so nodes 8
//! and 9 (0-based) are swapped when writing. TET4 (gmsh 4) is `VTK_TETRA` (10) in the same order.
//!
//! A series of frames on one mesh goes through one [`VtuWriter`]: the mesh arrays are encoded
//! (and compressed) once and copied into every frame.

use std::fmt::Write as _;
use std::io::Write as _;
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
/// Uncompressed bytes per zlib block (VTK's default is 32 KiB; larger blocks compress a little
/// better, and VTK reads any block size from the header).
pub const ZLIB_BLOCK_SIZE: usize = 1 << 20;

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

/// Floating-point type of an array in the file.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Precision {
    /// `Float64`: exact.
    #[default]
    F64,
    /// `Float32`: 24-bit mantissa (relative rounding 6e-8), enough to draw and color a field;
    /// half the bytes.
    F32,
}

impl Precision {
    fn vtk_type(self) -> &'static str {
        match self {
            Precision::F64 => "Float64",
            Precision::F32 => "Float32",
        }
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
    /// `components * count` values, finite (or NaN where undefined, for a partial field).
    pub data: &'a [f64],
    /// Type written to the file.
    pub precision: Precision,
    /// NaN marks the points (cells) where the field is undefined; infinities are still refused.
    pub partial: bool,
}

impl<'a> Field<'a> {
    /// A scalar field (Float64, defined everywhere).
    pub fn scalar(name: &'a str, data: &'a [f64]) -> Self {
        Field {
            name,
            components: 1,
            data,
            precision: Precision::F64,
            partial: false,
        }
    }

    /// A 3-vector field, `data[3 i + c]` (Float64, defined everywhere).
    pub fn vector(name: &'a str, data: &'a [f64]) -> Self {
        Field {
            components: 3,
            ..Field::scalar(name, data)
        }
    }

    /// The same field written as `Float32`.
    pub fn f32(self) -> Self {
        Field {
            precision: Precision::F32,
            ..self
        }
    }

    /// The same field, allowed NaN where it is undefined.
    pub fn partial(self) -> Self {
        Field {
            partial: true,
            ..self
        }
    }
}

/// How DataArrays are encoded (see the module documentation).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum VtuEncoding {
    /// zlib-compressed blocks, base64 (`format="binary"`, `vtkZLibDataCompressor`).
    #[default]
    Zlib,
    /// Inline base64 of raw little-endian values (`format="binary"`, uncompressed).
    Base64,
    /// Decimal text (`format="ascii"`).
    Ascii,
}

/// Writes `mesh` with point fields to `path` (zlib encoding, Float64 points), atomically.
pub fn write_vtu(path: &Path, mesh: &VtuMesh, point_fields: &[Field]) -> Result<(), OutputError> {
    write_vtu_with(path, mesh, point_fields, &[], VtuEncoding::Zlib)
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
    VtuWriter::new(target, mesh, encoding, Precision::F64)?.document(
        target,
        point_fields,
        cell_fields,
    )
}

/// Writes frames that share one mesh: the mesh is checked and encoded once, in [`VtuWriter::new`].
#[derive(Debug, Clone)]
pub struct VtuWriter {
    encoding: VtuEncoding,
    n_points: usize,
    n_cells: usize,
    /// The `<Points>` and `<Cells>` elements, encoded.
    geometry: String,
}

impl VtuWriter {
    /// Checks and encodes `mesh`; `target` names the mesh in error messages; `points` is the type
    /// of the coordinates in the file.
    pub fn new(
        target: &Path,
        mesh: &VtuMesh,
        encoding: VtuEncoding,
        points: Precision,
    ) -> Result<Self, OutputError> {
        let file = target.display().to_string();
        let cell_type = check_mesh(&file, mesh)?;
        let n_points = mesh.points.len();
        let n_cells = mesh.cell_count();
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
        // Int32 indices when they fit (compressed output only: the uncompressed encodings keep
        // the Int64 they always had).
        let narrow = encoding == VtuEncoding::Zlib
            && connectivity.len() < i32::MAX as usize
            && n_points < i32::MAX as usize;
        let index = |v: &[i64]| -> Values<'static> {
            if narrow {
                Values::I32(v.iter().map(|&x| x as i32).collect())
            } else {
                Values::I64(v.to_vec())
            }
        };
        let mut g = String::with_capacity(64 + 12 * (coords.len() + connectivity.len()));
        g.push_str("      <Points>\n");
        push_array(
            &mut g,
            encoding,
            "Points",
            3,
            &Values::float(&coords, points),
        );
        g.push_str("      </Points>\n      <Cells>\n");
        push_array(&mut g, encoding, "connectivity", 1, &index(&connectivity));
        push_array(&mut g, encoding, "offsets", 1, &index(&offsets));
        push_array(&mut g, encoding, "types", 1, &Values::U8(types));
        g.push_str("      </Cells>\n");
        Ok(VtuWriter {
            encoding,
            n_points,
            n_cells,
            geometry: g,
        })
    }

    /// The document of one frame: the mesh with these fields; `target` names the file in errors.
    pub fn document(
        &self,
        target: &Path,
        point_fields: &[Field],
        cell_fields: &[Field],
    ) -> Result<String, OutputError> {
        let file = target.display().to_string();
        check_fields(&file, "point", point_fields, self.n_points)?;
        check_fields(&file, "cell", cell_fields, self.n_cells)?;
        let field_bytes: usize = point_fields
            .iter()
            .chain(cell_fields)
            .map(|f| f.data.len())
            .sum();
        let mut s = String::with_capacity(512 + self.geometry.len() + 12 * field_bytes);
        s.push_str("<?xml version=\"1.0\"?>\n");
        s.push_str(
            "<VTKFile type=\"UnstructuredGrid\" version=\"1.0\" byte_order=\"LittleEndian\" \
             header_type=\"UInt64\"",
        );
        if self.encoding == VtuEncoding::Zlib {
            s.push_str(" compressor=\"vtkZLibDataCompressor\"");
        }
        s.push_str(">\n  <UnstructuredGrid>\n");
        let _ = writeln!(
            s,
            "    <Piece NumberOfPoints=\"{}\" NumberOfCells=\"{}\">",
            self.n_points, self.n_cells
        );
        s.push_str(&self.geometry);
        push_field_block(&mut s, self.encoding, "PointData", point_fields);
        push_field_block(&mut s, self.encoding, "CellData", cell_fields);
        s.push_str("    </Piece>\n  </UnstructuredGrid>\n</VTKFile>\n");
        Ok(s)
    }

    /// Writes one frame to `path` atomically.
    pub fn write(
        &self,
        path: &Path,
        point_fields: &[Field],
        cell_fields: &[Field],
    ) -> Result<(), OutputError> {
        let doc = self.document(path, point_fields, cell_fields)?;
        write_atomic(path, doc.as_bytes())
    }
}

/// Validates the mesh and returns its VTK cell type.
pub(crate) fn check_mesh(file: &str, mesh: &VtuMesh) -> Result<u8, OutputError> {
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

pub(crate) fn check_fields(
    file: &str,
    kind: &str,
    fields: &[Field],
    count: usize,
) -> Result<(), OutputError> {
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
        if f.partial {
            let finite_or_nan: Vec<f64> = f
                .data
                .iter()
                .map(|&v| if v.is_nan() { 0.0 } else { v })
                .collect();
            check_finite(&what, &finite_or_nan)?;
        } else {
            check_finite(&what, f.data)?;
        }
    }
    Ok(())
}

/// The values of one DataArray, as they go into the file.
enum Values<'a> {
    F64(&'a [f64]),
    /// f64 values written as Float32.
    F32(&'a [f64]),
    I64(Vec<i64>),
    I32(Vec<i32>),
    U8(Vec<u8>),
}

impl<'a> Values<'a> {
    fn float(v: &'a [f64], p: Precision) -> Self {
        match p {
            Precision::F64 => Values::F64(v),
            Precision::F32 => Values::F32(v),
        }
    }

    fn vtk_type(&self) -> &'static str {
        match self {
            Values::F64(_) => "Float64",
            Values::F32(_) => "Float32",
            Values::I64(_) => "Int64",
            Values::I32(_) => "Int32",
            Values::U8(_) => "UInt8",
        }
    }

    fn len(&self) -> usize {
        match self {
            Values::F64(v) | Values::F32(v) => v.len(),
            Values::I64(v) => v.len(),
            Values::I32(v) => v.len(),
            Values::U8(v) => v.len(),
        }
    }

    fn to_le_bytes(&self) -> Vec<u8> {
        match self {
            Values::F64(v) => v.iter().flat_map(|x| x.to_le_bytes()).collect(),
            Values::F32(v) => v.iter().flat_map(|&x| (x as f32).to_le_bytes()).collect(),
            Values::I64(v) => v.iter().flat_map(|x| x.to_le_bytes()).collect(),
            Values::I32(v) => v.iter().flat_map(|x| x.to_le_bytes()).collect(),
            Values::U8(v) => v.clone(),
        }
    }

    fn text(&self, i: usize) -> String {
        match self {
            Values::F64(v) => fmt_f64(v[i]),
            Values::F32(v) => {
                let x = v[i] as f32;
                if x.is_nan() {
                    "NaN".to_string()
                } else {
                    x.to_string()
                }
            }
            Values::I64(v) => v[i].to_string(),
            Values::I32(v) => v[i].to_string(),
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
        let values = Values::float(f.data, f.precision);
        debug_assert_eq!(values.vtk_type(), f.precision.vtk_type());
        push_array(s, encoding, f.name, f.components, &values);
    }
    let _ = writeln!(s, "      </{tag}>");
}

fn push_array(
    s: &mut String,
    encoding: VtuEncoding,
    name: &str,
    components: usize,
    values: &Values,
) {
    let format = match encoding {
        VtuEncoding::Zlib | VtuEncoding::Base64 => "binary",
        VtuEncoding::Ascii => "ascii",
    };
    let _ = write!(
        s,
        "        <DataArray type=\"{}\" Name=\"{}\" NumberOfComponents=\"{components}\" \
         format=\"{format}\">\n          ",
        values.vtk_type(),
        escape(name)
    );
    match encoding {
        VtuEncoding::Zlib => push_zlib(s, &values.to_le_bytes()),
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

/// Appends `data` compressed as `vtkZLibDataCompressor` does (module documentation): the base64
/// of the UInt64 block header, then the base64 of the compressed blocks.
fn push_zlib(s: &mut String, data: &[u8]) {
    let blocks: Vec<Vec<u8>> = data.chunks(ZLIB_BLOCK_SIZE).map(zlib_block).collect();
    let mut header = Vec::with_capacity(8 * (3 + blocks.len()));
    header.extend_from_slice(&(blocks.len() as u64).to_le_bytes());
    header.extend_from_slice(&(ZLIB_BLOCK_SIZE as u64).to_le_bytes());
    header.extend_from_slice(&((data.len() % ZLIB_BLOCK_SIZE) as u64).to_le_bytes());
    for b in &blocks {
        header.extend_from_slice(&(b.len() as u64).to_le_bytes());
    }
    base64::encode_into(&header, s);
    base64::encode_into(&blocks.concat(), s);
}

/// One zlib stream (RFC 1950) of `block`, at level 5 (VTK's default level).
fn zlib_block(block: &[u8]) -> Vec<u8> {
    let mut e = flate2::write::ZlibEncoder::new(
        Vec::with_capacity(block.len() / 2 + 64),
        flate2::Compression::new(5),
    );
    // Writing into a Vec cannot fail.
    let _ = e.write_all(block);
    e.finish().unwrap_or_default()
}

#[cfg(test)]
mod tests;
