//! `nlmodes forced PARAMETRIC_DIR --speed-sweep [--settings FILE] --out DIR` (issue 39,
//! item 2): the speed sweeps of the file's `[speed_sweep]` table on a parametric reduced model,
//! with the `[forced]` table's damping, load, levels, N and contact law, and its
//! `[speed_sweep.casing]` (the casing distortion at the file's `[rotation] operating_speed`,
//! `forced_speed_casing`). Every setting is checked before the model is read, the speed range
//! against the model's range and the engine orders against its crossings before any sweep
//! runs.

use std::path::Path;

use anyhow::Result;

use crate::forced::forced_settings::ForcedSection;
use crate::rotation::rotation_settings::RPM_TO_RAD_S;
use crate::speed_sweep::forced_speed::SweepInputs;
use crate::validate::Problems;

/// Runs the command (`section`: the `[forced]` table, already checked).
pub fn sweep(
    dir: &Path,
    settings: Option<&Path>,
    section: ForcedSection,
    out: &Path,
) -> Result<()> {
    let source = settings.map_or_else(|| "defaults".to_string(), |p| p.display().to_string());
    let (sweep, rotation) = match settings {
        Some(p) => crate::speed_sweep::speed_sweep_settings::load(p)?,
        None => (None, None),
    };
    let sweep = sweep.unwrap_or_default();
    let problems = || {
        let label = source.clone();
        Problems::new(move |key| format!("{label}: {key}"))
    };
    let mut p = problems();
    sweep.check(&mut p, None, "");
    crate::speed_sweep::speed_sweep_settings::check_forced_for_sweeps(&section, &mut p);
    crate::speed_sweep::forced_speed_distortion::check(&section, &sweep, &mut p);
    p.finish()?;
    crate::validate::check_output_dir(out, "--out")?;
    let model = crate::speed_sweep::forced_speed::read_parametric(dir)?;
    let (lo, hi) = model.range();
    let mut p = problems();
    let range_key = format!("the range of {}", dir.join("parametric.json").display());
    sweep.check(
        &mut p,
        Some([lo / RPM_TO_RAD_S, hi / RPM_TO_RAD_S]),
        &range_key,
    );
    p.finish()?;
    let reference = crate::backbone::system_of(model.reference(), None).map_err(|e| {
        e.context(crate::exit::BadInput(format!(
            "the parametric model {}",
            dir.display()
        )))
    })?;
    let checked = crate::forced::forced_inputs::ForcedModel {
        dir,
        reduced: model.reference(),
        system: &reference,
    };
    // The sweeps draw no orbits: no mesh needed. Their casing is checked at each crossing's
    // running gaps (`forced_speed_distortion::casing`), not at the reference model's.
    let without_orbits = ForcedSection {
        keep_peaks: false,
        keep: Vec::new(),
        distortion: None,
        ..section.clone()
    };
    let inputs = crate::forced::forced_inputs::check(&checked, &without_orbits, &source, None)?;
    let rotation = rotation.unwrap_or_default();
    let orders = rotation.engine_orders.clone();
    let alone = crate::speed_sweep::forced_speed_distortion::alone(&section, &sweep);
    let (plans, closure) = crate::speed_sweep::forced_speed::plan(
        &model,
        section.mode,
        &sweep,
        (&orders, alone),
        &source,
    )?;
    let study = crate::speed_sweep::forced_speed::run(
        &SweepInputs {
            model: &model,
            forced: &section,
            sweep: &sweep,
            damping_matrix: inputs.damping_matrix.as_ref(),
            file_load: inputs.file_load.as_ref(),
            source: &source,
        },
        &plans,
        closure,
    )?;
    crate::speed_sweep::forced_speed_output::write(&study, out)?;
    crate::ui::say(&crate::speed_sweep::forced_speed_report::summary(&study));
    let (solver, _) = crate::forced::solver_settings(&reference, &section)?;
    let casing_inputs = crate::speed_sweep::forced_speed_casing::CasingInputs {
        model: &model,
        dir,
        forced: &section,
        solver: &solver,
        damping_matrix: inputs.damping_matrix.as_ref(),
    };
    let casing = crate::speed_sweep::forced_speed_casing::run_enabled(
        &sweep,
        &casing_inputs,
        rotation.operating_speed,
        out,
    )?;
    crate::speed_sweep::forced_speed_report::stopped_early(&study, out)?;
    casing.map_or(Ok(()), |c| {
        crate::speed_sweep::forced_speed_casing::stopped_early(&c, out)
    })
}
