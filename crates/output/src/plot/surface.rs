//! Pictures of a (deformed) surface mesh: flat-shaded triangles in an orthographic view,
//! drawn back to front (painter's algorithm) with back faces culled, coloured by a value per
//! vertex, with an optional light-gray "ghost" (e.g. the undeformed shape) behind, point markers,
//! one panel per state side by side, a colour bar and notes. Rendered as SVG, rasterized to PNG.
//!
//! The painter's algorithm sorts whole triangles by mean depth; on a closed surface with back
//! faces culled, it is exact wherever front faces do not overlap, i.e. everywhere on a convex
//! shape, and is off by at most a triangle's width along folds seen edge-on.

use std::path::Path;

use super::color::{Color, Colormap};
use super::frame::{color_bar, title, ColorBar};
use super::svg::{text_width, Anchor, Svg, TextStyle};
use super::write_png_file;
use crate::finite::check_finite;
use crate::OutputError;

/// An orthographic view: `right` and `up` are the picture's x and y axes in world coordinates
/// (unit, orthogonal); the viewer looks along `-(right x up)`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct View {
    pub right: [f64; 3],
    pub up: [f64; 3],
}

/// A point marked with a circle: filled (red) or open (white).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Marker {
    pub position: [f64; 3],
    pub filled: bool,
}

/// One state of the surface.
#[derive(Debug, Clone, PartialEq)]
pub struct SurfacePanel {
    /// Text above the panel.
    pub subtitle: String,
    /// Vertex positions (world units).
    pub positions: Vec<[f64; 3]>,
    /// A value per vertex, mapped to the colormap (a triangle takes the mean of its vertices).
    pub values: Vec<f64>,
    /// Marked points.
    pub markers: Vec<Marker>,
    /// Light-gray positions drawn behind the panel's surface (e.g. the undeformed shape).
    pub ghost: Option<Vec<[f64; 3]>>,
}

/// Panels of one triangulated surface side by side, on a common scale and colour range.
#[derive(Debug, Clone, PartialEq)]
pub struct SurfacePicture {
    /// Title above the picture.
    pub title: String,
    /// Triangles as vertex indices, counter-clockwise seen from outside (outward normals).
    pub triangles: Vec<[usize; 3]>,
    pub panels: Vec<SurfacePanel>,
    pub view: View,
    pub colormap: Colormap,
    /// Label of the colour bar.
    pub value_label: String,
    /// Values at the ends of the colormap; `None`: the range of all panels' values.
    pub value_range: Option<(f64, f64)>,
    /// Lines of text under the panels.
    pub notes: Vec<String>,
    /// Width of one panel (px).
    pub panel_width: f64,
    /// Height of the panels' drawing area (px).
    pub panel_height: f64,
}

/// What every panel shares: top of the drawing area (px), px per world unit, the world point
/// at each panel's centre (picture coordinates) and the colour range.
struct PanelFrame {
    top: f64,
    scale: f64,
    center: (f64, f64),
    range: (f64, f64),
}

/// World point -> (x px, y px, depth toward the viewer).
type ToPixels<'a> = dyn Fn(&[f64; 3]) -> (f64, f64, f64) + 'a;

const NOTE_FONT: f64 = 12.0;
const SUBTITLE_FONT: f64 = 13.0;
const TITLE_FONT: f64 = 16.0;
/// Surface colour scale at grazing light; 1 facing the light.
const AMBIENT: f64 = 0.6;

impl SurfacePicture {
    fn what(&self) -> String {
        format!("surface picture `{}`", self.title)
    }

    fn check(&self) -> Result<(f64, f64), OutputError> {
        let what = self.what();
        if self.panels.is_empty() {
            return Err(OutputError::invalid(what, "no panel"));
        }
        if !(self.panel_width >= 100.0 && self.panel_height >= 100.0) {
            return Err(OutputError::invalid(
                what,
                format!(
                    "panel size {} x {} px; expected at least 100 x 100",
                    self.panel_width, self.panel_height
                ),
            ));
        }
        let v = &self.view;
        check_finite(&format!("view of {what}"), &[v.right, v.up].concat())?;
        let dot: f64 = (0..3).map(|i| v.right[i] * v.up[i]).sum();
        let unit = |a: [f64; 3]| ((a[0] * a[0] + a[1] * a[1] + a[2] * a[2]).sqrt() - 1.0).abs();
        if dot.abs() > 1e-9 || unit(v.right) > 1e-9 || unit(v.up) > 1e-9 {
            return Err(OutputError::invalid(
                format!("view of {what}"),
                "right and up must be orthogonal unit vectors",
            ));
        }
        let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
        for (k, p) in self.panels.iter().enumerate() {
            let pw = format!("panel {k} of {what}");
            let n = p.positions.len();
            if p.values.len() != n || p.ghost.as_ref().is_some_and(|g| g.len() != n) {
                return Err(OutputError::invalid(
                    pw,
                    format!(
                        "{n} positions but {} values (and a ghost of {:?})",
                        p.values.len(),
                        p.ghost.as_ref().map(Vec::len)
                    ),
                ));
            }
            if let Some(t) = self.triangles.iter().flatten().find(|&&i| i >= n) {
                return Err(OutputError::invalid(
                    pw,
                    format!("a triangle refers to vertex {t} of {n}"),
                ));
            }
            check_finite(&format!("positions of {pw}"), p.positions.as_flattened())?;
            check_finite(&format!("values of {pw}"), &p.values)?;
            if let Some(g) = &p.ghost {
                check_finite(&format!("ghost of {pw}"), g.as_flattened())?;
            }
            for m in &p.markers {
                check_finite(&format!("markers of {pw}"), &m.position)?;
            }
            for &i in self.triangles.iter().flatten() {
                lo = lo.min(p.values[i]);
                hi = hi.max(p.values[i]);
            }
        }
        let (lo, hi) = match self.value_range {
            Some((a, b)) => {
                check_finite(&format!("value range of {what}"), &[a, b])?;
                if a >= b {
                    return Err(OutputError::invalid(
                        format!("value range of {what}"),
                        format!("({a}, {b}) is empty; expected lo < hi"),
                    ));
                }
                (a, b)
            }
            None if hi > lo => (lo, hi),
            None if lo.is_finite() => (lo, lo + lo.abs().max(1.0)),
            None => (0.0, 1.0),
        };
        Ok((lo, hi))
    }

    /// Picture coordinates (right, up) and depth (toward the viewer) of a world point.
    fn project(&self, p: &[f64; 3]) -> (f64, f64, f64) {
        let (r, u) = (self.view.right, self.view.up);
        let n = cross(r, u);
        (dot(p, &r), dot(p, &u), dot(p, &n))
    }

    /// Renders the picture as an SVG document.
    pub fn to_svg(&self) -> Result<String, OutputError> {
        let (vlo, vhi) = self.check()?;
        // One scale for every panel: the bounding box of every drawn point.
        let (mut xl, mut xh, mut yl, mut yh) = (
            f64::INFINITY,
            f64::NEG_INFINITY,
            f64::INFINITY,
            f64::NEG_INFINITY,
        );
        for p in &self.panels {
            let pts = p.positions.iter().chain(p.ghost.iter().flatten());
            for q in pts {
                let (x, y, _) = self.project(q);
                (xl, xh, yl, yh) = (xl.min(x), xh.max(x), yl.min(y), yh.max(y));
            }
        }
        let span = (xh - xl).max(yh - yl).max(f64::MIN_POSITIVE);
        let pad = 12.0;
        let scale = ((self.panel_width - 2.0 * pad) / (xh - xl).max(1e-12 * span))
            .min((self.panel_height - 2.0 * pad) / (yh - yl).max(1e-12 * span));
        let top = 20.0 + TITLE_FONT + 12.0 + SUBTITLE_FONT + 8.0;
        let bar_room = 110.0;
        let notes_width = self
            .notes
            .iter()
            .map(|n| text_width(n, NOTE_FONT) + 20.0)
            .fold(0.0, f64::max);
        let width = (self.panel_width * self.panels.len() as f64 + bar_room).max(notes_width);
        let height = top + self.panel_height + 10.0 + NOTE_FONT * 1.5 * self.notes.len() as f64;
        let mut svg = Svg::new(width, height);
        // Panels centred in the room left of the colour bar (wider than them for long notes).
        let room = width - bar_room - self.panel_width * self.panels.len() as f64;
        let frame = PanelFrame {
            top,
            scale,
            center: (0.5 * (xl + xh), 0.5 * (yl + yh)),
            range: (vlo, vhi),
        };
        for (k, p) in self.panels.iter().enumerate() {
            let left = 0.5 * room + self.panel_width * k as f64;
            self.draw_panel(&mut svg, p, left, &frame);
        }
        let x_bar = width - bar_room + 10.0;
        color_bar(
            &mut svg,
            &ColorBar {
                x: x_bar,
                y0: top + 0.1 * self.panel_height,
                y1: top + 0.9 * self.panel_height,
                colormap: self.colormap,
                range: (vlo, vhi),
                label: &self.value_label,
                label_x: width - 10.0,
            },
        );
        title(&mut svg, 0.5 * width, &self.title, TITLE_FONT);
        for (i, note) in self.notes.iter().enumerate() {
            svg.text(
                10.0,
                top + self.panel_height + 10.0 + NOTE_FONT * (1.5 * i as f64 + 1.0),
                note,
                TextStyle {
                    size: NOTE_FONT,
                    anchor: Anchor::Start,
                    ..TextStyle::default()
                },
            );
        }
        Ok(svg.finish())
    }

    /// One panel whose left edge is at `left` (px).
    fn draw_panel(&self, svg: &mut Svg, p: &SurfacePanel, left: f64, frame: &PanelFrame) {
        let cx = left + 0.5 * self.panel_width;
        let cy = frame.top + 0.5 * self.panel_height;
        let to_px = |q: &[f64; 3]| {
            let (x, y, d) = self.project(q);
            (
                cx + (x - frame.center.0) * frame.scale,
                cy - (y - frame.center.1) * frame.scale,
                d,
            )
        };
        if let Some(g) = &p.ghost {
            // One path of every front face: a silhouette without seams, drawn at once.
            let ghost: Vec<(f64, f64)> = g
                .iter()
                .map(|q| {
                    let (x, y, _) = to_px(q);
                    (x, y)
                })
                .collect();
            let tris: Vec<[(f64, f64); 3]> =
                self.front_faces(g).map(|t| t.map(|i| ghost[i])).collect();
            svg.triangles_path(&tris, "#dadada");
        }
        self.draw_surface(svg, p, &to_px, frame.range);
        for m in &p.markers {
            let (x, y, _) = to_px(&m.position);
            svg.marker(x, y, 3.5, if m.filled { "#d62728" } else { "#ffffff" });
        }
        svg.text(
            cx,
            frame.top - 8.0,
            &p.subtitle,
            TextStyle {
                size: SUBTITLE_FONT,
                ..TextStyle::default()
            },
        );
    }

    /// Triangles facing the viewer at these positions.
    fn front_faces<'a>(
        &'a self,
        positions: &'a [[f64; 3]],
    ) -> impl Iterator<Item = [usize; 3]> + 'a {
        let n = cross(self.view.right, self.view.up);
        self.triangles
            .iter()
            .copied()
            .filter(move |t| dot(&normal(positions, t), &n) > 0.0)
    }

    /// The panel's front faces, back to front, flat-shaded.
    fn draw_surface(
        &self,
        svg: &mut Svg,
        p: &SurfacePanel,
        to_px: &ToPixels,
        (vlo, vhi): (f64, f64),
    ) {
        let px: Vec<(f64, f64, f64)> = p.positions.iter().map(to_px).collect();
        let n = cross(self.view.right, self.view.up);
        // Light from the viewer's upper left.
        let light = normalize([
            n[0] + 0.4 * self.view.up[0] - 0.3 * self.view.right[0],
            n[1] + 0.4 * self.view.up[1] - 0.3 * self.view.right[1],
            n[2] + 0.4 * self.view.up[2] - 0.3 * self.view.right[2],
        ]);
        let mut faces: Vec<([usize; 3], f64)> = self
            .front_faces(&p.positions)
            .map(|t| (t, t.iter().map(|&i| px[i].2).sum::<f64>()))
            .collect();
        faces.sort_by(|a, b| a.1.total_cmp(&b.1));
        // Without anti-aliasing, neighbouring triangles leave no hairline seam between them.
        svg.open_group("shape-rendering=\"crispEdges\"");
        for (t, _) in faces {
            let value = t.iter().map(|&i| p.values[i]).sum::<f64>() / 3.0;
            let shade = AMBIENT
                + (1.0 - AMBIENT) * dot(&normalize(normal(&p.positions, &t)), &light).max(0.0);
            let c = self.colormap.at((value - vlo) / (vhi - vlo));
            let fill = scaled(c, shade).hex();
            let pts = t.map(|i| (px[i].0, px[i].1));
            svg.polygon(&pts, &fill);
        }
        svg.close_group();
    }

    /// Writes the picture as PNG ([`super::PNG_SCALE`] px per SVG px) to `path` atomically.
    pub fn write_png(&self, path: &Path) -> Result<(), OutputError> {
        write_png_file(self.to_svg(), path)
    }
}

fn scaled(c: Color, s: f64) -> Color {
    let m = |x: u8| (f64::from(x) * s).round().clamp(0.0, 255.0) as u8;
    Color(m(c.0), m(c.1), m(c.2))
}

fn dot(a: &[f64; 3], b: &[f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

fn cross(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

fn normalize(a: [f64; 3]) -> [f64; 3] {
    let n = dot(&a, &a).sqrt();
    if n > 0.0 {
        a.map(|x| x / n)
    } else {
        a
    }
}

/// (b - a) x (c - a) of triangle `t`.
fn normal(p: &[[f64; 3]], t: &[usize; 3]) -> [f64; 3] {
    let (a, b, c) = (p[t[0]], p[t[1]], p[t[2]]);
    cross(
        [b[0] - a[0], b[1] - a[1], b[2] - a[2]],
        [c[0] - a[0], c[1] - a[1], c[2] - a[2]],
    )
}
