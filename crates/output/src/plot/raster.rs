//! SVG -> PNG with `resvg`, using the system fonts (loaded once per process).

use std::path::Path;
use std::sync::{Arc, OnceLock};

use resvg::tiny_skia;
use resvg::usvg;
use resvg::usvg::fontdb;

use crate::atomic::write_atomic;
use crate::OutputError;

/// PNG pixels per SVG pixel: 2 gives crisp lines and text on high-density screens and in print.
pub const PNG_SCALE: f32 = 2.0;

/// Families tried, in order, as the generic `sans-serif` family.
const PREFERRED_SANS: [&str; 5] = [
    "DejaVu Sans",
    "Liberation Sans",
    "Noto Sans",
    "FreeSans",
    "Arial",
];

/// The system font database, loaded on first use.
fn font_db() -> &'static Arc<fontdb::Database> {
    static DB: OnceLock<Arc<fontdb::Database>> = OnceLock::new();
    DB.get_or_init(|| {
        let mut db = fontdb::Database::new();
        db.load_system_fonts();
        let available = |name: &str| {
            db.faces()
                .any(|f| f.families.iter().any(|(fam, _)| fam == name))
        };
        let sans = PREFERRED_SANS
            .iter()
            .find(|n| available(n))
            .map(|n| n.to_string())
            .or_else(|| {
                db.faces()
                    .next()
                    .and_then(|f| f.families.first().map(|(fam, _)| fam.clone()))
            });
        if let Some(family) = sans {
            db.set_sans_serif_family(family);
        }
        Arc::new(db)
    })
}

/// Whether any system font was found (PNG text needs one).
pub fn fonts_available() -> bool {
    !font_db().is_empty()
}

/// `svg` parsed with the system fonts: its text laid out as the PNG draws it.
pub(crate) fn parse_with_fonts(svg: &str) -> Result<usvg::Tree, usvg::Error> {
    let options = usvg::Options {
        fontdb: Arc::clone(font_db()),
        font_family: "sans-serif".to_string(),
        ..usvg::Options::default()
    };
    usvg::Tree::from_str(svg, &options)
}

/// Rasterizes `svg` at `scale` PNG pixels per SVG pixel and writes it to `path` atomically.
/// Fails with [`OutputError::NoFonts`] when no font is installed, rather than writing a PNG
/// without its text.
pub fn svg_to_png(svg: &str, path: &Path, scale: f32) -> Result<(), OutputError> {
    let render_err = |reason: String| OutputError::Render {
        path: path.to_path_buf(),
        reason,
    };
    if !(scale.is_finite() && scale > 0.0 && scale <= 16.0) {
        return Err(render_err(format!("scale {scale}; expected in (0, 16]")));
    }
    let db = font_db();
    if db.is_empty() {
        return Err(OutputError::NoFonts {
            path: path.to_path_buf(),
        });
    }
    let tree = parse_with_fonts(svg).map_err(|e| render_err(format!("invalid SVG: {e}")))?;
    let size = tree
        .size()
        .to_int_size()
        .scale_by(scale)
        .ok_or_else(|| render_err(format!("cannot scale the image by {scale}")))?;
    let mut pixmap = tiny_skia::Pixmap::new(size.width(), size.height()).ok_or_else(|| {
        render_err(format!(
            "cannot allocate a {} x {} image",
            size.width(),
            size.height()
        ))
    })?;
    pixmap.fill(tiny_skia::Color::WHITE);
    resvg::render(
        &tree,
        tiny_skia::Transform::from_scale(scale, scale),
        &mut pixmap.as_mut(),
    );
    let png = pixmap
        .encode_png()
        .map_err(|e| render_err(format!("PNG encoding failed: {e}")))?;
    write_atomic(path, &png)
}

/// Size of a PNG image and the share of its pixels that are coloured (not white, gray or black:
/// max - min of the RGB channels above 40 of 255), e.g. to check that a picture shows a
/// colour-mapped object and not only its frame and text.
pub fn png_color_share(path: &Path) -> Result<(u32, u32, f64), OutputError> {
    let pixmap = tiny_skia::Pixmap::load_png(path).map_err(|e| OutputError::Render {
        path: path.to_path_buf(),
        reason: format!("cannot decode the PNG: {e}"),
    })?;
    let colored = pixmap
        .pixels()
        .iter()
        .filter(|p| {
            let c = p.demultiply();
            let (r, g, b) = (c.red(), c.green(), c.blue());
            r.max(g).max(b) - r.min(g).min(b) > 40
        })
        .count();
    let total = (pixmap.width() as usize * pixmap.height() as usize).max(1);
    Ok((
        pixmap.width(),
        pixmap.height(),
        colored as f64 / total as f64,
    ))
}
