//! Line plots: several series on linear axes, legend, reference lines. Where everything goes is
//! decided by [`LineLayout`] (legend and labels never over the data); this module draws it.

use std::path::{Path, PathBuf};

use super::frame::{self, TITLE_FONT};
use super::legend;
use super::line_layout::{marker_radius, LineLayout, REF_FONT};
use super::series::{LegendPosition, LineStyle, RefLine, Series};
use super::svg::{Anchor, Svg, TextStyle};
use super::{write_png_file, write_svg_and_png_files, write_svg_file};
use crate::finite::{check_finite, check_finite_value};
use crate::OutputError;

/// A 2D line plot.
#[derive(Debug, Clone, PartialEq)]
pub struct LinePlot {
    /// Title above the plot (may be empty).
    pub title: String,
    /// Label of the x axis.
    pub x_label: String,
    /// Label of the y axis.
    pub y_label: String,
    /// The curves, drawn in order.
    pub series: Vec<Series>,
    /// Reference lines, drawn under the curves.
    pub ref_lines: Vec<RefLine>,
    /// Fixed x axis limits; `None`: data range rounded out to nice ticks.
    pub x_range: Option<(f64, f64)>,
    /// Fixed y axis limits; `None`: data range rounded out to nice ticks.
    pub y_range: Option<(f64, f64)>,
    /// Legend placement.
    pub legend: LegendPosition,
    /// Image width (px of the SVG; the PNG is [`PNG_SCALE`] times larger).
    pub width: f64,
    /// Image height (px).
    pub height: f64,
}

impl LinePlot {
    /// An empty 800 x 520 plot.
    pub fn new(
        title: impl Into<String>,
        x_label: impl Into<String>,
        y_label: impl Into<String>,
    ) -> Self {
        LinePlot {
            title: title.into(),
            x_label: x_label.into(),
            y_label: y_label.into(),
            series: Vec::new(),
            ref_lines: Vec::new(),
            x_range: None,
            y_range: None,
            legend: LegendPosition::TopRight,
            width: 800.0,
            height: 520.0,
        }
    }

    /// Adds a series (builder form).
    pub fn with_series(mut self, s: Series) -> Self {
        self.series.push(s);
        self
    }

    /// Adds a reference line (builder form).
    pub fn with_ref_line(mut self, r: RefLine) -> Self {
        self.ref_lines.push(r);
        self
    }

    /// Fixes the x axis limits.
    pub fn with_x_range(mut self, lo: f64, hi: f64) -> Self {
        self.x_range = Some((lo, hi));
        self
    }

    /// Fixes the y axis limits.
    pub fn with_y_range(mut self, lo: f64, hi: f64) -> Self {
        self.y_range = Some((lo, hi));
        self
    }

    /// Sets the legend placement.
    pub fn with_legend(mut self, pos: LegendPosition) -> Self {
        self.legend = pos;
        self
    }

    /// Sets the image size (px).
    pub fn with_size(mut self, width: f64, height: f64) -> Self {
        self.width = width;
        self.height = height;
        self
    }

    fn what(&self) -> String {
        format!("plot `{}`", self.title)
    }

    fn check(&self) -> Result<(), OutputError> {
        let what = self.what();
        if !(self.width.is_finite()
            && self.height.is_finite()
            && self.width >= 200.0
            && self.height >= 150.0)
        {
            return Err(OutputError::invalid(
                what,
                format!(
                    "size {} x {} px; expected at least 200 x 150",
                    self.width, self.height
                ),
            ));
        }
        for s in &self.series {
            if s.x.len() != s.y.len() {
                return Err(OutputError::invalid(
                    format!("series `{}` of {what}", s.label),
                    format!("{} x values but {} y values", s.x.len(), s.y.len()),
                ));
            }
            check_finite(&format!("x of series `{}` of {what}", s.label), &s.x)?;
            check_finite(&format!("y of series `{}` of {what}", s.label), &s.y)?;
            if !(s.width.is_finite() && s.width > 0.0) {
                return Err(OutputError::invalid(
                    format!("series `{}` of {what}", s.label),
                    format!("line width {}; expected > 0", s.width),
                ));
            }
        }
        for r in &self.ref_lines {
            check_finite_value(&format!("reference line `{}` of {what}", r.label), r.value)?;
        }
        Ok(())
    }

    /// Where everything goes (px): the geometric model of the figure, whose
    /// [`LineLayout::clashes`] lists anything drawn over the data.
    pub fn layout(&self) -> Result<LineLayout, OutputError> {
        self.check()?;
        LineLayout::new(self)
    }

    /// Renders the plot as an SVG document.
    pub fn to_svg(&self) -> Result<String, OutputError> {
        let l = self.layout()?;
        let a = l.area;
        let (x0, x1, y0, y1) = (a.x, a.right(), a.y, a.bottom());
        let mut svg = Svg::new(l.width, l.height);
        svg.clip_rect("plot-area", x0, y0, a.w, a.h);
        // Grid and ticks.
        for (x, _) in &l.x_ticks {
            svg.line(*x, y0, *x, y1, "#e3e3e3", 1.0, None);
        }
        for (y, _) in &l.y_ticks {
            svg.line(x0, *y, x1, *y, "#e3e3e3", 1.0, None);
        }
        frame::ticks(&mut svg, (x0, x1, y0, y1), &l.x_ticks, &l.y_ticks);
        // Reference lines, then the curves, clipped to the plot area.
        svg.open_group("clip-path=\"url(#plot-area)\"");
        for s in &l.ref_lines {
            svg.line(s.a.0, s.a.1, s.b.0, s.b.1, "#555555", 1.3, Some("6 4"));
        }
        for (s, c) in self.series.iter().zip(&l.colors) {
            let pts = self.series_px(&l, s);
            let hex = c.hex();
            if s.style != LineStyle::None {
                svg.polyline(&pts, &hex, s.width, s.style.dash());
            }
            if s.markers {
                for &(x, y) in &pts {
                    svg.circle(x, y, marker_radius(s.width), &hex);
                }
            }
        }
        svg.close_group();
        svg.rect(x0, y0, a.w, a.h, "none", Some("#333333"));
        // Labels and title.
        frame::axis_labels(
            &mut svg,
            (x0, x1, y0, y1),
            l.x_label_y + 14.0,
            &self.x_label,
            &self.y_label,
        );
        frame::title(&mut svg, 0.5 * (x0 + x1), &self.title, TITLE_FONT);
        if let Some((rect, columns)) = l.legend {
            let entries: Vec<_> = self
                .series
                .iter()
                .zip(l.colors.iter().copied())
                .filter(|(s, _)| !s.label.is_empty())
                .collect();
            legend::draw(&mut svg, &entries, rect, columns);
        }
        for label in &l.ref_labels {
            let anchor = if label.start_anchored {
                Anchor::Start
            } else {
                Anchor::Middle
            };
            let style = TextStyle {
                size: REF_FONT,
                color: "#333333",
                anchor,
                ..TextStyle::default()
            };
            svg.text(label.baseline.0, label.baseline.1, &label.text, style);
        }
        Ok(svg.finish())
    }

    /// The points of `s` in px.
    fn series_px(&self, l: &LineLayout, s: &Series) -> Vec<(f64, f64)> {
        s.x.iter().zip(&s.y).map(|(&x, &y)| l.to_px(x, y)).collect()
    }

    /// Writes the SVG to `path` atomically.
    pub fn write_svg(&self, path: &Path) -> Result<(), OutputError> {
        write_svg_file(self.to_svg(), path)
    }

    /// Writes the plot as PNG ([`super::PNG_SCALE`] px per SVG px) to `path` atomically.
    pub fn write_png(&self, path: &Path) -> Result<(), OutputError> {
        write_png_file(self.to_svg(), path)
    }

    /// Writes `<base>.svg` and `<base>.png`; returns their paths.
    pub fn write_svg_and_png(&self, base: &Path) -> Result<(PathBuf, PathBuf), OutputError> {
        write_svg_and_png_files(self.to_svg(), base)
    }
}
