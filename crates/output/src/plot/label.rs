//! Labels placed beside a line plot (reference lines' and series' end labels): their font
//! size, box and record, shared by the layout and the end-label placement.

use super::color::Color;
use super::rect::Rect;

/// Font size of the reference lines' labels.
pub(crate) const REF_FONT: f64 = 11.0;

/// A reference line's label, or a series' end label: its box, baseline point, whether it is
/// anchored at its start (right of the frame) or its middle (above it), and its colour (a
/// series' own; grey for reference lines).
#[derive(Debug, Clone, PartialEq)]
pub struct RefLabel {
    pub text: String,
    pub rect: Rect,
    pub(crate) baseline: (f64, f64),
    pub(crate) start_anchored: bool,
    pub(crate) color: Option<Color>,
}

/// Box of a text of `size` px drawn at baseline `y`: glyphs reach 0.8 size above the baseline
/// and 0.25 size below it.
pub(crate) fn text_box(x: f64, y: f64, w: f64, size: f64) -> Rect {
    Rect::new(x, y - 0.8 * size, w, 1.05 * size)
}
