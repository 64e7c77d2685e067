//! `report.md`: a summary that answers the case's question first ([`summary`]), then the linear
//! frequencies, Craig-Bampton accuracy, the backbone table, convergence figures and the plots
//! of a case, in one page, and the inputs in an appendix at the end.

use anyhow::Result;
use nlmodes_modal::ReducedModel;
use nlmodes_output::{LegendPosition, LinePlot, Series};
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use crate::case::Case;
use crate::layout::{amplitude_tag, Layout};
use crate::post::results::{BackboneFile, Orbit};

mod summary;

/// What the post stage wrote for one kept amplitude.
pub struct KeptOutputs {
    pub orbit: Orbit,
    /// The amplitude's folder.
    pub dir: PathBuf,
    /// The mode-shape picture (Fig. 5), when the model has a mesh.
    pub shapes: Option<PathBuf>,
    /// The exact orbit of the massless contact boundary next to it, where there is one.
    pub boundary: Option<nlmodes_nnm::BoundaryHistory>,
}

fn rel(root: &Path, p: &Path) -> String {
    p.strip_prefix(root).unwrap_or(p).display().to_string()
}

/// Convergence figure: Powell's measure G and the Newton iterations at every backbone point.
fn convergence_figure(b: &BackboneFile, out: &Path) -> Result<()> {
    let g0 = b.gap_reference;
    let q: Vec<f64> = b.points.iter().map(|p| p.q / g0).collect();
    let g: Vec<f64> = b
        .points
        .iter()
        .map(|p| p.powell_measure.max(1e-300).log10())
        .collect();
    let it: Vec<f64> = b
        .points
        .iter()
        .map(|p| p.newton_iterations as f64)
        .collect();
    LinePlot::new(
        "Convergence of Algorithm 1",
        "q / g0",
        "log10 G (units of g0)",
    )
    .with_series(Series::new("log10 G", q.clone(), g).markers(true))
    .with_legend(LegendPosition::Hidden)
    .write_svg_and_png(&out.join("convergence_powell"))?;
    LinePlot::new("Newton iterations per point", "q / g0", "Newton iterations")
        .with_series(Series::new("Newton iterations", q, it).markers(true))
        .with_legend(LegendPosition::Hidden)
        .write_svg_and_png(&out.join("convergence_newton"))?;
    Ok(())
}

/// What the report is written from.
pub struct ReportInputs<'a> {
    pub case: &'a Case,
    pub layout: &'a Layout,
    pub model: &'a ReducedModel,
    pub backbone: &'a BackboneFile,
    pub kept: &'a [KeptOutputs],
    pub linear_modes_picture: Option<&'a Path>,
    /// The exact backbone of the massless contact boundary, where the backbone stage made one.
    pub exact: Option<&'a nlmodes_nnm::BoundaryBackbone>,
}

/// One section of `report.md`: its text from the inputs (empty when it has nothing to say).
type Section = fn(&ReportInputs<'_>) -> String;

/// The report, in order: a list of sections. A stage that runs before post (forced, speed,
/// campbell, speed_sweep) writes its own `section.md`, included by [`stage_sections`].
const SECTIONS: [Section; 10] = [
    title,
    summary::summary,
    introduction,
    linear_modes,
    backbone,
    manifold,
    kept_amplitudes,
    stage_sections,
    convergence,
    inputs,
];

/// Writes `report.md` (and the convergence figures it shows) in the layout's root.
pub fn write_report(r: &ReportInputs<'_>) -> Result<()> {
    let root = &r.layout.root;
    convergence_figure(r.backbone, root)?;
    let s: String = SECTIONS.iter().map(|section| section(r)).collect();
    crate::post::output::write_atomic(&root.join("report.md"), s.as_bytes())
}

fn title(r: &ReportInputs<'_>) -> String {
    format!("# nlmodes report: case `{}`\n\n", r.case.name())
}

fn introduction(r: &ReportInputs<'_>) -> String {
    let b = r.backbone;
    let f1 = b.omega_linear / (2.0 * std::f64::consts::PI);
    format!(
        "Nonlinear normal mode of a structure with frictionless unilateral contact (Laxalde, \
         Legrand & Pierre 2009). Displacements are normalized by the initial gap g0 = {:.4e} m, \
         frequencies by the first linear frequency f1 = {f1:.4} Hz.\n\n",
        b.gap_reference
    )
}

/// The appendix: the case as read (every key, defaults included).
fn inputs(r: &ReportInputs<'_>) -> String {
    format!(
        "## Appendix: inputs\n\nThe case as read, every key with its value (defaults \
         included):\n\n```toml\n{}```\n\n",
        toml::to_string(r.case).unwrap_or_default()
    )
}

fn linear_modes(r: &ReportInputs<'_>) -> String {
    let (model, root) = (r.model, &r.layout.root);
    let full = crate::mesh::fe_model::read_frequencies(&r.layout.modes().join("frequencies.csv"));
    let mut s = String::from("## Linear modes and Craig-Bampton accuracy\n\n");
    let _ = writeln!(
        s,
        "Reduced model: {} coordinates ({} contact nodes x 3 constraint modes + {} fixed-interface \
         modes). Master coordinate: {} (reduced DOF {}).\n",
        model.n(),
        model.contact_nodes.len(),
        model.n() - 3 * model.contact_nodes.len(),
        model.master.description,
        model.master.dof
    );
    let _ = writeln!(
        s,
        "| mode | full model [Hz] | reduced [Hz] | relative error |\n|---|---|---|---|"
    );
    for (i, f_r) in model.linear_frequencies_hz.iter().take(10).enumerate() {
        match full.as_ref().and_then(|f| f.get(i)) {
            Some(f) => {
                let _ = writeln!(
                    s,
                    "| {} | {f:.4} | {f_r:.4} | {:.2e} |",
                    i + 1,
                    (f_r - f) / f
                );
            }
            None => {
                let _ = writeln!(s, "| {} | | {f_r:.4} | |", i + 1);
            }
        }
    }
    if let Some(p) = r.linear_modes_picture {
        let _ = writeln!(s, "\n![linear modes]({})\n", rel(root, p));
    }
    let _ = writeln!(
        s,
        "\nLinear mode shapes of the full model: `modes/modes.vtu`, one point field per mode \
         (`mode_01`, `mode_02`, ...; frequencies in `modes/frequencies.csv`); \
         `scripts/paraview {}/modes/modes.vtu --mode 2` opens mode 2.\n",
        root.display()
    );
    s
}

fn backbone(r: &ReportInputs<'_>) -> String {
    let b = r.backbone;
    let g0 = b.gap_reference;
    let mut s = String::new();
    let _ = writeln!(
        s,
        "## Backbone (Fig. 3a) and frequency-energy plot\n\n![backbone](backbone.png)\n\
         ![frequency-energy](frequency_energy.png)\n\
         ![backbone diagnostics](backbone_diagnostics.png)\n\n\
         The linear segment and the main branch are drawn in blue (dashed where unstable, \
         dotted where the stability is undetermined: the trivial Floquet pair is off 1 by more \
         than 0.05 or by more than the unstable multiplier is off the unit circle, or the \
         shot orbit of the massless contact boundary lies more than 1e-2 in w from the point, \
         or its RK4 check disagrees; the `stability` column of the CSV). Points in contact get \
         their multipliers on the massless contact boundary: the modes up to (N + 1) w dynamic, \
         the others static on the contact rows, the contact displacements without mass, the \
         periodic orbit next to the point found by shooting and its monodromy computed exactly \
         (docs/STABILITY.md, Sec. 9). Internal-resonance tongues (branches where harmonic n of the orbit drives another linear \
         mode k, n w near w_k) in light blue on the frequency-energy plot and the diagnostics \
         figure, which also draws the exact orbits, the converged orbits, the stability changes \
         and the jumps; `backbone/backbone.csv` gives every point with its `branch` and \
         `branch_kind`.\n"
    );
    let _ = writeln!(
        s,
        "Grazing amplitude: q/g0 = {}. Termination: `{}`.\n",
        b.grazing_amplitude
            .map(|q| format!("{:.4}", q / g0))
            .unwrap_or_else(|| "none".into()),
        b.termination
    );
    internal_resonances(&mut s, b);
    boundary_comparison(&mut s, b);
    if let Some(e) = r.exact {
        s.push_str(&crate::backbone::backbone_exact::report_paragraph(b, e));
        s.push('\n');
    }
    s.push_str(&crate::backbone::converged::report_paragraph(
        b,
        &r.case.nnm.convergence(),
    ));
    backbone_table(&mut s, b);
    let _ = writeln!(s, "\nFull table: `backbone/backbone.csv`; every orbit's Fourier coefficients: `backbone/backbone.json`.\n");
    truncation_table(&mut s, b, r.kept, g0);
    s
}

/// The harmonic-balance orbits against the massless contact boundary's exact ones (the points
/// whose stability was shot; docs/STABILITY.md Sec. 9).
fn boundary_comparison(s: &mut String, b: &BackboneFile) {
    let largest = |v: &[f64]| v.iter().copied().fold(0.0, f64::max);
    let shot: Vec<(f64, f64, f64)> = b
        .points
        .iter()
        .filter_map(|p| {
            let st = p.stability.as_ref()?;
            let shot = st.method == nlmodes_nnm::StabilityMethod::Shooting;
            (shot && !st.contact_shares.is_empty()).then(|| {
                (
                    st.orbit_shift,
                    largest(&p.contact_fraction),
                    largest(&st.contact_shares),
                )
            })
        })
        .collect();
    if shot.is_empty() {
        return;
    }
    let mut shifts: Vec<f64> = shot.iter().map(|x| x.0).collect();
    shifts.sort_by(f64::total_cmp);
    let hb_max = largest(&shot.iter().map(|x| x.1).collect::<Vec<_>>());
    let ex_max = largest(&shot.iter().map(|x| x.2).collect::<Vec<_>>());
    let _ = writeln!(
        s,
        "Stability of the {} points in contact on the massless contact boundary (docs/STABILITY.md, \
         Sec. 9): its exact periodic orbit next to each point has w within {:.1e} (median) and \
         {:.1e} (largest) of the harmonic-balance w. A contact row of those orbits is closed for \
         up to {:.0} % of the period, against up to {:.0} % in the harmonic-balance orbits (contact \
         coordinates with mass: short, impact-like phases): the contact durations, unlike w and \
         the stability, depend on the contact model (`boundary_contact_share` in the CSV).\n",
        shot.len(),
        shifts[shifts.len() / 2],
        shifts[shifts.len() - 1],
        100.0 * ex_max,
        100.0 * hb_max,
    );
}

fn internal_resonances(s: &mut String, b: &BackboneFile) {
    if b.internal_resonances.is_empty() {
        return;
    }
    let g0 = b.gap_reference;
    let _ = writeln!(
        s,
        "Internal resonances met by the continuation (the main branch turned into a tongue \
         where harmonic n of the orbit drives linear mode k; the tongue is followed as its own \
         branch, up to a set number of points, and the main branch is continued past it by a \
         predictor on its secant beyond the tongue and filled back toward it, or as a last resort by a fixed-q hop flagged as a jump):\n\n\
         | q/g0 | w/w1 | mode k | harmonic n | detuning (n w - w_k)/w_k | energy share | tongue branch | main branch past it |\n\
         |---|---|---|---|---|---|---|---|"
    );
    for r in &b.internal_resonances {
        let _ = writeln!(
            s,
            "| {:.3} | {:.4} | {} | {} | {:+.2} % | {:.0} % | {} | {} |",
            r.q / g0,
            r.omega_ratio,
            r.mode + 1,
            r.harmonic,
            100.0 * r.detuning,
            100.0 * r.share,
            r.branch
                .map_or("not followed".to_string(), |id| id.to_string()),
            crate::backbone::passage_phrase(r, g0)
        );
    }
    let _ = writeln!(s);
}

/// About 25 rows of the backbone, with every fold, jump and bifurcation.
fn backbone_table(s: &mut String, b: &BackboneFile) {
    let g0 = b.gap_reference;
    let _ = writeln!(
        s,
        "Flag \"N too small\": a main-branch point in contact whose w is more than \
         `truncation_tolerance` from its converged orbit's (the exact orbit of the massless \
         contact boundary at the same q, docs/STABILITY.md Sec. 9.4; its w/w1 and the N of its \
         modes in the column \"converged w/w1 (N)\"), or that has none; for another point, its \
         highest harmonic holds more than `truncation_warning` of the contact motion.\n"
    );
    let _ = writeln!(
        s,
        "| q/g0 | w/w1 | converged w/w1 (N) | f [Hz] | nodes touching | max contact share (converged) | G | Newton its | stability (max abs mu, trivial-pair error) | flags |\n|---|---|---|---|---|---|---|---|---|---|"
    );
    let stride = (b.points.len() / 25).max(1);
    for (i, p) in b.points.iter().enumerate() {
        if i % stride != 0
            && i + 1 != b.points.len()
            && !p.fold
            && !p.jump
            && p.bifurcation.is_none()
        {
            continue;
        }
        let share = p.contact_fraction.iter().cloned().fold(0.0, f64::max);
        let stability = p
            .stability
            .as_ref()
            .map_or("not computed".to_string(), |st| {
                format!(
                    "{} ({:.4}, {:.1e})",
                    p.verdict().unwrap_or("not computed"),
                    st.max_multiplier_abs,
                    st.trivial_pair_error
                )
            });
        let bifurcation = p.bifurcation.as_deref().map(|k| k.replace('_', " "));
        let flags = [
            (b.on_tongue(p), "tongue"),
            (p.pre_fold, "grazing to fold"),
            (p.fold, "fold"),
            (p.jump, "jump"),
            (p.truncation_warning, "N too small"),
        ]
        .iter()
        .filter(|f| f.0)
        .map(|f| f.1.to_string())
        .chain(bifurcation)
        .collect::<Vec<_>>()
        .join(", ");
        let converged = p.converged.as_ref().map(|c| c.orbit());
        let converged_w = converged.map_or("-".to_string(), |c| {
            format!("{:.6} ({})", c.omega / b.omega_linear, c.harmonics)
        });
        let share = match converged {
            Some(c) => format!(
                "{share:.3} ({:.3})",
                c.contact_shares.iter().copied().fold(0.0, f64::max)
            ),
            None => format!("{share:.3}"),
        };
        let _ = writeln!(
            s,
            "| {:.3} | {:.6} | {converged_w} | {:.3} | {} | {share} | {:.1e} | {} | {stability} | {} |",
            p.q / g0,
            p.omega_ratio,
            p.frequency_hz,
            p.touching(),
            p.powell_measure,
            p.newton_iterations,
            flags
        );
    }
}

fn manifold(_: &ReportInputs<'_>) -> String {
    "## Manifold (Fig. 3b)\n\n![manifold displacement](manifold_displacement.png)\n![manifold velocity](manifold_velocity.png)\n\nData: `manifold.csv`.\n\n".into()
}

fn kept_amplitudes(r: &ReportInputs<'_>) -> String {
    let root = &r.layout.root;
    let g0 = r.backbone.gap_reference;
    let mut s =
        String::from("## Mode shapes and contact at the kept amplitudes (Figs. 5 and 4)\n\n");
    for k in r.kept {
        let o = &k.orbit;
        let tag = amplitude_tag(o.q / g0);
        let d = rel(root, &k.dir);
        let touching: Vec<String> = o
            .contact_fraction
            .iter()
            .enumerate()
            .filter(|(_, &f)| f > 0.0)
            .map(|(j, f)| format!("{} ({:.0} %)", j + 1, 100.0 * f))
            .collect();
        let _ = writeln!(
            s,
            "### q/g0 = {:.2}: w/w1 = {:.5}, period T = {:.4e} s\n\nNodes in contact (share of \
             the period): {}.\n",
            o.q / g0,
            o.omega_ratio,
            o.period(),
            if touching.is_empty() {
                "none".to_string()
            } else {
                touching.join(", ")
            }
        );
        if let Some(p) = &k.shapes {
            let _ = writeln!(s, "![mode shape]({})\n", rel(root, p));
        }
        let _ = writeln!(
            s,
            "![radial]({d}/radial_{tag}.png)\n![contact map]({d}/contact_map_{tag}.png)\n\n\
             ParaView: `scripts/paraview {}/{d}/mode_{tag}.xdmf` (time values in seconds over \
             one period; warp factor from the data).\n",
            root.display()
        );
        if let Some(h) = &k.boundary {
            s.push_str(&boundary_history_text(
                h,
                g0,
                r.backbone.omega_linear,
                &d,
                &tag,
            ));
        }
    }
    s
}

/// Fig. 4 from the exact orbit of the massless contact boundary next to a kept point, and the
/// contact durations it gives.
fn boundary_history_text(
    h: &nlmodes_nnm::BoundaryHistory,
    g0: f64,
    w1: f64,
    d: &str,
    tag: &str,
) -> String {
    let shares: Vec<String> = h
        .contact_shares
        .iter()
        .enumerate()
        .filter(|(_, &f)| f > 0.0)
        .map(|(j, f)| format!("{} ({:.0} %)", j + 1, 100.0 * f))
        .collect();
    format!(
        "The exact orbit of the massless contact boundary next to it ({} modes dynamic, no \
         harmonic truncated; docs/STABILITY.md Sec. 9.3): w/w1 = {:.5} at q/g0 = {:.2}; nodes \
         in contact (exact share of the period, from the switch instants): {}. Its contact \
         phases sit on the stop for their whole duration, where the harmonic balance of the \
         massive contact coordinates rounds them off \
         (`{d}/radial_boundary_{tag}.csv`).\n\n![radial, exact]({d}/radial_boundary_{tag}.png)\n",
        h.modes,
        h.omega / w1,
        h.q / g0,
        if shares.is_empty() {
            "none".to_string()
        } else {
            shares.join(", ")
        }
    )
}

/// The sections written by the stages that run before post (forced; speed, campbell and
/// speed_sweep for a rotating case, in the case-root report only): links are relative to the case root.
fn stage_sections(r: &ReportInputs<'_>) -> String {
    let layout = r.layout;
    let rotating = r.case.rotation.is_some() && layout.root == layout.shared;
    ["forced", "speed", "campbell", "speed_sweep"]
        .iter()
        .filter(|&&stage| stage == "forced" || rotating)
        .filter_map(|stage| {
            std::fs::read_to_string(layout.shared.join(stage).join("section.md")).ok()
        })
        .collect()
}

fn convergence(r: &ReportInputs<'_>) -> String {
    format!(
        "## Convergence\n\n{}\n![G](convergence_powell.png)\n![Newton](convergence_newton.png)\n\n",
        convergence_text(r.case, r.backbone)
    )
}

/// What Algorithm 1 reached: every point within epsilon, or how many were accepted stalled above
/// it (docs/DESIGN.md §3.5, `stall_factor`).
fn convergence_text(case: &Case, b: &BackboneFile) -> String {
    let a = &case.algorithm.algorithm;
    if a.method != nlmodes_nnm::ContactMethod::AugmentedLagrangian {
        return "Plain penalty law: one Newton solve per point, no multiplier update.\n".into();
    }
    let mut text = format!(
        "Algorithm 1 stops when Powell's measure G (penetration and complementarity error, units \
         of g0) is at most epsilon = {:e}.",
        a.epsilon
    );
    let measures = b.points.iter().map(|p| p.powell_measure);
    match crate::backbone::stalled_points(measures, a) {
        None => text += " Every point reached it.\n",
        Some((count, worst)) => {
            text += &format!(
                " {count} of {} points stalled above it and were kept at their last accepted \
                 iterate (G up to {worst:.2e}, at most `stall_factor` = {} x epsilon; \
                 `powell_measure` in backbone.csv).\n",
                b.points.len(),
                a.stall_factor
            )
        }
    }
    text
}

/// The harmonic-truncation estimates (docs/DESIGN.md §8.5): the backbone points where it was made
/// and the kept amplitudes.
fn truncation_table(s: &mut String, b: &BackboneFile, kept: &[KeptOutputs], g0: f64) {
    let rows: Vec<(&str, &Orbit)> = b
        .points
        .iter()
        .map(|p| ("backbone", p))
        .chain(kept.iter().map(|k| ("kept amplitude", &k.orbit)))
        .filter(|(_, p)| p.truncation.is_some())
        .collect();
    if rows.is_empty() {
        return;
    }
    let _ = writeln!(
        s,
        "### Harmonic truncation\n\nEach point below was solved again at the same q with twice the \
         harmonics; the change of w estimates the truncation error of w (calibrated on the penalty \
         oscillator, docs/VERIFICATION.md). \"another orbit\": the 2N solve found a different orbit \
         at that q (an internal resonance more harmonics reach), so no estimate.\n\n\
         | | q/g0 | w/w1 | 2N | change of w | change of contact share |\n|---|---|---|---|---|---|"
    );
    for (what, p) in rows {
        let Some(t) = &p.truncation else { continue };
        let change = if t.same_orbit {
            format!("{:.1e}", t.omega_change)
        } else {
            "another orbit".to_string()
        };
        let _ = writeln!(
            s,
            "| {what} | {:.3} | {:.5} | {} | {change} | {:.3} |",
            p.q / g0,
            p.omega_ratio,
            t.harmonics,
            t.contact_share_change
        );
    }
    let _ = writeln!(s);
}

/// The case-root `report.md` of a several-mode case: one section per mode (grazing, termination,
/// frequency at the last point, a link to its own report) and the combined frequency-energy plot.
pub fn write_modes_index(
    case: &Case,
    layout: &Layout,
    families: &[(usize, BackboneFile)],
) -> Result<()> {
    let mut s = String::new();
    let _ = writeln!(
        s,
        "# nlmodes report: case `{}`, {} modes\n\n\
         Each mode's family (linear segment, main branch from grazing, internal-resonance tongues, \
         stability) has its own report and files in `mode_<k>/`.\n\n\
         ![frequency-energy, all modes](frequency_energy_modes.png)\n",
        case.name(),
        families.len()
    );
    for (mode, b) in families {
        let g0 = b.gap_reference;
        let last = b.points.last();
        let m = mode + 1;
        // A mode whose backbone stopped early has its backbone files but no figures or report.
        let has_report = layout.for_mode(*mode).root.join("report.md").exists();
        let link = if has_report {
            format!("[report](mode_{m}/report.md)")
        } else {
            format!(
                "stopped early, no report (the points computed: `mode_{m}/backbone/backbone.csv`)"
            )
        };
        let picture = if has_report {
            format!("![backbone of mode {m}](mode_{m}/backbone.png)\n")
        } else {
            String::new()
        };
        let _ = writeln!(
            s,
            "## Mode {m}\n\n{link}: linear frequency {:.4} Hz, grazing at q/g0 = {}, last point \
             q/g0 = {:.3}, w/w1 = {:.5}; termination `{}`.\n\n{picture}",
            b.omega_linear / (2.0 * std::f64::consts::PI),
            b.grazing_amplitude
                .map_or("never".to_string(), |q| format!("{:.4}", q / g0)),
            last.map_or(0.0, |p| p.q / g0),
            last.map_or(1.0, |p| p.omega_ratio),
            b.termination,
        );
    }
    crate::post::output::write_atomic(&layout.root.join("report.md"), s.as_bytes())
}
