//! The speed sweeps' figure (`speed_sweep.png/.svg`; issue 39, items 2 and 4): the response
//! amplitude (the master's first harmonic over the running gap) against the speed (rpm), one
//! colour per sweep (engine order and level); stable solid, unstable dashed, undetermined
//! dotted; the stretches in contact under a thick light band of the sweep's colour; the folds
//! (where a run-up or a run-down jumps) as black dots; each crossing's speed as a reference line
//! labelled above the frame. The legend goes below the plot, never over the data. The sweeps:
//! DESIGN §10.10.

use std::path::Path;

use anyhow::Result;
use nlmodes_forced::{SpeedPoint, Verdict};
use nlmodes_output::plot::{Color, LegendPosition, LinePlot, LineStyle, RefLine, Series, PALETTE};

use crate::forced::forced_output::harmonic;
use crate::rotation::rotation_settings::RPM_TO_RAD_S;
use crate::speed_sweep::forced_speed::{SpeedSweepStudy, SweepRun};

const GREY: Color = Color(90, 90, 90);
const FOLD: Color = Color(0, 0, 0);

/// Runs of consecutive points sharing `key` (overlapping by one point, so the runs join).
fn runs_by<K: PartialEq + Copy>(
    run: &SweepRun,
    key: impl Fn(&SpeedPoint) -> K,
) -> Vec<(K, Vec<usize>)> {
    let mut runs: Vec<(K, Vec<usize>)> = Vec::new();
    for (i, p) in run.sweep.points.iter().enumerate() {
        let k = key(p);
        match runs.last_mut() {
            Some((last, idx)) if *last == k => idx.push(i),
            _ => {
                let mut idx = runs
                    .last()
                    .map_or_else(Vec::new, |(_, r)| vec![*r.last().expect("run")]);
                idx.push(i);
                runs.push((k, idx));
            }
        }
    }
    runs
}

/// `c` mixed with white (`t` = 0: `c`, 1: white).
fn lighter(c: Color, t: f64) -> Color {
    let mix = |v: u8| (f64::from(v) + t * (255.0 - f64::from(v))).round() as u8;
    Color(mix(c.0), mix(c.1), mix(c.2))
}

/// The curves of one sweep: the contact band under them, the curve by verdict, the folds.
fn sweep_series(st: &SpeedSweepStudy, run: &SweepRun, color: Color) -> Vec<Series> {
    let pts = &run.sweep.points;
    let amp = |i: usize| harmonic(&pts[i].point, st.master, 1).0 / pts[i].gap_reference;
    let xy = |idx: &[usize]| -> (Vec<f64>, Vec<f64>) {
        idx.iter()
            .map(|&i| (pts[i].speed / RPM_TO_RAD_S, amp(i)))
            .unzip()
    };
    let mut out = Vec::new();
    for (touching, idx) in runs_by(run, |p| p.point.touches()) {
        if touching {
            let (x, y) = xy(&idx);
            out.push(Series::new("", x, y).color(lighter(color, 0.65)).width(7.0));
        }
    }
    for (v, idx) in runs_by(run, |p| p.stability.map(|s| s.verdict)) {
        let style = match v {
            Some(Verdict::Unstable) => LineStyle::Dashed,
            Some(Verdict::Undetermined) => LineStyle::Dotted,
            _ => LineStyle::Solid,
        };
        let (x, y) = xy(&idx);
        out.push(Series::new("", x, y).color(color).style(style));
    }
    let folds: Vec<usize> = run.sweep.folds.iter().map(|f| f.point).collect();
    if !folds.is_empty() {
        let (x, y) = xy(&folds);
        let dots = Series::new("", x, y).style(LineStyle::None).markers(true);
        out.push(dots.color(FOLD));
    }
    out
}

/// Legend-only entries (no data): a sample of each style and mark.
fn key(label: &str, color: Color, style: LineStyle, width: f64, markers: bool) -> Series {
    let s = Series::new(label, Vec::new(), Vec::new()).color(color);
    s.style(style).width(width).markers(markers)
}

/// The plot of `st` (written by [`figure`]).
pub fn plot(st: &SpeedSweepStudy) -> LinePlot {
    let mut plot = LinePlot::new(
        format!(
            "Forced response along the speed at W = EO x speed (mode {})",
            st.mode + 1
        ),
        "speed (rpm)",
        "first harmonic of the master / running gap (q1/g0)",
    )
    .with_size(860.0, 520.0)
    .with_legend(LegendPosition::Below);
    let mut crossings: Vec<(usize, f64)> = Vec::new();
    for (k, run) in st.runs.iter().enumerate() {
        let color = PALETTE[k % PALETTE.len()];
        for s in sweep_series(st, run, color) {
            plot = plot.with_series(s);
        }
        let label = format!(
            "EO {}, level {} ({:.3e}){}",
            run.plan.engine_order,
            run.level,
            run.force,
            run.casing
                .as_ref()
                .map_or(String::new(), |c| format!(", {}", c.label()))
        );
        plot = plot.with_series(key(&label, color, LineStyle::Solid, 2.0, false));
        let c = (run.plan.engine_order, run.plan.crossing / RPM_TO_RAD_S);
        if !crossings.contains(&c) {
            crossings.push(c);
        }
    }
    for (eo, rpm) in crossings {
        plot = plot.with_ref_line(RefLine::vertical(rpm, format!("EO {eo} crossing")));
    }
    for (label, style) in [
        ("stable", LineStyle::Solid),
        ("unstable", LineStyle::Dashed),
        ("undetermined", LineStyle::Dotted),
    ] {
        plot = plot.with_series(key(label, GREY, style, 2.0, false));
    }
    plot.with_series(key(
        "in contact with the casing",
        lighter(GREY, 0.65),
        LineStyle::Solid,
        7.0,
        false,
    ))
    .with_series(key(
        "fold: the response jumps",
        FOLD,
        LineStyle::None,
        2.0,
        true,
    ))
}

/// `speed_sweep.png/.svg` in `dir`.
pub fn figure(st: &SpeedSweepStudy, dir: &Path) -> Result<()> {
    plot(st).write_svg_and_png(&dir.join("speed_sweep"))?;
    Ok(())
}
