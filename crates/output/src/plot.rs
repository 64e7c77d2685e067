//! Plots as SVG (own small writer) and PNG (SVG rasterized with `resvg`).
//!
//! * [`LinePlot`]: axes with "nice" ticks, title, axis labels, several [`Series`] (solid, dashed
//!   or dotted lines, optional markers), a legend, and dashed reference lines ([`RefLine`]) such as
//!   "contact at 1" or "grazing". Its [`LineLayout`] says where everything is drawn: the legend
//!   inside the plot area only where it meets no data, else beside or below it; reference-line
//!   labels outside the area ([`LineLayout::clashes`] lists any overlap).
//! * [`HeatMap`]: a matrix of values as colored cells with a color bar (the contact map: contact
//!   node x time).
//! * [`SurfacePicture`]: a triangulated surface (e.g. a deformed mesh) flat-shaded in an
//!   orthographic view, one panel per state, with a color bar (the mode-shape pictures).
//!
//! Title, axis labels, ticks and color bars come from one frame module shared by the three.
//!
//! Both render to an SVG string (`to_svg`) and write `.svg` / `.png` files atomically
//! (`write_svg`, `write_png`, `write_svg_and_png`). Non-finite data are refused.

mod axis;
mod clash;
mod color;
mod end_labels;
mod frame;
mod heatmap;
mod label;
mod legend;
mod line;
mod line_layout;
mod line_svg;
mod raster;
mod rect;
mod series;
mod surface;
mod svg;
mod ticks;

pub use color::{Color, Colormap, PALETTE};
pub use heatmap::HeatMap;
pub use line::LinePlot;
pub use line_layout::{LineLayout, RefLabel, Stroke};
pub use raster::{fonts_available, png_color_share, svg_to_png, PNG_SCALE};
pub use rect::Rect;
pub use series::{LegendPosition, LineStyle, Orientation, RefLine, Series};
pub use surface::{Marker, SurfacePanel, SurfacePicture, View};
pub use ticks::{nice_ticks, Ticks};

use std::ffi::OsString;
use std::path::{Path, PathBuf};

use crate::atomic::write_atomic;
use crate::OutputError;

/// `base` with `.ext` appended (not replacing anything: `q_5.7` gives `q_5.7.svg`).
pub(crate) fn with_appended_extension(base: &Path, ext: &str) -> PathBuf {
    let mut s: OsString = base.as_os_str().to_os_string();
    s.push(".");
    s.push(ext);
    PathBuf::from(s)
}

/// Writes a rendered SVG (or its rendering error, naming `path`) to `path` atomically.
pub(crate) fn write_svg_file(
    svg: Result<String, OutputError>,
    path: &Path,
) -> Result<(), OutputError> {
    let svg = svg.map_err(|e| prefix(e, path))?;
    write_atomic(path, svg.as_bytes())
}

/// Rasterizes a rendered SVG to a PNG at `path` ([`PNG_SCALE`] px per SVG px).
pub(crate) fn write_png_file(
    svg: Result<String, OutputError>,
    path: &Path,
) -> Result<(), OutputError> {
    let svg = svg.map_err(|e| prefix(e, path))?;
    svg_to_png(&svg, path, PNG_SCALE)
}

/// Writes `<base>.svg` and `<base>.png` from one rendering; returns their paths.
pub(crate) fn write_svg_and_png_files(
    svg: Result<String, OutputError>,
    base: &Path,
) -> Result<(PathBuf, PathBuf), OutputError> {
    let svg_path = with_appended_extension(base, "svg");
    let png_path = with_appended_extension(base, "png");
    let svg = svg.map_err(|e| prefix(e, &svg_path))?;
    write_atomic(&svg_path, svg.as_bytes())?;
    svg_to_png(&svg, &png_path, PNG_SCALE)?;
    Ok((svg_path, png_path))
}

/// Adds the output file to the "what" of an input error.
pub(crate) fn prefix(e: OutputError, path: &Path) -> OutputError {
    match e {
        OutputError::InvalidInput { what, reason } => OutputError::InvalidInput {
            what: format!("{what} ({})", path.display()),
            reason,
        },
        OutputError::NonFinite { what, index, value } => OutputError::NonFinite {
            what: format!("{what} ({})", path.display()),
            index,
            value,
        },
        other => other,
    }
}

#[cfg(test)]
mod layout_tests;
#[cfg(test)]
mod tests;
