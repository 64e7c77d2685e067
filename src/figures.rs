//! The figures of the post stage (SVG + PNG), after the paper's Figs. 3a, 3b and 4.

use anyhow::Result;
use nlmodes_output::plot::{Color, Colormap, PALETTE};
use nlmodes_output::{HeatMap, LegendPosition, LinePlot, LineStyle, RefLine, Series};
use std::path::Path;

use crate::results::{BackboneFile, Orbit};
use nlmodes_nnm::BoundaryBackbone;

/// One closed orbit of Fig. 3b: q / g0 and (master displacement, master velocity, contact-node
/// radial displacement) samples, all normalized.
pub type ManifoldOrbit = (f64, Vec<(f64, f64, f64)>);

/// The points of each branch, in continuation order: (branch id, points).
fn branches_of(b: &BackboneFile) -> Vec<(usize, Vec<&Orbit>)> {
    let count = b.branches.len().max(1);
    (0..count)
        .map(|id| (id, b.points.iter().filter(|p| p.branch == id).collect()))
        .filter(|(_, pts): &(usize, Vec<&Orbit>)| !pts.is_empty())
        .collect()
}

/// The point of its parent a branch leaves from (the grazing orbit for the main branch, the
/// main-branch point before a tongue), so that the curves stay connected.
fn parent_point<'a>(b: &'a BackboneFile, id: usize, first: &Orbit) -> Option<&'a Orbit> {
    let parent = b.branches.get(id).and_then(|br| br.parent)?;
    b.points
        .iter()
        .take_while(|p| !std::ptr::eq(*p, first))
        .filter(|p| p.branch == parent)
        .last()
}

/// The pieces of a main branch between its passages past tongues (docs/DESIGN.md §8.3): a
/// passage is where another branch's points (the tongue) come between two of its points.
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

/// Which legend entries are already drawn.
#[derive(Default)]
struct Labelled {
    stable: bool,
    tongue: bool,
    unstable: bool,
    undetermined: bool,
    passage: bool,
}

/// Adds one connected piece of a branch to `plot`, starting at `start` (its parent's point, or
/// none): runs of equal stability, stable (or not analysed) solid, unstable dashed,
/// undetermined dotted.
fn add_piece(
    mut plot: LinePlot,
    pts: &[&Orbit],
    start: Option<&Orbit>,
    tongue: bool,
    labelled: &mut Labelled,
    x_of: &impl Fn(&Orbit) -> f64,
) -> LinePlot {
    const TONGUE: Color = Color(0x9e, 0xc5, 0xe8);
    let mut run_start = 0;
    for k in 1..=pts.len() {
        if k < pts.len() && pts[k].verdict() == pts[run_start].verdict() {
            continue;
        }
        let unstable = pts[run_start].unstable();
        let undetermined = pts[run_start].verdict() == Some("undetermined");
        // The first run starts at `start`, the others overlap the previous run by one point, so
        // that the curve stays connected.
        let head = if run_start == 0 {
            start
        } else {
            Some(pts[run_start - 1])
        };
        let run: Vec<&Orbit> = head
            .into_iter()
            .chain(pts[run_start..k].iter().copied())
            .collect();
        let (label, seen) = match (tongue, unstable, undetermined) {
            (true, _, _) => ("internal-resonance tongues", &mut labelled.tongue),
            (false, true, _) => ("unstable (dashed)", &mut labelled.unstable),
            (false, false, true) => (
                "stability undetermined (dotted)",
                &mut labelled.undetermined,
            ),
            (false, false, false) => ("backbone (stable)", &mut labelled.stable),
        };
        let name = if *seen { "" } else { label };
        *seen = true;
        let series = Series::new(
            name,
            run.iter().map(|p| x_of(p)).collect::<Vec<f64>>(),
            run.iter().map(|p| p.omega_ratio).collect::<Vec<f64>>(),
        );
        let series = if tongue {
            series.color(TONGUE).width(1.2)
        } else {
            series.color(PALETTE[0]).markers(!unstable)
        };
        plot = plot.with_series(if unstable {
            series.style(LineStyle::Dashed)
        } else if undetermined {
            series.style(LineStyle::Dotted)
        } else {
            series
        });
        run_start = k;
    }
    plot
}

/// A plot of the whole family against `x_of`: the linear segment and the main branch in the
/// first colour, each tongue in a lighter one (docs/DESIGN.md §8), the passages of the main
/// branch past tongues dotted, folds and jumps marked.
fn family_plot(
    b: &BackboneFile,
    title: &str,
    xlabel: &str,
    x_of: impl Fn(&Orbit) -> f64,
) -> LinePlot {
    let mut plot = LinePlot::new(title, xlabel, "frequency ratio w / w1")
        .with_legend(LegendPosition::BottomRight);
    let mut labelled = Labelled::default();
    for (id, pts) in branches_of(b) {
        let tongue = b.on_tongue(pts[0]);
        let parts = if tongue {
            vec![pts.clone()]
        } else {
            pieces(b, &pts)
        };
        let mut start = parent_point(b, id, pts[0]);
        for part in &parts {
            if let (Some(from), false) = (start.filter(|_| !std::ptr::eq(part, &parts[0])), tongue)
            {
                let name = if labelled.passage {
                    ""
                } else {
                    "passage past a tongue"
                };
                labelled.passage = true;
                plot = plot.with_series(
                    Series::new(
                        name,
                        vec![x_of(from), x_of(part[0])],
                        vec![from.omega_ratio, part[0].omega_ratio],
                    )
                    .color(Color(0x88, 0x88, 0x88))
                    .width(1.0)
                    .style(LineStyle::Dotted),
                );
            }
            let head = if std::ptr::eq(part, &parts[0]) {
                start
            } else {
                None
            };
            plot = add_piece(plot, part, head, tongue, &mut labelled, &x_of);
            start = part.last().copied();
        }
    }
    let bif: Vec<(f64, f64)> = b
        .points
        .iter()
        .filter(|p| p.bifurcation.is_some())
        .map(|p| (x_of(p), p.omega_ratio))
        .collect();
    if !bif.is_empty() {
        let (bx, by): (Vec<f64>, Vec<f64>) = bif.into_iter().unzip();
        plot = plot.with_series(
            Series::new("bifurcation (stability change)", bx, by)
                .color(PALETTE[2])
                .style(LineStyle::None)
                .markers(true),
        );
    }
    let marks: Vec<(f64, f64)> = b
        .points
        .iter()
        .filter(|p| p.fold || p.jump)
        .map(|p| (x_of(p), p.omega_ratio))
        .collect();
    if !marks.is_empty() {
        let (mx, my): (Vec<f64>, Vec<f64>) = marks.into_iter().unzip();
        plot = plot.with_series(
            Series::new("fold / jump", mx, my)
                .color(PALETTE[1])
                .style(LineStyle::None)
                .markers(true),
        );
    }
    plot.with_ref_line(RefLine::horizontal(1.0, "linear"))
}

/// The exact backbone's pieces as thin grey lines against q / g0 (stable solid, unstable
/// dashed, undetermined dotted), the first labelled; the pieces' ends next to a hole, followed
/// through their tongues, light grey dotted.
fn exact_series(e: &BoundaryBackbone, g0: f64, w1: f64) -> Vec<Series> {
    let style = |v: &str| match v {
        "unstable" => LineStyle::Dashed,
        "stable" => LineStyle::Solid,
        _ => LineStyle::Dotted,
    };
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
                let name = if out.is_empty() {
                    "exact orbits, massless contact boundary"
                } else {
                    ""
                };
                out.push(
                    Series::new(
                        name,
                        run.iter().map(|p| p.q.abs() / g0).collect::<Vec<f64>>(),
                        run.iter().map(|p| p.omega / w1).collect::<Vec<f64>>(),
                    )
                    .color(Color(110, 110, 110))
                    .width(0.9)
                    .style(style(&run[0].verdict)),
                );
            }
            start = i;
        }
    }
    for (k, f) in e.hole_follows.iter().enumerate() {
        let name = if k == 0 {
            "exact orbits past a hole's edge, through its tongue"
        } else {
            ""
        };
        out.push(
            Series::new(
                name,
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

/// Fig. 3a: w / w1 against q / g0, grazing amplitude marked, tongues in a lighter colour, folds
/// and jumps as markers; the exact backbone of the massless contact boundary in grey when given,
/// and the converged orbits of the main-branch points in contact as black dots.
pub fn backbone_figure(
    b: &BackboneFile,
    exact: Option<&BoundaryBackbone>,
    out: &Path,
) -> Result<()> {
    let g0 = b.gap_reference;
    let mut plot = family_plot(
        b,
        "Backbone of the first nonlinear mode",
        "modal amplitude q / g0",
        |p| p.q / g0,
    );
    for series in exact.map_or_else(Vec::new, |e| exact_series(e, g0, b.omega_linear)) {
        plot = plot.with_series(series);
    }
    let converged: Vec<(f64, f64)> = b
        .points
        .iter()
        .filter_map(|p| {
            let c = p.converged.as_ref()?;
            Some((p.q / g0, c.orbit().omega / b.omega_linear))
        })
        .collect();
    if !converged.is_empty() {
        let (x, y): (Vec<f64>, Vec<f64>) = converged.into_iter().unzip();
        plot = plot.with_series(
            Series::new("converged orbit at each q (docs/STABILITY.md 9.4)", x, y)
                .color(Color(0, 0, 0))
                .style(LineStyle::None)
                .markers(true),
        );
    }
    if let Some(q) = b.grazing_amplitude {
        plot = plot.with_ref_line(RefLine::vertical(q / g0, "grazing"));
    }
    plot.write_svg_and_png(&out.join("backbone"))?;
    Ok(())
}

/// Frequency-energy plot (Kerschen, Peeters, Golinval & Vakakis 2009): w / w1 against
/// log10 of the energy at the turning point (J), the same branches as Fig. 3a. Points with no
/// energy (zero orbit) are left out.
pub fn frequency_energy_figure(b: &BackboneFile, out: &Path) -> Result<()> {
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
        return Ok(());
    }
    family_plot(
        &positive,
        "Frequency-energy plot of the nonlinear mode",
        "log10(energy / J)",
        |p| p.energy.log10(),
    )
    .write_svg_and_png(&out.join("frequency_energy"))?;
    Ok(())
}

/// Fig. 3b, as projections: the contact node's radial displacement against the master's
/// displacement, and against its velocity, one closed curve per amplitude.
pub fn manifold_figure(orbits: &[ManifoldOrbit], node: usize, out: &Path) -> Result<()> {
    let ylabel = format!("radial displacement of contact node {} / g0", node + 1);
    let mut disp = LinePlot::new(
        "Manifold of the first nonlinear mode (displacement)",
        "master displacement / g0",
        ylabel.clone(),
    )
    .with_legend(LegendPosition::Hidden);
    let mut vel = LinePlot::new(
        "Manifold of the first nonlinear mode (velocity)",
        "master velocity / (w1 g0)",
        ylabel,
    )
    .with_legend(LegendPosition::Hidden);
    for (i, (q, c)) in orbits.iter().enumerate() {
        let color = PALETTE[i % PALETTE.len()];
        let label = format!("q/g0 = {q:.2}");
        disp = disp.with_series(
            Series::new(
                label.clone(),
                c.iter().map(|p| p.0).collect::<Vec<_>>(),
                c.iter().map(|p| p.2).collect::<Vec<_>>(),
            )
            .color(color),
        );
        vel = vel.with_series(
            Series::new(
                label,
                c.iter().map(|p| p.1).collect::<Vec<_>>(),
                c.iter().map(|p| p.2).collect::<Vec<_>>(),
            )
            .color(color),
        );
    }
    disp = disp.with_ref_line(RefLine::horizontal(1.0, "contact"));
    vel = vel.with_ref_line(RefLine::horizontal(1.0, "contact"));
    disp.write_svg_and_png(&out.join("manifold_displacement"))?;
    vel.write_svg_and_png(&out.join("manifold_velocity"))?;
    Ok(())
}

/// Fig. 4: radial displacement / g0 of every contact node over one period; contact at 1.
pub fn radial_figure(series: &[Vec<(f64, f64)>], title: &str, file: &Path) -> Result<()> {
    let mut plot = LinePlot::new(title, "time t / T", "radial displacement / g0")
        .with_legend(LegendPosition::Hidden);
    let c = series.len();
    for (j, s) in series.iter().enumerate() {
        // Leading edge blue to trailing edge red.
        let t = if c > 1 {
            j as f64 / (c - 1) as f64
        } else {
            0.0
        };
        let color = Colormap::Viridis.at(t);
        plot = plot.with_series(
            Series::new(
                format!("node {}", j + 1),
                s.iter().map(|p| p.0).collect::<Vec<_>>(),
                s.iter().map(|p| p.1).collect::<Vec<_>>(),
            )
            .color(color),
        );
    }
    plot = plot.with_ref_line(RefLine::horizontal(1.0, "contact"));
    plot.write_svg_and_png(file)?;
    Ok(())
}

/// The contact map: contact force (N) of every node (rows, leading to trailing edge) over one
/// period (columns).
pub fn contact_map_figure(force: &[Vec<f64>], q: f64, dir: &Path, tag: &str) -> Result<()> {
    let rows = force.len();
    let cols = force.first().map(|v| v.len()).unwrap_or(0);
    anyhow::ensure!(rows > 0 && cols > 0, "empty contact force samples");
    let values: Vec<f64> = force.iter().flatten().copied().collect();
    let _ = q;
    let map = HeatMap::new(
        format!("Contact map ({tag})"),
        "time t / T",
        "contact node (leading to trailing edge)",
        "contact force [N]",
        rows,
        cols,
        values,
    )
    .with_x_extent(0.0, 1.0)
    .with_y_extent(0.5, rows as f64 + 0.5)
    .with_colormap(Colormap::GrayRed);
    map.write_svg_and_png(&dir.join(format!("contact_map_{tag}")))?;
    Ok(())
}

/// The frequency-energy plot of several modes' families in one figure (frequency in Hz, since
/// each mode has its own w1): each mode's linear segment and main branch in its own colour,
/// its tongues lighter and unlabelled.
pub fn combined_frequency_energy(families: &[(usize, BackboneFile)], out: &Path) -> Result<()> {
    let mut plot = LinePlot::new(
        "Frequency-energy plot of the nonlinear modes",
        "log10(energy / J)",
        "frequency [Hz]",
    )
    .with_legend(LegendPosition::TopLeft);
    for (i, (mode, b)) in families.iter().enumerate() {
        let color = PALETTE[i % PALETTE.len()];
        for (id, pts) in branches_of(b) {
            let tongue = b.on_tongue(pts[0]);
            let start = parent_point(b, id, pts[0]);
            let pts: Vec<&Orbit> = start
                .into_iter()
                .chain(pts)
                .filter(|p| p.energy > 0.0)
                .collect();
            if pts.is_empty() {
                continue;
            }
            let label = if id == 1 || (id == 0 && b.branches.len() <= 1) {
                format!("mode {}", mode + 1)
            } else {
                String::new()
            };
            let series = Series::new(
                label,
                pts.iter().map(|p| p.energy.log10()).collect::<Vec<_>>(),
                pts.iter().map(|p| p.frequency_hz).collect::<Vec<_>>(),
            )
            .color(color);
            plot = plot.with_series(if tongue {
                series.width(0.8).style(LineStyle::Dotted)
            } else {
                series
            });
        }
    }
    plot.write_svg_and_png(&out.join("frequency_energy_modes"))?;
    Ok(())
}
