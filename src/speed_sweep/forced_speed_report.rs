//! The speed sweeps for a reader (issue 39, items 2 and 4): the report's section, the terminal
//! lines, the exit status of sweeps that did not cover their window, and the forced verdict of
//! the interaction map (per engine-order crossing: the peak, the largest contact force, the
//! speeds with contact, the stability; "not swept" where no sweep went through it). Files:
//! `forced_speed_output`; figure: `forced_speed_figure`.

use std::fmt::Write as _;
use std::path::Path;

use anyhow::Result;

use crate::case::Case;
use crate::forced::forced_settings::LevelUnit;
use crate::layout::Layout;
use crate::post::results::speed_sweep::{self, CrossingRef, SpeedSweepFile, SweepRecord};
use crate::rotation::rotation_settings::RPM_TO_RAD_S;
use crate::speed_sweep::forced_speed::{SpeedSweepStudy, CLOSURE_SHARE};
use crate::speed_sweep::forced_speed_output::{summarize, SweepSummary};

fn rpm_list(v: &[[f64; 2]]) -> String {
    if v.is_empty() {
        return "none".into();
    }
    let parts: Vec<String> = v.iter().map(|[a, b]| format!("{a:.0}-{b:.0}")).collect();
    parts.join(", ")
}

fn folds_text(s: &SweepSummary) -> String {
    if s.folds.is_empty() {
        return "none".into();
    }
    let parts: Vec<String> = (s.folds.iter())
        .map(|f| format!("{:.1} ({})", f.speed_rpm, f.kind.replace('_', " ")))
        .collect();
    parts.join(", ")
}

/// The parametric model's error, as a sentence.
fn accuracy_text(st: &SpeedSweepStudy) -> String {
    match &st.accuracy {
        Some(a) => format!(
            "The parametric model's error measured between its sample speeds: frequencies \
             {:.1e} (interpolation alone, lowest {} modes), {} against the full model; running \
             gaps {:.1e} (relative).",
            a.worst_interpolation(),
            a.modes,
            a.worst_full_model()
                .map_or("not measured".into(), |e| format!("{e:.1e}")),
            a.worst_gap()
        ),
        None => "The parametric model carries no measured error.".into(),
    }
}

/// The report's section (`speed_sweep/section.md`).
pub fn section(st: &SpeedSweepStudy) -> String {
    let mut s = String::from("## Speed sweeps through the Campbell crossings\n\n");
    let _ = writeln!(
        s,
        "The forced response of linear mode {} at W = EO x speed, continued in the speed \
         through each crossing of the engine-order lines with the mode's Campbell curve, on \
         the parametric reduced model (K_r(speed) and the running gaps interpolated between \
         the Campbell speeds; the damping and the load of `[forced]`, the force constant in \
         the speed; traced first at `[forced] harmonics` N = {}, each sweep's N and its check \
         at 2N below the table). {} Amplitudes over the running gap at each speed. Data: \
         `speed_sweep/speed_sweep.csv`, `speed_sweep/speed_sweep.json`.\n",
        st.mode,
        st.harmonics,
        accuracy_text(st)
    );
    if let Some(c) = st.closure {
        let _ = writeln!(
            s,
            "The sweeps stop at {:.0} rpm, where the smallest running gap falls to {} % of the \
             cold gap.\n",
            c / RPM_TO_RAD_S,
            100.0 * CLOSURE_SHARE
        );
    }
    let _ = writeln!(
        s,
        "| EO | level | crossing (rpm, Hz) | swept (rpm) | peak q/g0 at rpm | folds (rpm) | \
         touches (rpm) | largest contact force (N) at rpm | stable / unstable / undetermined \
         | end |\n|---|---|---|---|---|---|---|---|---|---|"
    );
    for run in &st.runs {
        let r = summarize(st, run);
        let _ = writeln!(
            s,
            "| {} | {} | {:.1}, {:.2} | {:.0}-{:.0} | {:.3} at {:.1} | {} | {} | {:.3e}{} | {} / \
             {} / {} | {} |",
            r.engine_order,
            match &r.casing {
                Some(c) => format!("{} ({})", r.level, c.label()),
                None => r.level.to_string(),
            },
            r.crossing_rpm,
            r.crossing_hz,
            r.range_rpm[0],
            r.range_rpm[1],
            r.peak_q1_over_g0,
            r.peak_rpm,
            folds_text(&r),
            rpm_list(&r.contact_rpm),
            r.max_contact_force_n,
            r.max_contact_force_rpm
                .map_or(String::new(), |w| format!(" at {w:.1}")),
            r.stability[0],
            r.stability[1],
            r.stability[2],
            r.end.replace('|', "/")
        );
    }
    s.push('\n');
    for run in &st.runs {
        let r = summarize(st, run);
        let _ = writeln!(
            s,
            "- EO {}, level {}: {}.",
            r.engine_order, r.level, r.harmonics_note
        );
    }
    s + "\n![speed sweeps](speed_sweep/speed_sweep.png)\n\nSolid: stable, dashed: unstable, \
         dotted: undetermined (the Floquet analysis of `[forced]`, at each point's speed).\n\n"
}

/// The lines printed after the sweeps.
pub fn summary(st: &SpeedSweepStudy) -> String {
    let mut out = String::new();
    for run in &st.runs {
        let r = summarize(st, run);
        let _ = writeln!(
            out,
            "speed sweep EO {} (crossing {:.1} rpm, {:.2} Hz), level {}{}: peak q/g0 = {:.4} at \
             {:.1} rpm, folds {}, touches {}, largest contact force {:.3e} N, {} stable / {} \
             unstable / {} undetermined, {}; {}",
            r.engine_order,
            r.crossing_rpm,
            r.crossing_hz,
            r.level,
            r.casing
                .as_ref()
                .map_or(String::new(), |c| format!(", {}", c.label())),
            r.peak_q1_over_g0,
            r.peak_rpm,
            folds_text(&r),
            rpm_list(&r.contact_rpm),
            r.max_contact_force_n,
            r.stability[0],
            r.stability[1],
            r.stability[2],
            r.end,
            r.harmonics_note
        );
    }
    out
}

/// Ok when every sweep covered its window; otherwise a `StoppedEarly` error (exit code 3)
/// naming them and where the points are.
pub fn stopped_early(st: &SpeedSweepStudy, dir: &Path) -> Result<()> {
    let stopped: Vec<String> = (st.runs.iter())
        .filter(|r| !r.sweep.termination.covers_range())
        .map(|r| {
            format!(
                "EO {} level {}: {}",
                r.plan.engine_order,
                r.level,
                r.sweep.end_text()
            )
        })
        .collect();
    if stopped.is_empty() {
        return Ok(());
    }
    Err(anyhow::Error::new(crate::exit::StoppedEarly(format!(
        "speed sweeps stopped before the end of their window ({}); the points computed are in {}",
        stopped.join("; "),
        dir.display()
    ))))
}

/// The speed sweeps of the case as written in `speed_sweep/speed_sweep.json`, when the case
/// runs them (`[speed_sweep]`, enabled) and the file exists.
pub fn swept(case: &Case, layout: &Layout) -> anyhow::Result<Option<SpeedSweepFile>> {
    if !case.speed_sweep.as_ref().is_some_and(|s| s.enabled) {
        return Ok(None);
    }
    speed_sweep::read(&layout.shared.join("speed_sweep"))
}

/// A sweep's level as given and its load: "2 x grazing = 5.127e-1 N" or "5.000e-1 N".
pub fn level_text(case: &Case, s: &SweepRecord) -> String {
    let unit = case.forced.load.unit();
    match case.forced.level_unit {
        LevelUnit::Grazing => format!("{} x grazing = {:.3e} {unit}", s.level, s.force),
        _ => format!("{:.3e} {unit}", s.force),
    }
}

/// `v` with `digits` significant digits in plain notation ("206.3", "0.001234", "0").
pub fn significant(v: f64, digits: usize) -> String {
    if v == 0.0 || !v.is_finite() {
        return format!("{v}");
    }
    let magnitude = v.abs().log10().floor() as i64;
    let decimals = (digits as i64 - 1 - magnitude).max(0) as usize;
    format!("{v:.decimals$}")
}

/// The speeds with contact, "7451-7979", or "none".
pub fn contact_text(s: &SweepRecord) -> String {
    s.contact_span()
        .map_or("none".into(), |[a, b]| format!("{a:.0}-{b:.0}"))
}

/// Each sweep's N and its check at 2N ("EO 3 level 2: N = 20 (...)"), or "N not recorded".
fn notes(f: &SpeedSweepFile) -> String {
    let parts: Vec<String> = (f.sweeps.iter())
        .map(|s| {
            format!(
                "EO {} level {}: {}",
                s.engine_order,
                s.level,
                s.harmonics_note.as_deref().unwrap_or("N not recorded")
            )
        })
        .collect();
    parts.join("; ")
}

/// The forced verdict on the interaction map (`campbell/section.md`): one row per crossing of
/// the swept mode with an engine-order line (the Campbell stage's `crossings`) and sweep level;
/// `names` are the diagram's curves' (`crate::post::figures::curve_names`).
pub fn interaction_verdict(
    case: &Case,
    layout: &Layout,
    crossings: &[CrossingRef],
    names: &[String],
) -> anyhow::Result<String> {
    let file = swept(case, layout)?;
    let traced = file.as_ref().map_or(case.forced.mode, |f| f.mode);
    let mode = names
        .get(traced)
        .cloned()
        .unwrap_or_else(|| format!("mode {}", traced + 1));
    let rows = speed_sweep::verdicts(file.as_ref(), crossings, traced);
    let mut s = String::from("### Forced verdict at the engine-order crossings\n\n");
    let how = file.as_ref().map_or(
        "no speed sweep has run (`[speed_sweep]` absent or disabled)".to_string(),
        |f| {
            format!(
                "the speed sweeps of `[speed_sweep]` at W = EO x speed, traced first at N = \
                 {} ({}), amplitudes over the running gap (`speed_sweep/`)",
                f.harmonics,
                notes(f)
            )
        },
    );
    let _ = writeln!(
        s,
        "Each crossing of {mode} with an engine-order line in the Campbell range, and the \
         forced response through it: {how}. \"touches\": the lowest to the highest speed at \
         which the blade touches the casing; the stability of the points in contact where it \
         touches (of all points otherwise), with the folds where a run-up or a run-down \
         jumps. \"not swept\": no sweep went through that crossing.\n"
    );
    let _ = writeln!(
        s,
        "| EO | crossing (rpm) | level | touches (rpm) | peak q/g0 (at rpm, its stability) | \
         largest contact force (N, at rpm: on the exact orbits; the harmonic balance's) | \
         stability |\n|---|---|---|---|---|---|---|"
    );
    for row in &rows {
        let c = &row.crossing;
        if row.sweeps.is_empty() {
            let _ = writeln!(
                s,
                "| {} | {:.0} | not swept | | | | |",
                c.engine_order, c.speed_rpm
            );
        }
        for w in &row.sweeps {
            let _ = writeln!(
                s,
                "| {} | {:.0} | {}{} | {} | {:.3} ({:.0}{}) | {}{}{} | {} |",
                c.engine_order,
                c.speed_rpm,
                level_text(case, w),
                if w.complete {
                    String::new()
                } else {
                    format!(", partial: {}", w.end.replace('|', "/"))
                },
                contact_text(w),
                w.peak_q1_over_g0,
                w.peak_rpm,
                match w.peak_verdict() {
                    "" => String::new(),
                    v => format!(", {v}"),
                },
                exact_force_cell(w.retraces.last()),
                significant(w.max_contact_force_n, 4),
                w.max_contact_force_rpm
                    .map_or(String::new(), |r| format!(" ({r:.0})")),
                w.stability_text()
            );
        }
    }
    Ok(s + "\n")
}

/// The verdict table's exact-orbit force ("96.16 (8136); N = 40: "), before the harmonic
/// balance's: the last trace's `largest_contact_force_exact` where it was shot, else nothing.
fn exact_force_cell(last: Option<&crate::post::results::RetraceHead>) -> String {
    match last.and_then(|t| t.largest_contact_force_exact.map(|f| (t, f))) {
        Some((t, f)) => format!(
            "{}{}; N = {}: ",
            significant(f, 4),
            t.largest_contact_force_exact_rpm
                .map_or(String::new(), |r| format!(" ({r:.0})")),
            t.harmonics
        ),
        None => String::new(),
    }
}
