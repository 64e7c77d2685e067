//! What the speed sweeps write (issue 39, item 2): `speed_sweep.csv` (one row per point of
//! every sweep), `speed_sweep.json` (per sweep: the crossing, the window, the peak, the folds,
//! the speeds in contact, the largest contact force, the stability counts, how it ended; the
//! parametric model's measured error) and `speed_sweep.png/.svg` (the response against the
//! speed). Units: speeds in rpm and rad/s, frequencies in Hz, amplitudes in m and in running
//! gaps g0(Omega), forces in N. The report's section and the terminal lines:
//! `forced_speed_report`.

use std::path::Path;

use anyhow::{Context, Result};
use nlmodes_forced::{FoldKind, SpeedPoint, Verdict};
use nlmodes_output::{CsvTable, CsvValue};
use serde::Serialize;

use crate::forced::forced_output::{
    contact_summary, harmonic, max_abs_over_period, opt, verdict_word,
};
use crate::rotation::rotation_settings::RPM_TO_RAD_S;
use crate::speed_sweep::forced_speed::{harmonics_note, SpeedSweepStudy, SweepRun};

const TAU: f64 = std::f64::consts::TAU;

/// The largest gap value g = A u - g0 over the period's samples and the contact rows (m): >= 0
/// where the blade touches.
fn largest_gap(p: &SpeedPoint) -> f64 {
    p.point
        .gaps
        .iter()
        .copied()
        .fold(f64::NEG_INFINITY, f64::max)
}

/// The speeds (rpm) where the sweep starts and stops touching, in the order of the sweep: each
/// edge by linear interpolation of `largest_gap` between the points around it.
pub fn contact_intervals(run: &SweepRun) -> Vec<[f64; 2]> {
    let pts = &run.sweep.points;
    let edge = |a: &SpeedPoint, b: &SpeedPoint| {
        let (ga, gb) = (largest_gap(a), largest_gap(b));
        let u = if gb != ga { -ga / (gb - ga) } else { 0.5 };
        (a.speed + u.clamp(0.0, 1.0) * (b.speed - a.speed)) / RPM_TO_RAD_S
    };
    let mut out: Vec<[f64; 2]> = Vec::new();
    let mut from: Option<f64> = None;
    for (i, p) in pts.iter().enumerate() {
        let touching = p.point.touches();
        match (from, touching) {
            (None, true) => {
                from = Some(if i == 0 {
                    p.speed / RPM_TO_RAD_S
                } else {
                    edge(&pts[i - 1], p)
                });
            }
            (Some(f), false) => {
                out.push([f, edge(&pts[i - 1], p)]);
                from = None;
            }
            _ => {}
        }
    }
    if let (Some(f), Some(last)) = (from, pts.last()) {
        out.push([f, last.speed / RPM_TO_RAD_S]);
    }
    out
}

/// A fold as written: where and which way.
#[derive(Serialize)]
pub struct FoldRecord {
    pub speed_rpm: f64,
    /// `turns_back` (a run-up jumps here) or `turns_forward` (a run-down jumps here).
    pub kind: &'static str,
}

/// What `speed_sweep.json` says of one sweep.
#[derive(Serialize)]
pub struct SweepSummary {
    pub engine_order: usize,
    pub level: f64,
    /// The load scale (N; Pa for a pressure load).
    pub force: f64,
    pub crossing_rpm: f64,
    pub crossing_hz: f64,
    pub range_rpm: [f64; 2],
    pub points: usize,
    /// The point of largest first harmonic of the master: its speed, amplitude (m), amplitude
    /// in running gaps, detuning e Omega / w_mode(Omega).
    pub peak_rpm: f64,
    pub peak_q1_m: f64,
    pub peak_q1_over_g0: f64,
    pub peak_detuning: f64,
    pub folds: Vec<FoldRecord>,
    /// Speed intervals (rpm) along the sweep where the blade touches the casing, each in the
    /// order of the sweep (a stretch that passes a fold ends below its largest speed).
    pub contact_rpm: Vec<[f64; 2]>,
    /// The lowest and highest speed (rpm) at which any point of the sweep touches: the
    /// interpolated edges of `contact_rpm` and the speeds of the points in contact (folds
    /// included); `None` without contact.
    pub contact_span_rpm: Option<[f64; 2]>,
    /// The largest contact force of any contact node over the sweep (N) and its speed.
    pub max_contact_force_n: f64,
    pub max_contact_force_rpm: Option<f64>,
    /// Points stable, unstable, undetermined.
    pub stability: [usize; 3],
    /// The same counts over the points in contact.
    pub contact_stability: [usize; 3],
    /// The verdict of the peak point (`stable`, `unstable`, `undetermined`, `not computed`).
    pub peak_stability: String,
    pub complete: bool,
    pub end: String,
    /// N of the sweep's last trace (every point's but the raised ones', which carry theirs in
    /// the CSV).
    pub harmonics: usize,
    /// `[speed_sweep] adapt_harmonics` "retrace" or "check": every trace of the sweep at its N
    /// and what its check at 2N found, the last the sweep's (empty under "fixed").
    pub retraces: Vec<RetraceRecord>,
    /// `[speed_sweep] adapt_harmonics` "retrace": the points raised above the last trace's N
    /// where its check found them moving (docs/DESIGN.md §10.10; absent when none was).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub raised: Option<crate::forced::forced_output::RaisedRecord>,
    /// Whether the sweep's N is converged at every point checked (`null` under "fixed").
    pub harmonics_converged: Option<bool>,
    /// The check of N in words (`harmonics_note`).
    pub harmonics_note: String,
    /// The casing distortion (`[forced.distortion]`, docs/DESIGN.md §10.11), absent without.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub casing: Option<crate::speed_sweep::forced_speed_distortion::SweepCasing>,
}

/// One trace of a sweep at one N and its check at 2N (docs/DESIGN.md §10.10).
#[derive(Serialize)]
pub struct RetraceRecord {
    pub harmonics: usize,
    /// Indices (into that trace's points) of the points solved again at 2N.
    pub checked: Vec<usize>,
    /// Checked points that moved by more than `[forced] harmonic_tolerance`, or whose 2N solve
    /// failed.
    pub not_converged: usize,
    /// Largest relative change at 2N of the master's first harmonic and of the speed over the
    /// checked points.
    pub largest_change_q1: f64,
    pub largest_change_speed: f64,
    /// Whether 2N was within `[forced] max_harmonics` (else the trace could not be checked).
    pub checkable: bool,
    pub converged: bool,
    /// The trace's largest contact force (N) at its N and at 2N on the same row (`null`: no
    /// contact, not checked, or the 2N solve failed).
    pub largest_contact_force_n: Option<f64>,
    pub largest_contact_force_finer_n: Option<f64>,
    /// The largest contact force (N) on the exact orbits of the trace's strongest point and its
    /// peak (the massless boundary at their speeds, no truncation in N), and that orbit's
    /// speed (rpm): `null` where neither shoots.
    pub largest_contact_force_exact_n: Option<f64>,
    pub largest_contact_force_exact_rpm: Option<f64>,
}

/// The summary of one sweep.
pub fn summarize(st: &SpeedSweepStudy, run: &SweepRun) -> SweepSummary {
    let pts = &run.sweep.points;
    let q1 = |p: &SpeedPoint| harmonic(&p.point, st.master, 1).0;
    let peak = pts
        .iter()
        .max_by(|a, b| q1(a).total_cmp(&q1(b)))
        .expect("a sweep has points");
    let force = |p: &SpeedPoint| contact_summary(&p.point, st.contacts).2;
    let strongest = pts.iter().max_by(|a, b| force(a).total_cmp(&force(b)));
    let largest = strongest.map_or(0.0, force);
    let count = |v: Verdict, contact_only: bool| {
        pts.iter()
            .filter(|p| !contact_only || p.point.touches())
            .filter(|p| p.stability.is_some_and(|s| s.verdict == v))
            .count()
    };
    let verdicts = [Verdict::Stable, Verdict::Unstable, Verdict::Undetermined];
    let contact_rpm = contact_intervals(run);
    SweepSummary {
        engine_order: run.plan.engine_order,
        level: run.level,
        force: run.force,
        crossing_rpm: run.plan.crossing / RPM_TO_RAD_S,
        crossing_hz: run.plan.crossing_frequency / TAU,
        range_rpm: [run.plan.start, run.plan.end].map(|w| w / RPM_TO_RAD_S),
        points: pts.len(),
        peak_rpm: peak.speed / RPM_TO_RAD_S,
        peak_q1_m: q1(peak),
        peak_q1_over_g0: q1(peak) / peak.gap_reference,
        peak_detuning: excitation(run, peak) / peak.mode_frequency,
        folds: (run.sweep.folds.iter())
            .map(|f| FoldRecord {
                speed_rpm: f.speed / RPM_TO_RAD_S,
                kind: fold_word(f.kind),
            })
            .collect(),
        contact_span_rpm: contact_span(&contact_rpm, pts),
        contact_rpm,
        max_contact_force_n: largest,
        max_contact_force_rpm: strongest
            .filter(|_| largest > 0.0)
            .map(|p| p.speed / RPM_TO_RAD_S),
        stability: verdicts.map(|v| count(v, false)),
        contact_stability: verdicts.map(|v| count(v, true)),
        peak_stability: (peak.stability.as_ref())
            .map_or("not computed".into(), |s| verdict_word(Some(s))),
        complete: run.sweep.termination.covers_range(),
        end: run.sweep.end_text(),
        harmonics: run.sweep.harmonics,
        retraces: (run.sweep.retraces.iter())
            .map(|t| RetraceRecord {
                harmonics: t.harmonics,
                checked: t.checked.clone(),
                not_converged: t.not_converged,
                largest_change_q1: t.largest_change[0],
                largest_change_speed: t.largest_change[1],
                checkable: t.checkable,
                converged: t.converged(),
                largest_contact_force_n: t.force.map(|f| f.force),
                largest_contact_force_finer_n: t.force.and_then(|f| f.finer),
                largest_contact_force_exact_n: t.force.and_then(|f| f.exact).map(|e| e.force),
                largest_contact_force_exact_rpm: (t.force.and_then(|f| f.exact))
                    .map(|e| e.omega / run.plan.engine_order as f64 / RPM_TO_RAD_S),
            })
            .collect(),
        raised: (run.sweep.raised.as_ref()).map(crate::forced::forced_output::raised_record),
        harmonics_converged: run.sweep.harmonics_converged(),
        harmonics_note: harmonics_note(&run.sweep, st.harmonic_tolerance),
        casing: run.casing.clone(),
    }
}

/// The engine order's frequency e Omega (rad/s) at a point: the orbit's W without a casing
/// distortion, a multiple of its fundamental gcd(e, n) Omega with one.
fn excitation(run: &SweepRun, p: &SpeedPoint) -> f64 {
    run.plan.engine_order as f64 * p.speed
}

/// The lowest and highest speed (rpm) of the contact intervals' edges and of the points in
/// contact.
fn contact_span(intervals: &[[f64; 2]], pts: &[SpeedPoint]) -> Option<[f64; 2]> {
    let speeds = (pts.iter().filter(|p| p.point.touches()))
        .map(|p| p.speed / RPM_TO_RAD_S)
        .chain(intervals.iter().flatten().copied());
    speeds.fold(None, |span, v| match span {
        None => Some([v, v]),
        Some([lo, hi]) => Some([lo.min(v), hi.max(v)]),
    })
}

fn fold_word(k: FoldKind) -> &'static str {
    match k {
        FoldKind::TurnsBack => "turns_back",
        FoldKind::TurnsForward => "turns_forward",
    }
}

const HEADER: [&str; 23] = [
    "engine_order",
    "level",
    "force_N",
    "point",
    "speed_rpm",
    "speed_rad_s",
    "excitation_hz",
    "mode_frequency_hz",
    "detuning",
    "running_gap_m",
    "q1_m",
    "q1_over_g0",
    "master_max_over_g0",
    "contact_fraction",
    "nodes_in_contact",
    "max_contact_force_N",
    "stability",
    "largest_multiplier",
    "bifurcation",
    "fold",
    "speed_solves",
    "harmonics",
    "distortion_m",
];

/// `speed_sweep.csv`: one row per point of every sweep (columns: README "Speed sweeps").
pub fn csv(st: &SpeedSweepStudy) -> Result<CsvTable> {
    let mut table = CsvTable::new(&HEADER);
    for run in &st.runs {
        for (i, p) in run.sweep.points.iter().enumerate() {
            let g = p.gap_reference;
            let (share, nodes, largest) = contact_summary(&p.point, st.contacts);
            let fold = (run.sweep.folds.iter())
                .find(|f| f.point == i)
                .map_or("", |f| fold_word(f.kind));
            let bifurcation = p
                .stability
                .and_then(|s| s.bifurcation)
                .map_or(String::new(), |b| format!("{b:?}"));
            table.push_row(vec![
                CsvValue::from(run.plan.engine_order),
                run.level.into(),
                run.force.into(),
                i.into(),
                (p.speed / RPM_TO_RAD_S).into(),
                p.speed.into(),
                (excitation(run, p) / TAU).into(),
                (p.mode_frequency / TAU).into(),
                (excitation(run, p) / p.mode_frequency).into(),
                g.into(),
                harmonic(&p.point, st.master, 1).0.into(),
                (harmonic(&p.point, st.master, 1).0 / g).into(),
                (max_abs_over_period(&p.point, st.master) / g).into(),
                share.into(),
                nodes.into(),
                largest.into(),
                verdict_word(p.stability.as_ref()).into(),
                opt(p.stability.and_then(|s| s.largest_multiplier)),
                bifurcation.into(),
                fold.into(),
                p.corrections.into(),
                p.point.harmonics.into(),
                run.casing.as_ref().map_or(0.0, |c| c.amplitude_m).into(),
            ])?;
        }
    }
    Ok(table)
}

/// `speed_sweep.json`.
#[derive(Serialize)]
struct StudyRecord<'a> {
    units: &'static str,
    mode: usize,
    master: usize,
    cold_gap_m: f64,
    penalty_stiffness_n_per_m: Option<f64>,
    /// Where the sweeps stop: the smallest running gap at `CLOSURE_SHARE` of the cold gap.
    closure_rpm: Option<f64>,
    harmonics: usize,
    /// The parametric model's measured error (`parametric.json`'s `accuracy`).
    parametric_accuracy: Option<&'a nlmodes_modal::Accuracy>,
    sweeps: Vec<SweepSummary>,
}

/// Writes speed_sweep.csv, speed_sweep.json and the figure into `dir`.
pub fn write(st: &SpeedSweepStudy, dir: &Path) -> Result<()> {
    std::fs::create_dir_all(dir).with_context(|| format!("cannot create {}", dir.display()))?;
    csv(st)?.write(&dir.join("speed_sweep.csv"))?;
    let record = StudyRecord {
        units: "speeds in rpm, frequencies in Hz, amplitudes in m, forces in N",
        mode: st.mode,
        master: st.master,
        cold_gap_m: st.cold_gap,
        penalty_stiffness_n_per_m: st.penalty_stiffness,
        closure_rpm: st.closure.map(|w| w / RPM_TO_RAD_S),
        harmonics: st.harmonics,
        parametric_accuracy: st.accuracy.as_ref(),
        sweeps: st.runs.iter().map(|r| summarize(st, r)).collect(),
    };
    nlmodes_output::write_json(&dir.join("speed_sweep.json"), &record)?;
    crate::speed_sweep::forced_speed_figure::figure(st, dir)
}
