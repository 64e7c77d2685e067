//! Data and decorations of line plots: series, line styles, reference lines, legend placement.

use super::color::Color;

/// How a series' points are joined.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum LineStyle {
    /// Continuous line.
    #[default]
    Solid,
    /// Long dashes.
    Dashed,
    /// Dots.
    Dotted,
    /// No line (use markers).
    None,
}

impl LineStyle {
    pub(crate) fn dash(&self) -> Option<&'static str> {
        match self {
            LineStyle::Dashed => Some("7 4"),
            LineStyle::Dotted => Some("1.5 3.5"),
            LineStyle::Solid | LineStyle::None => None,
        }
    }
}

/// A curve y(x).
#[derive(Debug, Clone, PartialEq)]
pub struct Series {
    /// Legend text (empty: not in the legend).
    pub label: String,
    /// Abscissae.
    pub x: Vec<f64>,
    /// Ordinates, same length as `x`.
    pub y: Vec<f64>,
    /// Color; `None` takes the next palette color.
    pub color: Option<Color>,
    /// Line style.
    pub style: LineStyle,
    /// Draw a marker at every point.
    pub markers: bool,
    /// Line width (px); the markers' radius follows it ([`Series::marker_radius`]).
    pub width: f64,
    /// A label written at the series' end, outside the plot area, in the series' colour
    /// (empty: none): right of the frame at the last point's height when that point lies on
    /// the right end of the x range, else above the frame at its x (a line leaving the area
    /// through its top). Labels that would overlap are moved apart (`LineLayout`).
    pub end_label: String,
}

impl Series {
    /// A solid series without markers.
    pub fn new(label: impl Into<String>, x: impl Into<Vec<f64>>, y: impl Into<Vec<f64>>) -> Self {
        Series {
            label: label.into(),
            x: x.into(),
            y: y.into(),
            color: None,
            style: LineStyle::Solid,
            markers: false,
            width: 2.0,
            end_label: String::new(),
        }
    }

    /// Sets the color.
    pub fn color(mut self, c: Color) -> Self {
        self.color = Some(c);
        self
    }

    /// Sets the line style.
    pub fn style(mut self, s: LineStyle) -> Self {
        self.style = s;
        self
    }

    /// Turns markers on or off.
    pub fn markers(mut self, on: bool) -> Self {
        self.markers = on;
        self
    }

    /// Sets the label written at the series' end (see [`Series::end_label`]).
    pub fn end_label(mut self, text: impl Into<String>) -> Self {
        self.end_label = text.into();
        self
    }

    /// Sets the line width (px).
    pub fn width(mut self, w: f64) -> Self {
        self.width = w;
        self
    }

    /// Radius of its markers (px): 1.6 times the line width, 3.2 px at the default width 2, at
    /// least 1.6 px.
    pub fn marker_radius(&self) -> f64 {
        1.6 * self.width.max(1.0)
    }
}

/// Direction of a reference line.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Orientation {
    /// y = value.
    Horizontal,
    /// x = value.
    Vertical,
}

/// A dashed gray reference line across the plot, with a label (e.g. "contact at 1").
#[derive(Debug, Clone, PartialEq)]
pub struct RefLine {
    /// Horizontal (y = value) or vertical (x = value).
    pub orientation: Orientation,
    /// Position in data units.
    pub value: f64,
    /// Text written next to the line (may be empty).
    pub label: String,
}

impl RefLine {
    /// y = `value`.
    pub fn horizontal(value: f64, label: impl Into<String>) -> Self {
        RefLine {
            orientation: Orientation::Horizontal,
            value,
            label: label.into(),
        }
    }

    /// x = `value`.
    pub fn vertical(value: f64, label: impl Into<String>) -> Self {
        RefLine {
            orientation: Orientation::Vertical,
            value,
            label: label.into(),
        }
    }
}

/// Where the legend box goes. A legend is never drawn over data: a corner inside the plot area
/// is used only when the box there, with a margin, meets no curve, marker or reference line;
/// otherwise the legend goes beside the area ([`LegendPosition::Right`]) and the image widens.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum LegendPosition {
    /// The first free corner inside the area (top right, top left, bottom right, bottom
    /// left); beside the area when none is free.
    #[default]
    Auto,
    /// Top right corner if free, else beside the area.
    TopRight,
    /// Top left corner if free, else beside the area.
    TopLeft,
    /// Bottom right corner if free, else beside the area.
    BottomRight,
    /// Bottom left corner if free, else beside the area.
    BottomLeft,
    /// Beside the area, right of it, top-aligned (the image widens).
    Right,
    /// Below the x axis label, in as many columns as fit the image's width (the image grows).
    Below,
    /// No legend.
    Hidden,
}
