//! The `forced` stage of `nlmodes run` (issue 22): the forced study of `[forced]` on the
//! reduced model, crowned by the backbone of the same mode when the case traced it. Reruns when
//! the reduced model, `[forced]` or that backbone change. Writes `results/<case>/forced/`
//! (frf.csv, frf.json, figures) and `forced/section.md`, the report's section. With
//! `[rotation]` it runs again on the reduced model at the operating speed (K(Omega), running
//! gaps; issue 39, item 1), laid out in `results/<case>/speed/forced/`.

use std::fmt::Write as _;
use std::path::PathBuf;

use crate::forced::forced_output::verdict_counts;
use anyhow::Result;
use nlmodes_forced::Verdict;

use crate::case::Case;
use crate::forced::ForcedStudy;
use crate::layout::Layout;
use crate::post::results::BackboneFile;
use crate::stage::{Only, Stage};
use crate::stage_hash::fnv1a;

/// The stage: its inputs and where it writes.
pub struct ForcedStage<'a> {
    case: &'a Case,
    layout: &'a Layout,
    out: PathBuf,
    backbone: Option<PathBuf>,
    hash: String,
    /// Where the model is ("at rest", "at 8000 rpm"): the log lines' span, since the stages
    /// at rest and at speed run side by side (`crate::run`).
    label: String,
}

impl<'a> ForcedStage<'a> {
    /// The stage of `case` on the model of `layout` (`layout.model()`, at rest or at a speed)
    /// of hash `reduce_hash`, crowned by that layout's backbone; `label` says which in the log.
    pub fn new(case: &'a Case, layout: &'a Layout, reduce_hash: &str, label: &str) -> Self {
        let mode = case.forced.mode;
        let modes = case.continuation.modes_to_trace();
        let backbone = if modes.len() > 1 {
            modes
                .contains(&mode)
                .then(|| layout.for_mode(mode).backbone().join("backbone.json"))
        } else {
            (modes == [mode]).then(|| layout.backbone().join("backbone.json"))
        }
        .filter(|p| p.exists());
        let bb_bytes = backbone
            .as_ref()
            .and_then(|p| std::fs::read(p).ok())
            .unwrap_or_default();
        let settings = serde_json::to_vec(&case.forced).unwrap_or_default();
        let hash = fnv1a(&[reduce_hash.as_bytes(), &settings, &bb_bytes]);
        Self {
            case,
            layout,
            out: layout.shared.join("forced"),
            backbone,
            hash,
            label: label.to_string(),
        }
    }

    /// Runs the study and writes its files; a curve that stops before the end of its range makes
    /// it `StoppedEarly` (no stamp).
    fn study(&self) -> Result<()> {
        let span = tracing::info_span!("forced", at = %self.label);
        let _in_span = span.enter();
        let st = crate::ui::Stage::start("forced");
        let model = crate::backbone::load_model(&self.layout.model())?;
        let system = crate::backbone::system_of(&model, None)?;
        let backbone: Option<BackboneFile> = match &self.backbone {
            Some(p) => Some(crate::post::results::read_json(p)?),
            None => None,
        };
        let model_dir = self.layout.model();
        let checked = crate::forced::forced_inputs::ForcedModel {
            dir: &model_dir,
            reduced: &model,
            system: &system,
        };
        let given = self.backbone.as_deref().zip(backbone.as_ref());
        let inputs =
            crate::forced::forced_inputs::check(&checked, &self.case.forced, "[forced]", given)?;
        let (c, f) = (inputs.damping_matrix, inputs.file_load);
        let study =
            crate::forced::run(&system, &self.case.forced, c, f.as_ref(), backbone.as_ref())?;
        crate::forced::forced_output::write(&study, backbone.as_ref(), &self.out)?;
        crate::forced::level_sweep::write(&study, &self.out)?;
        let orbits = crate::forced::forced_paraview::write_orbits(&study, &model_dir, &self.out)?;
        tracing::info!("forced: {orbits} orbits written for ParaView in forced/orbits");
        crate::post::output::write_atomic(
            &self.out.join("section.md"),
            section(&study).as_bytes(),
        )?;
        let summary = crate::forced::forced_output::summary(&study)
            + &crate::forced::level_sweep::summary(&study);
        crate::ui::say(&summary);
        st.done(&format!("wrote {}", self.out.display()));
        crate::forced::stopped_early(&study, &self.out)
    }
}

impl Stage for ForcedStage<'_> {
    fn name(&self) -> String {
        "forced".into()
    }
    fn only(&self) -> Only {
        Only::Forced
    }
    fn hash(&self) -> &str {
        &self.hash
    }
    fn layout(&self) -> &Layout {
        self.layout
    }
    fn outputs(&self) -> Vec<PathBuf> {
        ["frf.csv", "frf.json", "section.md"]
            .map(|f| self.out.join(f))
            .to_vec()
    }
    fn work(&self) -> Result<()> {
        self.study()
    }
}

/// The report's section: damping per mode, the curves' peaks, folds and stability, figures.
fn section(st: &ForcedStudy) -> String {
    let mut s = String::from("## Forced response\n\n");
    let law = st.penalty_stiffness.map_or_else(
        || "exact contact (Algorithm 1)".to_string(),
        |k| format!("the penalty law, kc = {k:.4e} N/m per contact row"),
    );
    let _ = writeln!(
        s,
        "Harmonic force at harmonic {} of the response, swept over W / w = {} .. {} around \
         linear mode {} (w = {:.3} Hz), N = {} harmonics, {law}. Data: `forced/frf.csv`, every \
         orbit in `forced/frf.json`; each level's peak orbit (and those at `keep`) for ParaView \
         in `forced/orbits/`.\n",
        st.settings.harmonic,
        st.settings.range[0],
        st.settings.range[1],
        st.settings.mode,
        st.omega_mode / (2.0 * std::f64::consts::PI),
        st.settings.harmonics
    );
    if let Some(d) = &st.distortion {
        let _ = writeln!(
            s,
            "{}\n",
            crate::forced::forced_distortion::report_sentence(d)
        );
    }
    let _ = writeln!(s, "Damping each linear mode of the reduced model gets:\n");
    let _ = writeln!(s, "| mode | f (Hz) | damping ratio |\n|---|---|---|");
    for (k, (w, z)) in st
        .linear_frequencies
        .iter()
        .zip(&st.modal_damping)
        .enumerate()
        .take(10)
    {
        let _ = writeln!(
            s,
            "| {} | {:.3} | {:.4e} |",
            k,
            w / (2.0 * std::f64::consts::PI),
            z
        );
    }
    let _ = writeln!(s, "\n| level | load ({}) | peak q/g0 | at W/w | folds (W/w) | stable / unstable / undetermined | end |\n|---|---|---|---|---|---|---|", st.settings.load.unit());
    for c in &st.curves {
        let r = &c.response;
        let amp = |i: usize| {
            let p = &r.points[i];
            p.coefficients[(st.master, 1)].hypot(p.coefficients[(st.master, 2)])
        };
        let Some(peak) = crate::forced::forced_output::peak_point(c, st.master) else {
            continue;
        };
        let folds: Vec<String> = r
            .folds
            .iter()
            .map(|f| format!("{:.4}", f.at / st.omega_mode))
            .collect();
        let [stable, unstable, undetermined] = verdict_counts(r);
        let _ = writeln!(
            s,
            "| {} | {:.4e} | {:.4} | {:.5}{} | {} | {} / {} / {} | {} |",
            c.level,
            c.force,
            amp(peak) / st.gap_reference,
            r.points[peak].omega / st.omega_mode,
            crate::forced::forced_output::peak_note(c, peak),
            if folds.is_empty() {
                "none".to_string()
            } else {
                folds.join(", ")
            },
            stable,
            unstable,
            undetermined,
            r.end_text().replace('|', "/")
        );
    }
    let _ = writeln!(
        s,
        "\n![forced response](forced/frf.png)\n![max amplitude](forced/frf_max.png)\n\nSolid: \
         stable, dashed: unstable, dotted: undetermined. Stability of a point in contact: the \
         exact monodromy of the periodic orbit of the massless contact boundary next to it (the \
         modes up to (N + 1) W dynamic, the others static on the contact rows, the contact \
         displacements without mass; docs/STABILITY.md, Sec. 9), found by shooting with W free; \
         undetermined where that orbit lies more than 1e-2 (scaled) from the point \
         (`boundary_shift` in frf.csv) or |mu| is within 1e-3 + the Liouville error of 1. Out of \
         contact: the Floquet multipliers of the variational equation along the orbit, given \
         where one period of independent time integration returns the orbit to its start within \
         1e-3 (`period_residual`). Black: the backbone of the \
         same model; thin dotted: the single-nonlinear-mode synthesis from it.\n"
    );
    s + &exact_paragraph(st) + &crate::forced::level_sweep::report_section(st)
}

/// The report's paragraph on the exact curves (empty without any).
fn exact_paragraph(st: &ForcedStudy) -> String {
    let mut s = String::new();
    if st.curves.iter().all(|c| c.exact.is_none()) {
        return s;
    }
    let (g, w) = (st.gap_reference, st.omega_mode);
    let _ = writeln!(
        s,
        "Grey lines: each level's exact response curve on the massless contact boundary (the \
         modes up to (N + 1) W at the start of the range dynamic, the others static on the \
         contact rows, a penalty law's spring in series; a model whose modes are all resolved \
         is then the penalty equation itself), continued by shooting with no harmonic \
         truncated (`forced/frf_boundary.csv`; docs/STABILITY.md Sec. 9.2). Every point of it \
         has the verdict of its own exact monodromy. Against the harmonic-balance curve:\n\n\
         | level | peak q/g0 (HB / exact) | at W/w (HB / exact) | folds of the exact curve (W/w) \
         | exact points stable / unstable / undetermined | end |\n|---|---|---|---|---|---|"
    );
    for c in &st.curves {
        let (Some(e), Some(i)) = (
            &c.exact,
            crate::forced::forced_output::peak_point(c, st.master),
        ) else {
            continue;
        };
        let Some(p) = crate::forced::forced_exact::peak(e) else {
            continue;
        };
        let hb = &c.response.points[i];
        let hb_amp = crate::forced::forced_output::master_amplitude(hb, st.master);
        let folds = crate::forced::forced_exact::fold_ratios(e, w, 4);
        let count = |v: Verdict| crate::forced::forced_exact::count(e, v);
        let _ = writeln!(
            s,
            "| {} | {:.4} / {:.4} | {:.5} / {:.5} | {} | {} / {} / {} | {} |",
            c.level,
            hb_amp / g,
            p.master_amplitude / g,
            hb.omega / w,
            p.omega / w,
            if folds.is_empty() {
                "none".to_string()
            } else {
                folds.join(", ")
            },
            count(Verdict::Stable),
            count(Verdict::Unstable),
            count(Verdict::Undetermined),
            nlmodes_boundary::driven_end_text(&e.end)
        );
    }
    s.push('\n');
    s
}
