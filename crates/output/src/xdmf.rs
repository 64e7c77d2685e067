//! XDMF 3 time series with HDF5 heavy data, for ParaView: the mesh written once, a field per
//! frame, each array stored once however many frames use it.
//!
//! A series is two files: `NAME.xdmf` (XML, `Version="3.0"`) and `NAME.h5` (HDF5) beside it.
//! The XML holds one temporal collection (`GridType="Collection" CollectionType="Temporal"`)
//! with one uniform grid per frame; every frame's `Topology` and `Geometry` point to the same
//! two datasets, `/mesh/connectivity` (Int32, cells x nodes per cell, VTK node order) and
//! `/mesh/points` (Float32 or Float64, points x 3); its point `Attribute`s point to datasets
//! `/fields/<name>/<k>`. Arrays are compared byte for byte after conversion to the file's type:
//! two frames with the same values of a field (a static field such as a node flag, or the
//! frames at t and T - t of an orbit that is even in time) share one dataset. Every dataset is
//! one HDF5 chunk with the shuffle and deflate filters (standard HDF5 filters, read by ParaView
//! and h5py alike).
//!
//! Readers: ParaView (`Xdmf3ReaderS`/`Xdmf3ReaderT`, and the older `XDMF Reader`) animates the
//! collection with the time values written (`<Time Value=...>`): each of the three reads every
//! frame's points, cells and fields, shared arrays included, when asked for a time step as the
//! GUI asks (checked by `tests/paraview_readers.py` on every series of a run). Asked for no time
//! step, the Xdmf3 readers return an empty grid for any temporal collection (their output is
//! one grid and the collection's frames are many; a series written by meshio does the same),
//! and given a bare file name (no directory) ParaView 5.11's Xdmf3 readers join it to the HDF5
//! name (`mode.xdmfmode.h5`) and abort: nothing in the file changes either. meshio's
//! `meshio.xdmf.TimeSeriesReader` reads it with h5py.
//!
//! Topology: `Tetrahedron` or `Tetrahedron_10`, whose node order is VTK's (`VTK_TETRA`,
//! `VTK_QUADRATIC_TETRA`): the gmsh TET10 nodes 8 and 9 are swapped as in [`crate::vtu`].
//!
//! The HDF5 file is written under a temporary name and renamed, then the XML likewise
//! ([`crate::atomic`]): a reader sees the previous pair or the new one (the XML last).

use std::collections::HashMap;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use crate::atomic::{write_atomic, AtomicFile};
use crate::finite::check_finite_value;
use crate::number::fmt_f64;
use crate::vtu::{check_fields, check_mesh, Field, Precision, VtuMesh};
use crate::xml::escape;
use crate::OutputError;

/// Deflate level of the HDF5 datasets (1 fastest .. 9 smallest; 4 is within 2 % of 9 in size
/// on displacement fields, several times faster).
const DEFLATE_LEVEL: u8 = 4;

/// One instant of a series: its time value and its point fields.
#[derive(Debug, Clone)]
pub struct XdmfFrame<'a> {
    /// Time value shown by ParaView (the caller states the unit in the note).
    pub time: f64,
    /// Point fields of this frame (1 or 3 components; NaN allowed in partial fields).
    pub fields: Vec<Field<'a>>,
}

/// What [`write_xdmf_series`] wrote.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct XdmfWritten {
    /// The HDF5 file beside the XML.
    pub heavy_data: PathBuf,
    /// Field datasets stored (after sharing identical arrays).
    pub field_datasets: usize,
    /// Field arrays referenced by the frames (frames x fields).
    pub field_arrays: usize,
}

/// Writes `frames` on `mesh` as `path` (`.xdmf`) plus its `.h5` beside it (module
/// documentation). `points` is the type of the coordinates; `note` (e.g. the unit of the time
/// values) goes into an XML comment and, with the field names, into the HDF5 file's `note`
/// attribute. Every frame must have the same field names in the same order.
pub fn write_xdmf_series(
    path: &Path,
    mesh: &VtuMesh,
    points: Precision,
    frames: &[XdmfFrame],
    note: &str,
) -> Result<XdmfWritten, OutputError> {
    let file = path.display().to_string();
    check_mesh(&file, mesh)?;
    check_frames(&file, mesh.points.len(), frames)?;
    let heavy = path.with_extension("h5");
    let heavy_name = heavy
        .file_name()
        .and_then(|n| n.to_str())
        .ok_or_else(|| OutputError::invalid(&file, "the file name is not valid UTF-8"))?
        .to_string();
    let mut store = HeavyData::create(&heavy)?;
    store.mesh(mesh, points)?;
    let mut xml_frames = Vec::with_capacity(frames.len());
    for frame in frames {
        let mut attributes = Vec::with_capacity(frame.fields.len());
        for f in &frame.fields {
            attributes.push((f, store.field(f)?));
        }
        xml_frames.push((frame.time, attributes));
    }
    let written = XdmfWritten {
        heavy_data: heavy.clone(),
        field_datasets: store.datasets,
        field_arrays: frames.iter().map(|f| f.fields.len()).sum(),
    };
    store.finish(note)?;
    let xml = document(mesh, points, &heavy_name, &xml_frames, note);
    write_atomic(path, xml.as_bytes())?;
    Ok(written)
}

/// Times finite, every frame with the same fields, each field valid for `n_points`.
fn check_frames(file: &str, n_points: usize, frames: &[XdmfFrame]) -> Result<(), OutputError> {
    if frames.is_empty() {
        return Err(OutputError::invalid(file, "no frame to write"));
    }
    for (k, frame) in frames.iter().enumerate() {
        check_finite_value(&format!("time of frame {k} of {file}"), frame.time)?;
        check_fields(file, "point", &frame.fields, n_points)?;
        let names = |f: &XdmfFrame| -> Vec<String> {
            f.fields.iter().map(|x| x.name.to_string()).collect()
        };
        if names(frame) != names(&frames[0]) {
            return Err(OutputError::invalid(
                format!("frame {k} of {file}"),
                format!(
                    "fields {:?}; every frame needs the fields of frame 0, {:?}",
                    names(frame),
                    names(&frames[0])
                ),
            ));
        }
        if let Some(f) = frame
            .fields
            .iter()
            .find(|f| ![1, 3].contains(&f.components))
        {
            return Err(OutputError::invalid(
                format!("field `{}` of {file}", f.name),
                format!("{} components; expected 1 or 3", f.components),
            ));
        }
    }
    Ok(())
}

/// The HDF5 file being written, with the arrays already stored (for sharing).
struct HeavyData {
    target: PathBuf,
    /// Holds the temporary name until the commit (removed if dropped uncommitted).
    atomic: AtomicFile,
    file: hdf5_metno::File,
    /// (field name, bytes) -> dataset path.
    stored: HashMap<(String, Vec<u8>), String>,
    /// Field datasets written so far.
    datasets: usize,
}

impl HeavyData {
    fn create(target: &Path) -> Result<Self, OutputError> {
        let atomic = AtomicFile::create(target)?;
        let file = hdf5_metno::File::create(atomic.temp_path()).map_err(|e| h5(target, e))?;
        Ok(HeavyData {
            target: target.to_path_buf(),
            atomic,
            file,
            stored: HashMap::new(),
            datasets: 0,
        })
    }

    /// `/mesh/points` and `/mesh/connectivity` (VTK node order).
    fn mesh(&mut self, mesh: &VtuMesh, points: Precision) -> Result<(), OutputError> {
        let npc = mesh.nodes_per_cell;
        let coords: Vec<f64> = mesh.points.iter().flatten().copied().collect();
        self.float_dataset("/mesh/points", &coords, 3, points)?;
        let mut connectivity: Vec<i32> = Vec::with_capacity(mesh.connectivity.len());
        for cell in mesh.connectivity.chunks_exact(npc) {
            let start = connectivity.len();
            connectivity.extend(cell.iter().map(|&n| n as i32));
            if npc == 10 {
                connectivity.swap(start + 8, start + 9);
            }
        }
        if mesh.points.len() > i32::MAX as usize {
            return Err(OutputError::invalid(
                self.target.display().to_string(),
                "more than 2^31 points: Int32 connectivity cannot index them",
            ));
        }
        self.dataset(
            "/mesh/connectivity",
            &connectivity,
            &[mesh.cell_count(), npc],
        )
    }

    /// The dataset path of field `f`, written unless an identical array of the same field name
    /// is stored already.
    fn field(&mut self, f: &Field) -> Result<String, OutputError> {
        let bytes = float_bytes(f.data, f.precision);
        let key = (f.name.to_string(), bytes);
        if let Some(path) = self.stored.get(&key) {
            return Ok(path.clone());
        }
        let index = self.stored.keys().filter(|(n, _)| n == f.name).count();
        let path = format!("/fields/{}/{index:03}", f.name);
        self.float_dataset(&path, f.data, f.components, f.precision)?;
        self.datasets += 1;
        self.stored.insert(key, path.clone());
        Ok(path)
    }

    fn float_dataset(
        &self,
        path: &str,
        data: &[f64],
        components: usize,
        precision: Precision,
    ) -> Result<(), OutputError> {
        let rows = data.len() / components;
        let shape: &[usize] = if components == 1 {
            &[rows]
        } else {
            &[rows, components]
        };
        match precision {
            Precision::F32 => {
                let v: Vec<f32> = data.iter().map(|&x| x as f32).collect();
                self.dataset(path, &v, shape)
            }
            Precision::F64 => self.dataset(path, data, shape),
        }
    }

    /// One chunked, shuffled and deflated dataset of `shape` (one chunk), groups created.
    fn dataset<T: hdf5_metno::H5Type>(
        &self,
        path: &str,
        data: &[T],
        shape: &[usize],
    ) -> Result<(), OutputError> {
        let err = |e| h5(&self.target, e);
        let (group, name) = path.rsplit_once('/').unwrap_or(("", path));
        let mut g = self.file.group("/").map_err(err)?;
        for part in group.split('/').filter(|p| !p.is_empty()) {
            g = match g.group(part) {
                Ok(existing) => existing,
                Err(_) => g.create_group(part).map_err(err)?,
            };
        }
        let ds = g
            .new_dataset::<T>()
            .shape(shape)
            .chunk(shape.iter().map(|&n| n.max(1)).collect::<Vec<_>>())
            .shuffle()
            .deflate(DEFLATE_LEVEL)
            .create(name)
            .map_err(err)?;
        ds.write_raw(data).map_err(err)
    }

    /// Writes the note attribute, closes the file and renames it over the target.
    fn finish(self, note: &str) -> Result<(), OutputError> {
        let err = |e| h5(&self.target, e);
        let text: hdf5_metno::types::VarLenUnicode = note
            .parse()
            .map_err(|_| OutputError::invalid(self.target.display().to_string(), "note"))?;
        self.file
            .new_attr::<hdf5_metno::types::VarLenUnicode>()
            .create("note")
            .and_then(|a| a.write_scalar(&text))
            .map_err(err)?;
        self.file.close().map_err(err)?;
        self.atomic.commit()
    }
}

fn h5(path: &Path, e: hdf5_metno::Error) -> OutputError {
    OutputError::io(path, std::io::Error::other(format!("HDF5: {e}")))
}

/// Little-endian bytes of `data` in the file's type (the sharing key).
fn float_bytes(data: &[f64], precision: Precision) -> Vec<u8> {
    match precision {
        Precision::F32 => data
            .iter()
            .flat_map(|&x| (x as f32).to_le_bytes())
            .collect(),
        Precision::F64 => data.iter().flat_map(|x| x.to_le_bytes()).collect(),
    }
}

type XmlFrame<'a, 'b> = (f64, Vec<(&'b Field<'a>, String)>);

/// The XDMF document.
fn document(
    mesh: &VtuMesh,
    points: Precision,
    heavy: &str,
    frames: &[XmlFrame],
    note: &str,
) -> String {
    let (n_points, n_cells, npc) = (mesh.points.len(), mesh.cell_count(), mesh.nodes_per_cell);
    let topology = if npc == 10 {
        "Tetrahedron_10"
    } else {
        "Tetrahedron"
    };
    let heavy = escape(heavy);
    let item = |dims: String, kind: &str, precision: usize, dataset: &str| {
        format!(
            "<DataItem Dimensions=\"{dims}\" NumberType=\"{kind}\" Precision=\"{precision}\" \
             Format=\"HDF\">{heavy}:{}</DataItem>",
            escape(dataset)
        )
    };
    let bytes = |p: Precision| if p == Precision::F32 { 4 } else { 8 };
    let mut s = String::from("<?xml version=\"1.0\"?>\n");
    if !note.is_empty() {
        let _ = writeln!(s, "<!-- {} -->", note.replace("--", "- -"));
    }
    s.push_str(
        "<Xdmf Version=\"3.0\">\n  <Domain>\n    \
         <Grid Name=\"series\" GridType=\"Collection\" CollectionType=\"Temporal\">\n",
    );
    for (k, (time, attributes)) in frames.iter().enumerate() {
        let _ = writeln!(
            s,
            "      <Grid Name=\"frame_{k:03}\" GridType=\"Uniform\">\n        \
             <Time Value=\"{}\"/>\n        \
             <Topology TopologyType=\"{topology}\" NumberOfElements=\"{n_cells}\">\n          \
             {}\n        </Topology>\n        <Geometry GeometryType=\"XYZ\">\n          \
             {}\n        </Geometry>",
            fmt_f64(*time),
            item(format!("{n_cells} {npc}"), "Int", 4, "/mesh/connectivity"),
            item(
                format!("{n_points} 3"),
                "Float",
                bytes(points),
                "/mesh/points"
            ),
        );
        for (f, dataset) in attributes {
            let (kind, dims) = if f.components == 3 {
                ("Vector", format!("{n_points} 3"))
            } else {
                ("Scalar", format!("{n_points}"))
            };
            let _ = writeln!(
                s,
                "        <Attribute Name=\"{}\" AttributeType=\"{kind}\" Center=\"Node\">\n          \
                 {}\n        </Attribute>",
                escape(f.name),
                item(dims, "Float", bytes(f.precision), dataset),
            );
        }
        s.push_str("      </Grid>\n");
    }
    s.push_str("    </Grid>\n  </Domain>\n</Xdmf>\n");
    s
}

#[cfg(test)]
mod tests;
