//! The casing distortion at the operating speed (issue 39, item 6; `[speed_sweep.casing]`;
//! docs/ROTATION.md "Casing distortion at the operating speed"): the blade at one speed on the
//! parametric model, no aerodynamic load, an n-lobed casing whose intrusion delta grows over a
//! grid (`nlmodes_forced::casing_sweep`): does the casing's distortion make the blade rub, how
//! hard, stable or not. W is the lobe-passing frequency n Omega; every contact row sees the
//! gap g0_j(Omega) - delta cos(n Omega t + phase). Writes `casing.csv`, `casing.json` and
//! `casing.png/.svg` beside the speed sweeps. Units: m, N, rpm, Hz; amplitudes also over the
//! mean running gap g0 at the speed.

use std::path::Path;

use anyhow::{Context, Result};
use faer::Mat;
use nlmodes_forced::{
    casing_sweep, CasingPoint, CasingSweep, CasingSweepSettings, ForcedSettings, Verdict,
};
use nlmodes_modal::ParametricModel;
use nlmodes_output::plot::{Color, LegendPosition, LinePlot, LineStyle, RefLine, Series};
use nlmodes_output::{CsvTable, CsvValue};
use serde::{Deserialize, Serialize};

use crate::forced::forced_output::{
    contact_summary, harmonic, max_abs_over_period, opt, verdict_word,
};
use crate::forced::forced_settings::ForcedSection;
use crate::rotation::rotation_settings::RPM_TO_RAD_S;
use crate::speed_sweep::speed_sweep_settings::{CasingHarmonics, CasingSection};

const TAU: f64 = std::f64::consts::TAU;

/// The study's result.
pub struct CasingStudy {
    pub lobes: usize,
    /// Omega and W = n Omega (rad/s); the swept mode's frequency at Omega (rad/s).
    pub speed: f64,
    pub omega: f64,
    pub mode_frequency: f64,
    pub mode: usize,
    /// The mean, smallest and largest running gap at the speed (m).
    pub gap_reference: f64,
    pub smallest_gap: f64,
    pub largest_gap: f64,
    pub master: usize,
    pub contacts: usize,
    pub phase: f64,
    /// `[forced] harmonic_tolerance`.
    pub tolerance: f64,
    /// Whether N was refined point by point (`adapt_harmonics = "refine"`).
    pub refined: bool,
    pub sweep: CasingSweep,
}

/// What the sweep shares with the speed sweeps of the stage: the parametric model read from
/// `dir`, `[forced]`, its solver settings (N, the penalty law of the reference speed) and its
/// damping matrix.
pub struct CasingInputs<'a> {
    pub model: &'a ParametricModel,
    pub dir: &'a Path,
    pub forced: &'a ForcedSection,
    pub solver: &'a ForcedSettings,
    pub damping_matrix: Option<&'a Mat<f64>>,
}

/// Runs `[speed_sweep.casing]` at its speed (`operating_rpm` by default).
pub fn run(
    inputs: &CasingInputs<'_>,
    c: &CasingSection,
    operating_rpm: f64,
) -> Result<CasingStudy> {
    let rpm = c.speed.unwrap_or(operating_rpm);
    let reduced = crate::speed_sweep::forced_speed::model_at_speed(
        inputs.model,
        inputs.dir,
        rpm,
        "speed_sweep.casing.speed",
    )?;
    let system = crate::backbone::system_of(&reduced, None)?;
    let damping = (inputs.forced)
        .damping(inputs.damping_matrix.cloned())
        .matrix(&system)?;
    let gaps = system.gaps();
    let smallest = gaps.iter().copied().fold(f64::INFINITY, f64::min);
    let largest = gaps.iter().copied().fold(0.0, f64::max);
    let g0 = system.gap_reference();
    let lobes = c.lobes.max(1) as usize;
    let speed = rpm * RPM_TO_RAD_S;
    let mut settings = CasingSweepSettings::new(
        lobes as f64 * speed,
        c.grid(g0, smallest),
        inputs.solver.clone(),
    );
    settings.phase = c.phase;
    settings.stability = inputs.forced.stability;
    settings.harmonic_policy = c.adapt_harmonics.policy();
    settings.max_harmonics = inputs.forced.top_harmonics();
    settings.harmonic_tolerance = inputs.forced.harmonic_tolerance;
    let bar = crate::ui::bar(settings.amplitudes.len() as u64, "casing distortion");
    let sweep = casing_sweep(&system, &damping, &settings, |p| {
        bar.set_message(format!("delta {:.3} g0", p.amplitude / g0));
        bar.inc(1);
    })
    .context("the casing distortion sweep of [speed_sweep.casing]")?;
    bar.finish_and_clear();
    Ok(CasingStudy {
        lobes,
        speed,
        omega: settings.omega,
        mode_frequency: system.linear_frequencies()[inputs.forced.mode],
        mode: inputs.forced.mode,
        gap_reference: g0,
        smallest_gap: smallest,
        largest_gap: largest,
        master: system.master(),
        contacts: system.n_contacts(),
        phase: c.phase,
        tolerance: inputs.forced.harmonic_tolerance,
        refined: c.adapt_harmonics == CasingHarmonics::Refine,
        sweep,
    })
}

/// Runs `[speed_sweep.casing]` of `sweep` when enabled, at its speed (`operating_rpm` by
/// default), writes its files into `out` and prints its answer: the one path of the stage
/// (`forced_speed_stage`) and of `nlmodes forced --speed-sweep`.
pub fn run_enabled(
    sweep: &crate::speed_sweep::speed_sweep_settings::SpeedSweepSection,
    inputs: &CasingInputs<'_>,
    operating_rpm: f64,
    out: &Path,
) -> Result<Option<CasingStudy>> {
    let Some(c) = sweep.casing.as_ref().filter(|c| c.enabled) else {
        return Ok(None);
    };
    let study = run(inputs, c, operating_rpm)?;
    write(&study, out)?;
    let answer = sentence(&summarize(&study)).replace("**", "");
    crate::ui::say(&format!("casing distortion, {answer}"));
    Ok(Some(study))
}

/// What `casing.json` says (and the report reads back, `crate::post::results::speed_sweep`).
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct CasingSummary {
    pub lobes: usize,
    pub speed_rpm: f64,
    /// W = n Omega (Hz), the swept mode's frequency at the speed (Hz) and W over it.
    pub lobe_passing_hz: f64,
    pub mode: usize,
    pub mode_frequency_hz: f64,
    pub detuning: f64,
    /// The mean (g0), smallest and largest running gap at the speed (m).
    pub mean_running_gap_m: f64,
    pub smallest_running_gap_m: f64,
    pub largest_running_gap_m: f64,
    /// delta at which the casing first reaches the blade (the smallest running gap, m, and
    /// over g0); `None` when the amplitudes stay below it.
    pub onset_m: Option<f64>,
    pub onset_over_g0: Option<f64>,
    pub phase_rad: f64,
    /// The largest amplitude reached (m, over g0) and the response there.
    pub largest_amplitude_m: f64,
    pub largest_amplitude_over_g0: f64,
    pub q1_over_g0_at_largest: f64,
    pub master_max_over_g0_at_largest: f64,
    pub nodes_in_contact_at_largest: usize,
    pub max_contact_force_n_at_largest: f64,
    /// The largest contact force over the sweep (N).
    pub max_contact_force_n: f64,
    /// The same two on the exact orbits (each point in contact shot on its settled massless
    /// boundary for its stability: no truncation in N; `nlmodes_forced::ExactForce`); `null`
    /// where not shot.
    #[serde(default)]
    pub max_contact_force_exact_n_at_largest: Option<f64>,
    #[serde(default)]
    pub max_contact_force_exact_n: Option<f64>,
    /// Points stable, unstable, undetermined: all, and those in contact.
    pub stability: [usize; 3],
    pub contact_stability: [usize; 3],
    /// The largest multiplier modulus over the points in contact with a verdict and the
    /// amplitudes (m) between which points in contact are unstable (lowest, highest); the
    /// changes of stability in delta order (amplitude m, kind).
    #[serde(default)]
    pub largest_multiplier_in_contact: Option<f64>,
    #[serde(default)]
    pub unstable_span_m: Option<[f64; 2]>,
    #[serde(default)]
    pub stability_changes: Vec<(f64, String)>,
    /// Verdicts of the massless boundary checked by RK4 (every `verify_every`-th point in
    /// contact, docs/STABILITY.md Sec. 9.5) and the largest change it found (|mu|, and the
    /// periodicity of the shot orbit).
    #[serde(default)]
    pub rk4_checked: usize,
    #[serde(default)]
    pub rk4_largest_change: Option<f64>,
    /// Amplitudes (m) where the response jumps (a fold in delta).
    pub jumps_m: Vec<f64>,
    /// N of the trace, the N of every trace, whether it was checked at 2N, the points whose
    /// check moved them by more than `[forced] harmonic_tolerance` (or failed), and the largest
    /// change ([q1, largest contact force], relative) at the points' last doubling.
    pub harmonics: usize,
    pub traced: Vec<usize>,
    pub checked: bool,
    pub not_converged: usize,
    pub largest_change: [f64; 2],
    /// Under `adapt_harmonics = "refine"`: [N, points in contact carrying it, of them
    /// converged] for every N carried, ascending.
    #[serde(default)]
    pub harmonics_in_contact: Vec<[usize; 3]>,
    /// Checked points whose largest contact force moved by more than the tolerance at their
    /// last doubling (not converged on: `CasingPoint::force_converged`).
    #[serde(default)]
    pub force_not_converged: usize,
    #[serde(default)]
    pub refined: bool,
    pub complete: bool,
    pub end: String,
}

/// The summary of `st`.
pub fn summarize(st: &CasingStudy) -> CasingSummary {
    let pts = &st.sweep.points;
    let g0 = st.gap_reference;
    let last = pts.last().expect("a sweep has points");
    let (_, nodes, force) = contact_summary(&last.point, st.contacts);
    let largest = pts
        .iter()
        .map(|p| contact_summary(&p.point, st.contacts).2)
        .fold(0.0, f64::max);
    let count = |v: Verdict, contact_only: bool| {
        (pts.iter())
            .filter(|p| !contact_only || p.point.touches())
            .filter(|p| p.stability.is_some_and(|s| s.verdict == v))
            .count()
    };
    let verdicts = [Verdict::Stable, Verdict::Unstable, Verdict::Undetermined];
    let judged = (pts.iter())
        .filter(|p| p.point.touches())
        .filter_map(|p| p.stability.map(|s| (p.amplitude, s)))
        .filter(|(_, s)| s.verdict != Verdict::Undetermined);
    let largest_multiplier = judged
        .clone()
        .filter_map(|(_, s)| s.largest_multiplier)
        .reduce(f64::max);
    let unstable: Vec<f64> = (judged.filter(|(_, s)| s.verdict == Verdict::Unstable))
        .map(|(a, _)| a)
        .collect();
    let rk4: Vec<f64> = pts
        .iter()
        .filter_map(|p| p.stability.and_then(|s| s.rk4_change))
        .collect();
    let onset = (last.amplitude >= st.smallest_gap).then_some(st.smallest_gap);
    let change = pts
        .iter()
        .filter_map(|p| p.harmonic_change)
        .fold([0.0_f64; 2], |m, c| [m[0].max(c[0]), m[1].max(c[1])]);
    CasingSummary {
        lobes: st.lobes,
        speed_rpm: st.speed / RPM_TO_RAD_S,
        lobe_passing_hz: st.omega / TAU,
        mode: st.mode,
        mode_frequency_hz: st.mode_frequency / TAU,
        detuning: st.omega / st.mode_frequency,
        mean_running_gap_m: g0,
        smallest_running_gap_m: st.smallest_gap,
        largest_running_gap_m: st.largest_gap,
        onset_m: onset,
        onset_over_g0: onset.map(|v| v / g0),
        phase_rad: st.phase,
        largest_amplitude_m: last.amplitude,
        largest_amplitude_over_g0: last.amplitude / g0,
        q1_over_g0_at_largest: harmonic(&last.point, st.master, 1).0 / g0,
        master_max_over_g0_at_largest: max_abs_over_period(&last.point, st.master) / g0,
        nodes_in_contact_at_largest: nodes,
        max_contact_force_n_at_largest: force,
        max_contact_force_n: largest,
        max_contact_force_exact_n_at_largest: last.exact_force.map(|e| e.force),
        max_contact_force_exact_n: (pts.iter())
            .filter_map(|p| p.exact_force.map(|e| e.force))
            .reduce(f64::max),
        stability: verdicts.map(|v| count(v, false)),
        contact_stability: verdicts.map(|v| count(v, true)),
        largest_multiplier_in_contact: largest_multiplier,
        unstable_span_m: unstable.first().zip(unstable.last()).map(|(a, b)| [*a, *b]),
        stability_changes: (pts.iter())
            .filter_map(|p| {
                let b = p.stability?.bifurcation?;
                Some((p.amplitude, format!("{b:?}")))
            })
            .collect(),
        rk4_checked: rk4.len(),
        rk4_largest_change: rk4.iter().copied().reduce(f64::max),
        jumps_m: pts.iter().filter(|p| p.jump).map(|p| p.amplitude).collect(),
        harmonics: st.sweep.harmonics,
        traced: st.sweep.traced.clone(),
        checked: st.sweep.checked,
        not_converged: st.sweep.not_converged(st.tolerance),
        largest_change: change,
        harmonics_in_contact: harmonics_in_contact(st),
        force_not_converged: (pts.iter())
            .filter(|p| !p.force_converged(st.tolerance))
            .count(),
        refined: st.refined,
        complete: st.sweep.stopped.is_none(),
        end: st
            .sweep
            .stopped
            .as_ref()
            .map_or("complete".into(), |(a, why)| {
                format!("stopped at delta = {a:.4e} m: {why}")
            }),
    }
}

/// [N, points in contact at N, of them converged] for every N the points in contact carry.
fn harmonics_in_contact(st: &CasingStudy) -> Vec<[usize; 3]> {
    let mut out: Vec<[usize; 3]> = Vec::new();
    for p in st.sweep.points.iter().filter(|p| p.point.touches()) {
        let ok = usize::from(p.converged(st.tolerance));
        match out.iter_mut().find(|e| e[0] == p.point.harmonics) {
            Some(e) => {
                e[1] += 1;
                e[2] += ok;
            }
            None => out.push([p.point.harmonics, 1, ok]),
        }
    }
    out.sort_unstable();
    out
}

const HEADER: [&str; 21] = [
    "point",
    "lobes",
    "speed_rpm",
    "lobe_passing_hz",
    "amplitude_m",
    "amplitude_over_g0",
    "q1_m",
    "q1_over_g0",
    "master_max_over_g0",
    "contact_fraction",
    "nodes_in_contact",
    "max_contact_force_N",
    "stability",
    "largest_multiplier",
    "boundary_shift",
    "rk4_change",
    "jump",
    "harmonics",
    "harmonic_change_q1",
    "harmonic_change_force",
    "max_contact_force_exact_N",
];

/// `casing.csv`: one row per amplitude.
pub fn csv(st: &CasingStudy) -> Result<CsvTable> {
    let mut table = CsvTable::new(&HEADER);
    let g0 = st.gap_reference;
    for (i, p) in st.sweep.points.iter().enumerate() {
        let (share, nodes, force) = contact_summary(&p.point, st.contacts);
        let q1 = harmonic(&p.point, st.master, 1).0;
        table.push_row(vec![
            CsvValue::from(i),
            st.lobes.into(),
            (st.speed / RPM_TO_RAD_S).into(),
            (st.omega / TAU).into(),
            p.amplitude.into(),
            (p.amplitude / g0).into(),
            q1.into(),
            (q1 / g0).into(),
            (max_abs_over_period(&p.point, st.master) / g0).into(),
            share.into(),
            nodes.into(),
            force.into(),
            verdict_word(p.stability.as_ref()).into(),
            opt(p.stability.and_then(|s| s.largest_multiplier)),
            opt(p.stability.and_then(|s| s.boundary_shift)),
            opt(p.stability.and_then(|s| s.rk4_change)),
            usize::from(p.jump).into(),
            p.point.harmonics.into(),
            opt(p.harmonic_change.map(|c| c[0])),
            opt(p.harmonic_change.map(|c| c[1])),
            opt(p.exact_force.map(|e| e.force)),
        ])?;
    }
    Ok(table)
}

/// Writes `casing.csv`, `casing.json` and `casing.png/.svg` into `dir`.
pub fn write(st: &CasingStudy, dir: &Path) -> Result<()> {
    std::fs::create_dir_all(dir).with_context(|| format!("cannot create {}", dir.display()))?;
    csv(st)?.write(&dir.join("casing.csv"))?;
    nlmodes_output::write_json(&dir.join("casing.json"), &summarize(st))?;
    plot(st).write_svg_and_png(&dir.join("casing"))?;
    Ok(())
}

/// The figure: the largest contact force (N) against delta / g0, stable solid, unstable
/// dashed, undetermined dotted; the onset (the smallest running gap) a reference line; the
/// jumps as black dots; the legend below the plot.
fn plot(st: &CasingStudy) -> LinePlot {
    let g0 = st.gap_reference;
    let pts = &st.sweep.points;
    let xy = |idx: &[usize]| -> (Vec<f64>, Vec<f64>) {
        (idx.iter())
            .map(|&i| {
                let p = &pts[i];
                (p.amplitude / g0, contact_summary(&p.point, st.contacts).2)
            })
            .unzip()
    };
    let blue = Color(31, 119, 180);
    let mut plot = LinePlot::new(
        format!(
            "Casing with {} lobes at {:.0} rpm (W = {} x speed = {:.1} Hz, no load)",
            st.lobes,
            st.speed / RPM_TO_RAD_S,
            st.lobes,
            st.omega / TAU
        ),
        "casing intrusion delta / mean running gap",
        "largest contact force (N)",
    )
    .with_size(860.0, 520.0)
    .with_legend(LegendPosition::Below);
    for (v, idx) in verdict_runs(pts) {
        let style = match v {
            Some(Verdict::Unstable) => LineStyle::Dashed,
            Some(Verdict::Undetermined) => LineStyle::Dotted,
            _ => LineStyle::Solid,
        };
        let (x, y) = xy(&idx);
        plot = plot.with_series(Series::new("", x, y).color(blue).style(style));
    }
    let jumps: Vec<usize> = (0..pts.len()).filter(|&i| pts[i].jump).collect();
    if !jumps.is_empty() {
        let (x, y) = xy(&jumps);
        let dots = Series::new("the response jumps", x, y).style(LineStyle::None);
        plot = plot.with_series(dots.markers(true).color(Color(0, 0, 0)));
    }
    plot = plot.with_ref_line(RefLine::vertical(
        st.smallest_gap / g0,
        "smallest running gap".to_string(),
    ));
    for (label, style) in [
        ("stable", LineStyle::Solid),
        ("unstable", LineStyle::Dashed),
        ("undetermined", LineStyle::Dotted),
    ] {
        let key = Series::new(label, Vec::new(), Vec::new()).color(blue);
        plot = plot.with_series(key.style(style));
    }
    plot
}

/// Runs of consecutive points sharing a verdict, overlapping by one point.
fn verdict_runs(pts: &[CasingPoint]) -> Vec<(Option<Verdict>, Vec<usize>)> {
    let mut runs: Vec<(Option<Verdict>, Vec<usize>)> = Vec::new();
    for (i, p) in pts.iter().enumerate() {
        let v = p.stability.map(|s| s.verdict);
        match runs.last_mut() {
            Some((last, idx)) if *last == v => idx.push(i),
            _ => {
                let mut idx = runs
                    .last()
                    .map_or_else(Vec::new, |(_, r)| vec![r[r.len() - 1]]);
                idx.push(i);
                runs.push((v, idx));
            }
        }
    }
    runs
}

/// The answer in one sentence (the report's summary and the terminal).
pub fn sentence(s: &CasingSummary) -> String {
    let head = format!(
        "{} lobes at {:.0} rpm (W = {:.1} Hz, {:.2} x mode {}'s {:.1} Hz; no aerodynamic load; \
         running gaps {:.3}-{:.3} mm)",
        s.lobes,
        s.speed_rpm,
        s.lobe_passing_hz,
        s.detuning,
        s.mode + 1,
        s.mode_frequency_hz,
        1e3 * s.smallest_running_gap_m,
        1e3 * s.largest_running_gap_m
    );
    let rub = match s.onset_m {
        None => format!(
            "no rub up to delta = {:.3} mm (below the smallest running gap)",
            1e3 * s.largest_amplitude_m
        ),
        Some(onset) => format!(
            "**rubs once delta exceeds {:.3} mm** ({:.2} g0, the smallest running gap); at \
             delta = {:.3} mm ({:.2} g0) {} contact nodes touch, the largest contact force is \
             {} N{} and the master's first harmonic q1/g0 = {:.3}",
            1e3 * onset,
            s.onset_over_g0.unwrap_or(0.0),
            1e3 * s.largest_amplitude_m,
            s.largest_amplitude_over_g0,
            s.nodes_in_contact_at_largest,
            crate::speed_sweep::forced_speed_report::significant(
                s.max_contact_force_n_at_largest,
                3
            ),
            s.max_contact_force_exact_n_at_largest
                .map_or(String::new(), |f| format!(
                    " ({} N on its exact orbit: massless boundary, no truncation in N)",
                    crate::speed_sweep::forced_speed_report::significant(f, 3)
                )),
            s.q1_over_g0_at_largest
        ),
    };
    let stability = stability_words(s);
    let jumps = if s.jumps_m.is_empty() {
        String::new()
    } else {
        let mm: Vec<String> = s
            .jumps_m
            .iter()
            .map(|j| format!("{:.4}", 1e3 * j))
            .collect();
        format!("; the response jumps at delta = {} mm", mm.join(", "))
    };
    let n = harmonics_words(s);
    let end = if s.complete {
        String::new()
    } else {
        format!("; {}", s.end)
    };
    format!("{head}: {rub}; {stability}{jumps}; {n}{end}")
}

/// What the sentence says of N: the trace's, the N the points in contact carry (refined), and
/// whether their check at 2N moved them by more than the tolerance.
fn harmonics_words(s: &CasingSummary) -> String {
    let force = if s.force_not_converged > 0 {
        format!(
            "; the largest contact force is NOT converged in N at {} points (up to {:.0} % at \
             the last doubling)",
            s.force_not_converged,
            100.0 * s.largest_change[1]
        )
    } else {
        String::new()
    };
    let change = format!(
        "largest change of q1 at the last doubling {:.1e}{force}",
        s.largest_change[0]
    );
    if !s.checked {
        return format!("N = {}, not checked", s.harmonics);
    }
    if !s.refined {
        return if s.not_converged == 0 {
            format!("N = {} converged ({change})", s.harmonics)
        } else {
            format!(
                "N = {} NOT converged at {} points ({change})",
                s.harmonics, s.not_converged
            )
        };
    }
    let carried: Vec<String> = (s.harmonics_in_contact.iter())
        .map(|[n, k, _]| format!("N = {n} at {k}"))
        .collect();
    let total: usize = s.harmonics_in_contact.iter().map(|e| e[1]).sum();
    let verdict = if s.not_converged == 0 {
        format!("converged at all {total}")
    } else {
        format!("**NOT converged at {} of {total}**", s.not_converged)
    };
    format!(
        "N raised point by point from {} (points in contact: {}): {verdict} ({change})",
        s.harmonics,
        carried.join(", ")
    )
}

/// What the sentence says of the stability of the points in contact: the counts, where they
/// are unstable, the largest multiplier, the undetermined ones and the RK4 checks.
fn stability_words(s: &CasingSummary) -> String {
    let [st, un, und] = s.contact_stability;
    let total = st + un + und;
    if total == 0 {
        return "no point in contact".to_string();
    }
    let mut words = if un > 0 {
        let span = s.unstable_span_m.map_or(String::new(), |[a, b]| {
            format!(" (delta {:.4}-{:.4} mm)", 1e3 * a, 1e3 * b)
        });
        format!("**{un} of {total} points in contact unstable**{span}, {st} stable")
    } else if st > 0 {
        format!("stable at {st} of {total} points in contact")
    } else {
        format!("stability undetermined at all {total} points in contact")
    };
    if let Some(mu) = s.largest_multiplier_in_contact {
        words += &format!(", largest |mu| {mu:.4}");
    }
    if und > 0 && st + un > 0 {
        words += &format!(", {und} undetermined");
    }
    if s.rk4_checked > 0 {
        words += &format!(
            " (massless boundary with the moving gap; {} verdicts checked by RK4, largest \
             change {:.1e})",
            s.rk4_checked,
            s.rk4_largest_change.unwrap_or(0.0)
        );
    }
    words
}

/// The report's section (appended to `speed_sweep/section.md`).
pub fn section(st: &CasingStudy) -> String {
    format!(
        "## Casing distortion at {:.0} rpm\n\n`[speed_sweep.casing]`: a casing with {} lobes, every \
         contact row's gap g0_j - delta cos({} x speed x t + {} rad), its intrusion delta swept \
         at the fixed lobe-passing frequency W = {} x speed on the parametric model at that \
         speed, no aerodynamic load, the damping, N and penalty law of the speed sweeps; the \
         points worth checking solved again at 2N (docs/DESIGN.md §10.11, docs/ROTATION.md). \
         {}.\n\n\
         ![casing distortion](speed_sweep/casing.png)\n\nSolid: stable, dashed: unstable, \
         dotted: undetermined. Data: `speed_sweep/casing.csv`, `speed_sweep/casing.json`.\n\n",
        st.speed / RPM_TO_RAD_S,
        st.lobes,
        st.lobes,
        st.phase,
        st.lobes,
        sentence(&summarize(st)).replace("**", "")
    )
}

/// Ok when the sweep reached its last amplitude; otherwise a `StoppedEarly` error (exit code
/// 3) saying where it stopped and where the points are.
pub fn stopped_early(st: &CasingStudy, dir: &Path) -> Result<()> {
    match &st.sweep.stopped {
        None => Ok(()),
        Some((a, why)) => Err(anyhow::Error::new(crate::exit::StoppedEarly(format!(
            "the casing distortion sweep stopped at delta = {a:.4e} m ({why}); the points \
             computed are in {}",
            dir.display()
        )))),
    }
}
