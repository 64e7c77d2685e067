//! Line plots: several series on linear axes, legend, reference lines.

use std::path::{Path, PathBuf};

use super::color::{Color, PALETTE};
use super::frame::{self, TICK_FONT, TITLE_FONT};
use super::series::{LegendPosition, LineStyle, Orientation, RefLine, Series};
use super::svg::{text_width, Anchor, Svg, TextStyle};
use super::ticks::{nice_ticks, tick_label};
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

/// Axis limits and ticks.
struct Axis {
    lo: f64,
    hi: f64,
    ticks: Vec<f64>,
    step: f64,
}

impl Axis {
    /// Fixed limits if given; otherwise the data range widened by `pad` (fraction of the span) on
    /// both sides. Ticks are the nice values inside the limits.
    fn new(
        what: &str,
        fixed: Option<(f64, f64)>,
        data_lo: f64,
        data_hi: f64,
        pad: f64,
    ) -> Result<Self, OutputError> {
        let (lo, hi) = match fixed {
            Some((lo, hi)) => {
                check_finite(what, &[lo, hi])?;
                if lo >= hi {
                    return Err(OutputError::invalid(
                        what.to_string(),
                        format!("range ({lo}, {hi}) is empty; expected lo < hi"),
                    ));
                }
                (lo, hi)
            }
            None => {
                // A flat range is widened the way nice_ticks does it.
                let t = nice_ticks(data_lo, data_hi, 6);
                let (lo, hi) = if data_hi - data_lo <= 1e-9 * data_lo.abs().max(data_hi.abs())
                    || data_hi == data_lo
                {
                    (t.lo, t.hi)
                } else {
                    (data_lo, data_hi)
                };
                let span = hi - lo;
                (lo - pad * span, hi + pad * span)
            }
        };
        let t = nice_ticks(lo, hi, 6);
        let eps = 1e-9 * (hi - lo);
        Ok(Axis {
            lo,
            hi,
            ticks: t
                .values
                .into_iter()
                .filter(|v| *v >= lo - eps && *v <= hi + eps)
                .collect(),
            step: t.step,
        })
    }

    fn label(&self, v: f64) -> String {
        tick_label(v, self.step, self.lo.abs().max(self.hi.abs()))
    }
}

/// Margin added above and below the y data range (fraction of the range), as in most plotting
/// tools: curves do not run along the frame. The x axis spans the data exactly.
const Y_PAD: f64 = 0.05;

const LEGEND_FONT: f64 = 12.0;

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

    /// Renders the plot as an SVG document.
    pub fn to_svg(&self) -> Result<String, OutputError> {
        self.check()?;
        let what = self.what();
        let (mut xl, mut xh, mut yl, mut yh) = (
            f64::INFINITY,
            f64::NEG_INFINITY,
            f64::INFINITY,
            f64::NEG_INFINITY,
        );
        for s in &self.series {
            for (&x, &y) in s.x.iter().zip(&s.y) {
                xl = xl.min(x);
                xh = xh.max(x);
                yl = yl.min(y);
                yh = yh.max(y);
            }
        }
        for r in &self.ref_lines {
            match r.orientation {
                Orientation::Horizontal => {
                    yl = yl.min(r.value);
                    yh = yh.max(r.value);
                }
                Orientation::Vertical => {
                    xl = xl.min(r.value);
                    xh = xh.max(r.value);
                }
            }
        }
        if xl > xh {
            (xl, xh) = (0.0, 1.0);
        }
        if yl > yh {
            (yl, yh) = (0.0, 1.0);
        }
        let xa = Axis::new(&format!("x range of {what}"), self.x_range, xl, xh, 0.0)?;
        let ya = Axis::new(&format!("y range of {what}"), self.y_range, yl, yh, Y_PAD)?;

        // Layout (px).
        let y_tick_w = ya
            .ticks
            .iter()
            .map(|&v| text_width(&ya.label(v), TICK_FONT))
            .fold(0.0, f64::max);
        let left = frame::left_margin(y_tick_w);
        let right = 24.0;
        let top = frame::top_margin(&self.title);
        let bottom = frame::BOTTOM_MARGIN;
        let (x0, x1, y0, y1) = (left, self.width - right, top, self.height - bottom);
        let px = |x: f64| x0 + (x - xa.lo) / (xa.hi - xa.lo) * (x1 - x0);
        let py = |y: f64| y1 - (y - ya.lo) / (ya.hi - ya.lo) * (y1 - y0);

        let mut svg = Svg::new(self.width, self.height);
        svg.clip_rect("plot-area", x0, y0, x1 - x0, y1 - y0);
        // Grid and ticks.
        for &v in &xa.ticks {
            svg.line(px(v), y0, px(v), y1, "#e3e3e3", 1.0, None);
        }
        for &v in &ya.ticks {
            svg.line(x0, py(v), x1, py(v), "#e3e3e3", 1.0, None);
        }
        let xs: Vec<(f64, String)> = xa.ticks.iter().map(|&v| (px(v), xa.label(v))).collect();
        let ys: Vec<(f64, String)> = ya.ticks.iter().map(|&v| (py(v), ya.label(v))).collect();
        frame::ticks(&mut svg, (x0, x1, y0, y1), &xs, &ys);
        // Reference lines, then the curves, clipped to the plot area.
        svg.open_group("clip-path=\"url(#plot-area)\"");
        let ref_text = TextStyle {
            size: 11.0,
            color: "#333333",
            halo: true,
            ..TextStyle::default()
        };
        // Labels are drawn last (over curves and legend), with a white halo.
        let mut ref_labels: Vec<(f64, f64, &str, Anchor)> = Vec::new();
        for r in &self.ref_lines {
            match r.orientation {
                Orientation::Horizontal if r.value >= ya.lo && r.value <= ya.hi => {
                    let y = py(r.value);
                    svg.line(x0, y, x1, y, "#555555", 1.3, Some("6 4"));
                    // Above the line, or below it when that would leave the plot area.
                    let ty = if y - 5.0 - ref_text.size < y0 {
                        y + 5.0 + ref_text.size
                    } else {
                        y - 5.0
                    };
                    ref_labels.push((x1 - 6.0, ty, &r.label, Anchor::End));
                }
                Orientation::Vertical if r.value >= xa.lo && r.value <= xa.hi => {
                    let x = px(r.value);
                    svg.line(x, y0, x, y1, "#555555", 1.3, Some("6 4"));
                    ref_labels.push((x + 5.0, y0 + 14.0, &r.label, Anchor::Start));
                }
                _ => {}
            }
        }
        let colors: Vec<Color> = self
            .series
            .iter()
            .enumerate()
            .map(|(i, s)| s.color.unwrap_or(PALETTE[i % PALETTE.len()]))
            .collect();
        for (s, c) in self.series.iter().zip(&colors) {
            let pts: Vec<(f64, f64)> =
                s.x.iter()
                    .zip(&s.y)
                    .map(|(&x, &y)| (px(x), py(y)))
                    .collect();
            let hex = c.hex();
            if s.style != LineStyle::None {
                svg.polyline(&pts, &hex, s.width, s.style.dash());
            }
            if s.markers {
                for &(x, y) in &pts {
                    svg.circle(x, y, 1.6 * s.width.max(2.0), &hex);
                }
            }
        }
        svg.close_group();
        svg.rect(x0, y0, x1 - x0, y1 - y0, "none", Some("#333333"));

        // Labels and title.
        let area = (x0, x1, y0, y1);
        frame::axis_labels(&mut svg, area, self.height, &self.x_label, &self.y_label);
        frame::title(&mut svg, 0.5 * (x0 + x1), &self.title, TITLE_FONT);
        self.draw_legend(&mut svg, &colors, (x0, x1, y0, y1));
        for (x, y, text, anchor) in ref_labels {
            if !text.is_empty() {
                svg.text(x, y, text, TextStyle { anchor, ..ref_text });
            }
        }
        Ok(svg.finish())
    }

    fn draw_legend(&self, svg: &mut Svg, colors: &[Color], (x0, x1, y0, y1): (f64, f64, f64, f64)) {
        let entries: Vec<(&Series, &Color)> = self
            .series
            .iter()
            .zip(colors)
            .filter(|(s, _)| !s.label.is_empty())
            .collect();
        if entries.is_empty() || self.legend == LegendPosition::Hidden {
            return;
        }
        let row = LEGEND_FONT + 7.0;
        let sample = 28.0;
        let text_w = entries
            .iter()
            .map(|(s, _)| text_width(&s.label, LEGEND_FONT))
            .fold(0.0, f64::max);
        let w = 10.0 + sample + 8.0 + text_w + 10.0;
        let h = 8.0 + row * entries.len() as f64 + 4.0;
        let inset = 10.0;
        let (bx, by) = match self.legend {
            LegendPosition::TopLeft => (x0 + inset, y0 + inset),
            LegendPosition::BottomRight => (x1 - inset - w, y1 - inset - h),
            LegendPosition::BottomLeft => (x0 + inset, y1 - inset - h),
            _ => (x1 - inset - w, y0 + inset),
        };
        svg.open_group("opacity=\"0.92\"");
        svg.rect(bx, by, w, h, "#ffffff", Some("#aaaaaa"));
        svg.close_group();
        for (k, (s, c)) in entries.iter().enumerate() {
            let cy = by + 8.0 + row * (k as f64 + 0.5);
            let hex = c.hex();
            if s.style != LineStyle::None {
                svg.line(
                    bx + 10.0,
                    cy,
                    bx + 10.0 + sample,
                    cy,
                    &hex,
                    s.width,
                    s.style.dash(),
                );
            }
            if s.markers {
                svg.circle(bx + 10.0 + 0.5 * sample, cy, 1.6 * s.width.max(2.0), &hex);
            }
            svg.text(
                bx + 10.0 + sample + 8.0,
                cy + 0.35 * LEGEND_FONT,
                &s.label,
                TextStyle {
                    size: LEGEND_FONT,
                    anchor: Anchor::Start,
                    ..TextStyle::default()
                },
            );
        }
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
