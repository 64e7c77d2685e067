//! Output stage of nlmodes: everything the program writes goes through this crate.
//!
//! * [`atomic`]: files are written to a temporary name in the target directory, flushed, synced and
//!   renamed over the target, so a reader never sees a partial file and a failed write leaves no
//!   trace ([`write_atomic`], [`AtomicFile`], [`write_atomic_with`]).
//! * [`finite`]: guards that refuse NaN and infinities, naming the field ([`check_finite`]).
//! * [`vtu`] / [`pvd`]: VTK XML unstructured grids (TET4 / TET10) with point and cell data for
//!   ParaView, and PVD collections of them for time series.
//! * [`xdmf`]: XDMF 3 time series with HDF5 heavy data (one mesh, per-frame fields, identical
//!   arrays stored once) for ParaView and meshio.
//! * [`csv`]: small CSV tables written at full precision; [`json`]: pretty JSON of any
//!   `serde::Serialize` value, refusing non-finite numbers.
//! * [`plot`]: line plots and heat maps as SVG, rasterized to PNG with `resvg`.
//!
//! No function of this crate panics on bad input: all return [`OutputError`], whose message names
//! the file, field or value at fault.

pub mod atomic;
mod base64;
pub mod csv;
mod error;
pub mod finite;
pub mod json;
mod number;
pub mod plot;
pub mod pvd;
pub mod vtu;
pub mod xdmf;
mod xml;

pub use atomic::{remove_stale_temporaries, write_atomic, write_atomic_with, AtomicFile};
pub use csv::{write_csv_columns, CsvTable, CsvValue};
pub use error::OutputError;
pub use finite::{check_finite, check_finite_value};
pub use json::{to_json_string, write_json, write_json_compact};
pub use plot::{
    Color, Colormap, HeatMap, LegendPosition, LinePlot, LineStyle, Orientation, RefLine, Series,
};
pub use pvd::{write_pvd, write_pvd_with_note, PvdEntry};
pub use vtu::{
    vtu_document, write_vtu, write_vtu_with, Field, Precision, VtuEncoding, VtuMesh, VtuWriter,
};
pub use xdmf::{write_xdmf_series, XdmfFrame, XdmfWritten};
