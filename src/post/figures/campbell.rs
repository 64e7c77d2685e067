//! The Campbell diagram (`campbell/campbell.png/.svg`; docs/ROTATION.md "Campbell diagram"):
//! the tracked linear modes' frequencies (Hz) against the speed (rpm), each curve named at its
//! end right of the frame (1F, 1T, ... from [`super::mode_names`], or "mode k"), the
//! engine-order lines f = EO rpm / 60 dashed grey with "EO k" at their ends (right of the frame,
//! or above it where the line leaves through the top), the crossings as black dots, the bands of
//! the first nonlinear mode (grazing to the largest traced amplitude) as thick red segments at
//! their speeds, and the operating speed. The legend (crossings, bands) goes below the plot:
//! nothing is written over the data.

use std::path::Path;

use anyhow::Result;
use nlmodes_output::plot::{Color, PALETTE};
use nlmodes_output::{LegendPosition, LinePlot, LineStyle, RefLine, Series};

/// What the diagram shows (speeds in rpm, frequencies in Hz).
pub struct CampbellPicture<'a> {
    pub speeds_rpm: &'a [f64],
    /// Each curve's name and its frequency at each speed.
    pub curves: Vec<(String, &'a [f64])>,
    pub engine_orders: &'a [i64],
    /// (speed, frequency) of each crossing of a curve with an engine-order line.
    pub crossings: Vec<(f64, f64)>,
    /// (speed, lowest, highest frequency) of each band of the first nonlinear mode.
    pub bands: Vec<(f64, f64, f64)>,
    pub operating_rpm: f64,
}

const GREY: Color = Color(150, 150, 150);
const BAND: Color = Color(200, 30, 30);

/// The plot of `p` (written by [`campbell_figure`]).
pub fn campbell_plot(p: &CampbellPicture) -> LinePlot {
    let top = (p.curves.iter())
        .flat_map(|(_, f)| f.iter().copied())
        .chain(p.bands.iter().map(|b| b.2))
        .fold(0.0, f64::max)
        * 1.05;
    let top = if top > 0.0 { top } else { 1.0 };
    let lo = p.speeds_rpm.first().copied().unwrap_or(0.0);
    let hi = p.speeds_rpm.last().copied().unwrap_or(1.0).max(lo + 1.0);
    let mut plot = LinePlot::new("Campbell diagram", "speed (rpm)", "frequency (Hz)")
        .with_size(900.0, 560.0)
        .with_x_range(lo, hi)
        .with_y_range(0.0, top)
        .with_legend(LegendPosition::Below)
        .with_ref_line(RefLine::vertical(p.operating_rpm, "operating speed"));
    for &eo in p.engine_orders {
        let e = eo as f64 / 60.0;
        // The line up to the top of the plot or the end of the range, where its label goes.
        let end = hi.min(top / e);
        plot = plot.with_series(
            Series::new("", vec![lo, end], vec![e * lo, e * end])
                .color(GREY)
                .style(LineStyle::Dashed)
                .width(1.0)
                .end_label(format!("EO {eo}")),
        );
    }
    for (k, (name, f)) in p.curves.iter().enumerate() {
        plot = plot.with_series(
            Series::new("", p.speeds_rpm.to_vec(), f.to_vec())
                .color(PALETTE[k % PALETTE.len()])
                .end_label(name.clone()),
        );
    }
    if !p.crossings.is_empty() {
        let (x, y): (Vec<f64>, Vec<f64>) = p.crossings.iter().copied().unzip();
        plot = plot.with_series(
            Series::new("engine-order crossings", x, y)
                .style(LineStyle::None)
                .markers(true)
                .color(Color(0, 0, 0)),
        );
    }
    for (i, &(rpm, low, high)) in p.bands.iter().enumerate() {
        let label = if i == 0 {
            "band of nonlinear mode 1 (grazing to the largest amplitude traced)"
        } else {
            ""
        };
        plot = plot.with_series(
            Series::new(label, vec![rpm; 2], vec![low, high])
                .color(BAND)
                .width(6.0),
        );
    }
    plot
}

/// The names of the diagram's `count` curves: the modes of the parametric reduced model in
/// `parametric` (`results/<case>/parametric/`) at the first speed `first_rpm` of the diagram,
/// where each curve starts, named from their tip motion ([`super::mode_names`]); "mode k" for
/// all when that model cannot be read (said in the log).
pub fn curve_names(parametric: &Path, first_rpm: f64, count: usize) -> Vec<String> {
    let named = || -> Result<Vec<String>> {
        let model = nlmodes_modal::ParametricModel::read(parametric)?;
        let at = model.at(first_rpm * std::f64::consts::PI / 30.0)?;
        super::mode_names::mode_names(&at, count)
    };
    named().unwrap_or_else(|e| {
        tracing::warn!("Campbell diagram: modes not named ({e:#}): mode 1, mode 2, ...");
        (1..=count).map(|k| format!("mode {k}")).collect()
    })
}

/// Writes `campbell.png` and `campbell.svg` into `dir`.
pub fn campbell_figure(p: &CampbellPicture, dir: &Path) -> Result<()> {
    campbell_plot(p).write_svg_and_png(&dir.join("campbell"))?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Six Southwell curves, eight engine orders, two bands: every engine order and every
    /// mode labelled at its end, the legend outside the area, nothing over the data.
    #[test]
    fn lines_and_modes_are_labelled_outside_the_data() {
        let speeds: Vec<f64> = (0..=10).map(|i| 1000.0 * i as f64).collect();
        let f0 = [263.6, 1200.0, 1450.0, 2100.0, 2600.0, 2900.0];
        let s = [4.57, 18.1, -0.06, 25.2, 18.5, -0.41];
        let curves: Vec<Vec<f64>> = (0..6)
            .map(|k| {
                (speeds.iter())
                    .map(|r| (f0[k] * f0[k] + s[k] * (r / 60.0f64).powi(2)).sqrt())
                    .collect()
            })
            .collect();
        let names = [
            "1F (mode 1)",
            "1E (mode 2)",
            "1T (mode 3)",
            "mode 4",
            "2F (mode 5)",
        ];
        let orders: Vec<i64> = (1..=8).collect();
        let p = CampbellPicture {
            speeds_rpm: &speeds,
            curves: (curves.iter().enumerate())
                .map(|(k, f)| {
                    (
                        names.get(k).map_or("mode 6".into(), |n| n.to_string()),
                        &f[..],
                    )
                })
                .collect(),
            engine_orders: &orders,
            crossings: vec![(7525.0, 376.25)],
            bands: vec![(0.0, 263.6, 480.0), (8000.0, 388.4, 553.7)],
            operating_rpm: 8000.0,
        };
        let plot = campbell_plot(&p);
        let l = plot.layout().expect("layout");
        assert!(l.clashes().is_empty(), "{:?}", l.clashes());
        let labels: Vec<&str> = l.ref_labels.iter().map(|r| r.text.as_str()).collect();
        for want in [
            "EO 1",
            "EO 3",
            "EO 8",
            "1F (mode 1)",
            "mode 6",
            "operating speed",
        ] {
            assert!(labels.contains(&want), "{want} not in {labels:?}");
        }
        let (legend, _) = l.legend.expect("a legend for the crossings and the bands");
        assert!(!legend.overlaps(&l.area));
        let svg = plot.to_svg().unwrap();
        assert!(svg.contains(">EO 3</text>") && svg.contains(">1T (mode 3)</text>"));
    }
}
