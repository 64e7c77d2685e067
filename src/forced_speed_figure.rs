//! The speed sweeps' figure: the response amplitude against the speed for each engine order
//! (stable solid, unstable dashed, undetermined dotted).

use std::path::Path;

use anyhow::Result;
use nlmodes_forced::{SpeedPoint, Verdict};
use nlmodes_output::plot::{LegendPosition, LinePlot, LineStyle, Series, PALETTE};

use crate::forced_output::harmonic;
use crate::forced_speed::{SpeedSweepStudy, SweepRun};
use crate::rotation_settings::RPM_TO_RAD_S;

/// Runs of consecutive points with the same verdict (overlapping by one point).
fn verdict_runs(run: &SweepRun) -> Vec<(Option<Verdict>, Vec<usize>)> {
    let mut runs: Vec<(Option<Verdict>, Vec<usize>)> = Vec::new();
    for (i, p) in run.sweep.points.iter().enumerate() {
        let v = p.stability.map(|s| s.verdict);
        match runs.last_mut() {
            Some((last, idx)) if *last == v => idx.push(i),
            _ => {
                let mut idx = runs
                    .last()
                    .map_or_else(Vec::new, |(_, r)| vec![*r.last().expect("run")]);
                idx.push(i);
                runs.push((v, idx));
            }
        }
    }
    runs
}

/// `speed_sweep.png/.svg`: the master's first harmonic over the running gap against the speed
/// (rpm), one colour per sweep; stable solid, unstable dashed, undetermined dotted.
pub fn figure(st: &SpeedSweepStudy, dir: &Path) -> Result<()> {
    let mut plot = LinePlot::new(
        "Forced response along the speed (W = EO x speed)",
        "speed (rpm)",
        "first harmonic of the master / running gap",
    );
    let amp = |p: &SpeedPoint| harmonic(&p.point, st.master, 1).0 / p.gap_reference;
    for (k, run) in st.runs.iter().enumerate() {
        let color = PALETTE[k % PALETTE.len()];
        let mut label = format!(
            "EO {}, level {} ({:.3e}){}",
            run.plan.engine_order,
            run.level,
            run.force,
            run.casing
                .as_ref()
                .map_or(String::new(), |c| format!(", {}", c.label()))
        );
        for (v, idx) in verdict_runs(run) {
            let style = match v {
                Some(Verdict::Unstable) => LineStyle::Dashed,
                Some(Verdict::Undetermined) => LineStyle::Dotted,
                _ => LineStyle::Solid,
            };
            let pts = &run.sweep.points;
            let x: Vec<f64> = idx.iter().map(|&i| pts[i].speed / RPM_TO_RAD_S).collect();
            let y: Vec<f64> = idx.iter().map(|&i| amp(&pts[i])).collect();
            let series = Series::new(std::mem::take(&mut label), x, y);
            plot = plot.with_series(series.color(color).style(style));
        }
    }
    plot.with_legend(LegendPosition::TopLeft)
        .write_svg_and_png(&dir.join("speed_sweep"))?;
    Ok(())
}
