//! The speed sweeps for a reader (issue 39, item 2): the figure of the response against the
//! speed, the report's section, the terminal lines, and the exit status of sweeps that did not
//! cover their window. Files: `forced_speed_output`.

use std::fmt::Write as _;
use std::path::Path;

use anyhow::Result;

use crate::forced_speed::{SpeedSweepStudy, CLOSURE_SHARE};
use crate::forced_speed_output::{summarize, SweepSummary};
use crate::rotation_settings::RPM_TO_RAD_S;

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
         the Campbell speeds; the damping, the load and N = {} of `[forced]`, the force \
         constant in the speed). {} Amplitudes over the running gap at each speed. Data: \
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
             unstable / {} undetermined, {}",
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
            r.end
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
