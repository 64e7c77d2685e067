//! The frame shared by every plot: title, axis labels, ticks along a rectangle, colour bar.
//! [`super::LinePlot`], [`super::HeatMap`] and [`super::SurfacePicture`] draw these through the
//! functions here, so the plots look alike and a change of style is made once.

use super::color::Colormap;
use super::svg::{text_width, Anchor, Svg, TextStyle};
use super::ticks::{nice_ticks, tick_label};

pub(crate) const TICK_FONT: f64 = 12.0;
pub(crate) const LABEL_FONT: f64 = 14.0;
pub(crate) const TITLE_FONT: f64 = 16.0;

/// Space above the plot area: the title's, or a small margin without a title.
pub(crate) fn top_margin(title: &str) -> f64 {
    if title.is_empty() {
        16.0
    } else {
        20.0 + TITLE_FONT + 10.0
    }
}

/// Space under the plot area: tick labels and the x label.
pub(crate) const BOTTOM_MARGIN: f64 = 8.0 + TICK_FONT + 12.0 + LABEL_FONT + 14.0;

/// Space left of the plot area for y tick labels of width `tick_width` and the y label.
pub(crate) fn left_margin(tick_width: f64) -> f64 {
    16.0 + LABEL_FONT + 10.0 + tick_width + 8.0
}

/// Baseline of a title of `size` px.
pub(crate) fn title_baseline(size: f64) -> f64 {
    20.0 + size * 0.8
}

/// The title, bold, centred on `cx` at the top of the image (nothing if empty).
pub(crate) fn title(svg: &mut Svg, cx: f64, text: &str, size: f64) {
    if text.is_empty() {
        return;
    }
    svg.text(
        cx,
        title_baseline(size),
        text,
        TextStyle {
            size,
            bold: true,
            ..TextStyle::default()
        },
    );
}

/// The plot area (x0, x1, y0, y1) in px, y downward.
pub(crate) type Area = (f64, f64, f64, f64);

/// The x label under the area (its baseline 14 px above `height`, the bottom of the frame's
/// room) and the y label left of it.
pub(crate) fn axis_labels(svg: &mut Svg, area: Area, height: f64, x_label: &str, y_label: &str) {
    let (x0, x1, y0, y1) = area;
    let label = TextStyle {
        size: LABEL_FONT,
        ..TextStyle::default()
    };
    svg.text(0.5 * (x0 + x1), height - 14.0, x_label, label);
    svg.text(
        16.0 + LABEL_FONT * 0.8,
        0.5 * (y0 + y1),
        y_label,
        TextStyle {
            rotate: -90.0,
            ..label
        },
    );
}

/// Ticks and their labels under the area (`xs`: (px, label)) and left of it (`ys`).
pub(crate) fn ticks(svg: &mut Svg, area: Area, xs: &[(f64, String)], ys: &[(f64, String)]) {
    let (x0, _, _, y1) = area;
    let tick = TextStyle {
        size: TICK_FONT,
        ..TextStyle::default()
    };
    for (x, label) in xs {
        svg.line(*x, y1, *x, y1 + 5.0, "#333333", 1.0, None);
        svg.text(*x, y1 + 8.0 + TICK_FONT, label, tick);
    }
    for (y, label) in ys {
        svg.line(x0 - 5.0, *y, x0, *y, "#333333", 1.0, None);
        svg.text(
            x0 - 8.0,
            y + 0.35 * TICK_FONT,
            label,
            TextStyle {
                anchor: Anchor::End,
                ..tick
            },
        );
    }
}

/// A vertical colour bar.
pub(crate) struct ColorBar<'a> {
    /// Left edge (px).
    pub x: f64,
    /// Top and bottom (px).
    pub y0: f64,
    pub y1: f64,
    pub colormap: Colormap,
    /// Values at the bottom and the top.
    pub range: (f64, f64),
    pub label: &'a str,
    /// x of the rotated label's centre line (px).
    pub label_x: f64,
}

/// Width of the colour bar (px).
pub(crate) const BAR_WIDTH: f64 = 16.0;

/// Width taken right of the bar's left edge by the bar, its tick labels and its label, for
/// `range` (px).
pub(crate) fn color_bar_width(range: (f64, f64)) -> f64 {
    let (lo, hi) = range;
    let t = nice_ticks(lo, hi, 5);
    let vmax = lo.abs().max(hi.abs());
    let w = t
        .values
        .iter()
        .map(|&v| text_width(&tick_label(v, t.step, vmax), TICK_FONT))
        .fold(0.0, f64::max);
    BAR_WIDTH + 8.0 + w + 10.0 + LABEL_FONT + 12.0
}

/// Draws the colour bar with its ticks and label.
pub(crate) fn color_bar(svg: &mut Svg, bar: &ColorBar) {
    let (vlo, vhi) = bar.range;
    let (bx, y0, y1) = (bar.x, bar.y0, bar.y1);
    let slices = 128;
    svg.open_group("shape-rendering=\"crispEdges\"");
    for k in 0..slices {
        let t0 = k as f64 / slices as f64;
        let t1 = (k + 1) as f64 / slices as f64;
        let (ya, yb) = (y1 - t1 * (y1 - y0), y1 - t0 * (y1 - y0));
        let color = bar.colormap.at(0.5 * (t0 + t1)).hex();
        svg.rect(bx, ya, BAR_WIDTH, yb - ya, &color, None);
    }
    svg.close_group();
    svg.rect(bx, y0, BAR_WIDTH, y1 - y0, "none", Some("#333333"));
    let vt = nice_ticks(vlo, vhi, 5);
    let vmax = vlo.abs().max(vhi.abs());
    let eps = 1e-9 * (vhi - vlo);
    let tick = TextStyle {
        size: TICK_FONT,
        anchor: Anchor::Start,
        ..TextStyle::default()
    };
    for &v in vt
        .values
        .iter()
        .filter(|&&v| v >= vlo - eps && v <= vhi + eps)
    {
        let y = y1 - (v - vlo) / (vhi - vlo) * (y1 - y0);
        svg.line(
            bx + BAR_WIDTH,
            y,
            bx + BAR_WIDTH + 4.0,
            y,
            "#333333",
            1.0,
            None,
        );
        svg.text(
            bx + BAR_WIDTH + 7.0,
            y + 0.35 * TICK_FONT,
            &tick_label(v, vt.step, vmax),
            tick,
        );
    }
    svg.text(
        bar.label_x - LABEL_FONT * 0.2,
        0.5 * (y0 + y1),
        bar.label,
        TextStyle {
            size: LABEL_FONT,
            rotate: -90.0,
            ..TextStyle::default()
        },
    );
}
