//! Drawing a [`LinePlot`] as SVG from its [`LineLayout`], and writing it (SVG, PNG).

use std::path::{Path, PathBuf};

use super::frame::{self, TITLE_FONT};
use super::legend;
use super::line::LinePlot;
use super::line_layout::{LineLayout, REF_FONT};
use super::series::{LineStyle, Series};
use super::svg::{Anchor, Svg, TextStyle};
use super::{write_png_file, write_svg_and_png_files, write_svg_file};
use crate::OutputError;

impl LinePlot {
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
                    svg.circle(x, y, s.marker_radius(), &hex);
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
            let hex = label.color.map_or("#333333".to_string(), |c| c.hex());
            let style = TextStyle {
                size: REF_FONT,
                color: &hex,
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
