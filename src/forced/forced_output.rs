//! What the forced study writes: `frf.csv` (one row per point of every level), `frf.json`
//! (every orbit, the folds, the termination, the damping each mode gets), `frf.svg/.png` (the
//! curves crowned by the backbone, with the synthesis) and `frf_max.svg/.png` (max |u| of the
//! master). Units: W in rad/s and Hz, amplitudes in m and in gaps g0, forces in N.

use std::path::Path;

use anyhow::{Context, Result};
use nlmodes_forced::{
    CurveHarmonics, ForcedPoint, FrequencyResponse, HarmonicCheck, PointStability, RaisedRound,
    RaisedSegments, Verdict,
};
use nlmodes_hb::FullBasis;
use nlmodes_output::plot::{Color, LegendPosition, LinePlot, LineStyle, Series, PALETTE};
use nlmodes_output::{CsvTable, CsvValue};
use serde::Serialize;

use crate::forced::{ForcedCurve, ForcedStudy};
use crate::post::results::BackboneFile;

/// Amplitude and phase (rad) of harmonic h of coordinate i: a cos + b sin = r cos(h W t - phi).
pub(crate) fn harmonic(p: &ForcedPoint, i: usize, h: usize) -> (f64, f64) {
    let (a, b) = (p.coefficients[(i, 2 * h - 1)], p.coefficients[(i, 2 * h)]);
    (a.hypot(b), b.atan2(a))
}

/// max over the period of |u_i(t)| on 512 points.
pub(crate) fn max_abs_over_period(p: &ForcedPoint, i: usize) -> f64 {
    let t = p.coefficients.ncols();
    let c: Vec<f64> = (0..t).map(|k| p.coefficients[(i, k)]).collect();
    (0..512)
        .map(|s| FullBasis::value_at(&c, 2.0 * std::f64::consts::PI * s as f64 / 512.0).abs())
        .fold(0.0, f64::max)
}

/// Contact share of samples x rows, rows touching at some sample, largest force (N).
pub(crate) fn contact_summary(p: &ForcedPoint, rows: usize) -> (f64, usize, f64) {
    let m = p.contact_force.len() / rows.max(1);
    let touching = (0..rows)
        .filter(|&j| p.contact_force[j * m..(j + 1) * m].iter().any(|&f| f > 0.0))
        .count();
    let active = p.contact_force.iter().filter(|&&f| f > 0.0).count();
    let largest = p.contact_force.iter().copied().fold(0.0, f64::max);
    (
        active as f64 / p.contact_force.len().max(1) as f64,
        touching,
        largest,
    )
}

/// What the check of a point's N found, as frf.csv's word, and the relative changes of the
/// master's first harmonic and of W when N was last doubled.
pub(crate) fn harmonic_check(c: &HarmonicCheck) -> (&'static str, Option<[f64; 2]>) {
    match c {
        HarmonicCheck::Unchecked => ("", None),
        HarmonicCheck::Linear => ("linear", None),
        HarmonicCheck::Converged { change } => ("converged", Some(*change)),
        HarmonicCheck::NotConverged { change: Some(c) } => ("not_converged", Some(*c)),
        HarmonicCheck::NotConverged { change: None } => ("check_failed", None),
    }
}

/// A number, or an empty cell (never a NaN).
pub(crate) fn opt(v: Option<f64>) -> CsvValue {
    v.map_or(CsvValue::Text(String::new()), CsvValue::from)
}

pub(crate) fn verdict_word(s: Option<&PointStability>) -> String {
    match s.map(|s| s.verdict) {
        Some(Verdict::Stable) => "stable",
        Some(Verdict::Unstable) => "unstable",
        Some(Verdict::Undetermined) => "undetermined",
        None => "",
    }
    .to_string()
}

fn header(n: usize) -> Vec<String> {
    let mut h: Vec<String> = [
        "level",
        "force_N",
        "point",
        "omega_rad_s",
        "frequency_hz",
        "omega_ratio",
        "q1_over_g0",
        "master_max_abs_m",
        "master_max_over_g0",
    ]
    .iter()
    .map(|s| s.to_string())
    .collect();
    for who in ["master", "excitation"] {
        for k in 1..=n {
            h.push(format!("{who}_amp_h{k}_m"));
            h.push(format!("{who}_phase_h{k}_rad"));
        }
    }
    for s in [
        "contact_fraction",
        "nodes_in_contact",
        "max_contact_force_N",
        "stability",
        "largest_multiplier",
        "period_residual",
        "boundary_shift",
        "bifurcation",
        "fold",
        "hop",
        "piece",
        "harmonics",
        "harmonic_check",
        "harmonic_change_q1",
        "harmonic_change_omega",
        "distortion_m",
    ] {
        h.push(s.to_string());
    }
    h
}

/// First-harmonic amplitude of coordinate i (m).
pub(crate) fn master_amplitude(p: &ForcedPoint, i: usize) -> f64 {
    harmonic(p, i, 1).0
}

/// An empty table with frf.csv's columns.
pub(crate) fn csv_table(st: &ForcedStudy) -> CsvTable {
    CsvTable::new(&header(st.settings.harmonics))
}

/// The rows of one curve; a point's level and force are the curve's times its load scale (1
/// on a frequency curve).
pub(crate) fn push_curve(
    table: &mut CsvTable,
    st: &ForcedStudy,
    curve: &ForcedCurve,
) -> Result<()> {
    let (g, w, n) = (st.gap_reference, st.omega_mode, st.settings.harmonics);
    let r = &curve.response;
    for (i, p) in r.points.iter().enumerate() {
        let (q1, _) = harmonic(p, st.master, 1);
        let mmax = max_abs_over_period(p, st.master);
        let mut row: Vec<CsvValue> = vec![
            (curve.level * p.level).into(),
            (curve.force * p.level).into(),
            CsvValue::Int(i as i64),
            p.omega.into(),
            (p.omega / (2.0 * std::f64::consts::PI)).into(),
            (p.omega / w).into(),
            (q1 / g).into(),
            mmax.into(),
            (mmax / g).into(),
        ];
        for who in [st.master, st.excitation] {
            for h in 1..=n {
                let (a, ph) = harmonic(p, who, h);
                row.push(a.into());
                row.push(ph.into());
            }
        }
        let (share, touching, largest) = contact_summary(p, st.contacts);
        let stab = r.stability.get(i);
        let bif = stab
            .and_then(|s| s.bifurcation)
            .map_or(String::new(), |b| format!("{b:?}"));
        let fold = r.folds.iter().find(|f| f.point == i);
        row.extend([
            share.into(),
            CsvValue::Int(touching as i64),
            largest.into(),
            CsvValue::Text(verdict_word(stab)),
            opt(stab.and_then(|s| s.largest_multiplier)),
            opt(stab.and_then(|s| s.period_residual)),
            opt(stab.and_then(|s| s.boundary_shift)),
            CsvValue::Text(bif),
            CsvValue::Text(fold.map_or(String::new(), |f| format!("{:?}", f.kind))),
            CsvValue::Int(i64::from(r.hops.contains(&i))),
            CsvValue::Int(piece_of(r, i) as i64),
            CsvValue::Int(p.harmonics as i64),
        ]);
        let (word, change) = harmonic_check(&p.harmonic_check);
        row.push(CsvValue::Text(word.into()));
        row.push(opt(change.map(|c| c[0])));
        row.push(opt(change.map(|c| c[1])));
        row.push(distortion_m(st).into());
        table.push_row(row)?;
    }
    Ok(())
}

/// The casing distortion's amplitude delta (m; 0 without one): frf.csv's `distortion_m`.
pub(crate) fn distortion_m(st: &ForcedStudy) -> f64 {
    st.distortion.as_ref().map_or(0.0, |d| d.amplitude_m)
}

/// The figures' words for the casing distortion (empty without one).
pub(crate) fn distortion_title(st: &ForcedStudy) -> String {
    st.distortion.as_ref().map_or_else(String::new, |d| {
        format!(
            ", {}-lobe casing, delta = {:.3} g0 at {} W",
            d.lobes, d.amplitude_over_g0, d.harmonic
        )
    })
}

/// `frf.csv`.
pub fn frf_csv(st: &ForcedStudy) -> Result<CsvTable> {
    let mut table = csv_table(st);
    for curve in &st.curves {
        push_curve(&mut table, st, curve)?;
    }
    Ok(table)
}

/// One orbit in `frf.json`.
#[derive(Serialize)]
struct OrbitRecord {
    omega: f64,
    /// Reduced coefficients per coordinate: [u0, a1, b1, ..., aN, bN] (m).
    coefficients: Vec<Vec<f64>>,
    stability: String,
    largest_multiplier: Option<f64>,
    liouville_error: Option<f64>,
    period_residual: Option<f64>,
    /// The massless contact boundary's shot orbit: its scaled distance from this orbit (points
    /// in contact; docs/STABILITY.md Sec. 9).
    boundary_shift: Option<f64>,
    bifurcation: Option<String>,
    powell_measure: f64,
    newton_iterations: usize,
    /// N of the orbit's basis (issue 37: raised where the point needed it).
    harmonics: usize,
    /// `converged`, `max_harmonics`, `check_failed` or `linear` (frf.csv's `harmonic_check`).
    harmonic_check: String,
    /// [|dq1| / q1, |dW| / W] when N was last doubled.
    harmonic_change: Option<[f64; 2]>,
}

#[derive(Serialize)]
struct CurveRecord<'a> {
    level: f64,
    force_n: f64,
    termination: String,
    folds: Vec<(usize, f64, String)>,
    hops: &'a [usize],
    jump_frequencies_rad_s: Vec<f64>,
    synthesis: Vec<[f64; 4]>,
    orbits: Vec<OrbitRecord>,
    /// The exact curve on the massless contact boundary (`[forced] exact_curve`).
    exact_curve: Option<crate::forced::forced_exact::ExactCurveRecord>,
    /// `adapt_harmonics = "retrace"`: every trace of the curve at its N, the last the curve's.
    retraces: Vec<RetraceRecord>,
    /// `adapt_harmonics = "retrace"`: the points raised to twice the last trace's N where its
    /// check found them moving (`null` when none was).
    raised: Option<RaisedRecord>,
}

/// The points of a retraced curve raised to 2N and their check at 4N (DESIGN §10.8).
#[derive(Serialize)]
pub(crate) struct RaisedRecord {
    /// Each segment's first and last point (indices into `orbits`, inclusive).
    segments: Vec<[usize; 2]>,
    /// Points solved at the raised N in place of the trace's.
    raised: Vec<usize>,
    /// Points whose solve at the raised N failed.
    failed: Vec<usize>,
    /// The checks that decide (each round's, minus the points a later round raised again).
    check: RetraceRecord,
    /// Each round: the N it raised to, its segments, raised and failed points, its own check
    /// at twice that N.
    rounds: Vec<RaisedRoundRecord>,
}

/// One round of [`RaisedRecord`].
#[derive(Serialize)]
struct RaisedRoundRecord {
    harmonics: usize,
    segments: Vec<[usize; 2]>,
    raised: Vec<usize>,
    failed: Vec<usize>,
    check: RetraceRecord,
}

/// One trace of a curve at one N and its check at 2N (DESIGN §10.8).
#[derive(Serialize)]
struct RetraceRecord {
    harmonics: usize,
    /// Indices (into that trace's points) of the points solved again at 2N.
    checked: Vec<usize>,
    /// Checked points that moved by more than `harmonic_tolerance`, or whose 2N solve failed.
    not_converged: usize,
    /// Largest [|dq1| / q1, |dW| / W] over the checked points.
    largest_change: [f64; 2],
    /// Whether 2N was within max_harmonics (else the trace could not be checked).
    checkable: bool,
    /// The trace's largest contact force (force units) at its N and at 2N (`null`: no
    /// contact, not checked, or the 2N solve failed).
    largest_contact_force: Option<f64>,
    largest_contact_force_finer: Option<f64>,
    /// The largest contact force (force units) on the exact orbits of the trace's strongest
    /// point and its peak (the massless boundary, no truncation in N; `nlmodes_forced::
    /// ExactForce`), and that orbit's W (rad/s): `null` where neither shoots.
    largest_contact_force_exact: Option<f64>,
    largest_contact_force_exact_omega_rad_s: Option<f64>,
}

#[derive(Serialize)]
struct StudyRecord<'a> {
    omega_mode_rad_s: f64,
    gap_reference_m: f64,
    /// Master amplitude at which the swept linear mode first touches (m).
    grazing_amplitude_m: f64,
    master: usize,
    excitation: usize,
    linear_frequencies_rad_s: &'a [f64],
    modal_damping_ratios: &'a [f64],
    penalty_stiffness_n_per_m: Option<f64>,
    settings: &'a crate::forced::forced_settings::ForcedSection,
    /// The casing distortion (docs/DESIGN.md §10.11), `null` without one.
    distortion: Option<&'a crate::forced::forced_distortion::DistortionRecord>,
    curves: Vec<CurveRecord<'a>>,
}

fn retrace_record(t: &nlmodes_forced::CurveHarmonics) -> RetraceRecord {
    RetraceRecord {
        harmonics: t.harmonics,
        checked: t.checked.clone(),
        not_converged: t.not_converged,
        largest_change: t.largest_change,
        checkable: t.checkable,
        largest_contact_force: t.force.map(|f| f.force),
        largest_contact_force_finer: t.force.and_then(|f| f.finer),
        largest_contact_force_exact: t.force.and_then(|f| f.exact).map(|e| e.force),
        largest_contact_force_exact_omega_rad_s: t.force.and_then(|f| f.exact).map(|e| e.omega),
    }
}

/// The record of raised segments (JSON). Shared with the speed sweeps' summary.
pub(crate) fn raised_record(d: &RaisedSegments) -> RaisedRecord {
    RaisedRecord {
        segments: d.segments.clone(),
        raised: d.raised.clone(),
        failed: d.failed.clone(),
        check: retrace_record(&d.check),
        rounds: (d.rounds.iter())
            .map(|k| RaisedRoundRecord {
                harmonics: k.harmonics,
                segments: k.segments.clone(),
                raised: k.raised.clone(),
                failed: k.failed.clone(),
                check: retrace_record(&k.check),
            })
            .collect(),
    }
}

fn curve_record(c: &ForcedCurve) -> CurveRecord<'_> {
    let r = &c.response;
    let orbits = r
        .points
        .iter()
        .enumerate()
        .map(|(i, p)| {
            let s = r.stability.get(i);
            OrbitRecord {
                omega: p.omega,
                coefficients: (0..p.coefficients.nrows())
                    .map(|d| {
                        (0..p.coefficients.ncols())
                            .map(|k| p.coefficients[(d, k)])
                            .collect()
                    })
                    .collect(),
                stability: verdict_word(s),
                largest_multiplier: s.and_then(|s| s.largest_multiplier),
                liouville_error: s.and_then(|s| s.liouville_error),
                period_residual: s.and_then(|s| s.period_residual),
                boundary_shift: s.and_then(|s| s.boundary_shift),
                bifurcation: s.and_then(|s| s.bifurcation).map(|b| format!("{b:?}")),
                powell_measure: p.powell_measure,
                newton_iterations: p.newton_iterations,
                harmonics: p.harmonics,
                harmonic_check: harmonic_check(&p.harmonic_check).0.into(),
                harmonic_change: harmonic_check(&p.harmonic_check).1,
            }
        })
        .collect();
    let retraces = r.retraces.iter().map(retrace_record).collect();
    let raised = r.raised.as_ref().map(raised_record);
    CurveRecord {
        retraces,
        raised,
        level: c.level,
        force_n: c.force,
        termination: r.end_text(),
        folds: r
            .folds
            .iter()
            .map(|f| (f.point, f.at, format!("{:?}", f.kind)))
            .collect(),
        hops: &r.hops,
        jump_frequencies_rad_s: r.folds.iter().map(|f| f.at).collect(),
        synthesis: c
            .synthesis
            .iter()
            .map(|s| {
                let (lo, hi) = s.flanks.unwrap_or((f64::NAN, f64::NAN));
                [
                    s.q,
                    s.omega,
                    s.damping_ratio,
                    if lo.is_finite() { hi - lo } else { -1.0 },
                ]
            })
            .collect(),
        orbits,
        exact_curve: c.exact.as_ref().map(crate::forced::forced_exact::record),
    }
}

/// Writes frf.csv, frf.json and the figures into `dir` (the level sweeps' files:
/// `crate::forced::level_sweep::write`).
pub fn write(st: &ForcedStudy, backbone: Option<&BackboneFile>, dir: &Path) -> Result<()> {
    std::fs::create_dir_all(dir).with_context(|| format!("cannot create {}", dir.display()))?;
    frf_csv(st)?.write(&dir.join("frf.csv"))?;
    let exact_path = dir.join("frf_boundary.csv");
    match crate::forced::forced_exact::csv(st)? {
        Some(table) => table.write(&exact_path)?,
        // No stale exact curves from an earlier run beside this run's frf.csv.
        None if exact_path.exists() => std::fs::remove_file(&exact_path)
            .with_context(|| format!("cannot remove {}", exact_path.display()))?,
        None => {}
    }
    let record = StudyRecord {
        omega_mode_rad_s: st.omega_mode,
        gap_reference_m: st.gap_reference,
        grazing_amplitude_m: st.grazing_amplitude,
        master: st.master,
        excitation: st.excitation,
        linear_frequencies_rad_s: &st.linear_frequencies,
        modal_damping_ratios: &st.modal_damping,
        penalty_stiffness_n_per_m: st.penalty_stiffness,
        settings: &st.settings,
        distortion: st.distortion.as_ref(),
        curves: st.curves.iter().map(curve_record).collect(),
    };
    nlmodes_output::write_json_compact(&dir.join("frf.json"), &record)?;
    frf_figure(st, backbone, dir, false)?;
    frf_figure(st, backbone, dir, true)
}

/// The piece (1, or 2 for the trace from the end of the range) point `i` belongs to.
pub(crate) fn piece_of(r: &FrequencyResponse, i: usize) -> usize {
    r.pieces.iter().filter(|&&k| k <= i).count()
}

/// Runs of consecutive points with the same verdict, as (verdict, indices); a new piece of the
/// curve starts a new run.
pub(crate) fn verdict_runs(c: &ForcedCurve) -> Vec<(Option<Verdict>, Vec<usize>)> {
    let mut runs: Vec<(Option<Verdict>, Vec<usize>)> = Vec::new();
    let r = &c.response;
    for i in 0..r.points.len() {
        let v = r.stability.get(i).map(|s| s.verdict);
        let new_piece = i > 0 && r.pieces.contains(&i);
        match runs.last_mut() {
            Some((last, idx)) if *last == v && !new_piece => idx.push(i),
            _ => {
                // Overlap one point so the runs of a piece join.
                let mut idx = runs
                    .last()
                    .filter(|_| !new_piece)
                    .map_or_else(Vec::new, |(_, r)| vec![*r.last().expect("run")]);
                idx.push(i);
                runs.push((v, idx));
            }
        }
    }
    runs
}

/// The FRF figure: per level, amplitude / g0 (first harmonic of the master, or its max over
/// the period when `max_abs`) against W / w_mode; stable solid, unstable dashed, undetermined
/// dotted; the backbone and the synthesis over them.
fn frf_figure(
    st: &ForcedStudy,
    backbone: Option<&BackboneFile>,
    dir: &Path,
    max_abs: bool,
) -> Result<()> {
    let (g, w) = (st.gap_reference, st.omega_mode);
    let title = if max_abs {
        "Forced response: max |u| of the master"
    } else {
        "Forced response crowned by the backbone"
    };
    let title = format!("{title}{}", distortion_title(st));
    let ylabel = if max_abs {
        "max |u_master| / g0"
    } else {
        "first harmonic of the master / g0"
    };
    let mut plot = LinePlot::new(&title, "excitation frequency W / w_mode", ylabel);
    let amp = |p: &ForcedPoint| {
        if max_abs {
            max_abs_over_period(p, st.master) / g
        } else {
            harmonic(p, st.master, 1).0 / g
        }
    };
    for (k, c) in st.curves.iter().enumerate() {
        let color = PALETTE[k % PALETTE.len()];
        let mut labelled = false;
        for (v, idx) in verdict_runs(c) {
            let style = match v {
                Some(Verdict::Unstable) => LineStyle::Dashed,
                Some(Verdict::Undetermined) => LineStyle::Dotted,
                _ => LineStyle::Solid,
            };
            let x: Vec<f64> = idx
                .iter()
                .map(|&i| c.response.points[i].omega / w)
                .collect();
            let y: Vec<f64> = idx.iter().map(|&i| amp(&c.response.points[i])).collect();
            let label = if labelled {
                String::new()
            } else {
                format!(
                    "level {} ({:.3e} {})",
                    c.level,
                    c.force,
                    st.settings.load.unit()
                )
            };
            labelled = true;
            plot = plot.with_series(Series::new(label, x, y).color(color).style(style));
        }
        if let Some((from, to)) = c.response.gap() {
            // The ends of the branch not computed, joined by a dotted line when both are known.
            let ends: Vec<usize> = std::iter::once(from).chain(to).collect();
            let x: Vec<f64> = ends
                .iter()
                .map(|&i| c.response.points[i].omega / w)
                .collect();
            let y: Vec<f64> = ends.iter().map(|&i| amp(&c.response.points[i])).collect();
            plot = plot.with_series(
                Series::new(format!("level {}: branch not computed", c.level), x, y)
                    .color(Color(200, 0, 0))
                    .style(LineStyle::Dotted)
                    .markers(true),
            );
        }
        if !max_abs {
            let pts: Vec<((f64, f64), f64)> = c
                .synthesis
                .iter()
                .filter_map(|s| s.flanks.map(|f| (f, s.q / g)))
                .filter(|((lo, hi), _)| {
                    lo / w >= st.settings.range[0] && hi / w <= st.settings.range[1]
                })
                .collect();
            if !pts.is_empty() {
                let mut xs: Vec<f64> = pts.iter().map(|((lo, _), _)| lo / w).collect();
                let mut ys: Vec<f64> = pts.iter().map(|(_, q)| *q).collect();
                xs.extend(pts.iter().rev().map(|((_, hi), _)| hi / w));
                ys.extend(pts.iter().rev().map(|(_, q)| *q));
                let label = if k == 0 { "single-mode synthesis" } else { "" };
                plot = plot.with_series(
                    Series::new(label, xs, ys)
                        .color(color)
                        .width(0.8)
                        .style(LineStyle::Dotted),
                );
            }
        }
    }
    for (k, c) in st.curves.iter().enumerate() {
        for series in crate::forced::forced_exact::series(c, st, max_abs, k == 0) {
            plot = plot.with_series(series);
        }
    }
    if let (Some(b), false) = (backbone, max_abs) {
        // The main branch over the swept range only.
        let top = st.settings.range[1];
        let main: Vec<&crate::post::results::Orbit> = b
            .points
            .iter()
            .filter(|p| !b.on_tongue(p) && p.omega / w <= top)
            .collect();
        let x: Vec<f64> = main.iter().map(|p| p.omega / w).collect();
        let y: Vec<f64> = main.iter().map(|p| p.q / g).collect();
        plot = plot.with_series(
            Series::new("backbone (free, undamped)", x, y)
                .color(Color(0, 0, 0))
                .width(1.5),
        );
    }
    let name = if max_abs { "frf_max" } else { "frf" };
    // The legend inside the plot only where it covers no curve (the peaks lean right, so the
    // top left corner is tried first), else beside it.
    let plot = plot
        .with_x_range(st.settings.range[0], st.settings.range[1])
        .with_legend(LegendPosition::TopLeft);
    plot.write_svg_and_png(&dir.join(name))?;
    Ok(())
}

/// How many points of a curve are stable, unstable and undetermined.
pub(crate) fn verdict_counts(r: &FrequencyResponse) -> [usize; 3] {
    let count = |v: Verdict| r.stability.iter().filter(|s| s.verdict == v).count();
    [
        count(Verdict::Stable),
        count(Verdict::Unstable),
        count(Verdict::Undetermined),
    ]
}

/// The point of largest first-harmonic master amplitude of a curve.
pub fn peak_point(c: &ForcedCurve, master: usize) -> Option<usize> {
    let amp = |i: usize| harmonic(&c.response.points[i], master, 1).0;
    (0..c.response.points.len()).max_by(|&a, &b| amp(a).total_cmp(&amp(b)))
}

/// A warning when the peak is the last point of a curve: the range ends before the resonance
/// does, and the "peak" is only the end of the range.
pub fn peak_note(c: &ForcedCurve, peak: usize) -> &'static str {
    let complete = c.response.termination.covers_range();
    if complete && peak + 1 == c.response.points.len() && c.response.points.len() > 2 {
        " (the last point: the range ends before the peak, widen forced.range)"
    } else {
        ""
    }
}

/// Under `adapt_harmonics = "retrace"`: the N of the curve, what its check at 2N found and
/// where N was raised (one or two lines, empty under the other policies).
pub(crate) fn retrace_note(r: &FrequencyResponse, peak: usize, tolerance: f64) -> String {
    let Some(last) = r.retraces.last() else {
        return String::new();
    };
    let at_peak = match harmonic_check(&r.points[peak].harmonic_check) {
        (_, Some(c)) => format!(" (at the peak {:.1e} in q1, {:.1e} in W)", c[0], c[1]),
        _ => String::new(),
    };
    let traced: Vec<String> = r.retraces.iter().map(|t| t.harmonics.to_string()).collect();
    let converged = r.harmonics_converged() == Some(true);
    // A checked point whose 2N solve failed keeps that verdict, or (N raised around the
    // moving ones) is among the raised segments' failed points.
    let failed = (last.checked.iter())
        .filter(|&&i| {
            matches!(
                r.points[i].harmonic_check,
                HarmonicCheck::NotConverged { change: None }
            ) || r.raised.as_ref().is_some_and(|s| s.failed.contains(&i))
        })
        .count();
    let verdict = check_verdict(last, failed, r.raised.is_some(), tolerance);
    let over = if failed > 0 {
        format!(
            " (over the {} solved)",
            last.checked.len().saturating_sub(failed)
        )
    } else {
        String::new()
    };
    let mut out = format!(
        "           N = {} (traced at N = {}): {}{verdict}; largest change at 2N {:.1e} in q1, {:.1e} in W{over}{}{at_peak}\n",
        last.harmonics,
        traced.join(", "),
        // With N raised around the moving points the next line says whether the curve is
        // converged.
        if converged || r.raised.is_some() || !last.checkable {
            ""
        } else {
            "NOT converged: "
        },
        last.largest_change[0],
        last.largest_change[1],
        force_note(last, "N"),
    );
    if let Some(raised) = &r.raised {
        out += &raised_note(r, raised, tolerance);
    }
    out
}

/// How far the largest contact force of a curve's trace `last` moved at 2N (its point is
/// always checked, `nlmodes_forced::ForceCheck`), as a clause; empty when the trace never
/// touches or was not checked. Reported beside the check of N, not within its tolerance: a
/// stiff penalty law's peak force converges more slowly in N than the first harmonic.
pub(crate) fn force_note(last: &CurveHarmonics, unit: &str) -> String {
    let Some(f) = last.force else {
        return String::new();
    };
    let finer = 2 * last.harmonics;
    let check = match (f.finer, f.change()) {
        (Some(fine), Some(change)) => format!(
            "; the largest contact force {:.4} {unit} moves by {:.1} % at N = {finer} ({:.4} {unit})",
            f.force,
            100.0 * change,
            fine
        ),
        _ => format!(
            "; the largest contact force {:.4} {unit} could not be checked at N = {finer} (the \
             solve failed or landed on another orbit)",
            f.force
        ),
    };
    match f.exact {
        Some(e) => format!(
            "{check}, {:.4} {unit} on the exact orbit (massless boundary, no truncation in N) \
             at W = {:.6e} rad/s",
            e.force, e.omega
        ),
        None => check,
    }
}

/// What the check at 2N of a curve's trace `last` found, `failed` of its checked points not
/// solved again at 2N (the solve failed or landed on another orbit): `not_converged` counts
/// those beside the points that moved by more than `tolerance`, and `largest_change` is over
/// the solved ones only, so the two are told apart (as the speed sweep's note does).
pub(crate) fn check_verdict(
    last: &CurveHarmonics,
    failed: usize,
    raised: bool,
    tolerance: f64,
) -> String {
    if !last.checkable {
        return "not checked (2N above max_harmonics)".to_string();
    }
    if last.converged() {
        return format!("converged at its {} checked points", last.checked.len());
    }
    let moved = last.not_converged.saturating_sub(failed);
    format!(
        "of its {} checked points {moved} move by more than {tolerance:e} at 2N{} and {failed} \
         could not be solved again at 2N (the solve failed or landed on another orbit)",
        last.checked.len(),
        if raised && moved > 0 {
            " (N raised around them)"
        } else {
            ""
        }
    )
}

/// Where N was raised around the points that moved, and what the check of the raised points
/// found (one line), for a frequency response (its segments as W ranges).
fn raised_note(r: &FrequencyResponse, raised: &RaisedSegments, tolerance: f64) -> String {
    let range = |a: usize, b: usize| {
        let w = r.points[a..=b].iter().map(|p| p.omega);
        let (lo, hi) = w.fold((f64::INFINITY, 0.0_f64), |(l, h), v| (l.min(v), h.max(v)));
        match a == b {
            true => format!("W = {lo:.6e} rad/s"),
            false => format!("W = {lo:.6e}..{hi:.6e} rad/s"),
        }
    };
    raised_segments_note(raised, tolerance, &range, "W")
}

/// Where N was raised around the points that moved, and what the check of the raised points
/// found (one line): each round's segments and the points not solved at their raised N as
/// `range(first, last)` gives them, the changes of the curve's `parameter` ("W", "speed").
/// Shared with the speed sweeps' note.
pub(crate) fn raised_segments_note(
    raised: &RaisedSegments,
    tolerance: f64,
    range: &dyn Fn(usize, usize) -> String,
    parameter: &str,
) -> String {
    let rounds: Vec<String> = raised
        .rounds
        .iter()
        .map(|round| round_note(round, tolerance, range, parameter))
        .collect();
    let check = &raised.check;
    let verdict = if !check.checkable {
        "not checked (2N above the largest check)".to_string()
    } else if raised.converged() {
        "converged".to_string()
    } else {
        let failed: Vec<String> = raised.failed.iter().map(|&i| range(i, i)).collect();
        format!(
            "NOT converged: {} of the {} deciding checks move by more than {tolerance:e}, {} \
             points not solved at their raised N{}",
            check.not_converged,
            check.checked.len(),
            raised.failed.len(),
            match failed.is_empty() {
                true => String::new(),
                false => format!(" ({})", failed.join(", ")),
            }
        )
    };
    format!(
        "           N raised around the points that moved: {}; {verdict}\n",
        rounds.join("; then ")
    )
}

/// One round of raised segments: its N, points, segments' ranges and its own check at 2N.
fn round_note(
    round: &RaisedRound,
    tolerance: f64,
    range: &dyn Fn(usize, usize) -> String,
    parameter: &str,
) -> String {
    let n = round.harmonics;
    let ranges: Vec<String> = round.segments.iter().map(|[a, b]| range(*a, *b)).collect();
    let check = &round.check;
    let moved = if !check.checkable {
        "not checked".to_string()
    } else if check.not_converged == 0 {
        "none moves".to_string()
    } else if check.not_converged == 1 {
        format!("1 moves by more than {tolerance:e}")
    } else {
        format!("{} move by more than {tolerance:e}", check.not_converged)
    };
    format!(
        "to {n} at {} points in {} segment{} ({}), {} checked at {}: {moved} (largest change \
         {:.1e} in q1, {:.1e} in {parameter})",
        round.raised.len(),
        round.segments.len(),
        if round.segments.len() == 1 { "" } else { "s" },
        ranges.join(", "),
        check.checked.len(),
        2 * n,
        check.largest_change[0],
        check.largest_change[1]
    )
}

/// The lines printed after a forced run.
pub fn summary(st: &ForcedStudy) -> String {
    let (g, w) = (st.gap_reference, st.omega_mode);
    let mut out = format!(
        "forced response around mode {} (w = {:.2} rad/s, {:.3} Hz), damping ratio {:.3e}{}{}\n",
        st.settings.mode,
        w,
        w / (2.0 * std::f64::consts::PI),
        st.modal_damping[st.settings.mode],
        st.penalty_stiffness.map_or_else(
            || ", exact contact (Algorithm 1)".to_string(),
            |k| format!(", penalty kc = {k:.3e} N/m")
        ),
        distortion_title(st),
    );
    for c in &st.curves {
        let r = &c.response;
        let [stable, unstable, undetermined] = verdict_counts(r);
        if let Some(i) = peak_point(c, st.master) {
            let p = &r.points[i];
            out += &format!(
                "  level {:>8}: load {:.4e} {}, peak q/g0 = {:.4} at W/w = {:.5}{}, {} points, {} folds, {} stable / {} unstable / {} undetermined, {}\n",
                c.level,
                c.force,
                st.settings.load.unit(),
                harmonic(p, st.master, 1).0 / g,
                p.omega / w,
                peak_note(c, i),
                r.points.len(),
                r.folds.len(),
                stable,
                unstable,
                undetermined,
                r.end_text()
            );
            out += &retrace_note(r, i, st.settings.harmonic_tolerance);
        }
    }
    out + &crate::forced::forced_exact::summary(st)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A check of 8 points at 2N, 5 of them not solved again there, 2 moved by more than the
    /// tolerance, 1 within it: the note said "7 of its 8 checked points move by more than
    /// 1e-3" beside a largest change over the 3 solved. It must say which is which.
    #[test]
    fn the_check_verdict_tells_failed_solves_from_moved_points() {
        let last = CurveHarmonics {
            harmonics: 10,
            checked: (0..8).collect(),
            not_converged: 7,
            largest_change: [1.7e-3, 2.3e-4],
            checkable: true,
            force: None,
        };
        let note = check_verdict(&last, 5, false, 1e-3);
        assert!(note.contains("2 move by more than 1e-3"), "{note}");
        assert!(note.contains("5 could not be solved again at 2N"), "{note}");
        let note = check_verdict(&last, 0, true, 1e-3);
        assert!(
            note.contains("7 move by more than 1e-3 at 2N (N raised"),
            "{note}"
        );
        assert!(note.contains("0 could not be solved"), "{note}");
        let converged = CurveHarmonics {
            not_converged: 0,
            ..last
        };
        let note = check_verdict(&converged, 0, false, 1e-3);
        assert_eq!(note, "converged at its 8 checked points");
    }
}
