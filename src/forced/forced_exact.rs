//! The forced study's exact curves on the massless contact boundary (`[forced] exact_curve`;
//! docs/STABILITY.md Sec. 9.2): `frf_boundary.csv`, their records in frf.json, their lines on
//! the FRF figures and the summary lines (the report's paragraph: `forced_stage`).

use std::fmt::Write as _;

use nlmodes_forced::{BoundaryCurve, BoundaryCurvePoint, Verdict};
use nlmodes_output::{Color, CsvTable, CsvValue, LineStyle, Series};
use serde::Serialize;

use crate::forced::{ForcedCurve, ForcedStudy};

/// The columns of `frf_boundary.csv`.
const HEADER: [&str; 12] = [
    "level",
    "force_N",
    "point",
    "omega_rad_s",
    "frequency_hz",
    "omega_ratio",
    "q1_over_g0",
    "master_max_over_g0",
    "max_contact_force_N",
    "stability",
    "largest_multiplier",
    "fold",
];

fn word(v: Verdict) -> &'static str {
    match v {
        Verdict::Stable => "stable",
        Verdict::Unstable => "unstable",
        Verdict::Undetermined => "undetermined",
    }
}

/// `frf_boundary.csv`: one row per exact orbit of every level; `None` when no level has one.
pub fn csv(st: &ForcedStudy) -> anyhow::Result<Option<CsvTable>> {
    if st.curves.iter().all(|c| c.exact.is_none()) {
        return Ok(None);
    }
    let (g, w) = (st.gap_reference, st.omega_mode);
    let mut table = CsvTable::new(&HEADER);
    for c in &st.curves {
        let Some(e) = &c.exact else { continue };
        for (i, p) in e.points.iter().enumerate() {
            table.push_row(vec![
                c.level.into(),
                c.force.into(),
                CsvValue::Int(i as i64),
                p.omega.into(),
                (p.omega / (2.0 * std::f64::consts::PI)).into(),
                (p.omega / w).into(),
                (p.master_amplitude / g).into(),
                (p.master_max / g).into(),
                p.max_contact_force.into(),
                CsvValue::Text(word(p.verdict).into()),
                p.largest_multiplier.into(),
                CsvValue::Int(i64::from(p.fold)),
            ])?;
        }
    }
    Ok(Some(table))
}

/// One exact orbit in frf.json.
#[derive(Serialize)]
pub struct ExactPointRecord {
    omega: f64,
    master_amplitude_m: f64,
    master_max_m: f64,
    max_contact_force_n: f64,
    largest_multiplier: f64,
    stability: &'static str,
    fold: bool,
}

/// A level's exact curve in frf.json.
#[derive(Serialize)]
pub struct ExactCurveRecord {
    modes_dynamic: usize,
    end: String,
    points: Vec<ExactPointRecord>,
}

/// The record of a level's exact curve.
pub fn record(e: &BoundaryCurve) -> ExactCurveRecord {
    ExactCurveRecord {
        modes_dynamic: e.modes,
        end: nlmodes_boundary::driven_end_text(&e.end),
        points: e
            .points
            .iter()
            .map(|p| ExactPointRecord {
                omega: p.omega,
                master_amplitude_m: p.master_amplitude,
                master_max_m: p.master_max,
                max_contact_force_n: p.max_contact_force,
                largest_multiplier: p.largest_multiplier,
                stability: word(p.verdict),
                fold: p.fold,
            })
            .collect(),
    }
}

/// The exact curve of a level as thin grey lines (stable solid, unstable dashed), the first
/// labelled when `label`.
pub fn series(c: &ForcedCurve, st: &ForcedStudy, max_abs: bool, label: bool) -> Vec<Series> {
    let Some(e) = &c.exact else {
        return Vec::new();
    };
    let (g, w) = (st.gap_reference, st.omega_mode);
    let amp = |p: &BoundaryCurvePoint| {
        if max_abs {
            p.master_max / g
        } else {
            p.master_amplitude / g
        }
    };
    let mut out = Vec::new();
    let mut run: Vec<&BoundaryCurvePoint> = Vec::new();
    let flush = |run: &[&BoundaryCurvePoint], out: &mut Vec<Series>| {
        if run.len() < 2 {
            return;
        }
        let style = if run[1].verdict == Verdict::Unstable {
            LineStyle::Dashed
        } else {
            LineStyle::Solid
        };
        let name = if label && out.is_empty() {
            "exact orbits, massless contact boundary"
        } else {
            ""
        };
        out.push(
            Series::new(
                name,
                run.iter().map(|p| p.omega / w).collect::<Vec<f64>>(),
                run.iter().map(|p| amp(p)).collect::<Vec<f64>>(),
            )
            .color(Color(110, 110, 110))
            .width(0.9)
            .style(style),
        );
    };
    for p in &e.points {
        if let Some(last) = run.last() {
            if (last.verdict == Verdict::Unstable) != (p.verdict == Verdict::Unstable) {
                let joint = *last;
                flush(&run, &mut out);
                run = vec![joint];
            }
        }
        run.push(p);
    }
    flush(&run, &mut out);
    out
}

/// The exact curve's peak (largest first-harmonic master amplitude).
pub(crate) fn peak(e: &BoundaryCurve) -> Option<&BoundaryCurvePoint> {
    e.points
        .iter()
        .max_by(|a, b| a.master_amplitude.total_cmp(&b.master_amplitude))
}

/// The W / w_mode of the exact curve's folds, each with `digits` decimals.
pub(crate) fn fold_ratios(e: &BoundaryCurve, omega_mode: f64, digits: usize) -> Vec<String> {
    e.points
        .iter()
        .filter(|p| p.fold)
        .map(|p| format!("{:.*}", digits, p.omega / omega_mode))
        .collect()
}

/// How many points of the exact curve have verdict `v`.
pub(crate) fn count(e: &BoundaryCurve, v: Verdict) -> usize {
    e.points.iter().filter(|p| p.verdict == v).count()
}

/// One line per level with an exact curve: its peak, folds and verdicts.
pub fn summary(st: &ForcedStudy) -> String {
    let (g, w) = (st.gap_reference, st.omega_mode);
    let mut out = String::new();
    for c in &st.curves {
        let Some(e) = &c.exact else { continue };
        let Some(p) = peak(e) else { continue };
        let folds = fold_ratios(e, w, 5);
        let unstable = count(e, Verdict::Unstable);
        let _ = writeln!(
            out,
            "  level {:>8} exact on the massless boundary ({} modes dynamic): peak q/g0 = {:.4} at \
             W/w = {:.5}, folds at W/w = [{}], {} points ({} unstable), {}",
            c.level,
            e.modes,
            p.master_amplitude / g,
            p.omega / w,
            folds.join(", "),
            e.points.len(),
            unstable,
            nlmodes_boundary::driven_end_text(&e.end)
        );
    }
    out
}
