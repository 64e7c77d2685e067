//! The `speed_sweep` stage of `nlmodes run` (issue 39, item 2): the speed sweeps of
//! `[speed_sweep]` on the parametric reduced model the Campbell stage writes to
//! `results/<case>/parametric/`, with the `[forced]` table's damping, load, levels, N and
//! contact law. Reruns when the Campbell stage's inputs, `[forced]` or `[speed_sweep]` change.
//! Writes `results/<case>/speed_sweep/` (`forced_speed_output`) and its `section.md`.

use std::path::PathBuf;

use anyhow::Result;

use crate::case::Case;
use crate::layout::Layout;
use crate::rotation::rotation_settings::RotationSection;
use crate::speed_sweep::forced_speed::SweepInputs;
use crate::speed_sweep::speed_sweep_settings::SpeedSweepSection;
use crate::stage::{Only, Stage};
use crate::stage_hash::fnv1a;

/// The stage: its inputs and where it writes.
pub struct SpeedSweepStage<'a> {
    case: &'a Case,
    rotation: &'a RotationSection,
    sweep: &'a SpeedSweepSection,
    layout: &'a Layout,
    hash: String,
}

impl<'a> SpeedSweepStage<'a> {
    /// The stage of `case` on the parametric model of the Campbell stage of hash
    /// `campbell_hash`.
    pub fn new(
        case: &'a Case,
        rotation: &'a RotationSection,
        sweep: &'a SpeedSweepSection,
        layout: &'a Layout,
        campbell_hash: &str,
    ) -> Self {
        let settings = serde_json::to_vec(&(&case.forced, sweep)).unwrap_or_default();
        Self {
            case,
            rotation,
            sweep,
            layout,
            hash: fnv1a(&[campbell_hash.as_bytes(), &settings]),
        }
    }

    fn out(&self) -> PathBuf {
        self.layout.shared.join("speed_sweep")
    }

    /// The sweeps and their files; a sweep that stops before the end of its window makes it
    /// `StoppedEarly` (no stamp).
    fn study(&self) -> Result<()> {
        let st = crate::ui::Stage::start("speed sweep");
        let dir = self.layout.shared.join("parametric");
        let model = crate::speed_sweep::forced_speed::read_parametric(&dir)?;
        let reference = crate::backbone::system_of(model.reference(), None)?;
        let checked = crate::forced::forced_inputs::ForcedModel {
            dir: &dir,
            reduced: model.reference(),
            system: &reference,
        };
        let forced = crate::forced::forced_settings::ForcedSection {
            keep_peaks: false,
            keep: Vec::new(),
            ..self.case.forced.clone()
        };
        let source = "[forced] of the case (for [speed_sweep])";
        // The casing is checked at each crossing's running gaps
        // (`forced_speed_distortion::casing`), not at the reference model's.
        let without_casing = crate::forced::forced_settings::ForcedSection {
            distortion: None,
            ..forced.clone()
        };
        let inputs = crate::forced::forced_inputs::check(&checked, &without_casing, source, None)?;
        let case_file = format!("the case ({})", self.case.name());
        let alone = crate::speed_sweep::forced_speed_distortion::alone(&forced, self.sweep);
        let (plans, closure) = crate::speed_sweep::forced_speed::plan(
            &model,
            forced.mode,
            self.sweep,
            (&self.rotation.engine_orders, alone),
            &case_file,
        )?;
        let (solver, _) = crate::forced::solver_settings(&reference, &forced)?;
        let casing_inputs = crate::speed_sweep::forced_speed_casing::CasingInputs {
            model: &model,
            dir: &dir,
            forced: &forced,
            solver: &solver,
            damping_matrix: inputs.damping_matrix.as_ref(),
        };
        let out = self.out();
        let sweep_inputs = SweepInputs {
            model: &model,
            forced: &forced,
            sweep: self.sweep,
            damping_matrix: inputs.damping_matrix.as_ref(),
            file_load: inputs.file_load.as_ref(),
            source,
        };
        // The sweeps and the casing study are independent: run side by side, the casing
        // study's parallel work fills the core a sweep's continuation (one point after the
        // other) leaves idle.
        let rpm = self.rotation.operating_speed;
        let (study, casing) = rayon::join(
            || crate::speed_sweep::forced_speed::run(&sweep_inputs, &plans, closure),
            || {
                crate::speed_sweep::forced_speed_casing::run_enabled(
                    self.sweep,
                    &casing_inputs,
                    rpm,
                    &out,
                )
            },
        );
        let (study, casing) = (study?, casing?);
        crate::speed_sweep::forced_speed_output::write(&study, &out)?;
        let mut section = crate::speed_sweep::forced_speed_report::section(&study);
        crate::ui::say(&crate::speed_sweep::forced_speed_report::summary(&study));
        if let Some(c) = &casing {
            section += &crate::speed_sweep::forced_speed_casing::section(c);
        }
        crate::post::output::write_atomic(&out.join("section.md"), section.as_bytes())?;
        st.done(&format!("wrote {}", out.display()));
        crate::speed_sweep::forced_speed_report::stopped_early(&study, &out)?;
        casing.map_or(Ok(()), |c| {
            crate::speed_sweep::forced_speed_casing::stopped_early(&c, &out)
        })
    }

    /// `[speed_sweep.casing]`, when enabled.
    fn casing(&self) -> Option<&crate::speed_sweep::speed_sweep_settings::CasingSection> {
        self.sweep.casing.as_ref().filter(|c| c.enabled)
    }
}

impl Stage for SpeedSweepStage<'_> {
    fn name(&self) -> String {
        "speed_sweep".into()
    }
    fn only(&self) -> Only {
        Only::SpeedSweep
    }
    fn hash(&self) -> &str {
        &self.hash
    }
    fn layout(&self) -> &Layout {
        self.layout
    }
    fn outputs(&self) -> Vec<PathBuf> {
        let casing: &[&str] = match self.casing() {
            Some(_) => &["casing.csv", "casing.json"],
            None => &[],
        };
        (["speed_sweep.csv", "speed_sweep.json", "section.md"].iter())
            .chain(casing)
            .map(|f| self.out().join(f))
            .collect()
    }
    fn work(&self) -> Result<()> {
        self.study()
    }
}
