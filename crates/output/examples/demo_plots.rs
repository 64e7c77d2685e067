//! Writes demonstration plots (backbone, radial displacements, contact map) to a directory.
//!
//! `cargo run --release -p nlmodes-output --example demo_plots -- <output dir>`
//! The data are made up (an impact-oscillator-like backbone); they only show the plot styles.

use std::path::PathBuf;

use nlmodes_output::{Colormap, HeatMap, LegendPosition, LinePlot, LineStyle, RefLine, Series};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let dir = PathBuf::from(std::env::args().nth(1).unwrap_or_else(|| ".".to_string()));

    // Backbone: w/w1 = pi / (pi - arccos(g/A)) for a rigid stop (DESIGN 5), flat below grazing.
    let q: Vec<f64> = (0..=60).map(|i| 0.5 * i as f64).collect();
    let w: Vec<f64> = q
        .iter()
        .map(|&a| {
            if a <= 5.0 {
                1.0
            } else {
                let pi = std::f64::consts::PI;
                pi / (pi - (5.0 / a).acos())
            }
        })
        .collect();
    LinePlot::new("First nonlinear mode: backbone", "q / g0", "ω / ω1")
        .with_series(Series::new("harmonic balance", q.clone(), w.clone()).markers(true))
        .with_series(
            Series::new(
                "penalty reference",
                q.clone(),
                w.iter().map(|v| 1.0 + 0.9 * (v - 1.0)).collect::<Vec<_>>(),
            )
            .style(LineStyle::Dashed),
        )
        .with_ref_line(RefLine::vertical(5.0, "grazing"))
        .with_ref_line(RefLine::horizontal(1.0, "linear"))
        .with_legend(LegendPosition::TopLeft)
        .write_svg_and_png(&dir.join("demo_backbone"))?;

    // Radial displacements of 24 edge nodes over one period, contact at 1.
    let n = 24;
    let m = 200;
    let t: Vec<f64> = (0..=m).map(|k| k as f64 / m as f64).collect();
    let mut plot = LinePlot::new(
        "Radial displacement of the tip-edge nodes, q = 9.3",
        "t / T",
        "u_r / g0",
    )
    .with_ref_line(RefLine::horizontal(1.0, "contact at 1"))
    .with_legend(LegendPosition::Hidden);
    for j in 0..n {
        let amp = 0.4 + 0.8 * j as f64 / (n - 1) as f64;
        let y: Vec<f64> = t
            .iter()
            .map(|&t| (amp * (2.0 * std::f64::consts::PI * t).cos()).min(1.0))
            .collect();
        plot = plot.with_series(Series::new(format!("node {}", j + 1), t.clone(), y).width(1.4));
    }
    plot.write_svg_and_png(&dir.join("demo_radial"))?;

    // Contact map.
    let cols = 256;
    let mut values = vec![0.0; n * cols];
    for r in 0..n {
        for c in 0..cols {
            let tt = c as f64 / cols as f64;
            let first = r < 5 && (tt - 0.5).abs() < 0.07;
            let last = r + 4 >= n && (tt.min(1.0 - tt)) < 0.075;
            if first || last {
                values[r * cols + c] = 10.0 * (1.0 + r as f64 / n as f64);
            }
        }
    }
    HeatMap::new(
        "Contact map, q = 31.3",
        "t / T",
        "contact node (leading to trailing edge)",
        "contact force (N)",
        n,
        cols,
        values,
    )
    .with_x_extent(0.0, 1.0)
    .with_y_extent(0.5, n as f64 + 0.5)
    .with_colormap(Colormap::GrayRed)
    .write_svg_and_png(&dir.join("demo_contact_map"))?;
    println!("wrote demo plots to {}", dir.display());
    Ok(())
}
