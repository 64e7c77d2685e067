//! Plots as SVG (own small writer) and PNG (SVG rasterized with `resvg`).
//!
//! * [`LinePlot`]: axes with "nice" ticks, title, axis labels, several [`Series`] (solid, dashed
//!   or dotted lines, optional markers), a legend, and dashed reference lines ([`RefLine`]) such as
//!   "contact at 1" or "grazing".
//! * [`HeatMap`]: a matrix of values as colored cells with a color bar (the contact map: contact
//!   node x time).
//!
//! Both render to an SVG string (`to_svg`) and write `.svg` / `.png` files atomically
//! (`write_svg`, `write_png`, `write_svg_and_png`). Non-finite data are refused.

mod color;
mod heatmap;
mod line;
mod raster;
mod series;
mod svg;
mod ticks;

pub use color::{Color, Colormap, PALETTE};
pub use heatmap::HeatMap;
pub use line::LinePlot;
pub use raster::{fonts_available, svg_to_png, PNG_SCALE};
pub use series::{LegendPosition, LineStyle, Orientation, RefLine, Series};
pub use ticks::{nice_ticks, Ticks};

use std::ffi::OsString;
use std::path::{Path, PathBuf};

use crate::OutputError;

/// `base` with `.ext` appended (not replacing anything: `q_5.7` gives `q_5.7.svg`).
pub(crate) fn with_appended_extension(base: &Path, ext: &str) -> PathBuf {
    let mut s: OsString = base.as_os_str().to_os_string();
    s.push(".");
    s.push(ext);
    PathBuf::from(s)
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
mod tests;
