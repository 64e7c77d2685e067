//! Forced responses of the rotating blade on its parametric reduced model (issue 39, items 1
//! and 2; docs/ROTATION.md "Forced response at speed"): the reduced model at one speed
//! (`nlmodes forced PARAMETRIC_DIR --speed RPM`), and the speed sweeps of `[speed_sweep]`: for
//! each engine order e whose line crosses the traced mode's Campbell curve inside the speed
//! range, the forced response at W = e Omega continued in Omega over the detuning window
//! around the crossing (`nlmodes_forced::speed_sweep`), K_r(Omega), the running gaps, the
//! damping and the load following the speed. Writing: `forced_speed_output`.

use std::path::Path;

use anyhow::{Context, Result};
use faer::Mat;
use nlmodes_forced::{
    modal_ratios, speed_sweep, ForcedError, ForcedSettings, LobedCasing, SpeedFamily, SpeedProblem,
    SpeedSweep, SpeedSweepSettings,
};
use nlmodes_modal::{ParametricModel, ReducedModel};
use rayon::prelude::*;

use crate::exit::bad_input;
use crate::forced::forced_settings::ForcedSection;
use crate::rotation::rotation_settings::RPM_TO_RAD_S;
use crate::speed_sweep::speed_sweep_settings::SpeedSweepSection;

/// Speeds sampled over the range to find the crossings, the windows and the closure.
const GRID: usize = 201;

/// Where the sweeps stop short of a static closure: the smallest running gap at this share of
/// the cold gap.
pub const CLOSURE_SHARE: f64 = 0.01;

/// The parametric model in `dir`; any failure is bad input naming the directory.
pub fn read_parametric(dir: &Path) -> Result<ParametricModel> {
    ParametricModel::read(dir).map_err(|e| {
        anyhow::Error::new(e).context(crate::exit::BadInput(format!(
            "reading the parametric reduced model {}",
            dir.display()
        )))
    })
}

/// The reduced model at `rpm` of the parametric model `p` read from `dir`, with the recovery
/// basis of its reference (the same reduced coordinates at every speed); a speed outside the
/// model's range or where a running gap is closed is bad input naming `flag`.
pub fn model_at_speed(
    p: &ParametricModel,
    dir: &Path,
    rpm: f64,
    flag: &str,
) -> Result<ReducedModel> {
    let (lo, hi) = p.range();
    let omega = rpm * RPM_TO_RAD_S;
    if !(omega.is_finite() && omega >= lo && omega <= hi) {
        return Err(bad_input(format!(
            "{flag} = {rpm}: expected a speed within the range of the parametric model {} = \
             [{}, {}] rpm",
            dir.display(),
            lo / RPM_TO_RAD_S,
            hi / RPM_TO_RAD_S
        )));
    }
    let mut model = p
        .at(omega)
        .map_err(|e| bad_input(format!("{flag} = {rpm}: {e}")))?;
    model.recovery = p.reference().recovery.clone();
    Ok(model)
}

/// The forced problems along the speed: the parametric model at each speed, with the damping,
/// the load pattern and the force of one sweep.
struct ParametricFamily<'a> {
    model: &'a ParametricModel,
    section: &'a ForcedSection,
    /// C.mtx (`damping_matrix = true`): the same at every speed.
    damping_matrix: Option<&'a Mat<f64>>,
    file_load: Option<&'a Mat<f64>>,
    /// The level's load scale (`crate::forced::force_of`).
    force: f64,
    /// The problems built so far, by the speed's bits: a sweep's solves, their corrections onto
    /// the speed line, each point's stability and exact force ask for the same speeds again
    /// (session 28: 3568 builds for 2357 speeds on the EO 3 sweep), and a build is an
    /// eigen-decomposition of the reduced model.
    built: std::sync::Mutex<std::collections::HashMap<u64, SpeedProblem>>,
}

/// Problems a family keeps at most (each about 0.5 MB on the default blade; emptied, then
/// refilled, past this).
const MOST_BUILT: usize = 64;

impl ParametricFamily<'_> {
    /// The problem at `speed`, built once ([`Self::build`]) and kept.
    fn problem(&self, speed: f64) -> Result<SpeedProblem> {
        let lock = || (self.built.lock()).unwrap_or_else(|poisoned| poisoned.into_inner());
        if let Some(held) = lock().get(&speed.to_bits()) {
            return Ok(held.clone());
        }
        let problem = self.build(speed)?;
        let mut built = lock();
        if built.len() >= MOST_BUILT {
            built.clear();
        }
        built.insert(speed.to_bits(), problem.clone());
        Ok(problem)
    }

    /// The structure, damping and load at `speed` (rad/s).
    fn build(&self, speed: f64) -> Result<SpeedProblem> {
        let reduced = self.model.structure_at(speed)?;
        let system = crate::backbone::system_of(&reduced, None)?;
        let damping = self
            .section
            .damping(self.damping_matrix.cloned())
            .matrix(&system)?;
        let pattern = crate::forced::pattern(&system, self.section, self.file_load)?;
        Ok(SpeedProblem {
            load: pattern.scaled(self.force),
            system,
            damping,
        })
    }
}

impl SpeedFamily for ParametricFamily<'_> {
    fn at(&self, speed: f64) -> Result<SpeedProblem, ForcedError> {
        self.problem(speed).map_err(|e| ForcedError::Speed {
            speed,
            reason: format!("{e:#}"),
        })
    }
}

/// w (rad/s) of mode `mode` of the parametric model at `speed` (rad/s).
fn mode_frequency(model: &ParametricModel, mode: usize, speed: f64) -> Result<f64> {
    let k = model.stiffness_at(speed)?;
    let f = nlmodes_modal::reduced_model::linear_frequencies_hz(&k, model.mass(), mode + 1)?;
    Ok(2.0 * std::f64::consts::PI * f[mode])
}

/// The zeros of `g` between the first and last of `samples` ((speed, g(speed)), speeds
/// increasing, rad/s): its sign changes between samples, each refined by bisection to 1e-12 of
/// the last speed.
fn zeros(g: &dyn Fn(f64) -> Result<f64>, samples: &[(f64, f64)]) -> Result<Vec<f64>> {
    let top = samples.last().map_or(0.0, |s| s.0.abs());
    let mut out = Vec::new();
    for pair in samples.windows(2) {
        let [(a, ga), (b, gb)] = [pair[0], pair[1]];
        if ga == 0.0 {
            out.push(a);
            continue;
        }
        if ga * gb > 0.0 {
            continue;
        }
        let (mut lo, mut hi) = (a, b);
        while hi - lo > 1e-12 * top {
            let mid = 0.5 * (lo + hi);
            if g(mid)? * ga > 0.0 {
                lo = mid;
            } else {
                hi = mid;
            }
        }
        out.push(0.5 * (lo + hi));
    }
    Ok(out)
}

/// `GRID` speeds over [a, b] with `f` at each.
fn sampled(f: &dyn Fn(f64) -> Result<f64>, a: f64, b: f64) -> Result<Vec<(f64, f64)>> {
    (0..GRID)
        .map(|i| {
            let x = a + (b - a) * i as f64 / (GRID - 1) as f64;
            Ok((x, f(x)?))
        })
        .collect()
}

/// The Campbell curve of the traced mode over the sweep range: w (rad/s) sampled once, then
/// the speeds where e Omega = r w(Omega).
struct ModeCurve<'a> {
    model: &'a ParametricModel,
    mode: usize,
    samples: Vec<(f64, f64)>,
}

impl<'a> ModeCurve<'a> {
    fn new(model: &'a ParametricModel, mode: usize, (a, b): (f64, f64)) -> Result<Self> {
        let samples = sampled(&|x| mode_frequency(model, mode, x), a, b)?;
        Ok(Self {
            model,
            mode,
            samples,
        })
    }

    fn w(&self, speed: f64) -> Result<f64> {
        mode_frequency(self.model, self.mode, speed)
    }

    /// The speeds in [a, b] (within the sampled range) where e Omega = r w(Omega).
    fn detuned(&self, e: f64, r: f64, (a, b): (f64, f64)) -> Result<Vec<f64>> {
        let g = |x: f64| -> Result<f64> { Ok(e * x - r * self.w(x)?) };
        let mut at: Vec<(f64, f64)> = vec![(a, g(a)?)];
        at.extend(
            (self.samples.iter())
                .filter(|(x, _)| *x > a && *x < b)
                .map(|&(x, w)| (x, e * x - r * w)),
        );
        at.push((b, g(b)?));
        zeros(&g, &at)
    }
}

/// One sweep to run: an engine order's crossing and the speeds around it.
#[derive(Clone, Debug)]
pub struct SweepPlan {
    pub engine_order: usize,
    /// The crossing's speed (rad/s) and frequency w_mode = e Omega there (rad/s).
    pub crossing: f64,
    pub crossing_frequency: f64,
    /// The speeds swept (rad/s).
    pub start: f64,
    pub end: f64,
}

/// The speed range (rad/s) of the sweeps: `speed_range` or the model's, cut where the
/// smallest running gap falls to `CLOSURE_SHARE` of the cold gap; and that closure speed.
fn sweep_range(
    model: &ParametricModel,
    s: &SpeedSweepSection,
) -> Result<((f64, f64), Option<f64>)> {
    let (lo, hi) = s.speed_range.map_or_else(
        || model.range(),
        |[a, b]| (a * RPM_TO_RAD_S, b * RPM_TO_RAD_S),
    );
    let cold = model
        .contact()
        .iter()
        .map(|c| c.cold_gap)
        .fold(f64::INFINITY, f64::min);
    let open = |speed: f64| -> Result<f64> {
        let nodes = model.contact_nodes_at(speed)?;
        let g = nodes.iter().map(|n| n.gap).fold(f64::INFINITY, f64::min);
        Ok(g - CLOSURE_SHARE * cold)
    };
    let closure = zeros(&open, &sampled(&open, lo, hi)?)?.first().copied();
    Ok(((lo, closure.unwrap_or(hi)), closure))
}

/// The engine orders to sweep and the key that names them: `[speed_sweep] engine_orders` (or
/// the Campbell diagram's, `default_orders`), or the casing's lobes for a casing distortion
/// alone (`alone`: its lobes; docs/DESIGN.md §10.11).
fn orders(
    s: &SpeedSweepSection,
    default_orders: &[i64],
    alone: Option<usize>,
) -> (Vec<usize>, &'static str, bool) {
    match alone {
        Some(n) => (vec![n], "forced.distortion.lobes", true),
        None => (
            s.orders(default_orders),
            "speed_sweep.engine_orders",
            !s.engine_orders.is_empty(),
        ),
    }
}

/// The sweeps of `[speed_sweep]` on `model` around mode `mode`: every crossing of the engine
/// orders inside the range (the casing's lobes for a distortion alone, `alone`), each with its
/// window. An engine order listed without a crossing there, or no crossing at all, is bad input
/// naming `source`.
pub fn plan(
    model: &ParametricModel,
    mode: usize,
    s: &SpeedSweepSection,
    (default_orders, alone): (&[i64], Option<usize>),
    source: &str,
) -> Result<(Vec<SweepPlan>, Option<f64>)> {
    let ((lo, hi), closure) = sweep_range(model, s)?;
    let curve = ModeCurve::new(model, mode, (lo, hi))?;
    let mut plans = Vec::new();
    let (list, key, explicit) = orders(s, default_orders, alone);
    for e in list.iter().copied() {
        let ef = e as f64;
        let crossings = curve.detuned(ef, 1.0, (lo, hi))?;
        if crossings.is_empty() && explicit {
            let hz = |w: f64| w / std::f64::consts::TAU;
            return Err(bad_input(format!(
                "{source}: {key} = {e}: expected an engine order whose line \
                 crosses mode {mode} within [{:.1}, {:.1}] rpm (mode {mode}: {:.2} .. {:.2} Hz, \
                 {e} x speed: {:.2} .. {:.2} Hz)",
                lo / RPM_TO_RAD_S,
                hi / RPM_TO_RAD_S,
                hz(curve.w(lo)?),
                hz(curve.w(hi)?),
                hz(ef * lo),
                hz(ef * hi),
            )));
        }
        for crossing in crossings {
            let below = curve.detuned(ef, s.window[0], (lo, crossing))?;
            let above = curve.detuned(ef, s.window[1], (crossing, hi))?;
            plans.push(SweepPlan {
                engine_order: e,
                crossing,
                crossing_frequency: ef * crossing,
                start: below.last().copied().unwrap_or(lo).max(1e-3 * crossing),
                end: above.first().copied().unwrap_or(hi),
            });
        }
    }
    if plans.is_empty() {
        return Err(bad_input(format!(
            "{source}: no engine order of {:?} crosses mode {mode} within [{:.1}, {:.1}] rpm: \
             nothing to sweep (expected speed_sweep.engine_orders or speed_sweep.speed_range \
             with a crossing)",
            list,
            lo / RPM_TO_RAD_S,
            hi / RPM_TO_RAD_S
        )));
    }
    Ok((plans, closure))
}

/// One traced sweep.
pub struct SweepRun {
    pub plan: SweepPlan,
    /// The level as given and its load scale (N, or Pa for a pressure).
    pub level: f64,
    pub force: f64,
    pub sweep: SpeedSweep,
    /// The casing distortion of the sweep (`[forced.distortion]`), as run.
    pub casing: Option<crate::speed_sweep::forced_speed_distortion::SweepCasing>,
}

/// The study's result.
pub struct SpeedSweepStudy {
    pub mode: usize,
    pub master: usize,
    /// Contact rows.
    pub contacts: usize,
    /// The cold gap (m), the smallest of the contact nodes'.
    pub cold_gap: f64,
    pub penalty_stiffness: Option<f64>,
    /// Where the smallest running gap falls to `CLOSURE_SHARE` of the cold gap (rad/s).
    pub closure: Option<f64>,
    /// The parametric model's measured error.
    pub accuracy: Option<nlmodes_modal::Accuracy>,
    /// `[forced] harmonics` (the first trace's N) and `harmonic_tolerance`.
    pub harmonics: usize,
    pub harmonic_tolerance: f64,
    pub runs: Vec<SweepRun>,
}

/// What the sweeps share: the model, the settings and the inputs of `[forced]`.
pub struct SweepInputs<'a> {
    pub model: &'a ParametricModel,
    pub forced: &'a ForcedSection,
    pub sweep: &'a SpeedSweepSection,
    pub damping_matrix: Option<&'a Mat<f64>>,
    pub file_load: Option<&'a Mat<f64>>,
    /// Where the settings come from, for messages.
    pub source: &'a str,
}

impl SweepInputs<'_> {
    /// The forced problems of the sweeps along the speed, at load scale `force`.
    fn family(&self, force: f64) -> ParametricFamily<'_> {
        ParametricFamily {
            model: self.model,
            section: self.forced,
            damping_matrix: self.damping_matrix,
            file_load: self.file_load,
            force,
            built: Default::default(),
        }
    }

    /// The casing of each plan's sweep, checked at its crossing's speed before any sweep runs
    /// (`crate::speed_sweep::forced_speed_distortion::casing`).
    fn casings(&self, plans: &[SweepPlan]) -> Result<Vec<Option<LobedCasing>>> {
        let alone =
            crate::speed_sweep::forced_speed_distortion::alone(self.forced, self.sweep).is_some();
        plans
            .iter()
            .map(|plan| {
                let at = self.family(1.0).problem(plan.crossing)?;
                let checked = (&at.system, alone);
                crate::speed_sweep::forced_speed_distortion::casing(
                    self.forced,
                    plan.engine_order,
                    checked,
                    self.source,
                )
            })
            .collect()
    }
}

/// Runs every (crossing, level) sweep of `plans`, in parallel.
pub fn run(
    inputs: &SweepInputs<'_>,
    plans: &[SweepPlan],
    closure: Option<f64>,
) -> Result<SpeedSweepStudy> {
    let (model, s) = (inputs.model, inputs.forced);
    let reference = crate::backbone::system_of(model.reference(), None)?;
    let (solver, penalty_stiffness) = crate::forced::solver_settings(&reference, s)?;
    let levels = crate::speed_sweep::forced_speed_distortion::levels(s, inputs.sweep);
    let casings = inputs.casings(plans)?;
    let jobs: Vec<(&SweepPlan, Option<LobedCasing>, f64)> = (plans.iter().zip(casings))
        .flat_map(|(p, c)| levels.iter().map(move |&l| (p, c, l)))
        .collect();
    let bar = crate::ui::bar(jobs.len() as u64, "speed sweeps");
    let runs = jobs
        .par_iter()
        .map(|&(plan, casing, level)| {
            let run = one_sweep(inputs, (plan, casing), level, &solver, &bar);
            bar.inc(1);
            run
        })
        .collect::<Result<Vec<_>>>();
    bar.finish_and_clear();
    Ok(SpeedSweepStudy {
        mode: s.mode,
        master: model.reference().master.dof,
        contacts: model.contact().len(),
        cold_gap: model
            .contact()
            .iter()
            .map(|c| c.cold_gap)
            .fold(f64::INFINITY, f64::min),
        penalty_stiffness,
        closure,
        accuracy: model.accuracy().cloned(),
        harmonics: s.harmonics,
        harmonic_tolerance: s.harmonic_tolerance,
        runs: runs?,
    })
}

/// One sweep (under its casing, if any): the level's load scale at the crossing's speed, then
/// the continuation.
fn one_sweep(
    inputs: &SweepInputs<'_>,
    (plan, casing): (&SweepPlan, Option<LobedCasing>),
    level: f64,
    solver: &ForcedSettings,
    bar: &indicatif::ProgressBar,
) -> Result<SweepRun> {
    let s = inputs.forced;
    let mut family = inputs.family(1.0);
    let at_crossing = family.problem(plan.crossing)?;
    let pattern = crate::forced::pattern(&at_crossing.system, s, inputs.file_load)?;
    let zeta = modal_ratios(&at_crossing.system, &at_crossing.damping)[s.mode];
    family.force = crate::forced::force_of(&at_crossing.system, s, &pattern, zeta, level)?;
    let mut settings = SpeedSweepSettings::new(
        plan.engine_order,
        s.mode,
        (plan.start, plan.end),
        plan.crossing,
        solver.clone(),
    );
    settings.stability = s.stability;
    settings.max_points = inputs.sweep.max_points;
    settings.casing = casing;
    settings.harmonic_policy = inputs.sweep.adapt_harmonics.policy();
    settings.max_harmonics = s.top_harmonics();
    settings.harmonic_tolerance = s.harmonic_tolerance;
    let e = plan.engine_order;
    let sweep = speed_sweep(&family, &settings, |p| {
        bar.set_message(format!(
            "EO {e}, level {level}: {:.1} rpm",
            p.speed / RPM_TO_RAD_S
        ));
    })
    .with_context(|| format!("speed sweep at engine order {e}, level {level}"))?;
    tracing::info!(
        "speed sweep EO {e}, level {level}: {} points, {} folds, {}; {}",
        sweep.points.len(),
        sweep.folds.len(),
        sweep.end_text(),
        harmonics_note(&sweep, s.harmonic_tolerance)
    );
    let g0 = at_crossing.system.gap_reference();
    Ok(SweepRun {
        plan: plan.clone(),
        level,
        force: family.force,
        sweep,
        casing: casing
            .map(|c| crate::speed_sweep::forced_speed_distortion::SweepCasing::of(&c, e, g0)),
    })
}

/// The sweep's N and what its check at 2N found, in words ("N = 10, not checked" under
/// `adapt_harmonics = "fixed"`), and where N was raised around the points that moved (one
/// line: it also fills a table cell).
pub fn harmonics_note(sweep: &nlmodes_forced::SpeedSweep, tolerance: f64) -> String {
    let Some(last) = sweep.retraces.last() else {
        return format!("N = {}, not checked", sweep.harmonics);
    };
    let traced: Vec<usize> = sweep.retraces.iter().map(|t| t.harmonics).collect();
    // A checked point whose 2N solve failed keeps that verdict, or (N raised around the
    // moving ones) is among the raised segments' failed points.
    let raised = sweep.raised.as_ref();
    let checks: Vec<nlmodes_forced::HarmonicCheck> = (last.checked.iter())
        .filter_map(|&i| {
            let failed = raised.is_some_and(|r| r.failed.contains(&i));
            let check = sweep.points.get(i).map(|p| p.point.harmonic_check);
            match failed {
                true => Some(nlmodes_forced::HarmonicCheck::NotConverged { change: None }),
                false => check,
            }
        })
        .collect();
    let converged = sweep.harmonics_converged() == Some(true);
    let mut out = check_note(
        last,
        &traced,
        &checks,
        converged,
        raised.is_some(),
        tolerance,
    );
    if let Some(raised) = raised {
        let range = |a: usize, b: usize| {
            let rpm = sweep.points[a..=b].iter().map(|p| p.speed / RPM_TO_RAD_S);
            let (lo, hi) = rpm.fold((f64::INFINITY, 0.0_f64), |(l, h), v| (l.min(v), h.max(v)));
            match a == b {
                true => format!("{lo:.1} rpm"),
                false => format!("{lo:.1}..{hi:.1} rpm"),
            }
        };
        out += "; ";
        out +=
            crate::forced::forced_output::raised_segments_note(raised, tolerance, &range, "speed")
                .trim();
    }
    out
}

/// [`harmonics_note`] of the last trace `last` (its checked points' verdicts `checks`), the N
/// of every trace `traced`, whether the sweep's N is `converged` (with its raised segments,
/// when `raised`). `CurveHarmonics::not_converged` counts both the checked points that moved
/// by more than the tolerance at 2N and those whose 2N solve failed or landed on another
/// orbit, while `largest_change` is over the solved ones only: the two are told apart here.
fn check_note(
    last: &nlmodes_forced::CurveHarmonics,
    traced: &[usize],
    checks: &[nlmodes_forced::HarmonicCheck],
    converged: bool,
    raised: bool,
    tolerance: f64,
) -> String {
    use nlmodes_forced::HarmonicCheck;
    let failed = (checks.iter())
        .filter(|c| matches!(c, HarmonicCheck::NotConverged { change: None }))
        .count();
    let traced: Vec<String> = traced.iter().map(ToString::to_string).collect();
    // The frequency sweep's wording of the same check (one implementation).
    let verdict = crate::forced::forced_output::check_verdict(last, failed, raised, tolerance);
    let verdict = if last.checked.is_empty() {
        "no point in contact (linear: exact at any N)".to_string()
    } else if converged || raised || !last.checkable {
        // With N raised around the moving points the raised segments' note says whether the
        // sweep is converged (the last word).
        verdict
    } else {
        format!("NOT converged: {verdict}")
    };
    let solved = last.checked.len() - failed;
    format!(
        "N = {} (traced at N = {}): {verdict}; largest change at 2N {:.1e} in q1, {:.1e} in \
         speed (over the {solved} solved){}",
        last.harmonics,
        traced.join(", "),
        last.largest_change[0],
        last.largest_change[1],
        crate::forced::forced_output::force_note(last, "N")
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The default EO 3 sweep's check (issue 39, session 21): 8 points checked at 2N, 6 of
    /// them not solved again there, the other 2 within the tolerance (2.2e-4). The note said
    /// "6 of its 8 checked points move by more than 1e-3" beside "largest change 2.2e-4":
    /// the count was of the failed solves. It must say which is which.
    #[test]
    fn the_check_note_tells_failed_solves_from_moved_points() {
        use nlmodes_forced::{CurveHarmonics, HarmonicCheck};
        let last = CurveHarmonics {
            harmonics: 10,
            checked: (0..8).collect(),
            not_converged: 6,
            largest_change: [2.2e-4, 2.1e-4],
            checkable: true,
            force: None,
        };
        let mut checks = vec![HarmonicCheck::NotConverged { change: None }; 6];
        checks.extend(
            [HarmonicCheck::Converged {
                change: [2.2e-4, 2.1e-4],
            }; 2],
        );
        let note = check_note(&last, &[10], &checks, last.converged(), false, 1e-3);
        assert!(note.contains("0 move by more than 1e-3"), "{note}");
        assert!(note.contains("6 could not be solved again at 2N"), "{note}");
        assert!(note.contains("over the 2 solved"), "{note}");
        checks[0] = HarmonicCheck::NotConverged {
            change: Some([4e-3, 1e-4]),
        };
        let note = check_note(&last, &[10], &checks, last.converged(), false, 1e-3);
        assert!(note.contains("1 move by more than 1e-3"), "{note}");
        assert!(note.contains("5 could not be solved"), "{note}");
    }

    /// The rotating TET10 beam of `campbell_parametric` (10 x 2 x 2, turning about an axis
    /// through its root section: the rotating Euler-Bernoulli cantilever, linear prestress,
    /// reduced onto its tip face). Its lowest mode at speed is the bending in the plane of
    /// rotation, whose frequency follows w^2 = w0^2 + (S - 1) Omega^2 with the flapwise
    /// Southwell coefficient S = 1.1933 of the thin-beam closed form (spin softening takes 1).
    /// Without contact the EO 4 sweep crosses where 4 Omega = w, i.e.
    /// Omega_c = w0 / sqrt(16 - (S - 1)), within 1e-3 (measured 5.1e-4: the 2 x 2 mm section of
    /// this 3D beam shifts its coefficient by 0.016 from the thin beam's, each 0.01 of S moving
    /// Omega_c by 3e-4), and peaks within the half-power half-width
    /// zeta Omega_c e^2 / (e^2 - S + 1) of its crossing (1 % damping; measured -0.019 of it).
    /// About 2 s.
    #[test]
    fn beam_sweep_peaks_at_the_campbell_crossing() {
        let model = crate::campbell::campbell_parametric::tests::beam_model(false);
        let forced = ForcedSection {
            levels: vec![0.3],
            damping_ratio: 0.01,
            harmonics: 3,
            stability: false,
            ..ForcedSection::default()
        };
        let sweep = SpeedSweepSection {
            engine_orders: vec![4],
            window: [0.97, 1.03],
            ..SpeedSweepSection::default()
        };
        let (plans, closure) = plan(&model, 0, &sweep, (&[4], None), "test").unwrap();
        assert_eq!(plans.len(), 1);
        let inputs = SweepInputs {
            model: &model,
            forced: &forced,
            sweep: &sweep,
            damping_matrix: None,
            file_load: None,
            source: "test",
        };
        let study = run(&inputs, &plans, closure).unwrap();
        let summary = crate::speed_sweep::forced_speed_output::summarize(&study, &study.runs[0]);
        let w0 = mode_frequency(&model, 0, 0.0).unwrap();
        let (e, s) = (4.0_f64, 1.1933 - 1.0);
        let closed = w0 / (e * e - s).sqrt() / RPM_TO_RAD_S;
        let crossing = summary.crossing_rpm;
        let half = 0.01 * crossing * e * e / (e * e - s);
        println!(
            "beam EO 4: crossing {crossing:.4} rpm (rotating Euler-Bernoulli {closed:.4}, \
             {:.1e}), peak {:.4} rpm ({:+.3} half-widths), q/g0 {:.3}, {} points",
            (crossing - closed) / closed,
            summary.peak_rpm,
            (summary.peak_rpm - crossing) / half,
            summary.peak_q1_over_g0,
            summary.points
        );
        assert!((crossing - closed).abs() < 1e-3 * closed);
        assert!((summary.peak_rpm - crossing).abs() < half);
        assert!(summary.complete && summary.contact_rpm.is_empty());
    }
}
