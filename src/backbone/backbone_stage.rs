//! The `backbone` stage of `nlmodes run` for one mode on one reduced model (at rest, or at a
//! speed of `[rotation]`): trace, stability, converged orbits, kept
//! orbits, truncation estimates, files in
//! `<layout>/backbone/`. Reruns when the reduced model (the hash of the stage that wrote it) or
//! `[nnm]`, `[continuation]`, `[algorithm]`, `[stability]` change. A backbone stopped before
//! q_max keeps its results but no stamp (exit code 3).

use anyhow::Result;
use std::path::PathBuf;

use crate::backbone;
use crate::backbone::backbone_exact;
use crate::backbone::converged;
use crate::case::Case;
use crate::layout::Layout;
use crate::stage::{json, Only, Stage};
use crate::stage_hash::fnv1a;

pub struct BackboneStage<'a> {
    case: &'a Case,
    continuation: nlmodes_nnm::ContinuationSettings,
    layout: Layout,
    name: String,
    hash: String,
}

impl<'a> BackboneStage<'a> {
    /// The backbone of `mode` (0-based) on the model in `layout.model()`, written by the stage
    /// of hash `model_hash`; `name` is the stamp's.
    pub fn new(
        case: &'a Case,
        mode: usize,
        layout: Layout,
        model_hash: &str,
        name: String,
    ) -> Self {
        let continuation = nlmodes_nnm::ContinuationSettings {
            mode,
            ..case.continuation.clone()
        };
        let hash = fnv1a(&[
            model_hash.as_bytes(),
            &json(&case.nnm),
            &json(&continuation),
            &json(&case.algorithm),
            &json(&case.stability),
        ]);
        Self {
            case,
            continuation,
            layout,
            name,
            hash,
        }
    }

    /// Where its results are.
    pub fn results(&self) -> &Layout {
        &self.layout
    }
}

impl Stage for BackboneStage<'_> {
    fn name(&self) -> String {
        self.name.clone()
    }
    fn only(&self) -> Only {
        Only::Backbone
    }
    fn hash(&self) -> &str {
        &self.hash
    }
    fn layout(&self) -> &Layout {
        &self.layout
    }
    fn outputs(&self) -> Vec<PathBuf> {
        let d = self.layout.backbone();
        vec![d.join("backbone.json"), d.join("kept.json")]
    }
    fn work(&self) -> Result<()> {
        let (case, cont, out) = (self.case, &self.continuation, self.layout.backbone());
        let model = backbone::load_model(&self.layout.model())?;
        let system = backbone::system_of(&model, None)?;
        backbone::check_reaches_contact(&system, cont)?;
        let hs = nlmodes_nnm::HarmonicSettings::new(case.nnm.harmonics, case.nnm.samples)?;
        let mut b = backbone::trace(&system, hs, &case.algorithm, cont)?;
        backbone::stability(&system, &mut b, &case.stability)?;
        converged::converge(&system, &mut b, &case.stability, &case.nnm.convergence())?;
        let mut kept = backbone::kept_points(&system, hs, &case.algorithm, &b, &case.nnm.keep)?;
        let exact = backbone_exact::exact_outputs(&system, &b, &kept, &case.stability, cont.q_max)?;
        backbone::truncation(
            &system,
            hs,
            &case.algorithm,
            &mut b,
            &mut kept,
            case.nnm.truncation_every,
            case.nnm.truncation_tolerance,
        )?;
        backbone::write(&b, &out)?;
        backbone_exact::write(&exact, &b, &out)?;
        nlmodes_output::write_json(&out.join("kept.json"), &kept)?;
        crate::ui::say(&backbone::summary(&b, &case.algorithm));
        backbone::stopped_early(&b, &out)
    }
}
