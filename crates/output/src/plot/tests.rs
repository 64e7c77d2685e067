//! Plot tests: SVG validity (parsed by usvg), PNG files (signature, size, drawn content).

use super::*;
use crate::OutputError;
use resvg::tiny_skia::Pixmap;
use resvg::usvg;

/// Parses `svg` as SVG (XML well-formedness included) without fonts.
fn parse_svg(svg: &str) -> usvg::Tree {
    usvg::Tree::from_str(svg, &usvg::Options::default()).expect("valid SVG")
}

/// Checks that every opening tag is closed in order (a tiny XML structure checker, independent
/// of usvg): returns the number of elements.
fn balanced_elements(svg: &str) -> usize {
    let mut stack: Vec<String> = Vec::new();
    let mut count = 0;
    let mut rest = svg;
    while let Some(i) = rest.find('<') {
        let j = rest[i..].find('>').expect("unterminated tag") + i;
        let tag = &rest[i + 1..j];
        rest = &rest[j + 1..];
        if tag.starts_with('?') || tag.starts_with('!') {
            continue;
        }
        if let Some(name) = tag.strip_prefix('/') {
            assert_eq!(
                stack.pop().as_deref(),
                Some(name.trim()),
                "mismatched </{name}>"
            );
        } else {
            count += 1;
            if !tag.ends_with('/') {
                let name = tag.split_whitespace().next().expect("tag name");
                stack.push(name.to_string());
            }
        }
    }
    assert!(stack.is_empty(), "unclosed elements {stack:?}");
    count
}

fn backbone_plot() -> LinePlot {
    let q: Vec<f64> = (0..=40).map(|i| i as f64 * 0.8).collect();
    let w: Vec<f64> = q
        .iter()
        .map(|&q| {
            if q <= 4.0 {
                1.0
            } else {
                1.0 + 0.3 * (1.0 - 4.0 / q)
            }
        })
        .collect();
    let w2: Vec<f64> = w.iter().map(|v| 0.5 * (1.0 + v)).collect();
    LinePlot::new("Backbone of mode 1", "q / g0", "ω / ω1")
        .with_series(Series::new("harmonic balance", q.clone(), w).markers(true))
        .with_series(Series::new("penalty <ref>", q, w2).style(LineStyle::Dashed))
        .with_ref_line(RefLine::horizontal(1.0, "linear"))
        .with_ref_line(RefLine::vertical(4.0, "grazing"))
        .with_legend(LegendPosition::Auto)
}

fn count_near(p: &Pixmap, c: Color, tol: i32) -> usize {
    p.pixels()
        .iter()
        .filter(|px| {
            let d = |a: u8, b: u8| (i32::from(a) - i32::from(b)).abs() <= tol;
            px.alpha() == 255 && d(px.red(), c.0) && d(px.green(), c.1) && d(px.blue(), c.2)
        })
        .count()
}

#[test]
fn line_plot_svg_is_valid_and_complete() {
    let plot = backbone_plot();
    let svg = plot.to_svg().expect("svg");
    assert!(balanced_elements(&svg) > 50);
    let tree = parse_svg(&svg);
    // No corner is free of data (the curve rises to the top right, the grazing line crosses
    // the left ones, the linear line the bottom): the legend widens the image.
    let layout = plot.layout().expect("layout");
    assert!(layout.width > 800.0);
    assert_eq!(f64::from(tree.size().width()), layout.width);
    assert_eq!(svg.matches("<polyline").count(), 2);
    // 41 markers on the first series and one in the legend.
    assert_eq!(svg.matches("<circle").count(), 42);
    for text in [
        "Backbone of mode 1",
        "q / g0",
        "ω / ω1",
        "linear",
        "grazing",
        "penalty &lt;ref&gt;",
    ] {
        assert!(svg.contains(text), "missing {text}");
    }
    // The x axis spans the data, q in [0, 32], with nice ticks 0, 5, ..., 30.
    for t in ["0", "5", "10", "30"] {
        assert!(svg.contains(&format!(">{t}</text>")), "missing tick {t}");
    }
}

#[test]
fn line_plot_points_map_to_the_axes() {
    // One series from (0, 0) to (10, 5): the x axis spans [0, 10] exactly, the y axis [0, 5]
    // padded by 5 % of the span on both sides, so the end points sit on the left and right
    // edges of the frame, 0.05 / 1.1 of its height inside.
    let plot =
        LinePlot::new("", "x", "y").with_series(Series::new("", vec![0.0, 10.0], vec![0.0, 5.0]));
    let svg = plot.to_svg().expect("svg");
    let poly = svg.split("<polyline points=\"").nth(1).expect("polyline");
    let pts: Vec<(f64, f64)> = poly[..poly.find('"').expect("end")]
        .split(' ')
        .map(|p| {
            let (x, y) = p.split_once(',').expect("x,y");
            (x.parse().expect("x"), y.parse().expect("y"))
        })
        .collect();
    // The frame is the unfilled <rect>.
    let frame = svg
        .lines()
        .find(|l| l.starts_with("<rect") && l.contains("fill=\"none\""))
        .expect("frame");
    let attr = |name: &str| -> f64 {
        let k = frame.find(&format!(" {name}=\"")).expect(name) + name.len() + 3;
        frame[k..k + frame[k..].find('"').expect("quote")]
            .parse()
            .expect("number")
    };
    let (x, y, w, h) = (attr("x"), attr("y"), attr("width"), attr("height"));
    // Coordinates are written with 2 decimals: tolerance 0.01 px (+ rounding of both).
    let inset = 0.05 / 1.1 * h;
    assert!(
        (pts[0].0 - x).abs() < 0.011 && (pts[0].1 - (y + h - inset)).abs() < 0.011,
        "{pts:?}"
    );
    assert!(
        (pts[1].0 - (x + w)).abs() < 0.011 && (pts[1].1 - (y + inset)).abs() < 0.011,
        "{pts:?}"
    );
}

#[test]
fn line_plot_png_is_written_and_shows_the_curves_and_text() {
    assert!(
        fonts_available(),
        "no system font: install fonts-dejavu-core"
    );
    let dir = tempfile::tempdir().expect("tempdir");
    let (svg_path, png_path) = backbone_plot()
        .write_svg_and_png(&dir.path().join("backbone_q5.7"))
        .expect("write");
    assert_eq!(
        svg_path.file_name().and_then(|n| n.to_str()),
        Some("backbone_q5.7.svg")
    );
    let bytes = std::fs::read(&png_path).expect("png");
    assert_eq!(&bytes[..8], b"\x89PNG\r\n\x1a\n");
    let png = Pixmap::decode_png(&bytes).expect("decodable PNG");
    let width = backbone_plot().layout().expect("layout").width;
    assert_eq!(
        (png.width(), png.height()),
        ((2.0 * width).round() as u32, 1040)
    );
    // The first series color (palette 0) covers its line and markers; the dashed one too.
    assert!(count_near(&png, PALETTE[0], 8) > 2000);
    assert!(count_near(&png, PALETTE[1], 8) > 500);
    // Text is drawn (near-black glyph pixels in the title band), so fonts were found.
    let title_band_dark = (0..png.height() / 10)
        .flat_map(|y| (0..png.width()).map(move |x| (x, y)))
        .filter(|&(x, y)| {
            let p = png.pixel(x, y).expect("pixel");
            p.red() < 80 && p.green() < 80 && p.blue() < 80
        })
        .count();
    assert!(
        title_band_dark > 300,
        "title text missing ({title_band_dark} dark pixels)"
    );
    let svg_text = std::fs::read_to_string(&svg_path).expect("svg");
    parse_svg(&svg_text);
}

#[test]
fn bad_plot_data_is_refused_and_nothing_written() {
    let dir = tempfile::tempdir().expect("tempdir");
    let path = dir.path().join("bad.svg");
    let nan = LinePlot::new("t", "x", "y").with_series(Series::new(
        "s",
        vec![0.0, 1.0],
        vec![0.0, f64::NAN],
    ));
    let msg = nan.write_svg(&path).expect_err("NaN").to_string();
    assert!(
        msg.contains("y of series `s`") && msg.contains("bad.svg"),
        "{msg}"
    );
    let ragged =
        LinePlot::new("t", "x", "y").with_series(Series::new("s", vec![0.0, 1.0], vec![0.0]));
    assert!(ragged.write_png(&path).is_err());
    let empty_range = backbone_plot().with_x_range(1.0, 1.0);
    assert!(empty_range.to_svg().is_err());
    let inf_ref = backbone_plot().with_ref_line(RefLine::horizontal(f64::INFINITY, "x"));
    assert!(inf_ref.to_svg().is_err());
    assert_eq!(std::fs::read_dir(dir.path()).expect("dir").count(), 0);
}

#[test]
fn empty_and_fixed_range_plots_render() {
    let svg = LinePlot::new("", "x", "y").to_svg().expect("empty plot");
    parse_svg(&svg);
    let svg = backbone_plot()
        .with_x_range(2.0, 12.0)
        .with_y_range(0.99, 1.2)
        .to_svg()
        .expect("fixed ranges");
    parse_svg(&svg);
    assert!(svg.contains(">12</text>") && svg.contains(">1.20</text>"));
}

fn contact_map(rows: usize, cols: usize) -> HeatMap {
    // Contact force: nodes near both ends touch during part of the period.
    let mut values = vec![0.0; rows * cols];
    for r in 0..rows {
        for c in 0..cols {
            let t = c as f64 / cols as f64;
            let edge = r < 5 || r + 4 >= rows;
            if edge && (t - 0.5).abs() < 0.08 {
                values[r * cols + c] = 1.0 + r as f64;
            }
        }
    }
    HeatMap::new(
        "Contact map",
        "t / T",
        "contact node",
        "λ (N)",
        rows,
        cols,
        values,
    )
    .with_x_extent(0.0, 1.0)
    .with_y_extent(0.5, rows as f64 + 0.5)
}

#[test]
fn heat_map_svg_and_png() {
    let map = contact_map(24, 256);
    let svg = map.to_svg().expect("svg");
    balanced_elements(&svg);
    parse_svg(&svg);
    for text in [
        "Contact map",
        "t / T",
        "contact node",
        "λ (N)",
        ">0.4</text>",
        ">20</text>",
    ] {
        assert!(svg.contains(text), "missing {text}");
    }
    let dir = tempfile::tempdir().expect("tempdir");
    let (_, png_path) = map
        .write_svg_and_png(&dir.path().join("contact"))
        .expect("write");
    let png = Pixmap::decode_png(&std::fs::read(&png_path).expect("png")).expect("decode");
    // Zero (no contact) is the low end of viridis, the largest force the high end: both colors
    // must cover real areas of the image (cells and color bar).
    assert!(count_near(&png, Colormap::Viridis.at(0.0), 2) > 50_000);
    assert!(count_near(&png, Colormap::Viridis.at(1.0), 2) > 500);

    let gray = contact_map(3, 4)
        .with_colormap(Colormap::GrayRed)
        .with_value_range(0.0, 2.0);
    parse_svg(&gray.to_svg().expect("svg"));
}

#[test]
fn heat_map_input_checks() {
    let bad_len = HeatMap::new("h", "x", "y", "v", 2, 3, vec![0.0; 5]);
    assert!(bad_len
        .to_svg()
        .expect_err("length")
        .to_string()
        .contains("5 values"));
    let mut nan = contact_map(3, 4);
    nan.values[7] = f64::NAN;
    match nan.to_svg().expect_err("NaN") {
        OutputError::NonFinite { index, .. } => assert_eq!(index, 7),
        e => panic!("unexpected {e:?}"),
    }
    assert!(contact_map(3, 4).with_x_extent(1.0, 0.0).to_svg().is_err());
    assert!(contact_map(3, 4)
        .with_value_range(2.0, 2.0)
        .to_svg()
        .is_err());
    // Constant data (no contact at all) still renders.
    parse_svg(
        &HeatMap::new("h", "x", "y", "v", 2, 2, vec![0.0; 4])
            .to_svg()
            .expect("flat"),
    );
}

#[test]
fn appended_extension_keeps_dots() {
    assert_eq!(
        with_appended_extension(std::path::Path::new("out/q_9.3"), "png"),
        std::path::PathBuf::from("out/q_9.3.png")
    );
}

/// A unit cube's 12 outward triangles (counter-clockwise seen from outside).
fn cube() -> (Vec<[f64; 3]>, Vec<[usize; 3]>) {
    let p: Vec<[f64; 3]> = (0..8)
        .map(|i| [(i & 1) as f64, ((i >> 1) & 1) as f64, ((i >> 2) & 1) as f64])
        .collect();
    // Faces as quads (a, b, c, d) counter-clockwise from outside.
    let quads = [
        [0, 2, 3, 1], // z = 0, normal -z
        [4, 5, 7, 6], // z = 1, +z
        [0, 1, 5, 4], // y = 0, -y
        [2, 6, 7, 3], // y = 1, +y
        [0, 4, 6, 2], // x = 0, -x
        [1, 3, 7, 5], // x = 1, +x
    ];
    let t = quads
        .iter()
        .flat_map(|q| [[q[0], q[1], q[2]], [q[0], q[2], q[3]]])
        .collect();
    (p, t)
}

#[test]
fn surface_picture_draws_front_faces_only() {
    let (p, t) = cube();
    // Looking along -z (viewer on +z): only the two triangles of the z = 1 face face the viewer.
    let picture = SurfacePicture {
        title: "cube".into(),
        triangles: t,
        panels: vec![SurfacePanel {
            subtitle: "state".into(),
            values: p.iter().map(|q| q[2]).collect(),
            positions: p,
            markers: vec![Marker {
                position: [1.0, 1.0, 1.0],
                filled: true,
            }],
            ghost: None,
        }],
        view: View {
            right: [1.0, 0.0, 0.0],
            up: [0.0, 1.0, 0.0],
        },
        colormap: Colormap::Viridis,
        value_label: "z".into(),
        value_range: None,
        notes: vec!["a note".into()],
        panel_width: 200.0,
        panel_height: 200.0,
    };
    let svg = picture.to_svg().expect("svg");
    assert_eq!(svg.matches("<polygon").count(), 2, "{svg}");
    parse_svg(&svg);
    assert!(svg.contains("fill=\"#d62728\""), "filled marker");
    // A triangle referring to a missing vertex is refused.
    let mut bad = picture.clone();
    bad.triangles.push([0, 1, 99]);
    let err = bad.to_svg().expect_err("bad vertex");
    assert!(err.to_string().contains("vertex 99"), "{err}");
}
