//! Where a line plot draws what: axes, plot area, the data in px, the legend box and the
//! reference-line labels. The legend goes inside the plot area only at a corner whose box (with a
//! margin) meets no curve, marker or reference line; otherwise beside or below the area, which
//! grows the image. Reference-line labels go outside the area (above it for vertical lines,
//! right of it for horizontal ones). [`LineLayout::clashes`] checks the result: nothing the
//! figure labels with is drawn over its data or over other text.

use super::color::{Color, PALETTE};
use super::frame::{self, LABEL_FONT, TICK_FONT, TITLE_FONT};
use super::legend;
use super::line::LinePlot;
use super::rect::Rect;
use super::series::{LegendPosition, LineStyle, Orientation};
use super::svg::text_width;
use super::ticks::{nice_ticks, tick_label};
use crate::finite::check_finite;
use crate::OutputError;

/// Margin added above and below the y data range (fraction of the range), as in most plotting
/// tools: curves do not run along the frame. The x axis spans the data exactly.
const Y_PAD: f64 = 0.05;
/// Font size of the reference lines' labels.
pub(crate) const REF_FONT: f64 = 11.0;
/// Height of one row of vertical-line labels above the area (px).
const REF_ROW: f64 = REF_FONT + 5.0;
/// Space kept between the legend box and any data when it sits inside the area (px).
const CLEARANCE: f64 = 4.0;
/// Legend inset from the frame inside the area, and gap to the area outside it (px).
const INSET: f64 = 10.0;
/// Right margin without labels: room for the last x tick label (px).
const RIGHT: f64 = 24.0;

/// Axis limits and ticks.
pub(crate) struct Axis {
    pub lo: f64,
    pub hi: f64,
    pub ticks: Vec<f64>,
    step: f64,
}

impl Axis {
    /// Fixed limits if given; otherwise the data range widened by `pad` (fraction of the span) on
    /// both sides. Ticks are the nice values inside the limits.
    fn new(
        what: &str,
        fixed: Option<(f64, f64)>,
        data: (f64, f64),
        pad: f64,
    ) -> Result<Self, OutputError> {
        let (data_lo, data_hi) = data;
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

    pub fn label(&self, v: f64) -> String {
        tick_label(v, self.step, self.lo.abs().max(self.hi.abs()))
    }

    fn contains(&self, v: f64) -> bool {
        v >= self.lo && v <= self.hi
    }
}

/// A straight piece of a drawn line (px), with half its width.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Stroke {
    pub a: (f64, f64),
    pub b: (f64, f64),
    pub half_width: f64,
}

/// A reference line's label: its box, baseline point and whether it is anchored at its start
/// (right of a horizontal line) or its middle (above a vertical line).
#[derive(Debug, Clone, PartialEq)]
pub struct RefLabel {
    pub text: String,
    pub rect: Rect,
    pub(crate) baseline: (f64, f64),
    pub(crate) start_anchored: bool,
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

/// Box of a text of `size` px drawn at baseline `y`: glyphs reach 0.8 size above the baseline
/// and 0.25 size below it.
fn text_box(x: f64, y: f64, w: f64, size: f64) -> Rect {
    Rect::new(x, y - 0.8 * size, w, 1.05 * size)
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
        let horizontal: Vec<&str> = plot
            .ref_lines
            .iter()
            .filter(|r| r.orientation == Orientation::Horizontal && ya.contains(r.value))
            .map(|r| r.label.as_str())
            .filter(|l| !l.is_empty())
            .collect();
        let label_column = horizontal
            .iter()
            .map(|l| text_width(l, REF_FONT))
            .fold(0.0, f64::max);
        let right = if horizontal.is_empty() {
            RIGHT
        } else {
            RIGHT.max(6.0 + label_column + 10.0)
        };
        let x0 = frame::left_margin(y_tick_w);
        let x1 = plot.width - right;
        let px = |x: f64| x0 + (x - xa.lo) / (xa.hi - xa.lo) * (x1 - x0);
        let mut vertical = vertical_labels(plot, &xa, &px, plot.width);
        let rows = vertical.iter().map(|(_, row)| row + 1).max().unwrap_or(0);
        let y0 = frame::top_margin(&plot.title) + REF_ROW * rows as f64;
        let y1 = plot.height - frame::BOTTOM_MARGIN;
        let py = |y: f64| y1 - (y - ya.lo) / (ya.hi - ya.lo) * (y1 - y0);
        let mut ref_labels: Vec<RefLabel> = vertical
            .drain(..)
            .map(|(mut l, row)| {
                let base = y0 - 5.0 - REF_ROW * row as f64;
                l.rect.y = base - 0.8 * REF_FONT;
                l.baseline.1 = base;
                l
            })
            .collect();
        for r in plot.ref_lines.iter().filter(|r| {
            r.orientation == Orientation::Horizontal && ya.contains(r.value) && !r.label.is_empty()
        }) {
            let base = py(r.value) + 0.35 * REF_FONT;
            ref_labels.push(RefLabel {
                text: r.label.clone(),
                rect: text_box(x1 + 6.0, base, text_width(&r.label, REF_FONT), REF_FONT),
                baseline: (x1 + 6.0, base),
                start_anchored: true,
            });
        }
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
            let pts: Vec<(f64, f64)> = s.x.iter().zip(&s.y).map(|(&x, &y)| (px(x), py(y))).collect();
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
                let r = marker_radius(s.width);
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
            self.texts
                .push(text_box(cx - 0.5 * w, base, w, TITLE_FONT));
        }
        if !plot.x_label.is_empty() {
            let w = text_width(&plot.x_label, LABEL_FONT);
            self.texts
                .push(text_box(cx - 0.5 * w, self.x_label_y, w, LABEL_FONT));
        }
        for (x, label) in &self.x_ticks {
            let w = text_width(label, TICK_FONT);
            self.texts
                .push(text_box(x - 0.5 * w, a.bottom() + 8.0 + TICK_FONT, w, TICK_FONT));
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

    /// Whether `r` meets no drawn stroke or marker (inside the area, where they are drawn).
    fn clear_of_data(&self, r: &Rect) -> bool {
        let Some(r) = intersection(r, &self.area) else {
            return true;
        };
        self.strokes
            .iter()
            .chain(&self.ref_lines)
            .all(|s| !stroke_meets(&self.area, s, &r))
            && self
                .dots
                .iter()
                .all(|&(c, rad)| !Rect::new(c.0 - rad, c.1 - rad, 2.0 * rad, 2.0 * rad).overlaps(&r))
    }

    /// Everything wrong with the layout: the legend or a reference-line label over drawn data
    /// (curves, markers, reference lines) or over other text, across the frame, or out of the
    /// image. Empty for a good layout.
    pub fn clashes(&self) -> Vec<String> {
        let mut out = Vec::new();
        let image = Rect::new(0.0, 0.0, self.width, self.height);
        let mut boxes: Vec<(String, Rect)> = self
            .ref_labels
            .iter()
            .map(|l| (format!("label `{}`", l.text), l.rect))
            .collect();
        if let Some((r, _)) = self.legend {
            boxes.push(("legend".to_string(), r));
        }
        for (k, (name, r)) in boxes.iter().enumerate() {
            if !image.contains(r) {
                out.push(format!("{name} {r:?} leaves the {} x {} image", self.width, self.height));
            }
            if !self.clear_of_data(r) {
                out.push(format!("{name} {r:?} lies over drawn data"));
            }
            let within = self.area.inflate(-1.0).contains(r);
            if !within && self.area.inflate(1.0).overlaps(r) {
                out.push(format!("{name} {r:?} straddles the plot frame {:?}", self.area));
            }
            if let Some(t) = self.texts.iter().find(|t| t.overlaps(r)) {
                out.push(format!("{name} {r:?} covers text at {t:?}"));
            }
            for (other, o) in &boxes[k + 1..] {
                if o.overlaps(r) {
                    out.push(format!("{name} {r:?} overlaps {other} {o:?}"));
                }
            }
        }
        out
    }
}

/// Marker radius of a series of line width `width` (px): 3.2 px at the default width 2, at
/// least 1.6 px.
pub(crate) fn marker_radius(width: f64) -> f64 {
    1.6 * width.max(1.0)
}

/// The common part of two rectangles, if they share area.
fn intersection(a: &Rect, b: &Rect) -> Option<Rect> {
    let (x, y) = (a.x.max(b.x), a.y.max(b.y));
    let (r, btm) = (a.right().min(b.right()), a.bottom().min(b.bottom()));
    (r > x && btm > y).then(|| Rect::new(x, y, r - x, btm - y))
}

/// Whether the drawn part of stroke `s` (clipped to `area`) meets `r` (inside `area`).
fn stroke_meets(area: &Rect, s: &Stroke, r: &Rect) -> bool {
    // The stroke's width is cut by the clip too, but r lies inside the area: testing the
    // clipped centre line grown by the half width against r is exact there.
    area.inflate(s.half_width)
        .clip_segment(s.a, s.b)
        .is_some_and(|(a, b)| r.meets_stroke(a, b, s.half_width))
}

/// Data range (x, y) of the series and reference lines; (0, 1) for an empty axis.
fn data_ranges(plot: &LinePlot) -> ((f64, f64), (f64, f64)) {
    let (mut xl, mut xh, mut yl, mut yh) = (
        f64::INFINITY,
        f64::NEG_INFINITY,
        f64::INFINITY,
        f64::NEG_INFINITY,
    );
    for s in &plot.series {
        for (&x, &y) in s.x.iter().zip(&s.y) {
            (xl, xh, yl, yh) = (xl.min(x), xh.max(x), yl.min(y), yh.max(y));
        }
    }
    for r in &plot.ref_lines {
        match r.orientation {
            Orientation::Horizontal => (yl, yh) = (yl.min(r.value), yh.max(r.value)),
            Orientation::Vertical => (xl, xh) = (xl.min(r.value), xh.max(r.value)),
        }
    }
    let fix = |lo: f64, hi: f64| if lo > hi { (0.0, 1.0) } else { (lo, hi) };
    (fix(xl, xh), fix(yl, yh))
}

/// The labels of the vertical reference lines in range, centred above their lines (kept inside
/// the image), each in the lowest row (0 = right above the frame) where it overlaps no other.
/// Their y is set by the caller once the rows are known.
fn vertical_labels(
    plot: &LinePlot,
    xa: &Axis,
    px: &dyn Fn(f64) -> f64,
    width: f64,
) -> Vec<(RefLabel, usize)> {
    let mut placed: Vec<(RefLabel, usize)> = Vec::new();
    for r in plot.ref_lines.iter().filter(|r| {
        r.orientation == Orientation::Vertical && xa.contains(r.value) && !r.label.is_empty()
    }) {
        let w = text_width(&r.label, REF_FONT);
        let x = (px(r.value) - 0.5 * w).clamp(4.0, (width - 4.0 - w).max(4.0));
        let span = (x - 4.0, x + w + 4.0);
        let row = (0..)
            .find(|&row| {
                !placed.iter().any(|(l, k)| {
                    *k == row && l.rect.x < span.1 && span.0 < l.rect.right()
                })
            })
            .unwrap_or(0);
        placed.push((
            RefLabel {
                text: r.label.clone(),
                rect: Rect::new(x, 0.0, w, 1.05 * REF_FONT),
                baseline: (x + 0.5 * w, 0.0),
                start_anchored: false,
            },
            row,
        ));
    }
    placed
}
