//! Heat maps: a matrix of values drawn as colored cells, with a color bar.
//! Used for the contact map (contact node x time over one period).

use std::path::{Path, PathBuf};

use super::color::Colormap;
use super::frame::{self, TICK_FONT, TITLE_FONT};
use super::svg::{text_width, Svg};
use super::ticks::{nice_ticks, tick_label};
use super::{write_png_file, write_svg_and_png_files, write_svg_file};
use crate::finite::check_finite;
use crate::OutputError;

/// A `rows` x `cols` matrix of values on the rectangle `x_extent` x `y_extent`.
///
/// `values[r * cols + c]` is the cell of row `r` (drawn from the bottom: row 0 is lowest) and
/// column `c` (from the left). For the contact map: rows = contact nodes (leading to trailing
/// edge), columns = time samples of one period, `y_extent = (0.5, n + 0.5)` to center node `k`
/// on y = `k`, `x_extent = (0, 1)` for t / T.
#[derive(Debug, Clone, PartialEq)]
pub struct HeatMap {
    /// Title above the plot.
    pub title: String,
    /// Label of the x axis.
    pub x_label: String,
    /// Label of the y axis.
    pub y_label: String,
    /// Label of the color bar.
    pub value_label: String,
    /// Number of rows (>= 1).
    pub rows: usize,
    /// Number of columns (>= 1).
    pub cols: usize,
    /// Row-major values, `rows * cols` finite numbers.
    pub values: Vec<f64>,
    /// x of the left edge of column 0 and of the right edge of the last column.
    pub x_extent: (f64, f64),
    /// y of the bottom edge of row 0 and of the top edge of the last row.
    pub y_extent: (f64, f64),
    /// Values mapped to the ends of the colormap (clamped outside); `None`: data min and max.
    pub value_range: Option<(f64, f64)>,
    /// Colormap.
    pub colormap: Colormap,
    /// Image width (px).
    pub width: f64,
    /// Image height (px).
    pub height: f64,
}

impl HeatMap {
    /// An 800 x 520 heat map with extents (0, cols) x (0, rows) and the viridis colormap.
    pub fn new(
        title: impl Into<String>,
        x_label: impl Into<String>,
        y_label: impl Into<String>,
        value_label: impl Into<String>,
        rows: usize,
        cols: usize,
        values: Vec<f64>,
    ) -> Self {
        HeatMap {
            title: title.into(),
            x_label: x_label.into(),
            y_label: y_label.into(),
            value_label: value_label.into(),
            rows,
            cols,
            values,
            x_extent: (0.0, cols as f64),
            y_extent: (0.0, rows as f64),
            value_range: None,
            colormap: Colormap::Viridis,
            width: 800.0,
            height: 520.0,
        }
    }

    /// Sets the x extent (builder form).
    pub fn with_x_extent(mut self, lo: f64, hi: f64) -> Self {
        self.x_extent = (lo, hi);
        self
    }

    /// Sets the y extent (builder form).
    pub fn with_y_extent(mut self, lo: f64, hi: f64) -> Self {
        self.y_extent = (lo, hi);
        self
    }

    /// Fixes the value range of the colormap.
    pub fn with_value_range(mut self, lo: f64, hi: f64) -> Self {
        self.value_range = Some((lo, hi));
        self
    }

    /// Sets the colormap.
    pub fn with_colormap(mut self, c: Colormap) -> Self {
        self.colormap = c;
        self
    }

    fn what(&self) -> String {
        format!("heat map `{}`", self.title)
    }

    fn check(&self) -> Result<(f64, f64), OutputError> {
        let what = self.what();
        if self.rows == 0 || self.cols == 0 || self.values.len() != self.rows * self.cols {
            return Err(OutputError::invalid(
                what,
                format!(
                    "{} values for {} rows x {} columns; expected rows, columns >= 1 and \
                     rows x columns values",
                    self.values.len(),
                    self.rows,
                    self.cols
                ),
            ));
        }
        if !(self.width.is_finite()
            && self.height.is_finite()
            && self.width >= 250.0
            && self.height >= 150.0)
        {
            return Err(OutputError::invalid(
                what,
                format!(
                    "size {} x {} px; expected at least 250 x 150",
                    self.width, self.height
                ),
            ));
        }
        check_finite(&format!("values of {what}"), &self.values)?;
        for (name, (lo, hi)) in [("x extent", self.x_extent), ("y extent", self.y_extent)] {
            check_finite(&format!("{name} of {what}"), &[lo, hi])?;
            if lo >= hi {
                return Err(OutputError::invalid(
                    format!("{name} of {what}"),
                    format!("({lo}, {hi}) is empty; expected lo < hi"),
                ));
            }
        }
        match self.value_range {
            Some((lo, hi)) => {
                check_finite(&format!("value range of {what}"), &[lo, hi])?;
                if lo >= hi {
                    return Err(OutputError::invalid(
                        format!("value range of {what}"),
                        format!("({lo}, {hi}) is empty; expected lo < hi"),
                    ));
                }
                Ok((lo, hi))
            }
            None => {
                let lo = self.values.iter().copied().fold(f64::INFINITY, f64::min);
                let hi = self
                    .values
                    .iter()
                    .copied()
                    .fold(f64::NEG_INFINITY, f64::max);
                if hi > lo {
                    Ok((lo, hi))
                } else {
                    // Constant data (e.g. no contact at all): the value sits at the low end.
                    Ok((lo, lo + lo.abs().max(1.0)))
                }
            }
        }
    }

    /// Renders the heat map as an SVG document.
    pub fn to_svg(&self) -> Result<String, OutputError> {
        let (vlo, vhi) = self.check()?;
        let (xlo, xhi) = self.x_extent;
        let (ylo, yhi) = self.y_extent;
        let within = |t: &[f64], lo: f64, hi: f64| -> Vec<f64> {
            let eps = 1e-9 * (hi - lo);
            t.iter()
                .copied()
                .filter(|v| *v >= lo - eps && *v <= hi + eps)
                .collect()
        };
        let xt = nice_ticks(xlo, xhi, 6);
        let yt = nice_ticks(ylo, yhi, 6);
        let xticks = within(&xt.values, xlo, xhi);
        let yticks = within(&yt.values, ylo, yhi);
        let xmax = xlo.abs().max(xhi.abs());
        let ymax = ylo.abs().max(yhi.abs());

        let y_tick_w = yticks
            .iter()
            .map(|&v| text_width(&tick_label(v, yt.step, ymax), TICK_FONT))
            .fold(0.0, f64::max);
        let left = frame::left_margin(y_tick_w);
        let right = 20.0 + frame::color_bar_width((vlo, vhi));
        let top = frame::top_margin(&self.title);
        let bottom = frame::BOTTOM_MARGIN;
        let (x0, x1, y0, y1) = (left, self.width - right, top, self.height - bottom);
        if x1 - x0 < 20.0 || y1 - y0 < 20.0 {
            return Err(OutputError::invalid(
                self.what(),
                format!(
                    "size {} x {} px leaves no room for the cells",
                    self.width, self.height
                ),
            ));
        }
        let px = |x: f64| x0 + (x - xlo) / (xhi - xlo) * (x1 - x0);
        let py = |y: f64| y1 - (y - ylo) / (yhi - ylo) * (y1 - y0);
        let color_of = |v: f64| self.colormap.at((v - vlo) / (vhi - vlo)).hex();

        let mut svg = Svg::new(self.width, self.height);
        // Cells: runs of equal color within a row become one rectangle.
        svg.open_group("shape-rendering=\"crispEdges\"");
        let dx = (xhi - xlo) / self.cols as f64;
        let dy = (yhi - ylo) / self.rows as f64;
        for r in 0..self.rows {
            let (top_y, bot_y) = (py(ylo + (r + 1) as f64 * dy), py(ylo + r as f64 * dy));
            let row = &self.values[r * self.cols..(r + 1) * self.cols];
            let mut c = 0;
            while c < self.cols {
                let color = color_of(row[c]);
                let mut end = c + 1;
                while end < self.cols && color_of(row[end]) == color {
                    end += 1;
                }
                let (l, rr) = (px(xlo + c as f64 * dx), px(xlo + end as f64 * dx));
                svg.rect(l, top_y, rr - l, bot_y - top_y, &color, None);
                c = end;
            }
        }
        svg.close_group();
        svg.rect(x0, y0, x1 - x0, y1 - y0, "none", Some("#333333"));

        let area = (x0, x1, y0, y1);
        let xs: Vec<(f64, String)> = xticks
            .iter()
            .map(|&v| (px(v), tick_label(v, xt.step, xmax)))
            .collect();
        let ys: Vec<(f64, String)> = yticks
            .iter()
            .map(|&v| (py(v), tick_label(v, yt.step, ymax)))
            .collect();
        frame::ticks(&mut svg, area, &xs, &ys);
        frame::color_bar(
            &mut svg,
            &frame::ColorBar {
                x: x1 + 20.0,
                y0,
                y1,
                colormap: self.colormap,
                range: (vlo, vhi),
                label: &self.value_label,
                label_x: self.width - 12.0,
            },
        );
        frame::axis_labels(&mut svg, area, self.height, &self.x_label, &self.y_label);
        frame::title(&mut svg, 0.5 * (x0 + x1), &self.title, TITLE_FONT);
        Ok(svg.finish())
    }

    /// Writes the SVG to `path` atomically.
    pub fn write_svg(&self, path: &Path) -> Result<(), OutputError> {
        write_svg_file(self.to_svg(), path)
    }

    /// Writes the heat map as PNG ([`super::PNG_SCALE`] px per SVG px) to `path` atomically.
    pub fn write_png(&self, path: &Path) -> Result<(), OutputError> {
        write_png_file(self.to_svg(), path)
    }

    /// Writes `<base>.svg` and `<base>.png`; returns their paths.
    pub fn write_svg_and_png(&self, base: &Path) -> Result<(PathBuf, PathBuf), OutputError> {
        write_svg_and_png_files(self.to_svg(), base)
    }
}
