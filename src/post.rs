//! The post-processing stage: the paper's figures for our blade (Sec. 4: Figs. 3a, 3b, 4, 5),
//! CSV tables, VTU series for ParaView and a Markdown report.
//!
//! Displacements are normalized by the initial gap g0 and frequencies by the first linear
//! frequency w1, as in the paper.

use anyhow::{Context, Result};
use nlmodes_modal::ReducedModel;
use nlmodes_output::{write_pvd, CsvTable, Field, PvdEntry};
use serde::Deserialize;
use std::f64::consts::PI;
use std::path::{Path, PathBuf};

use crate::case::Case;
use crate::run::Layout;
use crate::{figures, ui};
use rayon::prelude::*;

/// What post-processing reads of a backbone point (a subset of `nlmodes_nnm::BackbonePoint`).
#[derive(Debug, Clone, Deserialize)]
pub struct Orbit {
    pub q: f64,
    pub omega: f64,
    pub omega_ratio: f64,
    pub frequency_hz: f64,
    pub contact_fraction: Vec<f64>,
    pub powell_measure: f64,
    pub newton_iterations: usize,
    pub fold: bool,
    pub jump: bool,
    pub truncation_warning: bool,
    /// u_n, n = 0..N (reduced coordinates).
    pub coefficients: Vec<Vec<f64>>,
    /// lambda_{j,k} at t_k = k T / m (N).
    pub contact_force: Vec<Vec<f64>>,
}

impl Orbit {
    /// u(t) at phase theta = w t.
    pub fn at_phase(&self, theta: f64) -> Vec<f64> {
        let n = self.coefficients[0].len();
        let mut u = vec![0.0; n];
        for (h, c) in self.coefficients.iter().enumerate() {
            let w = (h as f64 * theta).cos();
            for (ui, ci) in u.iter_mut().zip(c) {
                *ui += w * ci;
            }
        }
        u
    }

    /// du/dt at phase theta = w t.
    pub fn rate_at_phase(&self, theta: f64) -> Vec<f64> {
        let n = self.coefficients[0].len();
        let mut v = vec![0.0; n];
        for (h, c) in self.coefficients.iter().enumerate() {
            let w = -(h as f64) * self.omega * (h as f64 * theta).sin();
            for (vi, ci) in v.iter_mut().zip(c) {
                *vi += w * ci;
            }
        }
        v
    }

    /// Number of contact rows touching at some time of the period.
    pub fn touching(&self) -> usize {
        self.contact_fraction.iter().filter(|&&f| f > 0.0).count()
    }
}

/// The backbone file as post-processing reads it.
#[derive(Debug, Clone, Deserialize)]
pub struct BackboneFile {
    pub points: Vec<Orbit>,
    pub termination: serde_json::Value,
    pub omega_linear: f64,
    pub gap_reference: f64,
    pub grazing_amplitude: Option<f64>,
    /// Internal-resonance tongues skipped by the continuation.
    #[serde(default)]
    pub internal_resonances: Vec<nlmodes_nnm::InternalResonance>,
}

fn read_json<T: for<'de> Deserialize<'de>>(path: &Path) -> Result<T> {
    let bytes = std::fs::read(path).with_context(|| format!("cannot read {}", path.display()))?;
    serde_json::from_slice(&bytes).with_context(|| format!("invalid JSON in {}", path.display()))
}

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

    figures::backbone_figure(&b, out)?;
    let nonlinear = manifold_coordinate(&b);
    manifold(&model, &b, nonlinear, out)?;
    // The full mesh, read once for every VTU series.
    let mesh = match (&model.recovery, &model.mesh) {
        (Some(_), Some(mref)) => Some(
            nlmodes_fem::read_msh(Path::new(&mref.msh_file)).with_context(|| {
                format!("reading the mesh of the reduced model {}", mref.msh_file)
            })?,
        ),
        _ => None,
    };
    let mut written = Vec::new();
    for orbit in &kept {
        let tag = format!("q{:.1}", orbit.q / g0);
        let dir = out.join(format!("amplitude_{tag}"));
        std::fs::create_dir_all(&dir)
            .with_context(|| format!("cannot create {}", dir.display()))?;
        radial_history(&model, orbit, g0, &dir, &tag)?;
        contact_map(orbit, &dir, &tag)?;
        if let Some(mesh) = &mesh {
            vtu_series(case, &model, mesh, orbit, &dir, &tag)?;
        } else {
            tracing::warn!("the reduced model has no recovery basis or mesh: VTU output skipped");
        }
        written.push((orbit.clone(), dir));
    }
    crate::report::write_report(case, layout, &model, &b, &written)?;
    stage.done(&format!(
        "figures, tables and {} VTU series in {}",
        written.len(),
        out.display()
    ));
    Ok(())
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

/// Fig. 4: radial displacement / g0 of every contact node over one period.
fn radial_history(model: &ReducedModel, o: &Orbit, g0: f64, dir: &Path, tag: &str) -> Result<()> {
    let c = model.contact_nodes.len();
    let samples = 200;
    let mut header = vec!["t_over_T".to_string()];
    header.extend((1..=c).map(|j| format!("node_{j:02}")));
    let mut table = CsvTable::new(&header);
    let mut series = vec![Vec::with_capacity(samples + 1); c];
    for k in 0..=samples {
        let t = k as f64 / samples as f64;
        let r = radial(model, &o.at_phase(2.0 * PI * t));
        let mut row = vec![t];
        for j in 0..c {
            row.push(r[j] / g0);
            series[j].push((t, r[j] / g0));
        }
        table.push_numbers(&row)?;
    }
    table.write(&dir.join(format!("radial_{tag}.csv")))?;
    figures::radial_figure(&series, o.q / g0, dir, tag)
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

/// Fig. 5: a VTU per frame over one period on the full FE mesh, and a PVD collection.
fn vtu_series(
    case: &Case,
    model: &ReducedModel,
    mesh: &nlmodes_fem::Mesh,
    o: &Orbit,
    dir: &Path,
    tag: &str,
) -> Result<()> {
    let (Some(r), Some(mref)) = (&model.recovery, &model.mesh) else {
        return Ok(());
    };
    anyhow::ensure!(
        3 * mesh.n_nodes() == mref.n_full_dofs,
        "mesh {} has {} DOFs but the reduced model was built on {}",
        mref.msh_file,
        3 * mesh.n_nodes(),
        mref.n_full_dofs
    );
    let frames = case.nnm.frames.max(2);
    let m = o.contact_force.first().map(|v| v.len()).unwrap_or(1);
    let mut is_contact = vec![0.0; mesh.n_nodes()];
    let mut node_of = Vec::new();
    for cn in &model.contact_nodes {
        let n = cn
            .mesh_node
            .map(|t| t as usize - 1)
            .context("contact node without mesh node")?;
        is_contact[n] = 1.0;
        node_of.push(n);
    }
    // Reduced states of every frame as columns, recovered in one product.
    let times: Vec<f64> = (0..frames).map(|f| f as f64 / frames as f64).collect();
    let states: Vec<Vec<f64>> = times.iter().map(|t| o.at_phase(2.0 * PI * t)).collect();
    let reduced = faer::Mat::from_fn(r.ncols(), frames, |j, f| states[f][j]);
    let recovered = r * &reduced;
    let vtu = crate::output::vtu_mesh(mesh);
    let files: Vec<PathBuf> = (0..frames)
        .into_par_iter()
        .map(|f| -> Result<PathBuf> {
            let u = &states[f];
            let free = recovered.col(f).iter().copied().collect::<Vec<f64>>();
            let full = mref.expand_to_full(&free)?;
            let radial_disp = radial(model, u);
            let k = ((times[f] * m as f64).round() as usize) % m;
            let mut gap = vec![0.0; mesh.n_nodes()];
            let mut force = vec![0.0; mesh.n_nodes()];
            for (j, &n) in node_of.iter().enumerate() {
                gap[n] = radial_disp[j] - model.contact_nodes[j].gap;
                force[n] = o.contact_force[j][k];
            }
            let name = format!("frame_{f:03}.vtu");
            let fields = [
                Field::vector("displacement_m", &full),
                Field::scalar("radial_gap_m", &gap),
                Field::scalar("contact_force_n", &force),
                Field::scalar("contact_node", &is_contact),
            ];
            nlmodes_output::write_vtu(&dir.join(&name), &vtu, &fields)?;
            Ok(PathBuf::from(name))
        })
        .collect::<Result<_>>()?;
    let entries: Vec<PvdEntry> = files
        .iter()
        .zip(&times)
        .map(|(f, &t)| PvdEntry { time: t, file: f })
        .collect();
    write_pvd(&dir.join(format!("mode_{tag}.pvd")), &entries)?;
    Ok(())
}
