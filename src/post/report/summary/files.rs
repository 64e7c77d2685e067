//! What the summary reads of the other stages' files: the backbones' headline numbers, the
//! forced responses' peaks (`forced/frf.csv`), and what stopped early or is missing (the
//! terminations in `frf.json`, `speed_sweep.json` and the backbones at speed).

use std::collections::BTreeMap;
use std::path::Path;

use serde::Deserialize;

use super::ReportInputs;
use crate::case::Case;
use crate::post::results::{read_json, BackboneFile, RetraceHead};
use crate::speed_sweep::forced_speed_report::significant;

/// One line on a backbone: the linear frequency, grazing, the last main-branch point, how many
/// of its points are unstable, and how it ended when it did not reach q_max.
pub(super) fn backbone_headline(at: &str, b: &BackboneFile) -> String {
    let g0 = b.gap_reference;
    let f1 = b.omega_linear / std::f64::consts::TAU;
    let main: Vec<_> = b.points.iter().filter(|p| !b.on_tongue(p)).collect();
    let Some(last) = main.iter().max_by(|a, c| a.q.total_cmp(&c.q)) else {
        return String::new();
    };
    let unstable = (main.iter())
        .filter(|p| p.verdict() == Some("unstable"))
        .count();
    let grazing = b
        .grazing_amplitude
        .map_or("never".to_string(), |q| format!("at q/g0 = {:.2}", q / g0));
    let end = if b.reached_q_max() {
        String::new()
    } else {
        format!("; stopped early: {}", b.termination_text())
    };
    let gap = if at.is_empty() { "cold" } else { "running" };
    format!(
        "- **Free nonlinear mode{at}** (amplitudes over the {gap} gap): linear frequency {f1:.2} \
         Hz, grazing {grazing}, w/w1 = {:.4} at q/g0 = {:.1} ({} main-branch points, \
         {unstable} unstable){end}.\n",
        last.omega_ratio,
        last.q / g0,
        main.len()
    )
}

/// Per level of `frf.csv`: the peak (largest q1/g0) with its W/w and verdict, and the largest
/// contact force.
struct LevelPeak {
    q: f64,
    ratio: f64,
    stability: String,
    force: f64,
}

/// The largest contact force of each level's exact curve on the massless boundary
/// (`dir/frf_boundary.csv`, no harmonic truncated: the reference the harmonic-balance force
/// converges to in N), by level as written; empty without the file.
fn exact_forces(dir: &Path) -> BTreeMap<String, f64> {
    let mut out = BTreeMap::new();
    let Ok(text) = std::fs::read_to_string(dir.join("frf_boundary.csv")) else {
        return out;
    };
    let mut lines = text.lines();
    let Some(header) = lines.next() else {
        return out;
    };
    let header: Vec<&str> = header.split(',').collect();
    let col = |name: &str| header.iter().position(|h| *h == name);
    let (Some(l), Some(f)) = (col("level"), col("max_contact_force_N")) else {
        return out;
    };
    for line in lines {
        let c: Vec<&str> = line.split(',').collect();
        let (Some(level), Some(force)) = (c.get(l), c.get(f).and_then(|v| v.parse::<f64>().ok()))
        else {
            continue;
        };
        let entry = out.entry(level.to_string()).or_insert(0.0_f64);
        *entry = entry.max(force);
    }
    out
}

/// The peaks of `dir/frf.csv` by level (in file order), `None` when absent or unreadable.
fn level_peaks(dir: &Path) -> Option<Vec<(String, LevelPeak)>> {
    let text = std::fs::read_to_string(dir.join("frf.csv")).ok()?;
    let mut lines = text.lines();
    let header: Vec<&str> = lines.next()?.split(',').collect();
    let col = |name: &str| header.iter().position(|h| *h == name);
    let (l, q, w) = (col("level")?, col("q1_over_g0")?, col("omega_ratio")?);
    let (f, st) = (col("max_contact_force_N")?, col("stability")?);
    let mut out: Vec<(String, LevelPeak)> = Vec::new();
    let mut index = BTreeMap::new();
    for line in lines {
        let c: Vec<&str> = line.split(',').collect();
        let num = |i: usize| c.get(i).and_then(|v| v.parse::<f64>().ok());
        let (Some(qv), Some(wv)) = (num(q), num(w)) else {
            continue;
        };
        let level = c.get(l)?.to_string();
        let k = *index.entry(level.clone()).or_insert_with(|| {
            out.push((
                level,
                LevelPeak {
                    q: -1.0,
                    ratio: 0.0,
                    stability: String::new(),
                    force: 0.0,
                },
            ));
            out.len() - 1
        });
        let peak = &mut out[k].1;
        peak.force = peak.force.max(num(f).unwrap_or(0.0));
        if qv > peak.q {
            (peak.q, peak.ratio) = (qv, wv);
            peak.stability = c.get(st).unwrap_or(&"").to_string();
        }
    }
    Some(out)
}

/// One line on the forced response in `dir` (`at`: "" or " at 8000 rpm"); empty without it.
pub(super) fn forced_headline(case: &Case, dir: &Path, at: &str) -> String {
    let Some(peaks) = level_peaks(dir) else {
        return String::new();
    };
    let traces = last_traces(dir).unwrap_or_default();
    let exact = exact_forces(dir);
    let trace_of = |level: &str| {
        let l: f64 = level.parse().ok()?;
        (traces.iter())
            .find(|(v, _)| (v - l).abs() <= 1e-9 * l.abs().max(1e-300))
            .and_then(|(_, t)| t.as_ref())
    };
    let unit = match case.forced.level_unit {
        crate::forced::forced_settings::LevelUnit::Grazing => " x grazing".to_string(),
        _ => format!(" {}", case.forced.load.unit()),
    };
    let parts: Vec<String> = (peaks.iter())
        .map(|(level, p)| {
            let contact = if p.force > 0.0 {
                let reference = (exact.get(level).filter(|&&f| f > 0.0)).map(|&f| {
                    format!(
                        "the exact curve on the massless boundary: {} N",
                        significant(f, 3)
                    )
                });
                let tolerance = case.forced.harmonic_tolerance;
                force_words(
                    &format!("{} N", significant(p.force, 3)),
                    trace_of(level),
                    tolerance,
                    reference,
                )
            } else {
                "no contact".into()
            };
            let stability = if p.stability.is_empty() {
                String::new()
            } else {
                format!(", {}", p.stability)
            };
            format!(
                "level {level}{unit}: peak q/g0 = {:.2} at W/w = {:.3}{stability}, {contact}",
                p.q, p.ratio
            )
        })
        .collect();
    format!(
        "- **Forced response{at}** around mode {} (`[forced]`, amplitudes over the {} gap): \
         {}.\n",
        case.forced.mode + 1,
        if at.is_empty() { "cold" } else { "running" },
        parts.join("; ")
    )
}

#[derive(Deserialize)]
struct FrfHead {
    curves: Vec<CurveHead>,
}

#[derive(Deserialize)]
struct CurveHead {
    level: f64,
    termination: String,
    /// Every trace at its N with its check at 2N (absent from files of earlier versions).
    #[serde(default)]
    retraces: Vec<RetraceHead>,
}

/// Whether a curve's largest contact force is converged in N, as a clause for the parenthesis
/// after the force (`None` without a check): the last trace's strongest point at its N and at
/// 2N (`nlmodes_forced::ForceCheck`), against `tolerance` (`[forced] harmonic_tolerance`). Under
/// a stiff penalty law the peak force converges more slowly in N than the first harmonic: the
/// default blade's level 5 at rest moves 89 % from N = 20 to 40.
pub(crate) fn force_convergence(last: Option<&RetraceHead>, tolerance: f64) -> Option<String> {
    let t = last?;
    let (n, finer) = (t.harmonics, 2 * t.harmonics);
    match (t.largest_contact_force?, t.largest_contact_force_finer) {
        (f, Some(g)) if g > 0.0 => {
            let change = (f - g).abs() / g;
            let word = if change <= tolerance {
                "converged in N"
            } else {
                "NOT converged in N"
            };
            Some(format!(
                "{word}: the N = {n} trace's strongest point {} N, {} N at N = {finer}, {:.1} %",
                significant(f, 3),
                significant(g, 3),
                100.0 * change
            ))
        }
        _ => Some(format!(
            "NOT checked in N: the strongest point's solve at N = {finer} failed"
        )),
    }
}

/// A curve's or sweep's largest contact force as the summary words it: the force on the exact
/// orbits along the last trace (from its strongest point and peak) when they were shot
/// (`nlmodes_forced::ExactForce`: the massless boundary, no truncation in N; where, for a
/// sweep), the number to sign off, with the harmonic balance's `hb` ("268 N", "102 N at 8112
/// rpm") and its convergence in N (`force_convergence`) and `reference` in the parenthesis;
/// else the harmonic balance's with the same parenthesis.
pub(crate) fn force_words(
    hb: &str,
    last: Option<&RetraceHead>,
    tolerance: f64,
    reference: Option<String>,
) -> String {
    let convergence = force_convergence(last, tolerance);
    let exact = last.and_then(|t| t.largest_contact_force_exact.filter(|&f| f > 0.0));
    match exact {
        Some(f) => {
            let at = (last.and_then(|t| t.largest_contact_force_exact_rpm))
                .map_or(String::new(), |x| format!(" at {x:.0} rpm"));
            format!(
                "largest contact force **{} N**{at} on the exact orbits (massless boundary, no \
                 truncation in N){}",
                significant(f, 3),
                parenthesis(&[
                    Some(format!("the harmonic balance's {hb}")),
                    convergence,
                    reference
                ])
            )
        }
        None => format!(
            "largest contact force {hb}{}",
            parenthesis(&[convergence, reference])
        ),
    }
}

/// The clauses of the parenthesis after a largest contact force, joined (empty without any).
pub(crate) fn parenthesis(clauses: &[Option<String>]) -> String {
    let kept: Vec<&str> = clauses.iter().flatten().map(String::as_str).collect();
    match kept.is_empty() {
        true => String::new(),
        false => format!(" ({})", kept.join("; ")),
    }
}

/// The last trace of each curve of `dir/frf.json` by level (`None` when unreadable).
fn last_traces(dir: &Path) -> Option<Vec<(f64, Option<RetraceHead>)>> {
    let f = read_json::<FrfHead>(&dir.join("frf.json")).ok()?;
    Some(
        (f.curves.into_iter())
            .map(|c| (c.level, c.retraces.last().cloned()))
            .collect(),
    )
}

/// The forced curves in `dir` that did not cover their range, or the study missing.
fn forced_partial(dir: &Path, what: &str, out: &mut Vec<String>) {
    match read_json::<FrfHead>(&dir.join("frf.json")) {
        Err(_) => out.push(format!(
            "{what}: not computed (`nlmodes run --only forced`)"
        )),
        Ok(f) => out.extend(
            (f.curves.iter())
                .filter(|c| !c.termination.starts_with("complete"))
                .map(|c| format!("{what}, level {}: {}", c.level, c.termination)),
        ),
    }
}

/// A backbone at a speed that stopped before q_max, or is missing.
fn backbone_partial(dir: &Path, rpm: f64, out: &mut Vec<String>) {
    match read_json::<BackboneFile>(&dir.join("backbone/backbone.json")) {
        Err(_) => out.push(format!("the backbone at {rpm:.0} rpm: not computed")),
        Ok(b) if !b.reached_q_max() => out.push(format!(
            "the backbone at {rpm:.0} rpm stopped early ({})",
            b.termination_text()
        )),
        Ok(_) => {}
    }
}

/// Everything the case asks for that stopped early or is missing, as phrases.
pub(super) fn partial_results(r: &ReportInputs<'_>) -> Vec<String> {
    let (case, shared) = (r.case, &r.layout.shared);
    let mut out = Vec::new();
    if case.forced.enabled {
        forced_partial(
            &shared.join("forced"),
            "the forced response at rest",
            &mut out,
        );
    }
    let Some(rot) = &case.rotation else {
        return out;
    };
    let op = rot.operating_speed;
    backbone_partial(&shared.join("speed"), op, &mut out);
    for rpm in rot.extra_map_speeds() {
        let dir = crate::rotation::speed_stage::map_speed_layout(r.layout, rpm).root;
        backbone_partial(&dir, rpm, &mut out);
    }
    if case.forced.enabled {
        let what = format!("the forced response at {op:.0} rpm");
        forced_partial(&shared.join("speed/forced"), &what, &mut out);
    }
    if case.speed_sweep.as_ref().is_some_and(|s| s.enabled) {
        match crate::speed_sweep::forced_speed_report::swept(case, r.layout) {
            Ok(Some(f)) => out.extend((f.sweeps.iter()).filter(|s| !s.complete).map(|s| {
                format!(
                    "the speed sweep at EO {}, level {}: {}",
                    s.engine_order, s.level, s.end
                )
            })),
            _ => {
                out.push("the speed sweeps: not computed (`nlmodes run --only speed-sweep`)".into())
            }
        }
    }
    let casing = (case.speed_sweep.as_ref())
        .is_some_and(|s| s.enabled && s.casing.as_ref().is_some_and(|c| c.enabled));
    if casing {
        let dir = shared.join("speed_sweep");
        let read = crate::post::results::speed_sweep::read_casing::<
            crate::speed_sweep::forced_speed_casing::CasingSummary,
        >(&dir);
        match read {
            Ok(Some(c)) if !c.complete => out.push(format!("the casing distortion: {}", c.end)),
            Ok(Some(_)) => {}
            _ => out.push(
                "the casing distortion: not computed (`nlmodes run --only speed-sweep`)".into(),
            ),
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn trace(force: Option<f64>, finer: Option<f64>) -> RetraceHead {
        RetraceHead {
            harmonics: 20,
            largest_contact_force: force,
            largest_contact_force_finer: finer,
            largest_contact_force_exact: None,
            largest_contact_force_exact_rpm: None,
        }
    }

    /// The exact orbits' force leads when they were shot, the harmonic balance's and its
    /// convergence in the parenthesis; without them the harmonic balance's leads.
    #[test]
    fn the_exact_orbits_force_leads_the_truncated_one() {
        let shot = RetraceHead {
            largest_contact_force_exact: Some(96.156),
            largest_contact_force_exact_rpm: Some(8136.1),
            ..trace(Some(101.8), Some(94.85))
        };
        let words = force_words("102 N at 8112 rpm", Some(&shot), 1e-3, None);
        assert!(
            words.starts_with("largest contact force **96.2 N** at 8136 rpm on the exact orbits"),
            "{words}"
        );
        assert!(
            words.contains(
                "(the harmonic balance's 102 N at 8112 rpm; NOT converged in N: the N = 20"
            ),
            "{words}"
        );
        let truncated = force_words("268 N", Some(&trace(Some(267.9), Some(202.0))), 1e-3, None);
        assert!(
            truncated.starts_with("largest contact force 268 N (NOT converged in N"),
            "{truncated}"
        );
        assert_eq!(
            force_words("5 N", None, 1e-3, None),
            "largest contact force 5 N"
        );
    }

    /// The summary's word on a curve's largest contact force: NOT converged when its strongest
    /// point moves by more than the tolerance at 2N (with both forces and the change), converged
    /// within it, NOT checked when the 2N solve failed, nothing without a check or contact.
    #[test]
    fn the_largest_contact_force_says_whether_it_is_converged_in_n() {
        let moving = force_convergence(Some(&trace(Some(267.9), Some(202.0))), 1e-3).unwrap();
        assert!(moving.starts_with("NOT converged in N"), "{moving}");
        assert!(
            moving.contains("268 N, 202 N at N = 40, 32.6 %"),
            "{moving}"
        );
        let settled = force_convergence(Some(&trace(Some(100.0), Some(100.05))), 1e-3).unwrap();
        assert!(settled.starts_with("converged in N"), "{settled}");
        let failed = force_convergence(Some(&trace(Some(100.0), None)), 1e-3).unwrap();
        assert!(failed.starts_with("NOT checked in N"), "{failed}");
        assert_eq!(force_convergence(Some(&trace(None, None)), 1e-3), None);
        assert_eq!(force_convergence(None, 1e-3), None);
        assert_eq!(parenthesis(&[None, None]), "");
        let both = parenthesis(&[Some("a".into()), None, Some("b".into())]);
        assert_eq!(both, " (a; b)");
    }
}
