//! The figures of the post stage (SVG + PNG), after the paper's Figs. 3a, 3b and 4.

use anyhow::Result;
use nlmodes_output::plot::{Colormap, PALETTE};
use nlmodes_output::{HeatMap, LegendPosition, LinePlot, LineStyle, RefLine, Series};
use std::path::Path;

use crate::results::BackboneFile;

/// One closed orbit of Fig. 3b: q / g0 and (master displacement, master velocity, contact-node
/// radial displacement) samples, all normalized.
pub type ManifoldOrbit = (f64, Vec<(f64, f64, f64)>);

/// Fig. 3a: w / w1 against q / g0, grazing amplitude marked, folds and jumps as markers.
pub fn backbone_figure(b: &BackboneFile, out: &Path) -> Result<()> {
    let g0 = b.gap_reference;
    let x: Vec<f64> = b.points.iter().map(|p| p.q / g0).collect();
    let y: Vec<f64> = b.points.iter().map(|p| p.omega_ratio).collect();
    let mut plot = LinePlot::new(
        "Backbone of the first nonlinear mode",
        "modal amplitude q / g0",
        "frequency ratio w / w1",
    )
    .with_series(
        Series::new("backbone", x, y)
            .color(PALETTE[0])
            .markers(true),
    )
    .with_legend(LegendPosition::TopLeft);
    let marks: Vec<(f64, f64)> = b
        .points
        .iter()
        .filter(|p| p.fold || p.jump)
        .map(|p| (p.q / g0, p.omega_ratio))
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
    if let Some(q) = b.grazing_amplitude {
        plot = plot.with_ref_line(RefLine::vertical(q / g0, "grazing"));
    }
    plot = plot.with_ref_line(RefLine::horizontal(1.0, "linear"));
    plot.write_svg_and_png(&out.join("backbone"))?;
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
pub fn radial_figure(series: &[Vec<(f64, f64)>], q: f64, dir: &Path, tag: &str) -> Result<()> {
    let mut plot = LinePlot::new(
        format!("Radial displacement of the contact nodes, q/g0 = {q:.2}"),
        "time t / T",
        "radial displacement / g0",
    )
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
    plot.write_svg_and_png(&dir.join(format!("radial_{tag}")))?;
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
