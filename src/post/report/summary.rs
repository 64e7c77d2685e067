//! The summary `report.md` opens with (issue 39, item 4): a few lines that answer the engine
//! dynamicist's question for the case (excited at engine order e through the speed range, does
//! the blade rub the casing, how hard, at which speeds, is the response stable?) from the speed
//! sweeps' verdict (`crate::post::results::speed_sweep`), then the headline numbers of the backbone
//! and of the forced response, at rest and at the operating speed. Partial results (a stage
//! that stopped early, exit code 3, or a stage the case asks for without its files) are said
//! first. Speeds in rpm, frequencies in Hz, amplitudes over the (running) gap, forces in N.

use std::fmt::Write as _;

use super::ReportInputs;
use crate::campbell::campbell_stage::CampbellData;
use crate::post::results::speed_sweep::{verdicts, CrossingVerdict};
use crate::post::results::{read_json, BackboneFile};

mod files;

use files::{backbone_headline, forced_headline, partial_results};

/// The section: `## Summary` and its lines. In the case's own report (`results/<case>/`): the
/// partial results, the speed range's answer, the backbones and forced responses at rest and at
/// the operating speed; in the report of a speed (`speed/`, `speeds/<rpm>rpm/`) or of a mode
/// (`mode_<k>/`): that layout's backbone (and forced response at speed).
pub(super) fn summary(r: &ReportInputs<'_>) -> String {
    let case_root = r.layout.root == r.case.out_dir();
    let at_speed = !case_root && r.layout.root == r.layout.shared;
    let mut s = String::from("## Summary\n\n");
    let partial = if case_root {
        partial_results(r)
    } else {
        Vec::new()
    };
    if !partial.is_empty() {
        let _ = writeln!(
            s,
            "**Partial results:** {}. The numbers below cover what was computed.\n",
            partial.join("; ")
        );
    }
    if case_root {
        s += &speed_range_line(r).unwrap_or_default();
        s += &casing_line(r);
    }
    let here = if at_speed {
        let p: Option<serde_json::Value> = read_json(&r.layout.root.join("prestress.json")).ok();
        let rpm = p.and_then(|p| p["speed_rpm"].as_f64());
        rpm.map_or(" at speed".into(), |v| format!(" at {v:.0} rpm"))
    } else {
        String::new()
    };
    s += &backbone_headline(&here, r.backbone);
    let op = r.case.rotation.as_ref().map(|x| x.operating_speed);
    let speed = r.layout.shared.join("speed");
    if let (true, Some(rpm)) = (case_root, op) {
        if let Ok(b) = read_json::<BackboneFile>(&speed.join("backbone/backbone.json")) {
            s += &backbone_headline(&format!(" at {rpm:.0} rpm"), &b);
        }
    }
    if r.case.forced.enabled && (case_root || at_speed) {
        s += &forced_headline(r.case, &r.layout.shared.join("forced"), &here);
        if let (true, Some(rpm)) = (case_root, op) {
            s += &forced_headline(r.case, &speed.join("forced"), &format!(" at {rpm:.0} rpm"));
        }
    }
    s + "\nThe tables and figures follow; the case's inputs are in the appendix at the end.\n\n"
}

/// The answer over the speed range: per crossing of the swept mode, the sweeps through it
/// (where and how hard the blade rubs, its stability) and the crossings not swept; `None` for a
/// case without a Campbell diagram.
fn speed_range_line(r: &ReportInputs<'_>) -> Option<String> {
    let dir = r.layout.shared.join("campbell");
    let d: CampbellData = read_json(&dir.join("campbell.json")).ok()?;
    let file = crate::speed_sweep::forced_speed_report::swept(r.case, r.layout)
        .ok()
        .flatten();
    let traced = file.as_ref().map_or(r.case.forced.mode, |f| f.mode);
    let rows = verdicts(file.as_ref(), &d.crossing_refs(), traced);
    let (lo, hi) = (d.speeds_rpm[0], *d.speeds_rpm.last()?);
    let names =
        crate::post::figures::curve_names(&r.layout.shared.join("parametric"), lo, traced + 1);
    let mut s = format!(
        "- **Rubbing through {lo:.0}-{hi:.0} rpm** (forced at W = EO x speed through the \
         crossings of {} with the engine-order lines; `### Forced verdict at the \
         engine-order crossings` below):",
        names[traced]
    );
    let swept: Vec<&CrossingVerdict> = rows.iter().filter(|v| !v.sweeps.is_empty()).collect();
    if swept.is_empty() {
        s += " no speed sweep has run (add `[speed_sweep]` to the case).";
    }
    s.push('\n');
    for v in &swept {
        for w in &v.sweeps {
            s += &sweep_phrase(r, v, w);
        }
    }
    let not: Vec<String> = (rows.iter())
        .filter(|v| v.sweeps.is_empty())
        .map(|v| {
            let c = &v.crossing;
            format!("EO {} ({:.0} rpm)", c.engine_order, c.speed_rpm)
        })
        .collect();
    if !not.is_empty() {
        let _ = writeln!(s, "  - Not swept: {}.", not.join(", "));
    }
    Some(s)
}

/// The casing distortion at the operating speed (`[speed_sweep.casing]`), when it ran.
fn casing_line(r: &ReportInputs<'_>) -> String {
    let enabled = (r.case.speed_sweep.as_ref())
        .is_some_and(|s| s.enabled && s.casing.as_ref().is_some_and(|c| c.enabled));
    let dir = r.layout.shared.join("speed_sweep");
    let summary = crate::post::results::speed_sweep::read_casing::<
        crate::speed_sweep::forced_speed_casing::CasingSummary,
    >(&dir);
    match summary {
        Ok(Some(c)) if enabled => format!(
            "- **Casing distortion** (`## Casing distortion` below): {}.\n",
            crate::speed_sweep::forced_speed_casing::sentence(&c)
        ),
        _ => String::new(),
    }
}

/// One sweep as a sentence: where it touches, how hard, stable or not.
fn sweep_phrase(
    r: &ReportInputs<'_>,
    v: &CrossingVerdict,
    w: &crate::post::results::speed_sweep::SweepRecord,
) -> String {
    let c = &v.crossing;
    let level = crate::speed_sweep::forced_speed_report::level_text(r.case, w);
    let partial = if w.complete { "" } else { " (partial)" };
    let n = w
        .harmonics_note
        .as_ref()
        .map_or(String::new(), |note| format!(" {note}."));
    let head = format!(
        "  - **EO {}** at {level} (crossing {:.0} rpm, swept {:.0}-{:.0} rpm){partial}:",
        c.engine_order, c.speed_rpm, w.range_rpm[0], w.range_rpm[1]
    );
    match w.contact_span() {
        Some([a, b]) => format!(
            "{head} **rubs at {a:.0}-{b:.0} rpm**, peak q/g0 = {:.2} at {:.0} rpm{}, {}; \
             {}.{n}\n",
            w.peak_q1_over_g0,
            w.peak_rpm,
            match w.peak_verdict() {
                "" => String::new(),
                v => format!(" ({v})"),
            },
            files::force_words(
                &format!(
                    "{} N{}",
                    crate::speed_sweep::forced_speed_report::significant(w.max_contact_force_n, 3),
                    w.max_contact_force_rpm
                        .map_or(String::new(), |x| format!(" at {x:.0} rpm"))
                ),
                w.retraces.last(),
                r.case.forced.harmonic_tolerance,
                None
            ),
            w.stability_text()
        ),
        None => format!(
            "{head} no contact, peak q/g0 = {:.2} at {:.0} rpm; {}.{n}\n",
            w.peak_q1_over_g0,
            w.peak_rpm,
            w.stability_text()
        ),
    }
}
