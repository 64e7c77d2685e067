//! The figures of the post stage (SVG + PNG), after the paper's Figs. 3a, 3b and 4. The backbone
//! figures (Fig. 3a, its diagnostics, the frequency-energy plot) are in [`backbone`]; the
//! Campbell diagram in [`campbell`], its modes named by [`mode_names`].

use anyhow::Result;
use nlmodes_output::plot::{Colormap, PALETTE};
use nlmodes_output::{HeatMap, LegendPosition, LinePlot, LineStyle, RefLine, Series};
use std::path::Path;

use crate::post::results::{BackboneFile, Orbit};
use backbone::{branches_of, parent_point};
use nlmodes_nnm::BoundaryBackbone;

mod backbone;
mod campbell;
mod mode_names;

pub use campbell::{campbell_figure, curve_names, CampbellPicture};

/// One closed orbit of Fig. 3b: q / g0 and (master displacement, master velocity, contact-node
/// radial displacement) samples, all normalized.
pub type ManifoldOrbit = (f64, Vec<(f64, f64, f64)>);

/// Fig. 3a as the paper draws it (`backbone.png/.svg`) and its diagnostics
/// (`backbone_diagnostics.png/.svg`): tongues, the exact backbone of the massless contact
/// boundary (when given) and its holes' edges, converged orbits, stability changes, jumps.
pub fn backbone_figure(
    b: &BackboneFile,
    exact: Option<&BoundaryBackbone>,
    out: &Path,
) -> Result<()> {
    backbone::backbone_plot(b).write_svg_and_png(&out.join("backbone"))?;
    backbone::diagnostics_plot(b, exact).write_svg_and_png(&out.join("backbone_diagnostics"))?;
    Ok(())
}

/// The frequency-energy plot (`frequency_energy.png/.svg`), when any point has energy.
pub fn frequency_energy_figure(b: &BackboneFile, out: &Path) -> Result<()> {
    if let Some(plot) = backbone::frequency_energy_plot(b) {
        plot.write_svg_and_png(&out.join("frequency_energy"))?;
    }
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
    .with_legend(LegendPosition::Auto);
    let mut vel = LinePlot::new(
        "Manifold of the first nonlinear mode (velocity)",
        "master velocity / (w1 g0)",
        ylabel,
    )
    .with_legend(LegendPosition::Auto);
    // Colour by amplitude, smallest dark blue to largest yellow: each colour once, in order.
    let mut order: Vec<usize> = (0..orbits.len()).collect();
    order.sort_by(|&a, &b| orbits[a].0.total_cmp(&orbits[b].0));
    let shade = |i: usize| {
        let rank = order.iter().position(|&k| k == i).unwrap_or(0);
        Colormap::Viridis.at(rank as f64 / orbits.len().saturating_sub(1).max(1) as f64 * 0.9)
    };
    for &i in &order {
        let (q, c) = &orbits[i];
        let color = shade(i);
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
        // Node 1 (leading edge) dark purple to the last (trailing edge) yellow (viridis).
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
    .with_legend(LegendPosition::Auto);
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

#[cfg(test)]
mod tests;
