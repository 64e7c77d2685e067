//! The legend of a line plot: the size of its box for a number of columns, and its drawing.
//! Where the box goes is decided by [`super::line_layout`], which proves it clear of the data.

use super::color::Color;
use super::rect::Rect;
use super::series::{LineStyle, Series};
use super::svg::{text_width, Anchor, Svg, TextStyle};

const LEGEND_FONT: f64 = 12.0;
/// Height of one entry (px).
const ROW: f64 = LEGEND_FONT + 7.0;
/// Length of the line sample (px).
const SAMPLE: f64 = 28.0;
/// Space between the sample and the text (px).
const SAMPLE_GAP: f64 = 8.0;
/// Box padding left and right (px), and between columns.
const PAD: f64 = 10.0;
/// Box padding above the first and below the last row (px).
const PAD_TOP: f64 = 8.0;
const PAD_BOTTOM: f64 = 4.0;
/// [`text_width`] is an average over digits and lower-case letters; the legend's box takes
/// this much more, so that labels with capitals and wide letters stay inside it (checked
/// against the rendered glyphs by the plot tests).
const TEXT_SLACK: f64 = 1.1;

/// Width of one column of entries (sample, gap, the longest text), without padding.
fn column_width(labels: &[&str]) -> f64 {
    let text = labels
        .iter()
        .map(|l| text_width(l, LEGEND_FONT) * TEXT_SLACK)
        .fold(0.0, f64::max);
    SAMPLE + SAMPLE_GAP + text
}

/// Size (w, h) of the box of `labels` in `columns` columns (row by row).
pub(crate) fn box_size(labels: &[&str], columns: usize) -> (f64, f64) {
    let columns = columns.clamp(1, labels.len().max(1));
    let rows = labels.len().div_ceil(columns);
    let w = PAD + columns as f64 * (column_width(labels) + PAD);
    (w, PAD_TOP + ROW * rows as f64 + PAD_BOTTOM)
}

/// The most columns (at least 1) whose box is at most `width` px wide.
pub(crate) fn columns_within(labels: &[&str], width: f64) -> usize {
    let per = column_width(labels) + PAD;
    (((width - PAD) / per).floor() as usize).clamp(1, labels.len().max(1))
}

/// Draws the box at `at` with `entries` (series and their colours) in `columns` columns.
pub(crate) fn draw(svg: &mut Svg, entries: &[(&Series, Color)], at: Rect, columns: usize) {
    let labels: Vec<&str> = entries.iter().map(|(s, _)| s.label.as_str()).collect();
    let col_w = column_width(&labels) + PAD;
    svg.rect(at.x, at.y, at.w, at.h, "#ffffff", Some("#aaaaaa"));
    for (k, (s, c)) in entries.iter().enumerate() {
        let (row, col) = (k / columns.max(1), k % columns.max(1));
        let x = at.x + PAD + col as f64 * col_w;
        let cy = at.y + PAD_TOP + ROW * (row as f64 + 0.5);
        let hex = c.hex();
        if s.style != LineStyle::None {
            svg.line(x, cy, x + SAMPLE, cy, &hex, s.width, s.style.dash());
        }
        if s.markers {
            svg.circle(x + 0.5 * SAMPLE, cy, s.marker_radius(), &hex);
        }
        svg.text(
            x + SAMPLE + SAMPLE_GAP,
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
