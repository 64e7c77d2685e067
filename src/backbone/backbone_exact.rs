//! The exact backbone of the massless contact boundary beside the harmonic balance
//! (docs/STABILITY.md Sec. 9.3): computed after the stability stage when shooting is on,
//! written as `backbone/backbone_boundary.csv` and `backbone_boundary.json`, and the
//! harmonic-balance points of the main branch whose w it does not confirm named.

use std::path::Path;

use anyhow::{Context, Result};
use std::fmt::Write as _;

use nlmodes_nnm::{Backbone, BackbonePoint, BoundaryBackbone, BoundaryHistory, BranchKind, System};
use nlmodes_output::{CsvTable, CsvValue};

use crate::case::StabilitySection;
use crate::post::results::{BackboneFile, Orbit};
use crate::ui;

/// The columns of `backbone_boundary.csv`.
const HEADER: [&str; 13] = [
    "piece",
    "point",
    "q_over_g0",
    "q_m",
    "omega_rad_s",
    "frequency_hz",
    "omega_ratio",
    "master_max_over_g0",
    "max_contact_share",
    "switches",
    "stability",
    "max_multiplier_abs",
    "fold",
];

/// What the massless contact boundary adds to a backbone: its exact backbone and, for each
/// kept point, the exact orbit next to it (Fig. 4 from converged orbits).
pub struct ExactOutputs {
    pub backbone: Option<BoundaryBackbone>,
    /// One per kept point, in their order (`None` out of contact or where it did not converge).
    pub kept: Vec<Option<BoundaryHistory>>,
}

/// Time samples per period of a kept point's exact contact history (Fig. 4 draws 200).
const HISTORY_SAMPLES: usize = 200;

/// The exact backbone of `b`'s main branch up to q/g0 = `q_max` and the exact orbits next to
/// the kept points, when the stability stage shoots (`[stability] enabled` and `shooting`);
/// nothing otherwise, or where the boundary model does not apply. A failure is logged and
/// gives nothing: it never takes the backbone with it.
pub fn exact_outputs(
    system: &System,
    b: &Backbone,
    kept: &[BackbonePoint],
    settings: &StabilitySection,
    q_max: f64,
) -> Result<ExactOutputs> {
    let analysis = settings.analysis();
    let mut out = ExactOutputs {
        backbone: None,
        kept: vec![None; kept.len()],
    };
    if !settings.enabled || !analysis.shooting {
        return Ok(out);
    }
    let stage = ui::Stage::start("exact backbone");
    let floquet = nlmodes_nnm::FloquetAnalysis::new(system, analysis)
        .context("the modes of the massless contact boundary")?;
    out.backbone = nlmodes_nnm::boundary_backbone(&floquet, b, q_max * b.gap_reference)
        .unwrap_or_else(|e| {
            tracing::warn!(error = %e, "the exact backbone of the massless boundary failed");
            None
        });
    for (slot, p) in out.kept.iter_mut().zip(kept) {
        *slot = nlmodes_nnm::boundary_history(&floquet, p, HISTORY_SAMPLES).unwrap_or_else(|e| {
            tracing::warn!(q = p.q, error = %e, "the exact orbit next to a kept point failed");
            None
        });
    }
    let g = b.gap_reference;
    let histories = out.kept.iter().flatten().count();
    match &out.backbone {
        Some(e) => stage.done(&format!(
            "{} pieces, {} orbits, {} modes dynamic: {}; {}{histories} of {} kept points with \
             their exact orbit",
            e.pieces.len(),
            e.pieces.iter().map(|p| p.points.len()).sum::<usize>(),
            e.modes,
            pieces_text(e, g),
            crate::backbone::backbone_holes::summary(e, g),
            kept.len()
        )),
        None => stage.done("not computed (no point in contact, or every mode resolved)"),
    }
    Ok(out)
}

/// "q/g0 a-b (lower end; upper end), ..." of every piece.
pub fn pieces_text(e: &BoundaryBackbone, g: f64) -> String {
    e.pieces
        .iter()
        .map(|p| {
            let q =
                |f: fn(f64, f64) -> f64, init| p.points.iter().map(|x| x.q.abs() / g).fold(init, f);
            format!(
                "q/g0 {:.3}-{:.3} ({}; {})",
                q(f64::min, f64::INFINITY),
                q(f64::max, 0.0),
                end_text(&p.lower_end, g, std::ptr::eq(p, &e.pieces[0]), p.gap),
                end_text(&p.upper_end, g, false, p.gap)
            )
        })
        .collect::<Vec<_>>()
        .join(", ")
}

/// Why a piece's end ended, in words; `first` for the first piece (whose lower end is q_start),
/// `gap` for a piece seeded in a gap (whose upper range ends at the piece above).
fn end_text(end: &nlmodes_boundary::CurveEnd, g: f64, first: bool, gap: bool) -> String {
    use nlmodes_boundary::CurveEnd;
    match end {
        CurveEnd::Complete if gap => "met the piece above".into(),
        CurveEnd::Complete => "q_max reached".into(),
        CurveEnd::LeftRange if first => "q_start".into(),
        CurveEnd::LeftRange => "met the piece below".into(),
        CurveEnd::LeftFamily => "turns into a tongue".into(),
        other => other.text(|q| format!("q/g0 = {:.3}", q / g)),
    }
}

/// `backbone_boundary.csv`: one row per exact orbit.
pub fn csv(e: &BoundaryBackbone, b: &Backbone) -> Result<CsvTable> {
    let (g, w1) = (b.gap_reference, b.omega_linear);
    let mut table = CsvTable::new(&HEADER);
    for (k, piece) in e.pieces.iter().enumerate() {
        for (i, p) in piece.points.iter().enumerate() {
            let share = p.contact_shares.iter().copied().fold(0.0, f64::max);
            table.push_row(vec![
                CsvValue::Int(k as i64),
                CsvValue::Int(i as i64),
                (p.q.abs() / g).into(),
                p.q.abs().into(),
                p.omega.into(),
                (p.omega / (2.0 * std::f64::consts::PI)).into(),
                (p.omega / w1).into(),
                (p.master_max / g).into(),
                share.into(),
                p.switches.into(),
                CsvValue::Text(p.verdict.clone()),
                p.max_multiplier_abs
                    .map_or(CsvValue::Text(String::new()), |m| m.into()),
                CsvValue::Int(i64::from(p.fold)),
            ])?;
        }
    }
    Ok(table)
}

/// Writes `backbone_boundary.csv`, `backbone_boundary.json` and `kept_boundary.json` (the kept
/// points' exact orbits, `null` where none) into `dir`, or removes stale ones when there is no
/// exact backbone.
pub fn write(x: &ExactOutputs, b: &Backbone, dir: &Path) -> Result<()> {
    let (csv_path, json_path, kept_path) = (
        dir.join("backbone_boundary.csv"),
        dir.join("backbone_boundary.json"),
        dir.join("kept_boundary.json"),
    );
    if x.kept.iter().any(Option::is_some) {
        nlmodes_output::write_json(&kept_path, &x.kept)?;
    } else if kept_path.exists() {
        std::fs::remove_file(&kept_path)
            .with_context(|| format!("cannot remove {}", kept_path.display()))?;
    }
    let Some(e) = &x.backbone else {
        for p in [&csv_path, &json_path] {
            if p.exists() {
                std::fs::remove_file(p)
                    .with_context(|| format!("cannot remove {}", p.display()))?;
            }
        }
        return crate::backbone::backbone_holes::write(None, b.gap_reference, b.omega_linear, dir);
    };
    csv(e, b)?.write(&csv_path)?;
    nlmodes_output::write_json_compact(&json_path, e)?;
    crate::backbone::backbone_holes::write(Some(e), b.gap_reference, b.omega_linear, dir)
}

/// The parts of [a, b] (m) no piece covers.
fn gaps_in(ranges: &[(f64, f64)], a: f64, b: f64) -> Vec<(f64, f64)> {
    let mut out = Vec::new();
    let mut from = a;
    for &(lo, hi) in ranges {
        if lo > from && from < b {
            out.push((from, lo.min(b)));
        }
        from = from.max(hi);
    }
    if from < b {
        out.push((from, b));
    }
    out
}

fn intervals_text(gaps: &[(f64, f64)], g: f64) -> String {
    gaps.iter()
        .map(|(a, b)| format!("{:.3}-{:.3}", a / g, b / g))
        .collect::<Vec<_>>()
        .join(", ")
}

/// The report's paragraph on the exact backbone: its pieces, the q it covers (and the holes of
/// the harmonic balance's main branch it fills), and the main-branch points whose w the exact
/// orbit next to them does not confirm to `tolerance` (relative), named.
pub fn report_paragraph(b: &BackboneFile, e: &BoundaryBackbone) -> String {
    let g = b.gap_reference;
    let mut s = String::new();
    let orbits: usize = e.pieces.iter().map(|p| p.points.len()).sum();
    let _ = writeln!(
        s,
        "Exact backbone of the massless contact boundary (grey in Fig. 3a, \
         `backbone/backbone_boundary.csv`; docs/STABILITY.md Sec. 9.3): the same model as the \
         stability's with the first {} modes dynamic, its symmetric periodic orbits continued \
         in amplitude by shooting, no harmonic truncated: {} pieces, {orbits} orbits. A piece \
         ends where it turns into an internal-resonance tongue (another mode's harmonic holds \
         more energy than the fundamental, or q turns back by 5 %: the exact model meets tongues \
         at every harmonic n, not only n <= N); the next starts from the first \
         harmonic-balance point above it, and the gaps left are seeded from inside (between the \
         harmonic-balance points on either side); each piece is traced both ways.\n",
        e.modes,
        e.pieces.len()
    );
    s.push_str(&pieces_table(e, g, b.omega_linear));
    let main: Vec<&Orbit> = b.points.iter().filter(|p| on_main(b, p)).collect();
    s.push_str(&coverage_text(b, e, &main));
    s.push_str(&crate::backbone::backbone_holes::report_text(
        e,
        g,
        b.omega_linear,
    ));
    s
}

/// One row per piece: its q/g0 and w/w1 ranges and why its ends ended.
fn pieces_table(e: &BoundaryBackbone, g: f64, w1: f64) -> String {
    let mut s =
        String::from("| piece | q/g0 | w/w1 | lower end | upper end |\n|---|---|---|---|---|\n");
    for (k, p) in e.pieces.iter().enumerate() {
        let range = |f: &dyn Fn(&nlmodes_nnm::BoundaryBackbonePoint) -> f64| {
            let v = p.points.iter().map(f);
            let (lo, hi) = v.fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), x| {
                (a.min(x), b.max(x))
            });
            format!("{lo:.3}-{hi:.3}")
        };
        let _ = writeln!(
            s,
            "| {k} | {} | {} | {} | {} |",
            range(&|x| x.q.abs() / g),
            range(&|x| x.omega / w1),
            end_text(&p.lower_end, g, k == 0, p.gap),
            end_text(&p.upper_end, g, false, p.gap)
        );
    }
    s
}

/// The q from grazing to q_max the pieces leave, and what they give in each hole of the
/// harmonic balance's main branch.
fn coverage_text(b: &BackboneFile, e: &BoundaryBackbone, main: &[&Orbit]) -> String {
    let g = b.gap_reference;
    let ranges = e.covered();
    let q_hi = main.iter().map(|p| p.q).fold(0.0, f64::max);
    let q_lo = b.grazing_amplitude.unwrap_or(q_hi);
    let gaps = gaps_in(&ranges, q_lo, q_hi);
    let mut s = format!(
        "\nFrom grazing to q_max the exact pieces give w(q) {}.\n",
        if gaps.is_empty() {
            "for every q".to_string()
        } else {
            format!(
                "for every q/g0 but {} (between pieces that turn into tongues)",
                intervals_text(&gaps, g)
            )
        }
    );
    for r in &b.internal_resonances {
        let Some([a, c]) = r.unjoined else { continue };
        let left = gaps_in(&ranges, a, c);
        let inside: Vec<(f64, f64)> = ranges
            .iter()
            .map(|&(lo, hi)| (lo.max(a), hi.min(c)))
            .filter(|(lo, hi)| hi > lo)
            .collect();
        let covered_text = if inside.is_empty() {
            "no exact piece reaches into it".to_string()
        } else {
            format!(
                "the exact pieces give w(q) for {}",
                intervals_text(&inside, g)
            )
        };
        let left_text = if left.is_empty() {
            String::new()
        } else {
            format!(
                "; {} is left, where the exact curves turn into tongues too",
                intervals_text(&left, g)
            )
        };
        let _ = writeln!(
            s,
            "The harmonic balance's main branch is not traced for q/g0 {:.3}-{:.3}: \
             {covered_text}{left_text}.",
            a / g,
            c / g
        );
    }
    s
}

fn on_main(b: &BackboneFile, p: &Orbit) -> bool {
    matches!(
        b.branches.get(p.branch).map(|x| &x.kind),
        Some(BranchKind::Main)
    )
}
