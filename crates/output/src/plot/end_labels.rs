//! Labels at the ends of series ([`super::Series::end_label`]), outside the plot area: right of
//! the frame for a series whose last point lies on the right end of the x range, above the
//! frame at the last point's x for the others (lines leaving the area through its top). The
//! labels right of the frame are moved apart vertically where they would overlap; those above
//! it share the rows of the vertical reference lines' labels (`line_layout`).

use super::axis::Axis;
use super::color::{Color, PALETTE};
use super::label::{text_box, RefLabel, REF_FONT};
use super::line::LinePlot;
use super::svg::text_width;

/// Gap between the frame and a label right of it (px).
pub(crate) const GAP: f64 = 6.0;
/// Smallest distance between the baselines of two labels right of the frame (px).
const LINE: f64 = REF_FONT + 2.0;

/// A series' end label: its text, colour and last point (data units).
pub(crate) struct EndLabel {
    pub text: String,
    pub color: Color,
    pub end: (f64, f64),
}

/// The end labels of `plot`, split into those right of the frame and those above it.
pub(crate) fn end_labels(plot: &LinePlot, xa: &Axis) -> (Vec<EndLabel>, Vec<EndLabel>) {
    let eps = 1e-9 * (xa.hi - xa.lo);
    (plot.series.iter().enumerate())
        .filter(|(_, s)| !s.end_label.is_empty())
        .filter_map(|(i, s)| {
            Some(EndLabel {
                text: s.end_label.clone(),
                color: s.color.unwrap_or(PALETTE[i % PALETTE.len()]),
                end: (*s.x.last()?, *s.y.last()?),
            })
        })
        .partition(|l| l.end.0 >= xa.hi - eps)
}

/// Width of the widest label right of the frame (px), if any.
pub(crate) fn widest_right(plot: &LinePlot, xa: &Axis) -> Option<f64> {
    let (right, _) = end_labels(plot, xa);
    (right.iter())
        .map(|l| text_width(&l.text, REF_FONT))
        .fold(None, |m: Option<f64>, w| Some(m.map_or(w, |m| m.max(w))))
}

/// The labels right of the frame (right edge `x1`), at the height of their series' last point
/// (`py` maps data to px), clamped to the area [`top`, `bottom`].
pub(crate) fn right_labels(
    plot: &LinePlot,
    xa: &Axis,
    py: &dyn Fn(f64) -> f64,
    x1: f64,
    (top, bottom): (f64, f64),
) -> Vec<RefLabel> {
    let (right, _) = end_labels(plot, xa);
    right
        .into_iter()
        .map(|l| {
            let base = py(l.end.1).clamp(top, bottom) + 0.35 * REF_FONT;
            let w = text_width(&l.text, REF_FONT);
            RefLabel {
                rect: text_box(x1 + GAP, base, w, REF_FONT),
                text: l.text,
                baseline: (x1 + GAP, base),
                start_anchored: true,
                color: Some(l.color),
            }
        })
        .collect()
}

/// Moves the labels right of the frame apart: in order of height, each at least [`LINE`] px
/// below the one above it, then the column shifted up as a whole if it ends below `bottom`
/// (kept below `top`).
pub(crate) fn spread(labels: &mut [RefLabel], (top, bottom): (f64, f64)) {
    labels.sort_by(|a, b| a.baseline.1.total_cmp(&b.baseline.1));
    for k in 1..labels.len() {
        let floor = labels[k - 1].baseline.1 + LINE;
        if labels[k].baseline.1 < floor {
            move_to(&mut labels[k], floor);
        }
    }
    let overflow = labels.last().map_or(0.0, |l| l.baseline.1 - bottom);
    if overflow > 0.0 {
        let room = labels.first().map_or(0.0, |l| l.baseline.1 - top);
        let shift = overflow.min(room.max(0.0));
        for l in labels.iter_mut() {
            let y = l.baseline.1 - shift;
            move_to(l, y);
        }
    }
}

fn move_to(l: &mut RefLabel, baseline: f64) {
    l.rect.y += baseline - l.baseline.1;
    l.baseline.1 = baseline;
}
