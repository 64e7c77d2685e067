//! The post-processing stage: the paper's figures for our blade (Sec. 4: Figs. 3a, 3b, 4, 5),
//! CSV tables, VTU series for ParaView and a Markdown report.
//!
//! Displacements are normalized by the initial gap g0 and frequencies by the first linear
//! frequency w1, as in the paper.

pub(crate) mod figures;
pub(crate) mod output;
pub(crate) mod render;
pub(crate) mod report;
pub(crate) mod results;

use anyhow::{Context, Result};
use nlmodes_modal::{MeshReference, ReducedModel};
use nlmodes_output::{write_xdmf_series, CsvTable, Field, Precision, XdmfFrame};
use std::f64::consts::PI;
use std::path::{Path, PathBuf};

use crate::case::Case;
use crate::layout::{amplitude_tag, Layout};
use crate::post::render::{Snapshot, Surface};
use crate::post::results::{
    read_boundary_backbone, read_json, read_kept_boundary, BackboneFile, Orbit,
};
use crate::ui;
use nlmodes_nnm::BoundaryHistory;
use rayon::prelude::*;

/// Radial displacement (m) of every contact node, A u.
fn radial(model: &ReducedModel, u: &[f64]) -> Vec<f64> {
    model
        .contact_nodes
        .iter()
        .map(|c| (0..3).map(|i| c.radial[i] * u[c.dofs[i]]).sum())
        .collect()
}

/// Run the post-processing of a case whose backbone stage is done.
pub fn post(case: &Case, layout: &Layout) -> Result<()> {
    let stage = ui::Stage::start("post");
    let model = ReducedModel::read(&layout.model())
        .with_context(|| format!("reading the reduced model {}", layout.model().display()))?;
    let b: BackboneFile = read_json(&layout.backbone().join("backbone.json"))?;
    let kept: Vec<Orbit> = read_json(&layout.backbone().join("kept.json"))?;
    anyhow::ensure!(
        !b.points.is_empty(),
        "the backbone has no point: nothing to post-process"
    );
    let out = &layout.root;
    let g0 = b.gap_reference;

    let exact = read_boundary_backbone(&layout.backbone())?;
    let histories = read_kept_boundary(&layout.backbone(), kept.len())?;
    figures::backbone_figure(&b, exact.as_ref(), out)?;
    figures::frequency_energy_figure(&b, out)?;
    let nonlinear = manifold_coordinate(&b);
    manifold(&model, &b, nonlinear, out)?;
    // The full mesh, read once for every VTU series and picture.
    let full = FullMesh::of(&model)?;
    if full.is_none() {
        tracing::warn!("the reduced model has no recovery basis or mesh: ParaView series and mode-shape pictures skipped");
    }
    // The ParaView series and tables alongside the pictures: the series' sequential parts (tables,
    // figures, file writes) leave the second core free for the pictures' rasterization.
    let (dirs, pictures) = rayon::join(
        || -> Result<Vec<PathBuf>> {
            let mut dirs = Vec::new();
            for (i, orbit) in kept.iter().enumerate() {
                let tag = amplitude_tag(orbit.q / g0);
                let dir = layout.amplitude(&tag);
                std::fs::create_dir_all(&dir)
                    .with_context(|| format!("cannot create {}", dir.display()))?;
                radial_history(&model, orbit, g0, &dir, &tag)?;
                if let Some(h) = histories.get(i).and_then(Option::as_ref) {
                    radial_boundary(h, g0, b.omega_linear, &dir, &tag)?;
                }
                contact_map(orbit, &dir, &tag)?;
                if let Some(full) = &full {
                    xdmf_series(case, &model, full, orbit, g0, &dir, &tag)?;
                }
                dirs.push(dir);
            }
            Ok(dirs)
        },
        || pictures(&model, full.as_ref(), &kept, g0, &layout.figures()),
    );
    let (dirs, (shapes, modes_picture)) = (dirs?, pictures?);
    let written: Vec<crate::post::report::KeptOutputs> = kept
        .iter()
        .zip(dirs)
        .zip(shapes)
        .zip(histories)
        .map(
            |(((orbit, dir), shapes), boundary)| crate::post::report::KeptOutputs {
                orbit: orbit.clone(),
                dir,
                shapes,
                boundary,
            },
        )
        .collect();
    crate::post::report::write_report(&crate::post::report::ReportInputs {
        case,
        layout,
        model: &model,
        backbone: &b,
        kept: &written,
        linear_modes_picture: modes_picture.as_deref(),
        exact: exact.as_ref(),
    })?;
    stage.done(&format!(
        "figures, tables and {} ParaView series in {}",
        written.len(),
        out.display()
    ));
    Ok(())
}

/// Fig. 5 of every kept amplitude and the linear modes' picture, in parallel; none without a
/// mesh.
fn pictures(
    model: &ReducedModel,
    full: Option<&FullMesh>,
    kept: &[Orbit],
    g0: f64,
    figures: &Path,
) -> Result<(Vec<Option<PathBuf>>, Option<PathBuf>)> {
    let Some(full) = full else {
        return Ok((vec![None; kept.len()], None));
    };
    let (shapes, modes) = rayon::join(
        || {
            kept.par_iter()
                .map(|o| shape_figure(full, o, g0, figures, &amplitude_tag(o.q / g0)).map(Some))
                .collect::<Result<Vec<_>>>()
        },
        || linear_modes_figure(model, full, figures),
    );
    Ok((shapes?, Some(modes?)))
}

/// The full FE mesh of the reduced model and its boundary surface.
pub struct FullMesh<'a> {
    mesh: nlmodes_fem::Mesh,
    recovery: &'a faer::Mat<f64>,
    reference: &'a MeshReference,
    surface: Surface,
    /// Mesh node (0-based) of every contact node.
    contact_nodes: Vec<usize>,
}

impl<'a> FullMesh<'a> {
    /// `None` when the model has no recovery basis or mesh reference.
    pub fn of(model: &'a ReducedModel) -> Result<Option<Self>> {
        let (Some(recovery), Some(reference)) = (&model.recovery, &model.mesh) else {
            return Ok(None);
        };
        let mesh = nlmodes_fem::read_msh(Path::new(&reference.msh_file)).with_context(|| {
            format!(
                "reading the mesh of the reduced model {}",
                reference.msh_file
            )
        })?;
        anyhow::ensure!(
            3 * mesh.n_nodes() == reference.n_full_dofs,
            "mesh {} has {} DOFs but the reduced model was built on {}",
            reference.msh_file,
            3 * mesh.n_nodes(),
            reference.n_full_dofs
        );
        let contact_nodes = model
            .contact_nodes
            .iter()
            .map(|c| c.mesh_node.map(|t| t as usize - 1))
            .collect::<Option<Vec<usize>>>()
            .context("contact node without mesh node")?;
        let surface = Surface::of_mesh(&mesh);
        Ok(Some(FullMesh {
            mesh,
            recovery,
            reference,
            surface,
            contact_nodes,
        }))
    }

    /// Full nodal displacements (3 per node, m) of reduced states, recovered in one product.
    fn recover(&self, states: &[Vec<f64>]) -> Result<Vec<Vec<f64>>> {
        let r = self.recovery;
        let reduced = faer::Mat::from_fn(r.ncols(), states.len(), |j, f| states[f][j]);
        let recovered = r * &reduced;
        (0..states.len())
            .map(|f| {
                let free: Vec<f64> = recovered.col(f).iter().copied().collect();
                Ok(self.reference.expand_to_full(&free)?)
            })
            .collect()
    }
}

/// The "nonlinear coordinate" of Fig. 3b: the radial displacement of the contact node that is in
/// contact longest at the largest amplitude.
fn manifold_coordinate(b: &BackboneFile) -> usize {
    let last = b
        .points
        .iter()
        .max_by(|x, y| x.q.total_cmp(&y.q))
        .unwrap_or(&b.points[0]);
    last.contact_fraction
        .iter()
        .enumerate()
        .max_by(|x, y| x.1.total_cmp(y.1))
        .map(|(j, _)| j)
        .unwrap_or(0)
}

/// Fig. 3b: the contact node's radial displacement against the master's displacement and
/// velocity, over one period of about 12 orbits spread along the backbone.
fn manifold(model: &ReducedModel, b: &BackboneFile, j: usize, out: &Path) -> Result<()> {
    let g0 = b.gap_reference;
    let w1 = b.omega_linear;
    let master = model.master.dof;
    let stride = (b.points.len() / 12).max(1);
    let mut table = CsvTable::new(&[
        "point",
        "q_over_g0",
        "t_over_T",
        "master_displacement_over_g0",
        "master_velocity_over_w1_g0",
        "radial_displacement_over_g0",
    ]);
    let mut orbits = Vec::new();
    for (i, p) in b.points.iter().enumerate().step_by(stride) {
        let mut curve = Vec::new();
        for k in 0..=128 {
            let th = 2.0 * PI * k as f64 / 128.0;
            let u = p.at_phase(th);
            let v = p.rate_at_phase(th);
            let r = radial(model, &u)[j] / g0;
            let (um, vm) = (u[master] / g0, v[master] / (w1 * g0));
            table.push_numbers(&[i as f64, p.q / g0, k as f64 / 128.0, um, vm, r])?;
            curve.push((um, vm, r));
        }
        orbits.push((p.q / g0, curve));
    }
    table.write(&out.join("manifold.csv"))?;
    figures::manifold_figure(&orbits, j, out)
}

/// Fig. 4: radial displacement / g0 of every contact node over one period
/// (`radial_<tag>.csv` and figure).
fn radial_history(model: &ReducedModel, o: &Orbit, g0: f64, dir: &Path, tag: &str) -> Result<()> {
    let samples = 200;
    let series: Vec<Vec<(f64, f64)>> = {
        let frames: Vec<Vec<f64>> = (0..=samples)
            .map(|k| radial(model, &o.at_phase(2.0 * PI * k as f64 / samples as f64)))
            .collect();
        (0..model.contact_nodes.len())
            .map(|j| {
                let t = |k: usize| k as f64 / samples as f64;
                (0..=samples).map(|k| (t(k), frames[k][j] / g0)).collect()
            })
            .collect()
    };
    radial_table(&series)?.write(&dir.join(format!("radial_{tag}.csv")))?;
    let title = format!(
        "Radial displacement of the contact nodes, q/g0 = {:.2}",
        o.q / g0
    );
    figures::radial_figure(&series, &title, &dir.join(format!("radial_{tag}")))
}

/// Fig. 4 from the exact orbit of the massless contact boundary next to the kept point
/// (`radial_boundary_<tag>.csv` and figure): the contact phases with their exact durations.
fn radial_boundary(h: &BoundaryHistory, g0: f64, w1: f64, dir: &Path, tag: &str) -> Result<()> {
    let series: Vec<Vec<(f64, f64)>> = h
        .contact_displacement
        .iter()
        .map(|row| {
            let m = row.len().saturating_sub(1).max(1) as f64;
            row.iter()
                .enumerate()
                .map(|(k, u)| (k as f64 / m, u / g0))
                .collect()
        })
        .collect();
    radial_table(&series)?.write(&dir.join(format!("radial_boundary_{tag}.csv")))?;
    let title = format!(
        "Exact orbit of the massless contact boundary, q/g0 = {:.2} (w/w1 = {:.4})",
        h.q / g0,
        h.omega / w1
    );
    figures::radial_figure(&series, &title, &dir.join(format!("radial_boundary_{tag}")))
}

/// The table of Fig. 4: t/T and one column per contact node.
fn radial_table(series: &[Vec<(f64, f64)>]) -> Result<CsvTable> {
    let mut header = vec!["t_over_T".to_string()];
    header.extend((1..=series.len()).map(|j| format!("node_{j:02}")));
    let mut table = CsvTable::new(&header);
    let rows = series.first().map_or(0, Vec::len);
    for k in 0..rows {
        let mut row = vec![series[0][k].0];
        row.extend(series.iter().map(|s| s[k].1));
        table.push_numbers(&row)?;
    }
    Ok(table)
}

/// The contact map: contact force / its maximum for every node (row) and time sample (column).
fn contact_map(o: &Orbit, dir: &Path, tag: &str) -> Result<()> {
    let c = o.contact_force.len();
    let m = o.contact_force.first().map(|v| v.len()).unwrap_or(0);
    let mut header = vec!["t_over_T".to_string()];
    header.extend((1..=c).map(|j| format!("node_{j:02}_force_n")));
    let mut table = CsvTable::new(&header);
    for k in 0..m {
        let mut row = vec![k as f64 / m as f64];
        row.extend(o.contact_force.iter().map(|v| v[k]));
        table.push_numbers(&row)?;
    }
    table.write(&dir.join(format!("contact_map_{tag}.csv")))?;
    figures::contact_map_figure(&o.contact_force, o.q, dir, tag)
}

/// The frames of one kept amplitude for ParaView: an XDMF time series over one period on the full
/// FE mesh (`mode_<tag>.xdmf` + `mode_<tag>.h5`, `nlmodes_output::xdmf`), time values in seconds
/// (t = f T / frames). The mesh is stored once; the frames at t and T - t hold the same state
/// (the orbit is a cosine series, even in time: Eq. 10), computed bitwise equal by
/// [`Orbit::at_frame`], so they share their datasets.
///
/// Point fields (Float32: relative rounding 6e-8, far below what a picture shows):
/// `displacement_m` (m); `radial_gap_m` (m), the radial displacement minus the initial gap
/// (0 = touching, negative = open) and `contact_force_n` (N, at the nearest of the m force
/// samples), both defined on the contact nodes only and NaN elsewhere; `contact_node`, 1 on the
/// contact nodes and 0 elsewhere. Coordinates are Float32 too (2e-8 m on this blade).
fn xdmf_series(
    case: &Case,
    model: &ReducedModel,
    full: &FullMesh,
    o: &Orbit,
    g0: f64,
    dir: &Path,
    tag: &str,
) -> Result<()> {
    let frames = case.nnm.frames.max(2);
    let states: Vec<Vec<f64>> = (0..frames).map(|f| o.at_frame(f, frames)).collect();
    let forces: Vec<Vec<f64>> = (0..frames)
        .map(|f| {
            let k = o.force_sample_at_frame(f, frames);
            o.contact_force.iter().map(|row| row[k]).collect()
        })
        .collect();
    let period = o.period();
    let note = format!(
        "nlmodes: nonlinear mode at q/g0 = {:.4}, one period T = {:.9e} s (f = {:.6} Hz, \
         w/w1 = {:.6}) in {frames} frames; time values in seconds, frame f at t = f T / {frames}. \
         {FIELDS_NOTE} Heavy data in mode_{tag}.h5; frames at t and T - t share their arrays (the \
         orbit is even in time).",
        o.q / g0,
        period,
        o.frequency_hz,
        o.omega_ratio
    );
    remove_vtu_series(dir)?;
    let series = OrbitSeries {
        states: &states,
        forces: &forces,
        period,
        note: &note,
    };
    write_orbit_series(model, full, &series, &dir.join(format!("mode_{tag}.xdmf")))
}

/// What the point fields of an orbit's series are (the XDMF file's note).
pub const FIELDS_NOTE: &str = "Point fields (Float32): displacement_m (m); radial_gap_m (m, \
     radial displacement minus gap: 0 = touching, < 0 = open) and contact_force_n (N), defined on \
     the contact nodes only, NaN elsewhere; contact_node (1 on the contact nodes).";

/// One period of an orbit in reduced coordinates, for ParaView.
pub struct OrbitSeries<'a> {
    /// The reduced state at each frame (frame f at t = f T / frames).
    pub states: &'a [Vec<f64>],
    /// The contact forces (N, one per contact node) at each frame.
    pub forces: &'a [Vec<f64>],
    /// T (s).
    pub period: f64,
    /// The file's note.
    pub note: &'a str,
}

/// Writes `series` on the full FE mesh as an XDMF time series at `path` (+ `.h5`): the fields of
/// [`FIELDS_NOTE`], time values in seconds. Frames holding bitwise equal states share datasets.
pub fn write_orbit_series(
    model: &ReducedModel,
    full: &FullMesh,
    series: &OrbitSeries<'_>,
    path: &Path,
) -> Result<()> {
    let frames = series.states.len();
    let n_nodes = full.mesh.n_nodes();
    let mut is_contact = vec![0.0; n_nodes];
    for &n in &full.contact_nodes {
        is_contact[n] = 1.0;
    }
    let recovered = full.recover(series.states)?;
    let mut gaps = vec![vec![f64::NAN; n_nodes]; frames];
    let mut forces = vec![vec![f64::NAN; n_nodes]; frames];
    for f in 0..frames {
        let radial_disp = radial(model, &series.states[f]);
        for (j, &n) in full.contact_nodes.iter().enumerate() {
            gaps[f][n] = radial_disp[j] - model.contact_nodes[j].gap;
            forces[f][n] = series.forces[f][j];
        }
    }
    let frames_out: Vec<XdmfFrame> = (0..frames)
        .map(|f| XdmfFrame {
            time: f as f64 / frames as f64 * series.period,
            fields: vec![
                Field::vector("displacement_m", &recovered[f]).f32(),
                Field::scalar("radial_gap_m", &gaps[f]).f32().partial(),
                Field::scalar("contact_force_n", &forces[f]).f32().partial(),
                Field::scalar("contact_node", &is_contact).f32(),
            ],
        })
        .collect();
    let written = write_xdmf_series(
        path,
        &crate::post::output::vtu_mesh(&full.mesh),
        Precision::F32,
        &frames_out,
        series.note,
    )?;
    tracing::debug!(
        "{}: {} field arrays in {} datasets",
        written.heavy_data.display(),
        written.field_arrays,
        written.field_datasets
    );
    Ok(())
}

/// Removes the VTU frames and PVD that earlier versions wrote in an amplitude folder (the XDMF
/// series replaces them; stale frames of another orbit would mislead).
fn remove_vtu_series(dir: &Path) -> Result<()> {
    for entry in std::fs::read_dir(dir).with_context(|| format!("cannot list {}", dir.display()))? {
        let path = entry?.path();
        let name = path.file_name().map(|n| n.to_string_lossy().into_owned());
        let stale = name.is_some_and(|n| {
            (n.starts_with("frame_") && n.ends_with(".vtu"))
                || (n.starts_with("mode_") && n.ends_with(".pvd"))
        });
        if stale {
            std::fs::remove_file(&path)
                .with_context(|| format!("cannot remove {}", path.display()))?;
        }
    }
    Ok(())
}

/// Fig. 5: the deformed blade at t = 0, T/2 and the instant of largest contact force (if any
/// contact), one warp factor for the three; returns the picture's path.
fn shape_figure(full: &FullMesh, o: &Orbit, g0: f64, figures: &Path, tag: &str) -> Result<PathBuf> {
    let mut instants = vec![(0.0, "t = 0".to_string()), (0.5, "t = T/2".to_string())];
    let m = o.force_samples();
    let contact = o.largest_force_sample();
    if let Some(k) = contact {
        let t = k as f64 / m as f64;
        instants.push((t, format!("t = {t:.3} T (largest contact force)")));
    }
    let states: Vec<Vec<f64>> = instants
        .iter()
        .map(|(t, _)| o.at_phase(2.0 * PI * t))
        .collect();
    let recovered = full.recover(&states)?;
    // The warp factor and colour range hold over the whole period (sampled at 48 instants).
    let period_samples: Vec<Vec<f64>> = (0..48)
        .map(|i| o.at_phase(2.0 * PI * i as f64 / 48.0))
        .collect();
    let max_displacement = full
        .recover(&period_samples)?
        .iter()
        .map(|u| render::max_norm(u))
        .fold(0.0, f64::max);
    let snapshots: Vec<Snapshot> = instants
        .iter()
        .zip(recovered)
        .map(|((t, label), u)| {
            let k = o.force_sample_at(*t);
            Snapshot {
                label: label.clone(),
                displacement: u,
                contact_force: o.contact_force.iter().map(|v| v[k]).collect(),
            }
        })
        .collect();
    std::fs::create_dir_all(figures)
        .with_context(|| format!("cannot create {}", figures.display()))?;
    let path = figures.join(format!("shape_{tag}.png"));
    render::amplitude_figure(
        &full.surface,
        &full.mesh,
        &full.contact_nodes,
        &snapshots,
        max_displacement,
        &format!(
            "Nonlinear mode at q/g0 = {:.2}, w/w1 = {:.4} (f = {:.2} Hz){}",
            o.q / g0,
            o.omega_ratio,
            o.frequency_hz,
            if contact.is_none() {
                ", no contact"
            } else {
                ""
            }
        ),
        &path,
    )?;
    Ok(path)
}

/// The first linear modes of the reduced model (Craig-Bampton, recovered on the full mesh), as
/// pictures: returns the picture's path.
fn linear_modes_figure(model: &ReducedModel, full: &FullMesh, figures: &Path) -> Result<PathBuf> {
    let (values, vectors) =
        nlmodes_modal::dense_generalized_eigen(model.k.as_ref(), model.m.as_ref())?;
    let count = values.len().min(4);
    let states: Vec<Vec<f64>> = (0..count)
        .map(|j| vectors.col(j).iter().copied().collect())
        .collect();
    let shapes = full.recover(&states)?;
    let modes: Vec<(String, Vec<f64>)> = shapes
        .into_iter()
        .enumerate()
        .map(|(j, u)| {
            let f = values[j].max(0.0).sqrt() / (2.0 * PI);
            (format!("mode {}: {f:.1} Hz", j + 1), u)
        })
        .collect();
    std::fs::create_dir_all(figures)
        .with_context(|| format!("cannot create {}", figures.display()))?;
    let path = figures.join("linear_modes.png");
    render::modes_figure(
        &full.surface,
        &full.mesh,
        &full.contact_nodes,
        &modes,
        &path,
    )?;
    Ok(path)
}

/// A several-mode case (`[continuation] modes = [...]`): the combined frequency-energy plot of
/// every mode's family and a `report.md` at the case root with one section per mode, each linking
/// that mode's own report (`mode_<k + 1>/report.md`).
pub fn several_modes(case: &Case, layout: &Layout, modes: &[usize]) -> Result<()> {
    let mut families = Vec::new();
    for &k in modes {
        let path = layout.for_mode(k).backbone().join("backbone.json");
        if path.exists() {
            families.push((k, read_json::<BackboneFile>(&path)?));
        }
    }
    figures::combined_frequency_energy(&families, &layout.root)?;
    crate::post::report::write_modes_index(case, layout, &families)
}
