//! The forced-response study (issue 22; docs/DESIGN.md §10): damping, load and levels from
//! `[forced]`, one frequency continuation per level (in parallel), the backbone's synthesis of
//! each curve. Writing is `forced_output`.

pub(crate) mod forced_distortion;
pub(crate) mod forced_exact;
pub(crate) mod forced_inputs;
pub(crate) mod forced_output;
pub(crate) mod forced_paraview;
pub(crate) mod forced_settings;
pub(crate) mod forced_stage;
pub(crate) mod level_sweep;

use anyhow::{Context, Result};
use faer::Mat;
use indicatif::ProgressBar;
use nlmodes_boundary::CurveEnd;
use nlmodes_forced::{
    modal_ratios, response_curve, synthesize, BoundaryCurve, ForcedSettings, ForcedSolver,
    FreeOrbit, FrequencyResponse, FrfSettings, HarmonicLoad, Load, Sweep, SynthesizedPoint,
};
use nlmodes_nnm::{ContactMethod, HarmonicSettings, System};
use rayon::prelude::*;

use crate::exit::bad_input;
use crate::forced::forced_settings::{ForcedContact, ForcedLoadKind, ForcedSection, LevelUnit};
use crate::post::results::BackboneFile;

/// One curve: its level and the response.
pub struct ForcedCurve {
    /// The level as given (`level_unit`).
    pub level: f64,
    /// The level's load scale: largest entry of the force pattern (N), the total force of a
    /// group load (N), the pressure of a pressure load (Pa).
    pub force: f64,
    /// The traced curve.
    pub response: FrequencyResponse,
    /// The backbone's single-mode synthesis under this load (empty without a backbone).
    pub synthesis: Vec<SynthesizedPoint>,
    /// The exact curve on the massless contact boundary (`[forced] exact_curve`; `None` when
    /// not asked for or the model does not apply).
    pub exact: Option<BoundaryCurve>,
}

/// The study's result.
pub struct ForcedStudy {
    /// w of the swept mode (rad/s).
    pub omega_mode: f64,
    /// g0 (m).
    pub gap_reference: f64,
    /// Master amplitude of first contact of the swept mode (m).
    pub grazing_amplitude: f64,
    /// Master coordinate and the coordinate of the largest load entry.
    pub master: usize,
    pub excitation: usize,
    /// Number of contact rows.
    pub contacts: usize,
    /// Damping ratio each linear mode gets (from C).
    pub modal_damping: Vec<f64>,
    /// Linear frequencies (rad/s).
    pub linear_frequencies: Vec<f64>,
    /// The penalty stiffness used (N/m), if the penalty law.
    pub penalty_stiffness: Option<f64>,
    pub curves: Vec<ForcedCurve>,
    /// The continuations in force level at `level_sweeps` (level 1 and its force; the points'
    /// `level` is the load scale in `level_unit`).
    pub level_sweeps: Vec<ForcedCurve>,
    /// The settings it ran with.
    pub settings: ForcedSection,
    /// The casing distortion (`[forced.distortion]`, docs/DESIGN.md §10.11), as run.
    pub distortion: Option<crate::forced::forced_distortion::DistortionRecord>,
}

/// The unit force pattern: for each harmonic of the excitation its cosine and sine parts, the
/// largest entry over all of them 1 N, and the coordinate of that entry.
pub(crate) struct Pattern {
    harmonics: Vec<(usize, Vec<f64>, Vec<f64>)>,
    excitation: usize,
}

impl Pattern {
    /// The load of a level: the pattern times `force` (N).
    pub(crate) fn scaled(&self, force: f64) -> Load {
        let times = |v: &[f64]| v.iter().map(|x| x * force).collect();
        Load {
            harmonics: self
                .harmonics
                .iter()
                .map(|(h, c, s)| HarmonicLoad {
                    harmonic: *h,
                    cos: times(c),
                    sin: times(s),
                })
                .collect(),
        }
    }

    /// How the pattern's lowest harmonic drives the linear mode `phi`: |phi . (f_c + i f_s)|
    /// (per newton of the level), and sum_i |phi_i| (|f_c,i| + |f_s,i|), the bound of that
    /// product's rounding (n eps times it) and of its size.
    pub(crate) fn drive(&self, phi: &[f64]) -> Result<(f64, f64)> {
        let (_, c, sn) = self
            .harmonics
            .iter()
            .min_by_key(|(h, _, _)| *h)
            .context("empty load")?;
        let dot = |v: &[f64]| phi.iter().zip(v).map(|(a, b)| a * b).sum::<f64>();
        let bound = (phi.iter().zip(c).zip(sn))
            .map(|((p, c), s)| p.abs() * (c.abs() + s.abs()))
            .sum();
        Ok((dot(c).hypot(dot(sn)), bound))
    }
}

/// The pattern of `[forced] load` (`file`: the columns of F.mtx, `crate::forced::forced_settings::file_load`).
pub(crate) fn pattern(
    system: &System,
    s: &ForcedSection,
    file: Option<&Mat<f64>>,
) -> Result<Pattern> {
    let n = system.n_dofs();
    let mut harmonics = Vec::new();
    match (s.load, file) {
        (ForcedLoadKind::File | ForcedLoadKind::Group | ForcedLoadKind::Pressure, Some(f)) => {
            let hs = crate::forced::forced_settings::file_load_harmonics(s);
            let col = |j: usize| (0..n).map(|i| f[(i, j)]).collect::<Vec<f64>>();
            for (k, &h) in hs.iter().enumerate() {
                let sin = if f.ncols() == 1 {
                    vec![0.0; n]
                } else {
                    col(2 * k + 1)
                };
                harmonics.push((h, col(2 * k), sin));
            }
        }
        (ForcedLoadKind::File | ForcedLoadKind::Group | ForcedLoadKind::Pressure, None) => {
            anyhow::bail!("forced.load = {:?} without F.mtx", s.load)
        }
        (ForcedLoadKind::Master, _) => {
            let mut shape = vec![0.0; n];
            shape[system.master()] = 1.0;
            harmonics.push((s.harmonic, shape, vec![0.0; n]));
        }
        (ForcedLoadKind::Mode, _) => {
            let phi = system.linear_mode(s.load_mode)?;
            let m = system.mass();
            let shape = (0..n)
                .map(|i| (0..n).map(|j| m[(i, j)] * phi[j]).sum())
                .collect();
            harmonics.push((s.harmonic, shape, vec![0.0; n]));
        }
    }
    let (mut big, mut excitation) = (0.0_f64, 0);
    for (_, c, sn) in &harmonics {
        for (i, v) in c.iter().chain(sn.iter()).enumerate() {
            if v.abs() > big {
                (big, excitation) = (v.abs(), i % n);
            }
        }
    }
    anyhow::ensure!(big > 0.0, "[forced] the load pattern is zero");
    // A group load is 1 N in total, a pressure load 1 Pa: its levels are the total force or the
    // pressure, not the largest entry.
    let unit = if s.load.is_full_model_load() {
        1.0
    } else {
        big
    };
    for (_, c, sn) in &mut harmonics {
        c.iter_mut().chain(sn.iter_mut()).for_each(|v| *v /= unit);
    }
    Ok(Pattern {
        harmonics,
        excitation,
    })
}

/// Force (N, largest entry) of a level: as given, or the multiple of the force whose linear
/// resonant master response |phi_m| |phi . (f_c + i f_s)| / (2 zeta w^2) of the pattern's lowest
/// harmonic reaches the grazing amplitude.
pub(crate) fn force_of(
    system: &System,
    s: &ForcedSection,
    pattern: &Pattern,
    zeta: f64,
    level: f64,
) -> Result<f64> {
    if s.level_unit == LevelUnit::Newton || level == 0.0 {
        return Ok(level);
    }
    let phi = system.linear_mode(s.mode)?;
    let w = system.linear_frequencies()[s.mode];
    let q = system
        .grazing_amplitude(s.mode)?
        .context("mode never touches")?;
    let (drive, _) = pattern.drive(&phi)?;
    let unit_peak = phi[system.master()].abs() * drive / (2.0 * zeta * w * w);
    anyhow::ensure!(
        unit_peak > 0.0 && zeta > 0.0,
        "forced.level_unit = \"grazing\" needs a load that drives mode {} and damping on it \
         (zeta = {zeta}, |phi . f| = {drive:e})",
        s.mode
    );
    Ok(level * q.abs() / unit_peak)
}

/// The harmonic balance and contact law of `[forced]` on `system`: N, m, and the penalty law's
/// kc = `penalty_factor` x the median static contact stiffness of the rows (N/m; `None` for
/// exact contact). The casing distortion is the caller's (it depends on the sweep).
pub(crate) fn solver_settings(
    system: &System,
    s: &ForcedSection,
) -> Result<(ForcedSettings, Option<f64>)> {
    let mut settings = ForcedSettings::new(s.harmonics)?;
    if s.samples > 0 {
        settings.harmonics = HarmonicSettings::new(s.harmonics, s.samples)?;
    }
    let penalty_stiffness = (s.contact == ForcedContact::Penalty).then(|| {
        let mut ks = system.contact_stiffness().to_vec();
        ks.sort_by(f64::total_cmp);
        s.penalty_factor * ks[ks.len() / 2]
    });
    if let Some(stiffness) = penalty_stiffness {
        settings.algorithm.method = ContactMethod::Penalty { stiffness };
    }
    Ok((settings, penalty_stiffness))
}

/// Runs every level of the study (in parallel), with the backbone's synthesis when given.
pub fn run(
    system: &System,
    s: &ForcedSection,
    damping_matrix: Option<Mat<f64>>,
    file_load: Option<&Mat<f64>>,
    backbone: Option<&BackboneFile>,
) -> Result<ForcedStudy> {
    let c = s
        .damping(damping_matrix)
        .matrix(system)
        .map_err(|e| bad_input(format!("[forced] damping: {e}")))?;
    let ratios = modal_ratios(system, &c);
    let pattern = pattern(system, s, file_load)?;
    let excitation = pattern.excitation;
    let (mut settings, penalty_stiffness) = solver_settings(system, s)?;
    let g0 = system.gap_reference();
    settings.distortion = s.distortion.as_ref().map(|d| d.frequency_sweep(g0));
    let w = system.linear_frequencies()[s.mode];
    let frf = FrfSettings {
        stability: s.stability,
        max_harmonics: Some(s.top_harmonics()),
        harmonic_policy: s.adapt_harmonics.policy(system.n_contacts()),
        harmonic_tolerance: s.harmonic_tolerance,
        ..FrfSettings::new(s.range[0] * w, s.range[1] * w)
    };
    let sweep = LevelSweeps {
        system,
        damping: &c,
        pattern: &pattern,
        zeta: ratios[s.mode],
        settings: &settings,
    };
    let levels = s.curve_levels();
    let bar = crate::ui::bar(levels.len() as u64, "forced");
    // The stage's span ("at rest", "at 8000 rpm") on the pool's threads too.
    let span = tracing::Span::current();
    let (curves, level_sweeps) = own_pool()?.install(|| {
        let curves = levels
            .par_iter()
            .map(|&level| {
                let _in_span = span.enter();
                let curve = sweep.frequency_curve(s, level, (&frf, &bar), backbone);
                bar.inc(1);
                curve
            })
            .collect::<Result<Vec<_>>>()?;
        bar.finish_and_clear();
        anyhow::Ok((curves, sweep.run(s)?))
    })?;
    Ok(ForcedStudy {
        omega_mode: w,
        gap_reference: system.gap_reference(),
        grazing_amplitude: system.grazing_amplitude(s.mode)?.map_or(f64::NAN, f64::abs),
        master: system.master(),
        excitation,
        contacts: system.n_contacts(),
        modal_damping: ratios,
        linear_frequencies: system.linear_frequencies(),
        penalty_stiffness,
        curves,
        level_sweeps,
        settings: s.clone(),
        distortion: s
            .distortion
            .as_ref()
            .map(|d| crate::forced::forced_distortion::DistortionRecord::of_frequency_sweep(d, g0)),
    })
}

/// A pool of worker threads for one forced study (as many as the global pool's): the studies at
/// rest and at the operating speed run side by side (`crate::run`), and on one shared pool the
/// second one's levels waited for the first's (a rayon worker serves the jobs queued by its own
/// work before those injected from another thread: measured on the default case, the study at
/// rest started its levels 57 s after the one at speed). With a pool each, the system shares
/// the cores between the two studies' threads.
fn own_pool() -> Result<rayon::ThreadPool> {
    rayon::ThreadPoolBuilder::new()
        .num_threads(rayon::current_num_threads())
        .thread_name(|i| format!("forced-{i}"))
        .build()
        .context("cannot start the forced study's worker threads")
}

/// What the curves of the study share: the frequency curves of the levels and the
/// continuations in force level at fixed frequencies (`[forced] level_sweeps`; their files:
/// `crate::forced::level_sweep`).
struct LevelSweeps<'a> {
    system: &'a System,
    /// C (N s/m).
    damping: &'a Mat<f64>,
    pattern: &'a Pattern,
    /// Damping ratio of the swept mode (for `level_unit = "grazing"`).
    zeta: f64,
    settings: &'a ForcedSettings,
}

impl LevelSweeps<'_> {
    /// The frequency curve of one level (its exact curve and the backbone's synthesis when
    /// asked for and they apply), its progress on `bar`.
    fn frequency_curve(
        &self,
        s: &ForcedSection,
        level: f64,
        (frf, bar): (&FrfSettings, &ProgressBar),
        backbone: Option<&BackboneFile>,
    ) -> Result<ForcedCurve> {
        let force = force_of(self.system, s, self.pattern, self.zeta, level)?;
        let load = self.pattern.scaled(force);
        let solver = ForcedSolver::new(self.system, self.damping, &load, self.settings.clone())?;
        let curve = trace_level(&solver, frf, bar, level)?;
        let exact = if s.exact_curve {
            exact_level(&solver, &curve, frf, level)?
        } else {
            None
        };
        // The single-mode synthesis is the backbone under a load: not a casing distortion's.
        let synthesis = match (backbone, &self.settings.distortion) {
            (Some(b), None) => synthesis_of(self.system, self.damping, &load, b)?,
            _ => Vec::new(),
        };
        Ok(ForcedCurve {
            level,
            force,
            response: curve,
            synthesis,
            exact,
        })
    }

    /// One curve per `level_sweeps` frequency (in parallel); none when the list is empty.
    fn run(&self, s: &ForcedSection) -> Result<Vec<ForcedCurve>> {
        if s.level_sweeps.is_empty() {
            return Ok(Vec::new());
        }
        let unit = force_of(self.system, s, self.pattern, self.zeta, 1.0)?;
        let load = self.pattern.scaled(unit);
        let w = self.system.linear_frequencies()[s.mode];
        let bar = crate::ui::bar(s.level_sweeps.len() as u64, "level sweeps");
        let curves = s
            .level_sweeps
            .par_iter()
            .map(|&ratio| {
                let frf = FrfSettings {
                    sweep: Sweep::Level { omega: ratio * w },
                    stability: s.stability,
                    max_harmonics: Some(s.top_harmonics()),
                    harmonic_policy: s.adapt_harmonics.policy(self.system.n_contacts()),
                    harmonic_tolerance: s.harmonic_tolerance,
                    ..FrfSettings::new(s.level_range[0], s.level_range[1])
                };
                let solver =
                    ForcedSolver::new(self.system, self.damping, &load, self.settings.clone())?;
                let response = response_curve(&solver, &frf, |p| {
                    bar.set_message(format!("W/w = {ratio}: level {:.3}", p.level));
                })?;
                tracing::info!(
                    "level sweep at W/w = {ratio}: {} points, {} folds, {}",
                    response.points.len(),
                    response.folds.len(),
                    response.end_text()
                );
                bar.inc(1);
                Ok(ForcedCurve {
                    level: 1.0,
                    force: unit,
                    response,
                    synthesis: Vec::new(),
                    exact: None,
                })
            })
            .collect::<Result<Vec<_>>>();
        bar.finish_and_clear();
        curves
    }
}

/// The fixed W of a level sweep (rad/s).
pub fn sweep_frequency(c: &ForcedCurve) -> f64 {
    match c.response.sweep {
        Sweep::Level { omega } => omega,
        Sweep::Frequency => f64::NAN,
    }
}

/// One level's frequency continuation, its progress on the shared bar.
fn trace_level(
    solver: &ForcedSolver<'_>,
    frf: &FrfSettings,
    bar: &ProgressBar,
    level: f64,
) -> Result<FrequencyResponse> {
    let curve = response_curve(solver, frf, |p| {
        bar.set_message(format!("level {level}: W = {:.1} rad/s", p.omega));
    })?;
    tracing::info!(
        "forced level {level}: {} points, {} folds, {}",
        curve.points.len(),
        curve.folds.len(),
        curve.end_text()
    );
    Ok(curve)
}

/// One level's exact curve on the massless contact boundary, from the harmonic-balance curve's
/// first point over the same range.
fn exact_level(
    solver: &ForcedSolver<'_>,
    curve: &FrequencyResponse,
    frf: &FrfSettings,
    level: f64,
) -> Result<Option<BoundaryCurve>> {
    // The exact curve is a second method beside the harmonic balance: its failure is reported,
    // it does not take the level's results with it. Its dynamic modes are those below
    // (N + 1) W at the N the curve converged to (`retraces`), the modes that curve resolves;
    // where that boundary's curve does not reach the end of the range (an added mode's
    // internal resonance: the blade's level 5 with 6 modes stops at W/w = 1.080), the one of
    // the base N is kept when it does, and the log says so.
    let converged = match curve.retraces.last() {
        Some(r) if r.harmonics != solver.basis().harmonics() => {
            Some(solver.with_harmonics(r.harmonics)?)
        }
        _ => None,
    };
    let mut exact = exact_curve(converged.as_ref().unwrap_or(solver), curve, frf, level);
    let stopped =
        |e: &Option<BoundaryCurve>| e.as_ref().is_some_and(|e| e.end != CurveEnd::Complete);
    if converged.is_some() && stopped(&exact) {
        let base = exact_curve(solver, curve, frf, level);
        if base.as_ref().is_some_and(|e| e.end == CurveEnd::Complete) {
            if let Some(e) = &exact {
                tracing::info!(
                    "forced level {level}: the exact curve with the {} modes below (N + 1) W at \
                     the curve's N stopped ({}); the one with the base N's modes is kept",
                    e.modes,
                    nlmodes_boundary::driven_end_text(&e.end)
                );
            }
            exact = base;
        }
    }
    match &exact {
        Some(e) => tracing::info!(
            "forced level {level}: exact curve on the massless boundary ({} modes dynamic): {} \
             points, {} folds, {}",
            e.modes,
            e.points.len(),
            e.points.iter().filter(|p| p.fold).count(),
            nlmodes_boundary::driven_end_text(&e.end)
        ),
        None => tracing::info!(
            "forced level {level}: no exact curve (exact contact on a model whose modes are all \
             resolved, a casing distortion (the boundary's gaps are constant), or its first \
             orbit did not converge)"
        ),
    }
    Ok(exact)
}

/// The exact curve of `solver`'s massless boundary at `curve`'s level, `None` when it fails
/// (logged).
fn exact_curve(
    solver: &ForcedSolver<'_>,
    curve: &FrequencyResponse,
    frf: &FrfSettings,
    level: f64,
) -> Option<BoundaryCurve> {
    match solver.boundary_curve(&curve.points, frf.end, frf.stability_margin) {
        Ok(exact) => exact,
        Err(e) => {
            tracing::warn!("forced level {level}: no exact curve on the massless boundary: {e}");
            None
        }
    }
}

/// The single-nonlinear-mode synthesis of the backbone's main-branch points under `load` (the
/// backbone checked against the model first: `crate::forced::forced_inputs`).
fn synthesis_of(
    system: &System,
    c: &Mat<f64>,
    load: &Load,
    b: &BackboneFile,
) -> Result<Vec<SynthesizedPoint>> {
    let orbits: Vec<FreeOrbit<'_>> = b
        .points
        .iter()
        .filter(|p| !b.on_tongue(p))
        .map(|p| FreeOrbit {
            q: p.q,
            omega: p.omega,
            coefficients: &p.coefficients,
        })
        .collect();
    Ok(synthesize(system.mass(), c.as_ref(), load, &orbits)?)
}

/// Ok when every curve reached the end of its range; otherwise a
/// [`crate::exit::StoppedEarly`] error (exit code 3) naming the levels that stopped and where
/// the partial results are.
pub fn stopped_early(st: &ForcedStudy, dir: &std::path::Path) -> Result<()> {
    let w = st.omega_mode;
    let stopped: Vec<String> = st
        .curves
        .iter()
        .filter(|c| !c.response.termination.covers_range())
        .map(|c| {
            let exact = match &c.exact {
                Some(e) if e.end == CurveEnd::Complete => {
                    "; its exact curve on the massless boundary is complete, in frf_boundary.csv"
                }
                _ => "",
            };
            format!("level {}: {}{exact}", c.level, c.response.end_text())
        })
        .chain(
            st.level_sweeps
                .iter()
                .filter(|c| !c.response.termination.covers_range())
                .map(|c| {
                    let at = sweep_frequency(c) / w;
                    format!("level sweep at W/w = {at}: {}", c.response.end_text())
                }),
        )
        .collect();
    if stopped.is_empty() {
        return Ok(());
    }
    let hint = ". frf.png marks the branch not computed and report.md's forced section names \
                it; a narrower range (forced.range) or a larger max_harmonics may carry the \
                trace through";
    Err(anyhow::Error::new(crate::exit::StoppedEarly(format!(
        "forced response stopped before the end of its range ({}); the points computed are in \
         {}{hint}",
        stopped.join("; "),
        dir.display()
    ))))
}
