//! The files of the continuations in force level at fixed excitation frequencies (`[forced]
//! level_sweeps`, issue 22 item 4; traced by `crate::forced::run`, docs/DESIGN.md §10.5): at
//! each W the response is continued in the load scale s over `level_range` (in `level_unit`)
//! from the linear response, through the folds of the S-curve where the response jumps as the
//! force grows or falls. Outputs: `level_sweeps.csv` (the columns of
//! frf.csv, one curve per frequency), `level_sweeps.png`/`.svg` (first-harmonic amplitude of the
//! master / g0 against the level; stable solid, unstable dashed, undetermined dotted).

use std::path::Path;

use anyhow::Result;
use nlmodes_forced::Verdict;
use nlmodes_output::plot::{LinePlot, LineStyle, Series, PALETTE};

use crate::forced::forced_output::verdict_counts;
use crate::forced::forced_settings::{ForcedSection, LevelUnit};
use crate::forced::{sweep_frequency, ForcedStudy};

fn unit_label(s: &ForcedSection) -> String {
    match s.level_unit {
        LevelUnit::Newton => format!("load ({})", s.load.unit()),
        LevelUnit::Grazing => "load / grazing load".into(),
    }
}

/// Writes level_sweeps.csv and the figure when the study has sweeps.
pub fn write(st: &ForcedStudy, dir: &Path) -> Result<()> {
    if st.level_sweeps.is_empty() {
        return Ok(());
    }
    let mut table = crate::forced::forced_output::csv_table(st);
    for c in &st.level_sweeps {
        crate::forced::forced_output::push_curve(&mut table, st, c)?;
    }
    table.write(&dir.join("level_sweeps.csv"))?;
    figure(st, dir)
}

/// First-harmonic master amplitude / g0 against the level, per frequency, styled by verdict.
fn figure(st: &ForcedStudy, dir: &Path) -> Result<()> {
    let mut plot = LinePlot::new(
        "Response to a growing force at fixed frequencies",
        unit_label(&st.settings),
        "first harmonic of the master / g0",
    );
    for (k, c) in st.level_sweeps.iter().enumerate() {
        let color = PALETTE[k % PALETTE.len()];
        let mut labelled = false;
        for (v, idx) in crate::forced::forced_output::verdict_runs(c) {
            let style = match v {
                Some(Verdict::Unstable) => LineStyle::Dashed,
                Some(Verdict::Undetermined) => LineStyle::Dotted,
                _ => LineStyle::Solid,
            };
            let points = &c.response.points;
            let x: Vec<f64> = idx.iter().map(|&i| points[i].level).collect();
            let y: Vec<f64> = idx
                .iter()
                .map(|&i| {
                    crate::forced::forced_output::master_amplitude(&points[i], st.master)
                        / st.gap_reference
                })
                .collect();
            let label = if labelled {
                String::new()
            } else {
                format!("W/w = {:.4}", sweep_frequency(c) / st.omega_mode)
            };
            labelled = true;
            plot = plot.with_series(Series::new(label, x, y).color(color).style(style));
        }
    }
    plot.write_svg_and_png(&dir.join("level_sweeps"))?;
    Ok(())
}

/// The summary lines of the sweeps (after the frequency curves').
pub fn summary(st: &ForcedStudy) -> String {
    let mut out = String::new();
    for c in &st.level_sweeps {
        let r = &c.response;
        let folds: Vec<String> = r
            .folds
            .iter()
            .map(|f| format!("{:.4} ({:?})", f.at, f.kind))
            .collect();
        let [stable, unstable, undetermined] = verdict_counts(r);
        out += &format!(
            "  level sweep at W/w = {:.4}: {} points, folds at level {}, {} stable / {} unstable / {} undetermined, {}\n",
            sweep_frequency(c) / st.omega_mode,
            r.points.len(),
            if folds.is_empty() { "none".to_string() } else { folds.join(", ") },
            stable,
            unstable,
            undetermined,
            r.end_text()
        );
    }
    out
}

/// The report's subsection on the sweeps (empty without them).
pub fn report_section(st: &ForcedStudy) -> String {
    if st.level_sweeps.is_empty() {
        return String::new();
    }
    let [a, b] = st.settings.level_range;
    let mut s = format!(
        "### Response to a growing force\n\nAt fixed W the response is continued in force level \
         from {a} to {b} ({}), through the folds where it jumps as the force grows (the fold \
         turning back) or falls (the fold turning forward). Data: `forced/level_sweeps.csv`.\n\n\
         | W / w | points | folds (level, kind) | stable / unstable / undetermined | end |\n\
         |---|---|---|---|---|\n",
        unit_label(&st.settings)
    );
    for c in &st.level_sweeps {
        let r = &c.response;
        let folds: Vec<String> = r
            .folds
            .iter()
            .map(|f| format!("{:.4} {:?}", f.at, f.kind))
            .collect();
        let [stable, unstable, undetermined] = verdict_counts(r);
        s += &format!(
            "| {:.4} | {} | {} | {} / {} / {} | {} |\n",
            sweep_frequency(c) / st.omega_mode,
            r.points.len(),
            if folds.is_empty() {
                "none".into()
            } else {
                folds.join(", ")
            },
            stable,
            unstable,
            undetermined,
            r.end_text().replace('|', "/")
        );
    }
    s + "\n![level sweeps](forced/level_sweeps.png)\n"
}
