//! The backbone figures: Fig. 3a as the paper draws it (the backbone alone: stable solid,
//! unstable dashed, grazing and folds marked), the same curve with every diagnostic the
//! program computes around it (tongues, exact orbits of the massless contact boundary, the
//! holes' edges, converged orbits, stability changes, jumps) in a figure of its own, and the
//! frequency-energy plot. The stability is read from each point's verdict word (`stable`,
//! `unstable`, `undetermined`: the `stability` column of backbone.csv).

use nlmodes_nnm::BoundaryBackbone;
use nlmodes_output::plot::{Color, PALETTE};
use nlmodes_output::{LegendPosition, LinePlot, LineStyle, RefLine, Series};

use crate::post::results::{BackboneFile, Orbit};

/// The backbone's colour (linear segment and main branch).
const BACKBONE: Color = PALETTE[0];
/// Tongues: the backbone's colour, lighter.
const TONGUE: Color = Color(0x9e, 0xc5, 0xe8);
/// Folds and jumps.
const FOLD: Color = PALETTE[1];
/// Stability changes.
const BIFURCATION: Color = PALETTE[2];
/// The dotted line across a passage of the main branch past a tongue.
const PASSAGE: Color = Color(0x88, 0x88, 0x88);

/// The points of each branch, in continuation order: (branch id, points).
pub(super) fn branches_of(b: &BackboneFile) -> Vec<(usize, Vec<&Orbit>)> {
    let count = b.branches.len().max(1);
    (0..count)
        .map(|id| (id, b.points.iter().filter(|p| p.branch == id).collect()))
        .filter(|(_, pts): &(usize, Vec<&Orbit>)| !pts.is_empty())
        .collect()
}

/// The point of its parent a branch leaves from (the grazing orbit for the main branch, the
/// main-branch point before a tongue), so that the curves stay connected.
pub(super) fn parent_point<'a>(b: &'a BackboneFile, id: usize, first: &Orbit) -> Option<&'a Orbit> {
    let parent = b.branches.get(id).and_then(|br| br.parent)?;
    b.points
        .iter()
        .take_while(|p| !std::ptr::eq(*p, first))
        .filter(|p| p.branch == parent)
        .last()
}

/// The pieces of a branch between its passages past tongues (docs/DESIGN.md §8.3): a passage
/// is where another branch's points (the tongue) come between two of its points.
fn pieces<'a>(b: &'a BackboneFile, pts: &[&'a Orbit]) -> Vec<Vec<&'a Orbit>> {
    let index = |p: &Orbit| {
        b.points
            .iter()
            .position(|q| std::ptr::eq(q, p))
            .unwrap_or(0)
    };
    let mut out: Vec<Vec<&Orbit>> = vec![Vec::new()];
    for (k, &p) in pts.iter().enumerate() {
        if k > 0 {
            let (i, j) = (index(pts[k - 1]), index(p));
            if b.points[i + 1..j].iter().any(|q| b.on_tongue(q)) {
                out.push(Vec::new());
            }
        }
        out.last_mut().expect("one piece at least").push(p);
    }
    out
}

/// The backbone proper (every branch but the tongues: the linear segment and the main branch),
/// as connected pieces, each starting at its parent's point where it has one.
fn backbone_pieces(b: &BackboneFile) -> Vec<Vec<&Orbit>> {
    let mut out = Vec::new();
    for (id, pts) in branches_of(b) {
        if b.on_tongue(pts[0]) {
            continue;
        }
        let mut parts = pieces(b, &pts);
        if let Some(start) = parent_point(b, id, pts[0]) {
            parts[0].insert(0, start);
        }
        out.extend(parts);
    }
    out
}

/// The tongues, each from the main-branch point it leaves.
fn tongues(b: &BackboneFile) -> Vec<Vec<&Orbit>> {
    branches_of(b)
        .into_iter()
        .filter(|(_, pts)| b.on_tongue(pts[0]))
        .map(|(id, pts)| parent_point(b, id, pts[0]).into_iter().chain(pts).collect())
        .collect()
}

/// Line style of a verdict: unstable dashed, undetermined dotted, stable (or not analysed)
/// solid.
fn style_of(verdict: Option<&str>) -> LineStyle {
    match verdict {
        Some("unstable") => LineStyle::Dashed,
        Some("undetermined") => LineStyle::Dotted,
        _ => LineStyle::Solid,
    }
}

/// Line style of a harmonic-balance point, from its verdict word.
fn point_style(p: &Orbit) -> LineStyle {
    if p.unstable() {
        LineStyle::Dashed
    } else {
        style_of(p.verdict())
    }
}

/// One piece cut into runs of one line style: each point's style holds on either side of it
/// up to the midpoints with its neighbours, so a change of stability shows where it happens.
/// Returns (style, x, y) per run.
fn stability_runs(
    piece: &[&Orbit],
    x_of: &dyn Fn(&Orbit) -> f64,
) -> Vec<(LineStyle, Vec<f64>, Vec<f64>)> {
    let xy: Vec<(f64, f64)> = piece.iter().map(|p| (x_of(p), p.omega_ratio)).collect();
    let style: Vec<LineStyle> = piece.iter().map(|p| point_style(p)).collect();
    let mid = |i: usize| (0.5 * (xy[i].0 + xy[i + 1].0), 0.5 * (xy[i].1 + xy[i + 1].1));
    let mut runs = Vec::new();
    let mut start = 0;
    for k in 1..=piece.len() {
        if k < piece.len() && style[k] == style[start] {
            continue;
        }
        // Points start..k share a style; the run reaches halfway to the neighbours.
        let mut pts: Vec<(f64, f64)> = Vec::new();
        if start > 0 {
            pts.push(mid(start - 1));
        }
        pts.extend_from_slice(&xy[start..k]);
        if k < piece.len() {
            pts.push(mid(k - 1));
        }
        if pts.len() >= 2 {
            let (x, y) = pts.into_iter().unzip();
            runs.push((style[start], x, y));
        }
        start = k;
    }
    runs
}

/// Which legend entries a plot has drawn already (each style labelled once).
#[derive(Default)]
struct Labels(Vec<String>);

impl Labels {
    /// `label` the first time, empty after.
    fn once(&mut self, label: &str) -> String {
        if self.0.iter().any(|l| l == label) {
            String::new()
        } else {
            self.0.push(label.to_string());
            label.to_string()
        }
    }
}

/// The legend text of a backbone line style.
fn style_label(style: LineStyle, analysed: bool) -> &'static str {
    match style {
        LineStyle::Dashed => "unstable",
        LineStyle::Dotted => "stability undetermined",
        _ if analysed => "stable",
        _ => "backbone",
    }
}

/// Adds `pieces` drawn by stability in `look` (colour, width, and one legend text for every
/// style, or `None`: a text per style).
fn add_curves(
    mut plot: LinePlot,
    pieces: &[Vec<&Orbit>],
    look: (Color, f64, Option<&str>),
    labels: &mut Labels,
    x_of: &dyn Fn(&Orbit) -> f64,
) -> LinePlot {
    let (color, width, fixed_label) = look;
    let analysed = pieces.iter().flatten().any(|p| p.verdict().is_some());
    for piece in pieces {
        for (style, x, y) in stability_runs(piece, x_of) {
            let label = labels.once(fixed_label.unwrap_or(style_label(style, analysed)));
            let series = Series::new(label, x, y)
                .color(color)
                .width(width)
                .style(style);
            plot = plot.with_series(series);
        }
    }
    plot
}

/// The dotted lines across the backbone's passages past tongues (from a piece's last point to
/// the next piece's first, within one branch).
fn add_passages(
    mut plot: LinePlot,
    pieces: &[Vec<&Orbit>],
    labels: &mut Labels,
    x_of: &dyn Fn(&Orbit) -> f64,
) -> LinePlot {
    for pair in pieces.windows(2) {
        let (Some(&from), Some(&to)) = (pair[0].last(), pair[1].first()) else {
            continue;
        };
        // The next branch starts at its parent's point: that is no passage.
        if from.branch != to.branch || std::ptr::eq(from, to) {
            continue;
        }
        let label = labels.once("passage past an internal-resonance tongue");
        plot = plot.with_series(
            Series::new(
                label,
                vec![x_of(from), x_of(to)],
                vec![from.omega_ratio, to.omega_ratio],
            )
            .color(PASSAGE)
            .width(1.0)
            .style(LineStyle::Dotted),
        );
    }
    plot
}

/// Markers at the points `pick` selects (none: nothing added).
fn add_markers(
    plot: LinePlot,
    points: &[&Orbit],
    pick: impl Fn(&Orbit) -> bool,
    (label, color, width): (&str, Color, f64),
    x_of: &dyn Fn(&Orbit) -> f64,
) -> LinePlot {
    let (x, y): (Vec<f64>, Vec<f64>) = points
        .iter()
        .filter(|p| pick(p))
        .map(|p| (x_of(p), p.omega_ratio))
        .unzip();
    if x.is_empty() {
        return plot;
    }
    plot.with_series(
        Series::new(label, x, y)
            .color(color)
            .width(width)
            .style(LineStyle::None)
            .markers(true),
    )
}

/// The grazing amplitude as a vertical line (against q / g0 only).
fn with_grazing(plot: LinePlot, b: &BackboneFile) -> LinePlot {
    match b.grazing_amplitude {
        Some(q) => plot.with_ref_line(RefLine::vertical(q / b.gap_reference, "grazing")),
        None => plot,
    }
}

/// Fig. 3a as the paper draws it: w / w1 against q / g0 of the linear segment and the main
/// branch, stable solid, unstable dashed (undetermined dotted), the passages past tongues
/// dotted grey, folds marked, grazing marked.
pub fn backbone_plot(b: &BackboneFile) -> LinePlot {
    let g0 = b.gap_reference;
    let x_of = |p: &Orbit| p.q / g0;
    let pieces = backbone_pieces(b);
    let mut labels = Labels::default();
    let plot = LinePlot::new(
        "Backbone of the first nonlinear mode",
        "modal amplitude q / g0",
        "frequency ratio w / w1",
    )
    .with_legend(LegendPosition::Auto);
    let plot = add_curves(plot, &pieces, (BACKBONE, 2.0, None), &mut labels, &x_of);
    let plot = add_passages(plot, &pieces, &mut labels, &x_of);
    let all: Vec<&Orbit> = pieces.iter().flatten().copied().collect();
    let plot = add_markers(plot, &all, |p| p.fold, ("fold", FOLD, 2.0), &x_of);
    with_grazing(plot, b)
}

/// The exact backbone's pieces as thin grey lines against q / g0 (stable solid, unstable
/// dashed, undetermined dotted); the pieces' ends next to a hole, followed through their
/// tongues, light grey dotted.
fn exact_series(e: &BoundaryBackbone, g0: f64, w1: f64, labels: &mut Labels) -> Vec<Series> {
    let mut out = Vec::new();
    for piece in &e.pieces {
        let pts = &piece.points;
        let mut start = 0;
        for i in 1..=pts.len() {
            if i < pts.len() && pts[i].verdict == pts[start].verdict {
                continue;
            }
            // A run of one verdict, joined to the next run's first point.
            let run = &pts[start..(i + 1).min(pts.len())];
            if run.len() >= 2 {
                let label = labels.once("exact orbits (massless contact boundary)");
                out.push(
                    Series::new(
                        label,
                        run.iter().map(|p| p.q.abs() / g0).collect::<Vec<f64>>(),
                        run.iter().map(|p| p.omega / w1).collect::<Vec<f64>>(),
                    )
                    .color(Color(110, 110, 110))
                    .width(0.9)
                    .style(style_of(Some(run[0].verdict.as_str()))),
                );
            }
            start = i;
        }
    }
    for f in &e.hole_follows {
        let label = labels.once("exact orbits past a hole's edge");
        out.push(
            Series::new(
                label,
                f.points
                    .iter()
                    .map(|p| p.q.abs() / g0)
                    .collect::<Vec<f64>>(),
                f.points.iter().map(|p| p.omega / w1).collect::<Vec<f64>>(),
            )
            .color(Color(175, 175, 175))
            .width(0.8)
            .style(LineStyle::Dotted),
        );
    }
    out
}

/// The diagnostics around Fig. 3a: the harmonic-balance backbone (thin, by stability), its
/// passages, the tongues, the exact backbone of the massless contact boundary and the holes'
/// edges (when given), the converged orbit at each q (docs/STABILITY.md 9.4), stability
/// changes, folds and jumps; the legend below the plot.
pub fn diagnostics_plot(b: &BackboneFile, exact: Option<&BoundaryBackbone>) -> LinePlot {
    let g0 = b.gap_reference;
    let x_of = |p: &Orbit| p.q / g0;
    let pieces = backbone_pieces(b);
    let mut labels = Labels::default();
    let plot = LinePlot::new(
        "Backbone diagnostics: tongues, exact and converged orbits",
        "modal amplitude q / g0",
        "frequency ratio w / w1",
    )
    .with_size(1000.0, 600.0)
    .with_legend(LegendPosition::Below);
    let hb = "harmonic balance (dashed unstable, dotted undetermined)";
    let mut plot = add_curves(plot, &pieces, (BACKBONE, 1.4, Some(hb)), &mut labels, &x_of);
    plot = add_passages(plot, &pieces, &mut labels, &x_of);
    let tongue = "internal-resonance tongues";
    plot = add_curves(
        plot,
        &tongues(b),
        (TONGUE, 1.2, Some(tongue)),
        &mut labels,
        &x_of,
    );
    for series in exact.map_or_else(Vec::new, |e| {
        exact_series(e, g0, b.omega_linear, &mut labels)
    }) {
        plot = plot.with_series(series);
    }
    let (x, y): (Vec<f64>, Vec<f64>) = b
        .points
        .iter()
        .filter_map(|p| {
            Some((
                p.q / g0,
                p.converged.as_ref()?.orbit().omega / b.omega_linear,
            ))
        })
        .unzip();
    if !x.is_empty() {
        plot = plot.with_series(
            Series::new("converged orbit at each q", x, y)
                .color(Color(0, 0, 0))
                .width(1.5)
                .style(LineStyle::None)
                .markers(true),
        );
    }
    let all: Vec<&Orbit> = b.points.iter().collect();
    let change = ("stability change", BIFURCATION, 1.5);
    plot = add_markers(plot, &all, |p| p.bifurcation.is_some(), change, &x_of);
    plot = add_markers(
        plot,
        &all,
        |p| p.fold || p.jump,
        ("fold / jump", FOLD, 1.5),
        &x_of,
    );
    with_grazing(plot, b)
}

/// Frequency-energy plot (Kerschen, Peeters, Golinval & Vakakis 2009): w / w1 against log10 of
/// the energy at the turning point (J), the backbone drawn as in Fig. 3a with its tongues in
/// light blue. Points with no energy (zero orbit) are left out; `None` when none has any.
pub fn frequency_energy_plot(b: &BackboneFile) -> Option<LinePlot> {
    let positive = BackboneFile {
        points: b
            .points
            .iter()
            .filter(|p| p.energy > 0.0)
            .cloned()
            .collect(),
        ..b.clone()
    };
    if positive.points.is_empty() {
        return None;
    }
    let x_of = |p: &Orbit| p.energy.log10();
    let pieces = backbone_pieces(&positive);
    let mut labels = Labels::default();
    let plot = LinePlot::new(
        "Frequency-energy plot of the nonlinear mode",
        "log10(energy / J)",
        "frequency ratio w / w1",
    )
    .with_legend(LegendPosition::Auto);
    let mut plot = add_curves(plot, &pieces, (BACKBONE, 2.0, None), &mut labels, &x_of);
    plot = add_passages(plot, &pieces, &mut labels, &x_of);
    let tongue = "internal-resonance tongues";
    plot = add_curves(
        plot,
        &tongues(&positive),
        (TONGUE, 1.2, Some(tongue)),
        &mut labels,
        &x_of,
    );
    let all: Vec<&Orbit> = pieces.iter().flatten().copied().collect();
    Some(add_markers(
        plot,
        &all,
        |p| p.fold,
        ("fold", FOLD, 2.0),
        &x_of,
    ))
}
