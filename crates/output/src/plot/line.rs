//! Line plots: several series on linear axes, legend, reference lines: what a plot shows.
//! Where everything goes is decided by [`super::LineLayout`] (legend and labels never over the
//! data), and [`super::line_svg`] draws it.

use super::series::{LegendPosition, RefLine, Series};
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

    pub(crate) fn what(&self) -> String {
        format!("plot `{}`", self.title)
    }

    pub(crate) fn check(&self) -> Result<(), OutputError> {
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
}
