//! The checks of a line plot's layout: nothing it labels with (legend, reference-line labels)
//! is drawn over its data, over other text, across the frame or out of the image.

use super::line_layout::{LineLayout, Stroke};
use super::rect::Rect;

impl LineLayout {
    /// Whether `r` meets no drawn stroke or marker (inside the area, where they are drawn).
    pub(crate) fn clear_of_data(&self, r: &Rect) -> bool {
        let Some(r) = intersection(r, &self.area) else {
            return true;
        };
        self.strokes
            .iter()
            .chain(&self.ref_lines)
            .all(|s| !stroke_meets(&self.area, s, &r))
            && self.dots.iter().all(|&(c, rad)| {
                !Rect::new(c.0 - rad, c.1 - rad, 2.0 * rad, 2.0 * rad).overlaps(&r)
            })
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
                out.push(format!(
                    "{name} {r:?} leaves the {} x {} image",
                    self.width, self.height
                ));
            }
            if !self.clear_of_data(r) {
                out.push(format!("{name} {r:?} lies over drawn data"));
            }
            let within = self.area.inflate(-1.0).contains(r);
            if !within && self.area.inflate(1.0).overlaps(r) {
                out.push(format!(
                    "{name} {r:?} straddles the plot frame {:?}",
                    self.area
                ));
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
