//! The backbone stage: nonlinear mode of a reduced model traced in amplitude (Algorithm 1 at every
//! point, pseudo-arc-length continuation), written as `backbone.csv` and `backbone.json`.

pub(crate) mod backbone_exact;
pub(crate) mod backbone_holes;
pub(crate) mod backbone_stage;
pub(crate) mod converged;

use anyhow::{Context, Result};
use nlmodes_modal::ReducedModel;
use nlmodes_nnm::{
    analyze_backbone, backbone, Backbone, Bifurcation, BranchKind, ContinuationSettings,
    HarmonicSettings, SolverSettings, System, Termination,
};
use rayon::prelude::*;
use std::fmt::Write as _;

use crate::case::StabilitySection;
use std::path::Path;

use crate::ui;
use nlmodes_output::{CsvTable, CsvValue};

/// The nnm system of a reduced model: its K, M, contact rows (radial unit vectors, Eq. 17), gaps
/// and master coordinate (`master` overrides the model's default).
pub fn system_of(model: &ReducedModel, master: Option<usize>) -> Result<System> {
    let master = master.unwrap_or(model.master.dof);
    Ok(System::new(
        model.m.clone(),
        model.k.clone(),
        model.contact_rows(),
        model.gaps(),
        master,
    )?)
}

/// An amplitude range that stays below grazing has no contact: the mode is linear there, and the
/// run is almost certainly a mistake (wrong gap, wrong master or wrong q_max). Error naming both.
pub fn check_reaches_contact(system: &System, cont: &ContinuationSettings) -> Result<()> {
    let g = system.gap_reference();
    match system.grazing_amplitude(cont.mode)? {
        Some(q) if cont.q_max * g < q.abs() => anyhow::bail!(
            "the amplitude range q/g0 = {} .. {} stays below grazing (contact starts at q/g0 = {:.4}): \
             raise q_max above it",
            cont.q_start,
            cont.q_max,
            q.abs() / g
        ),
        None => anyhow::bail!("no contact row moves in mode {}: the mode never touches", cont.mode),
        _ => Ok(()),
    }
}

/// Trace the backbone with a progress bar over q / g0.
pub fn trace(
    system: &System,
    harmonics: HarmonicSettings,
    params: &SolverSettings,
    cont: &ContinuationSettings,
) -> Result<Backbone> {
    let stage = ui::Stage::start("backbone");
    let scale = 100.0;
    let bar = ui::bar((cont.q_max * scale) as u64, "backbone");
    let g = system.gap_reference();
    let result = backbone(system, harmonics, params.clone(), cont, |p| {
        bar.set_position(((p.q / g).max(0.0) * scale) as u64);
        bar.set_message(format!(
            "q/g0 = {:.3}, w/w1 = {:.5}",
            p.q / g,
            p.omega_ratio
        ));
    })
    .context("tracing the backbone")?;
    bar.finish_and_clear();
    match &result.termination {
        Termination::ReachedMaxAmplitude => {}
        other => tracing::warn!(
            "the backbone stopped before q_max = {} g0: {other:?}; the {} points computed are written",
            cont.q_max,
            result.points.len()
        ),
    }
    let jumps = result.points.iter().filter(|p| p.jump).count();
    if jumps > 0 {
        tracing::info!(
            "{jumps} points accepted at the smallest step (corners of the sampled branch, or hops \
             past tongues), flagged J"
        );
    }
    stage.done(&format!(
        "{} points, last q/g0 = {:.3}, w/w1 = {:.5}",
        result.points.len(),
        result.points.last().map(|p| p.q / g).unwrap_or(0.0),
        result.points.last().map(|p| p.omega_ratio).unwrap_or(1.0)
    ));
    Ok(result)
}

/// The a-posteriori truncation estimate (docs/DESIGN.md §8.5) at every `every`-th point of the
/// linear segment and main branch (0: none) and at each point of `extra` (the kept orbits):
/// each re-solved with 2N harmonics; a summary of the points beyond `tolerance` is logged.
pub fn truncation(
    system: &System,
    harmonics: HarmonicSettings,
    params: &SolverSettings,
    b: &mut Backbone,
    extra: &mut [nlmodes_nnm::BackbonePoint],
    every: usize,
    tolerance: f64,
) -> Result<()> {
    let stage = ui::Stage::start("truncation");
    let chosen: Vec<usize> = (0..b.points.len())
        .filter(|&i| {
            every > 0 && on_main_branch(b, i) && (i % every == 0 || i + 1 == b.points.len())
        })
        .collect();
    let estimate = |p: &nlmodes_nnm::BackbonePoint| {
        nlmodes_nnm::truncation_estimate(system, harmonics, params, p)
            .map_err(|e| {
                let q_over_g0 = p.q / system.gap_reference();
                tracing::warn!(q_over_g0, error = %e, "truncation estimate failed")
            })
            .ok()
    };
    // Independent re-solves, in parallel (each depends on its point alone).
    let found: Vec<_> = chosen.par_iter().map(|&i| estimate(&b.points[i])).collect();
    for (&i, t) in chosen.iter().zip(found) {
        b.points[i].truncation = t;
    }
    extra
        .par_iter_mut()
        .for_each(|p| p.truncation = estimate(p));
    let done: Vec<&nlmodes_nnm::TruncationEstimate> = b
        .points
        .iter()
        .chain(extra.iter())
        .filter_map(|p| p.truncation.as_ref())
        .collect();
    let other = done.iter().filter(|t| !t.same_orbit).count();
    if other > 0 {
        tracing::warn!(
            "at {other} of {} points checked the 2N solve found another orbit at the same q (an \
             internal resonance more harmonics reach): no truncation estimate there",
            done.len()
        );
    }
    let beyond = done
        .iter()
        .filter(|t| t.same_orbit && !t.within(tolerance))
        .count();
    if beyond > 0 {
        tracing::warn!(
            "at {beyond} of {} points checked, doubling N = {} moves w or the contact share by \
             more than {tolerance}: raise [nnm] harmonics there (backbone.csv, truncation columns)",
            done.len(),
            harmonics.harmonics
        );
    }
    stage.done(&format!(
        "{} points re-solved with 2N harmonics, {beyond} beyond {tolerance}",
        done.len()
    ));
    Ok(())
}

/// Whether point `i` lies on the linear segment or the main branch (not on a tongue).
pub fn on_main_branch(b: &Backbone, i: usize) -> bool {
    !matches!(
        b.branches.get(b.points[i].branch).map(|br| &br.kind),
        Some(BranchKind::Tongue { .. })
    )
}

/// Floquet stability of every point (the massless contact boundary for points in contact, Hill's
/// method or the event-based monodromy otherwise; docs/STABILITY.md), when `settings.enabled`:
/// its own progress bar and stage timing, so the extra time shows. The "N too small" flag of a
/// point in contact is set afterwards by `converged::converge`, against its converged orbit.
pub fn stability(system: &System, b: &mut Backbone, settings: &StabilitySection) -> Result<()> {
    if !settings.enabled {
        tracing::info!("stability: off ([stability] enabled = false)");
        return Ok(());
    }
    let stage = ui::Stage::start("stability");
    let bar = ui::bar(b.points.len() as u64, "stability");
    let failed = analyze_backbone(system, b, &settings.analysis(), |done, _| {
        bar.set_position(done as u64)
    })
    .context("Floquet analysis of the backbone")?;
    bar.finish_and_clear();
    if failed > 0 {
        tracing::warn!(
            "{failed} of {} points have no stability (the analysis failed there)",
            b.points.len()
        );
    }
    let count = |word: &str| {
        b.points
            .iter()
            .filter_map(|p| p.stability.as_ref())
            .filter(|s| nlmodes_nnm::verdict_word(&nlmodes_nnm::VerdictInputs::of(s)) == word)
            .count()
    };
    let bifurcations = b.points.iter().filter(|p| p.bifurcation.is_some()).count();
    stage.done(&format!(
        "{} points analysed: {} stable, {} unstable, {} undetermined (the method's own error \
         cannot back a verdict: docs/STABILITY.md), {bifurcations} bifurcations{}",
        b.points.len() - failed,
        count("stable"),
        count("unstable"),
        count("undetermined"),
        checks_text(b),
    ));
    Ok(())
}

/// ", k of k RK4 checks agree" for the points whose shooting verdict was checked
/// (`[stability] verify_every`), empty when none was.
fn checks_text(b: &Backbone) -> String {
    let checks: Vec<&nlmodes_nnm::ShootingCheck> = b
        .points
        .iter()
        .filter_map(|p| p.stability.as_ref()?.check.as_ref())
        .collect();
    if checks.is_empty() {
        return String::new();
    }
    let agree = checks.iter().filter(|c| c.agrees()).count();
    let worst = checks
        .iter()
        .map(|c| c.max_multiplier_change)
        .fold(0.0, f64::max);
    format!(
        "; RK4 check of the massless boundary: {agree} of {} agree (largest |mu| to {worst:.1e})",
        checks.len()
    )
}

/// Columns of `backbone.csv` (units in the names).
pub const CSV_COLUMNS: [&str; 43] = [
    "point",
    "q_over_g0",
    "q_m",
    "omega_rad_s",
    "frequency_hz",
    "omega_ratio",
    "energy_j",
    "mean_gap_over_g0",
    "max_gap_over_g0",
    "max_penetration_over_g0",
    "max_contact_fraction",
    "nodes_in_contact",
    "powell_measure",
    "outer_iterations",
    "inner_solves",
    "newton_iterations",
    "fold",
    "jump",
    "truncation_warning",
    "primary_share",
    "secondary_mode",
    "secondary_harmonic",
    "secondary_share",
    "branch",
    "branch_kind",
    "pre_fold",
    "max_multiplier_abs",
    "trivial_pair_error",
    "bifurcation",
    "truncation_omega_change",
    "truncation_share_change",
    "truncation_same_orbit",
    "stability",
    "boundary_omega_change",
    "boundary_contact_share",
    "converged_omega_ratio",
    "converged_harmonics",
    "converged_modes",
    "converged_max_contact_share",
    "converged_omega_change",
    "converged_share_change",
    "convergence",
    "omega_error_to_converged",
];

/// `backbone.csv`: one row per point, in continuation order (non-finite values are refused).
pub fn backbone_csv(b: &Backbone) -> Result<CsvTable> {
    let g = b.gap_reference;
    let mut table = CsvTable::new(&CSV_COLUMNS);
    for (i, p) in b.points.iter().enumerate() {
        let touching = p.contact_fraction.iter().filter(|&&f| f > 0.0).count();
        let max_frac = p.contact_fraction.iter().cloned().fold(0.0, f64::max);
        let int = |v: usize| CsvValue::Int(v as i64);
        let flag = |v: bool| CsvValue::Int(i64::from(v));
        let row = vec![
            int(i),
            (p.q / g).into(),
            p.q.into(),
            p.omega.into(),
            p.frequency_hz.into(),
            p.omega_ratio.into(),
            p.energy.into(),
            (p.mean_gap_overall / g).into(),
            (p.max_gap_overall / g).into(),
            (p.max_penetration / g).into(),
            max_frac.into(),
            int(touching),
            p.powell_measure.into(),
            int(p.outer_iterations),
            int(p.inner_solves),
            int(p.newton_iterations),
            flag(p.fold),
            flag(p.jump),
            flag(p.truncation_warning),
            p.primary_share.into(),
            int(p.secondary_mode + 1),
            int(p.secondary_harmonic),
            p.secondary_share.into(),
            int(p.branch),
            CsvValue::Text(branch_kind(b, p.branch)),
            flag(p.pre_fold),
        ];
        // Stability: empty cells where it was not computed (never a NaN).
        let stab = p.stability.as_ref();
        let text = |v: Option<String>| CsvValue::Text(v.unwrap_or_default());
        let mut row = row;
        row.push(text(stab.map(|s| s.max_multiplier_abs.to_string())));
        row.push(text(stab.map(|s| s.trivial_pair_error.to_string())));
        row.push(text(p.bifurcation.map(bifurcation_name)));
        // The 2N re-solve, where it was made (empty elsewhere).
        let trunc = p.truncation.as_ref();
        row.push(text(trunc.map(|t| t.omega_change.to_string())));
        row.push(text(trunc.map(|t| t.contact_share_change.to_string())));
        row.push(text(trunc.map(|t| u8::from(t.same_orbit).to_string())));
        // stable / unstable / undetermined (the trivial pair's confidence, issue 24).
        row.push(text(stab.map(|s| {
            nlmodes_nnm::verdict_word(&nlmodes_nnm::VerdictInputs::of(s)).to_string()
        })));
        // The massless boundary's exact orbit (shooting method only): |w_hb / w - 1| and the
        // largest share of the period a contact row is closed.
        let shot = stab.filter(|s| s.method == nlmodes_nnm::StabilityMethod::Shooting);
        row.push(text(shot.map(|s| s.orbit_shift.to_string())));
        row.push(text(shot.map(|s| {
            s.contact_shares
                .iter()
                .copied()
                .fold(0.0, f64::max)
                .to_string()
        })));
        row.extend(converged_cells(p, b.omega_linear));
        table
            .push_row(row)
            .with_context(|| format!("backbone point {i}"))?;
    }
    Ok(table)
}

/// The converged orbit's cells of a row (docs/STABILITY.md Sec. 9.4; empty where there is none).
fn converged_cells(p: &nlmodes_nnm::BackbonePoint, omega_linear: f64) -> Vec<CsvValue> {
    let Some(c) = p.converged.as_ref() else {
        return vec![CsvValue::Text(String::new()); 8];
    };
    let o = c.orbit();
    let opt = |v: Option<f64>| v.map_or(CsvValue::Text(String::new()), CsvValue::from);
    let stop = match c.stop {
        nlmodes_nnm::ConvergenceStop::Converged => "converged",
        nlmodes_nnm::ConvergenceStop::MaxHarmonics => "max_harmonics",
        nlmodes_nnm::ConvergenceStop::SolveFailed => "solve_failed",
    };
    vec![
        (o.omega / omega_linear).into(),
        CsvValue::Int(o.harmonics as i64),
        CsvValue::Int(o.modes as i64),
        o.contact_shares.iter().copied().fold(0.0, f64::max).into(),
        opt(c.omega_change),
        opt(c.share_change),
        CsvValue::Text(stop.into()),
        c.omega_error(p.omega).into(),
    ]
}

/// The CSV name of a bifurcation.
fn bifurcation_name(b: Bifurcation) -> String {
    match b {
        Bifurcation::FoldOrBranchPoint => "fold_or_branch_point",
        Bifurcation::PeriodDoubling => "period_doubling",
        Bifurcation::NeimarkSacker => "neimark_sacker",
    }
    .to_string()
}

/// `linear`, `main`, or `tongue_k<mode>_n<harmonic>` (mode 1-based), for the CSV.
pub fn branch_kind(b: &Backbone, branch: usize) -> String {
    match b.branches.get(branch).map(|br| &br.kind) {
        Some(BranchKind::Linear) => "linear".into(),
        Some(BranchKind::Main) | None => "main".into(),
        Some(BranchKind::Tongue { mode, harmonic }) => format!("tongue_k{}_n{harmonic}", mode + 1),
    }
}

/// Write `backbone.csv` and `backbone.json` (every point with its Fourier coefficients, contact
/// forces, and the run's termination) into `dir`.
pub fn write(b: &Backbone, dir: &Path) -> Result<()> {
    std::fs::create_dir_all(dir).with_context(|| format!("cannot create {}", dir.display()))?;
    for p in &b.points {
        anyhow::ensure!(
            p.omega.is_finite() && p.q.is_finite(),
            "refusing to write a non-finite backbone point (q = {}, w = {})",
            p.q,
            p.omega
        );
    }
    backbone_csv(b)?.write(&dir.join("backbone.csv"))?;
    nlmodes_output::write_json_compact(&dir.join("backbone.json"), b)?;
    Ok(())
}

/// Exit-code plumbing (issue 14): Ok when the backbone reached q_max with points beyond its
/// start; otherwise a [`crate::exit::StoppedEarly`] error (exit code 3) with the reason, the
/// written partial results in `dir` (backbone.csv, and the reason as `termination` in
/// backbone.json) named.
pub fn stopped_early(b: &Backbone, dir: &Path) -> Result<()> {
    let g = b.gap_reference;
    let first = b.points.first().map_or(f64::NAN, |p| p.q);
    let progressed = b.points.iter().any(|p| p.q > first);
    if progressed && b.termination == Termination::ReachedMaxAmplitude {
        return Ok(());
    }
    let last = b.points.last().map_or(f64::NAN, |p| p.q / g);
    let reason = if progressed {
        format!("{:?}", b.termination)
    } else {
        format!("no point beyond the first ({:?})", b.termination)
    };
    Err(anyhow::Error::new(crate::exit::StoppedEarly(format!(
        "the backbone stopped early at q/g0 = {last:.4}: {reason}; the {} points computed are \
         in {} (backbone.csv; the reason is `termination` in backbone.json)",
        b.points.len(),
        dir.display()
    ))))
}

/// Read a reduced-model directory.
pub fn load_model(dir: &Path) -> Result<ReducedModel> {
    ReducedModel::read(dir).with_context(|| format!("reading the reduced model {}", dir.display()))
}

/// The points an augmented-Lagrangian run kept with Powell's measure above epsilon (stalled,
/// `AlgorithmParams::stall_factor`): their count and largest measure, None if there are none.
pub fn stalled_points(
    measures: impl Iterator<Item = f64>,
    algorithm: &nlmodes_nnm::AlgorithmParams,
) -> Option<(usize, f64)> {
    if algorithm.method != nlmodes_nnm::ContactMethod::AugmentedLagrangian {
        return None;
    }
    measures
        .filter(|&g| g > algorithm.epsilon)
        .fold(None, |acc, g| match acc {
            None => Some((1, g)),
            Some((n, worst)) => Some((n + 1, f64::max(worst, g))),
        })
}

/// A short table of the backbone (about 15 rows) for the terminal; `params` are the solver
/// settings it was traced with (for the points accepted above epsilon).
pub fn summary(b: &Backbone, params: &SolverSettings) -> String {
    let g = b.gap_reference;
    let mut s = format!(
        "linear frequency {:.4} Hz, grazing at q/g0 = {}\n{:>8} {:>10} {:>14} {:>8} {:>6}\n",
        b.omega_linear / (2.0 * std::f64::consts::PI),
        b.grazing_amplitude
            .map(|q| format!("{:.4}", q / g))
            .unwrap_or_else(|| "never".into()),
        "q/g0",
        "w/w1",
        "frequency [Hz]",
        "touching",
        "flags"
    );
    let stride = (b.points.len() / 15).max(1);
    for (i, p) in b.points.iter().enumerate() {
        if i % stride != 0 && i + 1 != b.points.len() && !p.fold && !p.jump {
            continue;
        }
        let touching = p.contact_fraction.iter().filter(|&&f| f > 0.0).count();
        let tongue = matches!(
            b.branches.get(p.branch).map(|br| &br.kind),
            Some(BranchKind::Tongue { .. })
        );
        let flags = format!(
            "{}{}{}{}",
            if tongue { "T" } else { "" },
            if p.fold { "F" } else { "" },
            if p.jump { "J" } else { "" },
            if p.truncation_warning { "N" } else { "" }
        );
        let _ = writeln!(
            s,
            "{:>8.3} {:>10.6} {:>14.4} {:>8} {:>6}",
            p.q / g,
            p.omega_ratio,
            p.frequency_hz,
            touching,
            flags
        );
    }
    for r in &b.internal_resonances {
        let _ = writeln!(
            s,
            "internal resonance at q/g0 = {:.3}, w/w1 = {:.4}: harmonic {} near linear mode {} \
             (detuning {:+.1} %, {:.0} % of the energy), {}; {}",
            r.q / g,
            r.omega_ratio,
            r.harmonic,
            r.mode + 1,
            100.0 * r.detuning,
            100.0 * r.share,
            r.branch.map_or("not followed".to_string(), |id| format!(
                "followed as branch {id}"
            )),
            passage_phrase(r, g)
        );
    }
    if let Some((count, worst)) =
        stalled_points(b.points.iter().map(|p| p.powell_measure), &params.algorithm)
    {
        let _ = writeln!(
            s,
            "{count} points accepted where Algorithm 1 stalled above epsilon = {:e} (G up to \
             {worst:.2e} g0, at most stall_factor x epsilon; powell_measure in backbone.csv)",
            params.algorithm.epsilon,
        );
    }
    let _ = writeln!(
        s,
        "termination: {:?}   (flags: F fold, J jump, N harmonics too few, T tongue branch)",
        b.termination
    );
    s
}

/// The orbits at the amplitudes kept for detailed output (q / g0 values), each solved exactly at
/// that q from the backbone point nearest to it, on the first stretch of the branch (in
/// continuation order) that reaches that amplitude. Amplitudes the branch never reached are skipped
/// with a warning.
pub fn kept_points(
    system: &System,
    harmonics: HarmonicSettings,
    params: &SolverSettings,
    b: &Backbone,
    keep: &[f64],
) -> Result<Vec<nlmodes_nnm::BackbonePoint>> {
    let g = b.gap_reference;
    let mut solver = nlmodes_nnm::Solver::new(system, harmonics, params.clone())?;
    let mut out = Vec::new();
    // The linear segment and the main branch, in continuation order (not the tongues).
    let main: Vec<&nlmodes_nnm::BackbonePoint> = b
        .points
        .iter()
        .filter(|p| {
            matches!(
                b.branches.get(p.branch).map(|br| &br.kind),
                None | Some(BranchKind::Linear | BranchKind::Main)
            )
        })
        .collect();
    for &k in keep {
        let target = k * g;
        let crossing = main
            .windows(2)
            .position(|w| (w[0].q - target) * (w[1].q - target) <= 0.0);
        let Some(i) = crossing else {
            tracing::warn!("kept amplitude q/g0 = {k} is outside the computed branch: skipped");
            continue;
        };
        let (a, c) = (main[i], main[i + 1]);
        let start = if (a.q - target).abs() <= (c.q - target).abs() {
            a
        } else {
            c
        };
        let p = solver
            .solve_point(target, nlmodes_nnm::Start::Point(start))
            .with_context(|| format!("solving the orbit at the kept amplitude q/g0 = {k}"))?;
        out.push(p);
    }
    Ok(out)
}

/// How the main branch got past a tongue, in words, and whether its two pieces meet (`g`: the
/// gap reference that normalizes q).
pub fn passage_phrase(r: &nlmodes_nnm::InternalResonance, g: f64) -> String {
    let how = match r.passed {
        Some(nlmodes_nnm::Passage::Predictor) => {
            "main branch continued past it (predictor beyond it, filled back toward it)"
        }
        Some(nlmodes_nnm::Passage::FixedQHop) => "main branch continued past it by a fixed-q hop",
        None => return "the main branch stopped there".into(),
    };
    let why = r.fill_back_stop.as_deref().unwrap_or("unknown");
    match r.unjoined {
        None if r.passed == Some(nlmodes_nnm::Passage::Predictor) => {
            format!("{how}; the pieces meet")
        }
        None => how.into(),
        Some([a, b]) if b > a => format!(
            "{how}; the pieces do not meet: the main branch is not traced for q/g0 between {:.3} \
             and {:.3} (the fill-back from above stopped there: {why})",
            a / g,
            b / g
        ),
        Some([a, b]) => format!(
            "{how}; the pieces overlap in q/g0 ({:.3} .. {:.3}) without meeting (the fill-back \
             stopped: {why})",
            b / g,
            a / g
        ),
    }
}
