//! Legends and labels never over the data: the layout's geometry ([`LineLayout::clashes`]) on
//! plots whose data fill the area, leave one corner free, or carry long legends; and the glyphs
//! as the rasterizer lays them out (usvg with the system fonts) inside the boxes the layout
//! reserved for them.

use super::raster::parse_with_fonts;
use super::*;
use resvg::usvg;

const POSITIONS: [LegendPosition; 7] = [
    LegendPosition::Auto,
    LegendPosition::TopRight,
    LegendPosition::TopLeft,
    LegendPosition::BottomRight,
    LegendPosition::BottomLeft,
    LegendPosition::Right,
    LegendPosition::Below,
];

/// Curves through every part of the area: sines of several phases over [0, 10] x [-1, 1], with
/// markers on one of them, a horizontal and a vertical reference line.
fn crowded(labels: &[&str]) -> LinePlot {
    let x: Vec<f64> = (0..=400).map(|i| i as f64 * 0.025).collect();
    let mut plot = LinePlot::new("Crowded plot", "x", "y")
        .with_ref_line(RefLine::horizontal(0.5, "contact"))
        .with_ref_line(RefLine::vertical(3.0, "grazing"));
    for (k, label) in labels.iter().enumerate() {
        let phase = k as f64 * std::f64::consts::PI / labels.len() as f64;
        let y: Vec<f64> = x.iter().map(|&t| (2.0 * t + phase).sin()).collect();
        plot = plot.with_series(Series::new(*label, x.clone(), y).markers(k == 0));
    }
    plot
}

/// A backbone-like curve in the lower left half: the top right corner is free.
fn rising() -> LinePlot {
    let q: Vec<f64> = (0..=60).map(|i| i as f64 * 0.5).collect();
    let w: Vec<f64> = q.iter().map(|&q| 1.0 + 0.01 * q).collect();
    LinePlot::new("Rising", "q / g0", "w / w1")
        .with_series(Series::new("backbone", q.clone(), w))
        .with_series(
            Series::new("a point", vec![0.0], vec![1.6])
                .style(LineStyle::None)
                .markers(true),
        )
        .with_ref_line(RefLine::vertical(4.0, "grazing"))
}

#[test]
fn a_legend_over_crowded_data_goes_outside_the_area() {
    let labels = [
        "stable",
        "unstable (dashed)",
        "fold",
        "a longer legend entry, with capitals",
    ];
    for pos in POSITIONS {
        let plot = crowded(&labels).with_legend(pos);
        let l = plot.layout().expect("layout");
        assert!(l.clashes().is_empty(), "{pos:?}: {:?}", l.clashes());
        let (legend, _) = l.legend.expect("a legend");
        assert!(
            !legend.overlaps(&l.area),
            "{pos:?}: {legend:?} in {:?}",
            l.area
        );
        if pos == LegendPosition::Below {
            assert!(
                legend.y > l.area.bottom() && l.height > plot.height,
                "{legend:?}"
            );
        } else {
            assert!(
                legend.x > l.area.right() && l.width > plot.width,
                "{legend:?}"
            );
        }
        // Reference-line labels sit outside the area too.
        assert_eq!(l.ref_labels.len(), 2);
        assert!(l.ref_labels.iter().all(|r| !r.rect.overlaps(&l.area)));
    }
}

#[test]
fn a_legend_takes_a_free_corner_only() {
    let l = rising().layout().expect("layout");
    assert!(l.clashes().is_empty(), "{:?}", l.clashes());
    let (legend, _) = l.legend.expect("a legend");
    // Auto tries the top right corner first: free of the curve, but the marker at (0, 1.6)
    // sits top left, so a top-left request goes elsewhere.
    assert!(l.area.contains(&legend), "{legend:?} in {:?}", l.area);
    assert!(legend.x > l.area.x + 0.5 * l.area.w && legend.y < l.area.y + 0.5 * l.area.h);
    assert_eq!(
        (l.width, l.height),
        (800.0, 520.0),
        "the image keeps its size"
    );
    let top_left = rising()
        .with_legend(LegendPosition::TopLeft)
        .layout()
        .expect("layout");
    let (legend, _) = top_left.legend.expect("a legend");
    assert!(legend.x > top_left.area.right(), "{legend:?}");
    assert!(top_left.clashes().is_empty(), "{:?}", top_left.clashes());
}

#[test]
fn clashes_are_found() {
    // A layout with a legend moved onto the curves is reported.
    let mut l = crowded(&["one"]).layout().expect("layout");
    let (mut legend, columns) = l.legend.expect("a legend");
    legend.x = l.area.x + 0.5 * l.area.w;
    legend.y = l.area.y + 0.5 * l.area.h;
    l.legend = Some((legend, columns));
    let c = l.clashes();
    assert!(c.iter().any(|m| m.contains("over drawn data")), "{c:?}");
    // Over the title, and out of the image.
    let mut l = rising().layout().expect("layout");
    l.legend = Some((Rect::new(l.width - 20.0, 2.0, 60.0, 40.0), 1));
    let c = l.clashes();
    assert!(c.iter().any(|m| m.contains("leaves the")), "{c:?}");
    let title = l.texts[0];
    l.legend = Some((title, 1));
    assert!(l.clashes().iter().any(|m| m.contains("covers text")));
}

#[test]
fn close_vertical_lines_get_label_rows_of_their_own() {
    let plot = rising()
        .with_ref_line(RefLine::vertical(4.5, "another line"))
        .with_ref_line(RefLine::vertical(20.0, "far"));
    let l = plot.layout().expect("layout");
    assert!(l.clashes().is_empty(), "{:?}", l.clashes());
    let y: Vec<f64> = l.ref_labels.iter().map(|r| r.rect.y).collect();
    assert!(y[0] != y[1] && y[0] == y[2], "{y:?}");
}

/// Rendered boxes of the text nodes of `svg` whose text is `text` (usvg with system fonts).
fn rendered_boxes(tree: &usvg::Tree, text: &str) -> Vec<Rect> {
    fn walk(g: &usvg::Group, text: &str, out: &mut Vec<Rect>) {
        for node in g.children() {
            match node {
                usvg::Node::Group(g) => walk(g, text, out),
                usvg::Node::Text(t)
                    if t.chunks().iter().map(|c| c.text()).collect::<String>() == text =>
                {
                    let b = t.abs_bounding_box();
                    out.push(Rect::new(
                        f64::from(b.left()),
                        f64::from(b.top()),
                        f64::from(b.width()),
                        f64::from(b.height()),
                    ));
                }
                _ => {}
            }
        }
    }
    let mut out = Vec::new();
    walk(tree.root(), text, &mut out);
    out
}

#[test]
fn the_rendered_text_stays_in_its_boxes() {
    assert!(
        fonts_available(),
        "no system font: install fonts-dejavu-core"
    );
    let labels = [
        "converged orbit at each q (docs/STABILITY.md 9.4)",
        "WWW MMM capitals",
        "exact orbits, massless contact boundary",
    ];
    for pos in [
        LegendPosition::Right,
        LegendPosition::Below,
        LegendPosition::Auto,
    ] {
        let plot = crowded(&labels).with_legend(pos);
        let l = plot.layout().expect("layout");
        let tree = parse_with_fonts(&plot.to_svg().expect("svg")).expect("parse");
        let (legend, _) = l.legend.expect("a legend");
        for label in labels {
            let boxes = rendered_boxes(&tree, label);
            assert_eq!(boxes.len(), 1, "{label}");
            assert!(
                legend.contains(&boxes[0]),
                "{pos:?}: `{label}` {:?} outside {legend:?}",
                boxes[0]
            );
        }
        for r in &l.ref_labels {
            let b = rendered_boxes(&tree, &r.text)[0];
            assert!(
                !b.overlaps(&l.area),
                "`{}` {b:?} over the area {:?}",
                r.text,
                l.area
            );
            assert!(!b.overlaps(&legend), "`{}` {b:?} over the legend", r.text);
            assert!(
                r.rect.inflate(2.0).contains(&b),
                "`{}`: {b:?} vs {:?}",
                r.text,
                r.rect
            );
        }
    }
}

/// A Campbell-like plot: rising curves and straight lines that leave the area through its
/// right side at nearby heights (their labels would overlap: moved apart) and through its top
/// (labels in the rows above the frame, beside a vertical reference line's): every label
/// outside the area, none over data or text, each at its series' end, and the rendered glyphs
/// inside their boxes.
#[test]
fn end_labels_sit_outside_the_area_apart() {
    let (hi, top) = (10.0, 100.0);
    let mut plot = LinePlot::new("Ends", "speed", "frequency")
        .with_x_range(0.0, hi)
        .with_y_range(0.0, top)
        .with_legend(LegendPosition::Hidden)
        .with_ref_line(RefLine::vertical(8.0, "operating speed"));
    for (k, slope) in [4.0, 4.3, 4.6, 12.0, 20.0].into_iter().enumerate() {
        let end = hi.min(top / slope);
        plot = plot.with_series(
            Series::new("", vec![0.0, end], vec![0.0, slope * end]).end_label(format!("EO {k}")),
        );
    }
    plot = plot.with_series(
        Series::new("", vec![0.0, 5.0, hi], vec![30.0, 35.0, 44.0]).end_label("mode 1 (1F)"),
    );
    let l = plot.layout().expect("layout");
    assert!(l.clashes().is_empty(), "{:?}", l.clashes());
    let labels: Vec<&RefLabel> = l
        .ref_labels
        .iter()
        .filter(|r| r.text != "operating speed")
        .collect();
    assert_eq!(labels.len(), 6);
    for r in &labels {
        assert!(!r.rect.overlaps(&l.area), "{r:?}");
    }
    let right = |t: &str| labels.iter().find(|r| r.text == t).expect(t).rect;
    assert!(right("EO 0").x > l.area.right() && right("mode 1 (1F)").x > l.area.right());
    assert!(right("EO 4").bottom() < l.area.y && right("EO 3").bottom() < l.area.y);
    let (_, y_end) = l.to_px(hi, 44.0);
    assert!((right("mode 1 (1F)").y + 0.5 * right("mode 1 (1F)").h - y_end).abs() < 20.0);
    let tree = parse_with_fonts(&plot.to_svg().expect("svg")).expect("parse");
    for r in &labels {
        let b = rendered_boxes(&tree, &r.text)[0];
        assert!(
            r.rect.inflate(2.0).contains(&b),
            "`{}`: {b:?} vs {:?}",
            r.text,
            r.rect
        );
    }
}
