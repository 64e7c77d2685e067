//! The holes the exact backbone's pieces leave in the main branch, and why they stay (issue 24
//! item 3; docs/STABILITY.md Sec. 9.3): the pieces' ends next to each hole, followed through
//! their tongues (`nlmodes_nnm::HoleFollow`), written as `backbone/backbone_boundary_holes.csv`
//! and explained in the report.

use std::fmt::Write as _;
use std::path::Path;

use anyhow::{Context, Result};
use nlmodes_nnm::{BoundaryBackbone, HoleFollow, HoleFollowEnd};
use nlmodes_output::{CsvTable, CsvValue};

/// The columns of `backbone_boundary_holes.csv`.
const HEADER: [&str; 11] = [
    "hole_from_q_over_g0",
    "hole_to_q_over_g0",
    "side",
    "point",
    "q_over_g0",
    "omega_ratio",
    "primary_share",
    "secondary_mode",
    "secondary_harmonic",
    "secondary_share",
    "stability",
];

/// Writes `backbone_boundary_holes.csv` into `dir` (one row per followed orbit), or removes a
/// stale one when no hole was followed. `g`: the reference gap (m), `w1`: the linear frequency
/// (rad/s).
pub fn write(e: Option<&BoundaryBackbone>, g: f64, w1: f64, dir: &Path) -> Result<()> {
    let path = dir.join("backbone_boundary_holes.csv");
    let follows = e.map_or(&[][..], |e| &e.hole_follows[..]);
    if follows.is_empty() {
        if path.exists() {
            std::fs::remove_file(&path)
                .with_context(|| format!("cannot remove {}", path.display()))?;
        }
        return Ok(());
    }
    let mut table = CsvTable::new(&HEADER);
    for f in follows {
        for (i, p) in f.points.iter().enumerate() {
            table.push_row(vec![
                (f.hole[0] / g).into(),
                (f.hole[1] / g).into(),
                CsvValue::Text(side(f).into()),
                CsvValue::Int(i as i64),
                (p.q.abs() / g).into(),
                (p.omega / w1).into(),
                p.primary_share.into(),
                CsvValue::Int(p.secondary_mode as i64 + 1),
                p.secondary_harmonic.into(),
                p.secondary_share.into(),
                CsvValue::Text(p.verdict.clone()),
            ])?;
        }
    }
    table.write(&path)?;
    Ok(())
}

/// "k hole edges followed through their tongues (a become another mode's family, b cross the
/// hole); " for the stage's log line, empty when no hole was followed.
pub fn summary(e: &BoundaryBackbone, g: f64) -> String {
    let f = &e.hole_follows;
    if f.is_empty() {
        return String::new();
    }
    let count = |end: HoleFollowEnd| f.iter().filter(|x| x.end == end).count();
    let mut holes: Vec<String> = f
        .iter()
        .map(|x| format!("{:.3}-{:.3}", x.hole[0] / g, x.hole[1] / g))
        .collect();
    holes.dedup();
    format!(
        "holes q/g0 {}: {} edges followed through their tongues ({} become another mode's \
         family, {} cross the hole); ",
        holes.join(", "),
        f.len(),
        count(HoleFollowEnd::OtherMode),
        count(HoleFollowEnd::MetOtherSide)
    )
}

fn side(f: &HoleFollow) -> &'static str {
    if f.from_below {
        "below"
    } else {
        "above"
    }
}

/// The report's sentences on the holes left: for each, where the pieces on either side go when
/// followed through their tongues.
pub fn report_text(e: &BoundaryBackbone, g: f64, w1: f64) -> String {
    let mut s = String::new();
    let mut holes: Vec<[f64; 2]> = e.hole_follows.iter().map(|f| f.hole).collect();
    holes.dedup();
    for hole in holes {
        let _ = write!(
            s,
            "\nThe hole q/g0 {:.3}-{:.3}: each piece next to it was followed on through its tongue \
             (the tongue stop off; light grey dots in Fig. 3a, `backbone/backbone_boundary_holes.csv`).",
            hole[0] / g,
            hole[1] / g
        );
        for f in e.hole_follows.iter().filter(|f| f.hole == hole) {
            let _ = write!(s, " {}", follow_sentence(f, g, w1));
        }
        s.push('\n');
    }
    s
}

/// What one follow found, as a sentence.
fn follow_sentence(f: &HoleFollow, g: f64, w1: f64) -> String {
    let which = if f.from_below {
        format!("The piece below (up to q/g0 = {:.3})", f.hole[0] / g)
    } else {
        format!("The piece above (from q/g0 = {:.3})", f.hole[1] / g)
    };
    let Some(last) = f.points.last() else {
        return format!("{which} could not be followed (no converged step).");
    };
    let at = format!(
        "at q/g0 = {:.3}, w/w1 = {:.4}",
        last.q.abs() / g,
        last.omega / w1
    );
    match &f.end {
        HoleFollowEnd::MetOtherSide => format!(
            "{which} crosses the hole through its tongue and meets the piece on the other side \
             {at} ({} orbits): the main family is connected there, w(q) across the hole is on \
             these orbits.",
            f.points.len()
        ),
        HoleFollowEnd::OtherMode => format!(
            "{which} becomes another mode's family: {at} the traced mode's fundamental holds {:.1} \
             % of the energy and harmonic {} of linear mode {} holds {:.0} % ({} orbits), so the main \
             family does not cross the hole that way.",
            100.0 * last.primary_share,
            last.secondary_harmonic,
            last.secondary_mode + 1,
            100.0 * last.secondary_share,
            f.points.len()
        ),
        HoleFollowEnd::Stopped(end) => format!(
            "{which} was followed for {} orbits up to {at} without meeting the other side or \
             leaving the traced mode ({}).",
            f.points.len(),
            end.text(|q| format!("q/g0 = {:.3}", q / g))
        ),
    }
}
