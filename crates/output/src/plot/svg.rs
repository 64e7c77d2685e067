//! A minimal SVG document builder (coordinates in px, y downward).

use std::fmt::Write as _;

use crate::xml::escape;

/// Font stack of all plot text: DejaVu Sans is what the rasterizer finds on Debian
/// (`fonts-dejavu-core`); the others are fallbacks for SVG viewers elsewhere.
pub(crate) const FONT_FAMILY: &str = "DejaVu Sans, Liberation Sans, Arial, Helvetica, sans-serif";

/// Approximate advance width of a character of DejaVu Sans, as a fraction of the font size
/// (used to size legends and margins; average over digits and lower-case letters).
pub(crate) const CHAR_WIDTH: f64 = 0.6;

/// Horizontal text anchor.
#[derive(Debug, Clone, Copy)]
pub(crate) enum Anchor {
    Start,
    Middle,
    End,
}

/// Text appearance.
#[derive(Debug, Clone, Copy)]
pub(crate) struct TextStyle<'a> {
    pub size: f64,
    pub anchor: Anchor,
    pub color: &'a str,
    pub bold: bool,
    /// Rotation in degrees about the anchor point (clockwise, SVG convention).
    pub rotate: f64,
    /// White outline behind the glyphs, so the text stays legible over lines.
    pub halo: bool,
}

impl Default for TextStyle<'_> {
    fn default() -> Self {
        TextStyle {
            size: 12.0,
            anchor: Anchor::Middle,
            color: "#222222",
            bold: false,
            rotate: 0.0,
            halo: false,
        }
    }
}

/// An SVG document being built.
pub(crate) struct Svg {
    buf: String,
}

impl Svg {
    /// Starts a `width` x `height` px document with a white background.
    pub fn new(width: f64, height: f64) -> Self {
        let mut buf = String::new();
        let _ = writeln!(
            buf,
            "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n<svg xmlns=\"http://www.w3.org/2000/svg\" \
             width=\"{width}\" height=\"{height}\" viewBox=\"0 0 {width} {height}\" \
             font-family=\"{FONT_FAMILY}\">"
        );
        let _ = writeln!(
            buf,
            "<rect x=\"0\" y=\"0\" width=\"{width}\" height=\"{height}\" fill=\"#ffffff\"/>"
        );
        Svg { buf }
    }

    /// Defines a rectangular clip path `id`.
    pub fn clip_rect(&mut self, id: &str, x: f64, y: f64, w: f64, h: f64) {
        let _ = writeln!(
            self.buf,
            "<defs><clipPath id=\"{id}\"><rect x=\"{x:.2}\" y=\"{y:.2}\" width=\"{w:.2}\" \
             height=\"{h:.2}\"/></clipPath></defs>"
        );
    }

    /// Opens a group with raw attributes (e.g. `clip-path="url(#c)"`).
    pub fn open_group(&mut self, attrs: &str) {
        let _ = writeln!(self.buf, "<g {attrs}>");
    }

    pub fn close_group(&mut self) {
        self.buf.push_str("</g>\n");
    }

    /// A rectangle; `stroke` None for no outline.
    pub fn rect(&mut self, x: f64, y: f64, w: f64, h: f64, fill: &str, stroke: Option<&str>) {
        let _ = write!(
            self.buf,
            "<rect x=\"{x:.2}\" y=\"{y:.2}\" width=\"{w:.2}\" height=\"{h:.2}\" fill=\"{fill}\""
        );
        if let Some(s) = stroke {
            let _ = write!(self.buf, " stroke=\"{s}\" stroke-width=\"1\"");
        }
        self.buf.push_str("/>\n");
    }

    /// A straight line; `dash` is an SVG dash array such as `"6 4"`.
    #[allow(clippy::too_many_arguments)]
    pub fn line(
        &mut self,
        x1: f64,
        y1: f64,
        x2: f64,
        y2: f64,
        stroke: &str,
        width: f64,
        dash: Option<&str>,
    ) {
        let _ = write!(
            self.buf,
            "<line x1=\"{x1:.2}\" y1=\"{y1:.2}\" x2=\"{x2:.2}\" y2=\"{y2:.2}\" stroke=\"{stroke}\" \
             stroke-width=\"{width}\""
        );
        if let Some(d) = dash {
            let _ = write!(self.buf, " stroke-dasharray=\"{d}\"");
        }
        self.buf.push_str("/>\n");
    }

    /// An open polyline through `points`.
    pub fn polyline(
        &mut self,
        points: &[(f64, f64)],
        stroke: &str,
        width: f64,
        dash: Option<&str>,
    ) {
        if points.len() < 2 {
            return;
        }
        self.buf.push_str("<polyline points=\"");
        for (i, (x, y)) in points.iter().enumerate() {
            if i > 0 {
                self.buf.push(' ');
            }
            let _ = write!(self.buf, "{x:.2},{y:.2}");
        }
        let _ = write!(
            self.buf,
            "\" fill=\"none\" stroke=\"{stroke}\" stroke-width=\"{width}\" \
             stroke-linejoin=\"round\" stroke-linecap=\"round\""
        );
        if let Some(d) = dash {
            let _ = write!(self.buf, " stroke-dasharray=\"{d}\"");
        }
        self.buf.push_str("/>\n");
    }

    /// A filled circle with a white outline.
    pub fn circle(&mut self, x: f64, y: f64, r: f64, fill: &str) {
        let _ = writeln!(
            self.buf,
            "<circle cx=\"{x:.2}\" cy=\"{y:.2}\" r=\"{r}\" fill=\"{fill}\" stroke=\"#ffffff\" \
             stroke-width=\"0.8\"/>"
        );
    }

    /// Triangles filled in one colour, as one path.
    pub fn triangles_path(&mut self, triangles: &[[(f64, f64); 3]], fill: &str) {
        self.buf.push_str("<path d=\"");
        for [a, b, c] in triangles {
            let _ = write!(
                self.buf,
                "M{:.1} {:.1}L{:.1} {:.1}L{:.1} {:.1}Z",
                a.0, a.1, b.0, b.1, c.0, c.1
            );
        }
        let _ = writeln!(self.buf, "\" fill=\"{fill}\"/>");
    }

    /// A filled triangle (or polygon), without outline.
    pub fn polygon(&mut self, points: &[(f64, f64)], fill: &str) {
        self.buf.push_str("<polygon points=\"");
        for (i, (x, y)) in points.iter().enumerate() {
            if i > 0 {
                self.buf.push(' ');
            }
            let _ = write!(self.buf, "{x:.2},{y:.2}");
        }
        let _ = writeln!(self.buf, "\" fill=\"{fill}\"/>");
    }

    /// A filled circle with a black outline (a marked point).
    pub fn marker(&mut self, x: f64, y: f64, r: f64, fill: &str) {
        let _ = writeln!(
            self.buf,
            "<circle cx=\"{x:.2}\" cy=\"{y:.2}\" r=\"{r}\" fill=\"{fill}\" stroke=\"#000000\" \
             stroke-width=\"1\"/>"
        );
    }

    /// Text at (x, y) (baseline), escaped.
    pub fn text(&mut self, x: f64, y: f64, content: &str, style: TextStyle) {
        let anchor = match style.anchor {
            Anchor::Start => "start",
            Anchor::Middle => "middle",
            Anchor::End => "end",
        };
        let _ = write!(
            self.buf,
            "<text x=\"{x:.2}\" y=\"{y:.2}\" font-size=\"{}\" text-anchor=\"{anchor}\" fill=\"{}\"",
            style.size, style.color
        );
        if style.bold {
            self.buf.push_str(" font-weight=\"bold\"");
        }
        if style.halo {
            self.buf.push_str(
                " stroke=\"#ffffff\" stroke-width=\"3\" stroke-linejoin=\"round\" paint-order=\"stroke\"",
            );
        }
        if style.rotate != 0.0 {
            let _ = write!(
                self.buf,
                " transform=\"rotate({} {x:.2} {y:.2})\"",
                style.rotate
            );
        }
        let _ = writeln!(self.buf, ">{}</text>", escape(content));
    }

    /// Closes the document.
    pub fn finish(mut self) -> String {
        self.buf.push_str("</svg>\n");
        self.buf
    }
}

/// Approximate rendered width of `text` at `size` px.
pub(crate) fn text_width(text: &str, size: f64) -> f64 {
    text.chars().count() as f64 * CHAR_WIDTH * size
}
