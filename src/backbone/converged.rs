//! The converged orbits of the main branch (issue 24 item 2; docs/STABILITY.md Sec. 9.4): every
//! main-branch point in contact gets the exact orbit of the massless contact boundary at its own
//! q, with N (which sets the modes kept dynamic) doubled until w and the contact shares change by
//! less than the tolerances; the harmonic-balance point is flagged "N too small" where its w is
//! farther than `truncation_tolerance` from that orbit's. Stage `converged orbits`.

use anyhow::{Context, Result};
use std::fmt::Write as _;

use nlmodes_nnm::{
    Backbone, BackbonePoint, ConvergedOrbit, ConvergenceSettings, ConvergenceStop, System,
};

use crate::backbone::on_main_branch;
use crate::case::StabilitySection;
use crate::post::results::{BackboneFile, Orbit};
use crate::ui;

/// The converged orbit of every main-branch point in contact and the "N too small" flag set from
/// it (`nlmodes_nnm::converge_points`), with the stage's progress bar and summary line. Nothing
/// when the stability stage does not shoot (`[stability] enabled`, `shooting`).
pub fn converge(
    system: &System,
    b: &mut Backbone,
    stability: &StabilitySection,
    settings: &ConvergenceSettings,
) -> Result<()> {
    let analysis = stability.analysis();
    if !stability.enabled || !analysis.shooting {
        return Ok(());
    }
    let chosen: Vec<usize> = (0..b.points.len())
        .filter(|&i| on_main_branch(b, i) && in_contact(&b.points[i]))
        .collect();
    if chosen.is_empty() {
        return Ok(());
    }
    let stage = ui::Stage::start("converged orbits");
    let floquet = nlmodes_nnm::FloquetAnalysis::new(system, analysis)
        .context("the modes of the massless contact boundary")?;
    let bar = ui::bar(chosen.len() as u64, "converged orbits");
    nlmodes_nnm::converge_points(&floquet, b, &chosen, settings, || bar.inc(1));
    bar.finish_and_clear();
    stage.done(&summary(b, &chosen, settings));
    Ok(())
}

/// Whether any contact force of the point is positive.
fn in_contact(p: &BackbonePoint) -> bool {
    p.contact_force.iter().flatten().any(|&f| f > 0.0)
}

/// "k of n converged (a at N = 10, b at N = 20, ...); c not (why); d harmonic-balance points
/// farther than tol from theirs (flagged N)".
fn summary(b: &Backbone, chosen: &[usize], settings: &ConvergenceSettings) -> String {
    let points: Vec<&BackbonePoint> = chosen.iter().map(|&i| &b.points[i]).collect();
    let orbits: Vec<&ConvergedOrbit> = points.iter().filter_map(|p| p.converged.as_ref()).collect();
    let mut by_n = std::collections::BTreeMap::<usize, usize>::new();
    for c in orbits.iter().filter(|c| c.converged()) {
        *by_n.entry(c.orbit().harmonics).or_default() += 1;
    }
    let counts: Vec<String> = by_n
        .iter()
        .map(|(n, k)| format!("{k} at N = {n}"))
        .collect();
    let converged = orbits.iter().filter(|c| c.converged()).count();
    let flagged = points.iter().filter(|p| p.truncation_warning).count();
    format!(
        "{converged} of {} main-branch points in contact converged (w to {:e}, contact shares to \
         {} when N is doubled, N <= {}): {}; {} without an orbit, {} not converged; {flagged} \
         harmonic-balance points farther than {:e} from their converged w (flagged N)",
        points.len(),
        settings.omega_tolerance,
        settings.share_tolerance,
        settings.max_harmonics,
        if counts.is_empty() {
            "none".to_string()
        } else {
            counts.join(", ")
        },
        points.len() - orbits.len(),
        orbits.len() - converged,
        settings.omega_tolerance,
    )
}

/// The report's paragraph on the converged orbits: how many converged, how far the harmonic
/// balance is from them, and every main-branch point in contact that has no converged orbit
/// named with why. Empty when none was computed.
pub fn report_paragraph(b: &BackboneFile, settings: &ConvergenceSettings) -> String {
    let g = b.gap_reference;
    let main: Vec<&Orbit> = b
        .points
        .iter()
        .filter(|p| !b.on_tongue(p) && p.contact_fraction.iter().any(|&f| f > 0.0))
        .collect();
    let with: Vec<(&Orbit, &ConvergedOrbit)> = main
        .iter()
        .filter_map(|p| Some((*p, p.converged.as_ref()?)))
        .collect();
    if with.is_empty() {
        return String::new();
    }
    let converged = with.iter().filter(|(_, c)| c.converged()).count();
    let close = with
        .iter()
        .filter(|(p, c)| c.omega_error(p.omega) <= settings.omega_tolerance)
        .count();
    let mut s = format!(
        "\nConverged orbits (docs/STABILITY.md Sec. 9.4; columns `converged_*` of \
         `backbone/backbone.csv`, `backbone_diagnostics.png`): each main-branch point in contact is \
         given the exact periodic orbit of the massless contact boundary at its own q where one \
         is found within 1 % of its w, no harmonic truncated in time; N only sets the modes kept dynamic (w_k <= shooting_cutoff (N + 1) \
         w) and is doubled up to N = {} until w changes by at most {:.0e} and every contact \
         share by at most {} of the period. {converged} of the {} points in contact converged; \
         the harmonic-balance w is within {:.0e} of its converged w at {close} of the {} points \
         with one (the others flagged \"N too small\").\n",
        settings.max_harmonics,
        settings.omega_tolerance,
        settings.share_tolerance,
        main.len(),
        settings.omega_tolerance,
        with.len(),
    );
    let named: Vec<&&Orbit> = main
        .iter()
        .filter(|p| p.converged.as_ref().is_none_or(|c| !c.converged()))
        .collect();
    if named.is_empty() {
        s.push('\n');
        return s;
    }
    s.push_str(
        "\nThe points without a converged orbit, and why:\n\n| q/g0 | w/w1 | converged w/w1 \
         (N) | change of w at 2N | change of a share at 2N | why |\n|---|---|---|---|---|---|\n",
    );
    for p in named {
        let c = p.converged.as_ref();
        let num = |v: Option<f64>| v.map_or("-".to_string(), |x| format!("{x:.1e}"));
        let _ = writeln!(
            s,
            "| {:.3} | {:.6} | {} | {} | {} | {} |",
            p.q / g,
            p.omega_ratio,
            c.map_or("-".to_string(), |c| format!(
                "{:.6} ({})",
                c.orbit().omega / b.omega_linear,
                c.orbit().harmonics
            )),
            num(c.and_then(|c| c.omega_change)),
            num(c.and_then(|c| c.share_change)),
            why(b, p, c, settings),
        );
    }
    s.push('\n');
    s
}

/// Why a point has no converged orbit, with the internal resonance nearest it in q.
fn why(b: &BackboneFile, p: &Orbit, c: Option<&ConvergedOrbit>, s: &ConvergenceSettings) -> String {
    let g = b.gap_reference;
    let reason = match c.map(|c| c.stop) {
        None => "no exact orbit of the boundary at this q within 1 % of the point's w".to_string(),
        Some(ConvergenceStop::SolveFailed) => "the orbit with the modes of 2N was not found".into(),
        Some(ConvergenceStop::MaxHarmonics) => {
            let moving = |v: Option<f64>, tol: f64| v.is_some_and(|x| x > tol);
            let what = match (
                moving(c.and_then(|c| c.omega_change), s.omega_tolerance),
                moving(c.and_then(|c| c.share_change), s.share_tolerance),
            ) {
                (true, true) => "w and a contact share still move",
                (true, false) => "w still moves",
                (false, true) => "a contact share still moves",
                (false, false) => "no finer N within max_harmonics",
            };
            format!(
                "{what} at N = {} (raise `[nnm] max_harmonics`)",
                s.max_harmonics
            )
        }
        Some(ConvergenceStop::Converged) => return String::new(),
    };
    // An internal resonance the continuation met within 10 % in q.
    let nearest = b
        .internal_resonances
        .iter()
        .filter(|r| (r.q - p.q).abs() <= 0.1 * p.q.abs())
        .min_by(|x, y| (x.q - p.q).abs().total_cmp(&(y.q - p.q).abs()));
    match nearest {
        Some(r) => format!(
            "{reason}; next to the internal resonance at q/g0 = {:.2} (harmonic {} near mode {})",
            r.q / g,
            r.harmonic,
            r.mode + 1
        ),
        None => reason,
    }
}
