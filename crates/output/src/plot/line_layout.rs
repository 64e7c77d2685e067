//! Where a line plot draws what: axes, plot area, the data in px, the legend box and the
//! reference-line labels. The legend goes inside the plot area only at a corner whose box (with a
//! margin) meets no curve, marker or reference line; otherwise beside or below the area, which
//! grows the image. Reference-line labels go outside the area (above it for vertical lines,
//! right of it for horizontal ones). [`LineLayout::clashes`] checks the result: nothing the
//! figure labels with is drawn over its data or over other text.

use super::axis::{data_ranges, Axis, Y_PAD};
use super::color::{Color, PALETTE};
use super::end_labels;
use super::frame::{self, LABEL_FONT, TICK_FONT, TITLE_FONT};
pub use super::label::RefLabel;
pub(crate) use super::label::{text_box, REF_FONT};
use super::legend;
use super::line::LinePlot;
use super::rect::Rect;
use super::series::{LegendPosition, LineStyle, Orientation};
use super::svg::text_width;
use crate::OutputError;

/// Height of one row of vertical-line labels above the area (px).
const REF_ROW: f64 = REF_FONT + 5.0;
/// Space kept between the legend box and any data when it sits inside the area (px).
const CLEARANCE: f64 = 4.0;
/// Legend inset from the frame inside the area, and gap to the area outside it (px).
const INSET: f64 = 10.0;
/// Right margin without labels: room for the last x tick label (px).
const RIGHT: f64 = 24.0;

/// A straight piece of a drawn line (px), with half its width.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Stroke {
    pub a: (f64, f64),
    pub b: (f64, f64),
    pub half_width: f64,
}

/// The geometric model of a rendered [`LinePlot`] (px, y downward): what `to_svg` draws where.
#[derive(Debug, Clone, PartialEq)]
pub struct LineLayout {
    /// Image size (the plot's size, grown by a legend beside or below the area).
    pub width: f64,
    pub height: f64,
    /// The plot area (the frame); curves are clipped to it.
    pub area: Rect,
    /// Title, axis labels and tick labels.
    pub texts: Vec<Rect>,
    /// The legend box, with its number of columns.
    pub legend: Option<(Rect, usize)>,
    /// The reference lines' labels.
    pub ref_labels: Vec<RefLabel>,
    /// Every drawn piece of a curve.
    pub strokes: Vec<Stroke>,
    /// The reference lines in range.
    pub ref_lines: Vec<Stroke>,
    /// Every drawn marker: centre and radius.
    pub dots: Vec<((f64, f64), f64)>,
    /// Tick positions with their labels, along x (px, label) and y.
    pub(crate) x_ticks: Vec<(f64, String)>,
    pub(crate) y_ticks: Vec<(f64, String)>,
    /// Series colours (the palette where a series sets none).
    pub(crate) colors: Vec<Color>,
    /// Baseline of the x label.
    pub(crate) x_label_y: f64,
    /// The axes' limits (data units): (x lo, x hi), (y lo, y hi).
    limits: ((f64, f64), (f64, f64)),
}

impl LineLayout {
    /// Lays out `plot` (checked by the caller).
    pub(crate) fn new(plot: &LinePlot) -> Result<Self, OutputError> {
        let what = format!("plot `{}`", plot.title);
        let (xd, yd) = data_ranges(plot);
        let xa = Axis::new(&format!("x range of {what}"), plot.x_range, xd, 0.0)?;
        let ya = Axis::new(&format!("y range of {what}"), plot.y_range, yd, Y_PAD)?;
        let y_tick_w = ya
            .ticks
            .iter()
            .map(|&v| text_width(&ya.label(v), TICK_FONT))
            .fold(0.0, f64::max);
        let right = right_margin(plot, &xa, &ya);
        let x0 = frame::left_margin(y_tick_w);
        let x1 = plot.width - right;
        let px = |x: f64| x0 + (x - xa.lo) / (xa.hi - xa.lo) * (x1 - x0);
        let vertical = vertical_labels(plot, &xa, &px, plot.width);
        let rows = vertical.iter().map(|(_, row)| row + 1).max().unwrap_or(0);
        let y0 = frame::top_margin(&plot.title) + REF_ROW * rows as f64;
        let y1 = plot.height - frame::BOTTOM_MARGIN;
        let py = |y: f64| y1 - (y - ya.lo) / (ya.hi - ya.lo) * (y1 - y0);
        let mut ref_labels: Vec<RefLabel> = vertical
            .into_iter()
            .map(|(mut l, row)| {
                let base = y0 - 5.0 - REF_ROW * row as f64;
                l.rect.y = base - 0.8 * REF_FONT;
                l.baseline.1 = base;
                l
            })
            .collect();
        let mut beside = horizontal_labels(plot, &ya, &py, x1);
        beside.extend(end_labels::right_labels(plot, &xa, &py, x1, (y0, y1)));
        end_labels::spread(&mut beside, (y0, y1 + 0.35 * REF_FONT));
        ref_labels.extend(beside);
        let area = Rect::new(x0, y0, x1 - x0, y1 - y0);
        let colors: Vec<Color> = plot
            .series
            .iter()
            .enumerate()
            .map(|(i, s)| s.color.unwrap_or(PALETTE[i % PALETTE.len()]))
            .collect();
        let mut layout = LineLayout {
            width: plot.width,
            height: plot.height,
            area,
            texts: Vec::new(),
            legend: None,
            ref_labels,
            strokes: Vec::new(),
            ref_lines: Vec::new(),
            dots: Vec::new(),
            x_ticks: xa.ticks.iter().map(|&v| (px(v), xa.label(v))).collect(),
            y_ticks: ya.ticks.iter().map(|&v| (py(v), ya.label(v))).collect(),
            colors,
            x_label_y: y1 + frame::BOTTOM_MARGIN - 14.0,
            limits: ((xa.lo, xa.hi), (ya.lo, ya.hi)),
        };
        layout.data(plot, &xa, &ya, &px, &py);
        layout.fixed_texts(plot);
        layout.place_legend(plot, right);
        Ok(layout)
    }

    /// The curves, markers and reference lines in px.
    fn data(
        &mut self,
        plot: &LinePlot,
        xa: &Axis,
        ya: &Axis,
        px: &dyn Fn(f64) -> f64,
        py: &dyn Fn(f64) -> f64,
    ) {
        let a = self.area;
        for r in &plot.ref_lines {
            let (p, q) = match r.orientation {
                Orientation::Horizontal if ya.contains(r.value) => {
                    ((a.x, py(r.value)), (a.right(), py(r.value)))
                }
                Orientation::Vertical if xa.contains(r.value) => {
                    ((px(r.value), a.y), (px(r.value), a.bottom()))
                }
                _ => continue,
            };
            self.ref_lines.push(Stroke {
                a: p,
                b: q,
                half_width: 0.65,
            });
        }
        for s in &plot.series {
            let pts: Vec<(f64, f64)> =
                s.x.iter()
                    .zip(&s.y)
                    .map(|(&x, &y)| (px(x), py(y)))
                    .collect();
            if s.style != LineStyle::None {
                for w in pts.windows(2) {
                    self.strokes.push(Stroke {
                        a: w[0],
                        b: w[1],
                        half_width: 0.5 * s.width,
                    });
                }
                if let [only] = pts[..] {
                    self.dots.push((only, 0.5 * s.width));
                }
            }
            if s.markers {
                let r = s.marker_radius();
                self.dots.extend(pts.iter().map(|&p| (p, r)));
            }
        }
    }

    /// A data point (x, y) in px.
    pub fn to_px(&self, x: f64, y: f64) -> (f64, f64) {
        let (a, ((xl, xh), (yl, yh))) = (&self.area, self.limits);
        (
            a.x + (x - xl) / (xh - xl) * a.w,
            a.bottom() - (y - yl) / (yh - yl) * a.h,
        )
    }

    /// Title, axis labels and tick labels.
    fn fixed_texts(&mut self, plot: &LinePlot) {
        let a = self.area;
        let cx = 0.5 * (a.x + a.right());
        if !plot.title.is_empty() {
            // Bold text: about 10 % wider than the estimate.
            let w = 1.1 * text_width(&plot.title, TITLE_FONT);
            let base = frame::title_baseline(TITLE_FONT);
            self.texts.push(text_box(cx - 0.5 * w, base, w, TITLE_FONT));
        }
        if !plot.x_label.is_empty() {
            let w = text_width(&plot.x_label, LABEL_FONT);
            self.texts
                .push(text_box(cx - 0.5 * w, self.x_label_y, w, LABEL_FONT));
        }
        for (x, label) in &self.x_ticks {
            let w = text_width(label, TICK_FONT);
            self.texts.push(text_box(
                x - 0.5 * w,
                a.bottom() + 8.0 + TICK_FONT,
                w,
                TICK_FONT,
            ));
        }
        for (y, label) in &self.y_ticks {
            let w = text_width(label, TICK_FONT);
            self.texts
                .push(text_box(a.x - 8.0 - w, y + 0.35 * TICK_FONT, w, TICK_FONT));
        }
    }

    /// The legend box: inside the area at a free corner when asked (or by default), else beside
    /// the area (right of its labels) or below the x label; the image grows to hold it.
    fn place_legend(&mut self, plot: &LinePlot, right: f64) {
        let labels: Vec<&str> = plot
            .series
            .iter()
            .map(|s| s.label.as_str())
            .filter(|l| !l.is_empty())
            .collect();
        if labels.is_empty() || plot.legend == LegendPosition::Hidden {
            return;
        }
        let a = self.area;
        let (w, h) = legend::box_size(&labels, 1);
        let corner = |c: LegendPosition| {
            let x = match c {
                LegendPosition::TopLeft | LegendPosition::BottomLeft => a.x + INSET,
                _ => a.right() - INSET - w,
            };
            let y = match c {
                LegendPosition::TopLeft | LegendPosition::TopRight => a.y + INSET,
                _ => a.bottom() - INSET - h,
            };
            Rect::new(x, y, w, h)
        };
        let tried: &[LegendPosition] = match plot.legend {
            LegendPosition::Auto => &[
                LegendPosition::TopRight,
                LegendPosition::TopLeft,
                LegendPosition::BottomRight,
                LegendPosition::BottomLeft,
            ],
            LegendPosition::TopRight => &[LegendPosition::TopRight],
            LegendPosition::TopLeft => &[LegendPosition::TopLeft],
            LegendPosition::BottomRight => &[LegendPosition::BottomRight],
            LegendPosition::BottomLeft => &[LegendPosition::BottomLeft],
            _ => &[],
        };
        let inside = tried
            .iter()
            .map(|&c| corner(c))
            .find(|r| a.inflate(-1.0).contains(r) && self.clear_of_data(&r.inflate(CLEARANCE)));
        let (rect, columns) = match (inside, plot.legend) {
            (Some(r), _) => (r, 1),
            (None, LegendPosition::Below) => {
                let columns = legend::columns_within(&labels, plot.width - 2.0 * INSET);
                let (w, h) = legend::box_size(&labels, columns);
                let y = self.x_label_y + 0.25 * LABEL_FONT + INSET;
                let x = (a.x + 0.5 * (a.w - w)).max(INSET);
                (Rect::new(x, y, w, h), columns)
            }
            (None, _) => (Rect::new(a.right() + right, a.y, w, h), 1),
        };
        // Whole px, so that the PNG is exactly PNG_SCALE times the SVG.
        self.width = self.width.max((rect.right() + INSET).ceil());
        self.height = self.height.max((rect.bottom() + INSET).ceil());
        self.legend = Some((rect, columns));
    }
}

/// Right margin: room for the last x tick label, or for the labels of the horizontal
/// reference lines in range and the series' end labels right of the frame (px).
fn right_margin(plot: &LinePlot, xa: &Axis, ya: &Axis) -> f64 {
    let widest = plot
        .ref_lines
        .iter()
        .filter(|r| r.orientation == Orientation::Horizontal && ya.contains(r.value))
        .filter(|r| !r.label.is_empty())
        .map(|r| text_width(&r.label, REF_FONT))
        .chain(end_labels::widest_right(plot, xa))
        .fold(None, |m: Option<f64>, w| Some(m.map_or(w, |m| m.max(w))));
    widest.map_or(RIGHT, |w| RIGHT.max(end_labels::GAP + w + 10.0))
}

/// The labels of the horizontal reference lines in range, right of the area (whose right edge
/// is `x1`), centred on their lines.
fn horizontal_labels(
    plot: &LinePlot,
    ya: &Axis,
    py: &dyn Fn(f64) -> f64,
    x1: f64,
) -> Vec<RefLabel> {
    plot.ref_lines
        .iter()
        .filter(|r| {
            r.orientation == Orientation::Horizontal && ya.contains(r.value) && !r.label.is_empty()
        })
        .map(|r| {
            let base = py(r.value) + 0.35 * REF_FONT;
            RefLabel {
                text: r.label.clone(),
                rect: text_box(x1 + 6.0, base, text_width(&r.label, REF_FONT), REF_FONT),
                baseline: (x1 + 6.0, base),
                start_anchored: true,
                color: None,
            }
        })
        .collect()
}

/// The labels of the vertical reference lines in range and the end labels of the series that
/// leave the area through its top, centred above their x (kept inside the image), each in the
/// lowest row (0 = right above the frame) where it overlaps no other. Their y is set by the
/// caller once the rows are known.
fn vertical_labels(
    plot: &LinePlot,
    xa: &Axis,
    px: &dyn Fn(f64) -> f64,
    width: f64,
) -> Vec<(RefLabel, usize)> {
    let lines = plot.ref_lines.iter().filter(|r| {
        r.orientation == Orientation::Vertical && xa.contains(r.value) && !r.label.is_empty()
    });
    let (_, above) = end_labels::end_labels(plot, xa);
    let wanted = lines.map(|r| (r.value, r.label.clone(), None)).chain(
        (above.into_iter())
            .filter(|l| xa.contains(l.end.0))
            .map(|l| (l.end.0, l.text, Some(l.color))),
    );
    let mut placed: Vec<(RefLabel, usize)> = Vec::new();
    for (value, text, color) in wanted {
        let w = text_width(&text, REF_FONT);
        let x = (px(value) - 0.5 * w).clamp(4.0, (width - 4.0 - w).max(4.0));
        let span = (x - 4.0, x + w + 4.0);
        let row = (0..)
            .find(|&row| {
                !placed
                    .iter()
                    .any(|(l, k)| *k == row && l.rect.x < span.1 && span.0 < l.rect.right())
            })
            .unwrap_or(0);
        placed.push((
            RefLabel {
                text,
                rect: Rect::new(x, 0.0, w, 1.05 * REF_FONT),
                baseline: (x + 0.5 * w, 0.0),
                start_anchored: false,
                color,
            },
            row,
        ));
    }
    placed
}
