//! Axis-aligned rectangles in px (y downward) and what meets them: the geometry behind the
//! placement checks of legends and labels (nothing may be drawn over the data).

/// A rectangle `x..x + w` by `y..y + h` (px, y downward).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Rect {
    pub x: f64,
    pub y: f64,
    pub w: f64,
    pub h: f64,
}

impl Rect {
    pub fn new(x: f64, y: f64, w: f64, h: f64) -> Self {
        Rect { x, y, w, h }
    }

    /// Right edge.
    pub fn right(&self) -> f64 {
        self.x + self.w
    }

    /// Bottom edge.
    pub fn bottom(&self) -> f64 {
        self.y + self.h
    }

    /// The rectangle grown by `d` on every side.
    pub fn inflate(&self, d: f64) -> Rect {
        Rect::new(self.x - d, self.y - d, self.w + 2.0 * d, self.h + 2.0 * d)
    }

    /// Whether the two share area (touching edges do not count).
    pub fn overlaps(&self, o: &Rect) -> bool {
        self.x < o.right() && o.x < self.right() && self.y < o.bottom() && o.y < self.bottom()
    }

    /// Whether `o` lies inside this rectangle (edges included).
    pub fn contains(&self, o: &Rect) -> bool {
        o.x >= self.x && o.y >= self.y && o.right() <= self.right() && o.bottom() <= self.bottom()
    }

    /// The part of segment `a`-`b` inside the rectangle (Liang-Barsky), if any.
    pub fn clip_segment(&self, a: (f64, f64), b: (f64, f64)) -> Option<((f64, f64), (f64, f64))> {
        let (dx, dy) = (b.0 - a.0, b.1 - a.1);
        let (mut t0, mut t1) = (0.0_f64, 1.0_f64);
        // p t <= q for each of the four edges.
        for (p, q) in [
            (-dx, a.0 - self.x),
            (dx, self.right() - a.0),
            (-dy, a.1 - self.y),
            (dy, self.bottom() - a.1),
        ] {
            if p == 0.0 {
                if q < 0.0 {
                    return None;
                }
            } else {
                let t = q / p;
                if p < 0.0 {
                    t0 = t0.max(t);
                } else {
                    t1 = t1.min(t);
                }
            }
        }
        (t0 <= t1).then_some((
            (a.0 + t0 * dx, a.1 + t0 * dy),
            (a.0 + t1 * dx, a.1 + t1 * dy),
        ))
    }

    /// Whether a stroke of half width `half` along `a`-`b` meets the rectangle (the segment
    /// against the rectangle grown by `half`: exact for the square caps, conservative at the
    /// corners for round ones).
    pub fn meets_stroke(&self, a: (f64, f64), b: (f64, f64), half: f64) -> bool {
        self.inflate(half).clip_segment(a, b).is_some()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn segments_are_clipped_to_the_rectangle() {
        let r = Rect::new(0.0, 0.0, 10.0, 10.0);
        let (a, b) = r.clip_segment((-5.0, 5.0), (15.0, 5.0)).expect("crosses");
        assert_eq!((a, b), ((0.0, 5.0), (10.0, 5.0)));
        assert!(r.clip_segment((-5.0, -1.0), (15.0, -1.0)).is_none());
        // A diagonal passing by the corner (x + y = -1) misses; x + y = 1 cuts it.
        assert!(r.clip_segment((-1.0, 0.0), (0.0, -1.0)).is_none());
        assert!(r.clip_segment((-1.0, 2.0), (2.0, -1.0)).is_some());
        // Inside entirely, and a point segment.
        assert_eq!(
            r.clip_segment((1.0, 1.0), (2.0, 3.0)),
            Some(((1.0, 1.0), (2.0, 3.0)))
        );
        assert!(r.clip_segment((11.0, 1.0), (11.0, 1.0)).is_none());
        // The stroke width counts.
        assert!(!r.meets_stroke((-2.0, -5.0), (-2.0, 15.0), 1.5));
        assert!(r.meets_stroke((-2.0, -5.0), (-2.0, 15.0), 2.5));
    }

    #[test]
    fn overlap_and_containment() {
        let r = Rect::new(0.0, 0.0, 10.0, 10.0);
        assert!(r.overlaps(&Rect::new(9.0, 9.0, 5.0, 5.0)));
        assert!(!r.overlaps(&Rect::new(10.0, 0.0, 5.0, 5.0)));
        assert!(r.contains(&Rect::new(0.0, 0.0, 10.0, 10.0)));
        assert!(!r.contains(&Rect::new(5.0, 5.0, 6.0, 1.0)));
    }
}
