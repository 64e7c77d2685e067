//! The parametric reduced model of the rotating blade over the Campbell range (issue 39, item 2;
//! docs/ROTATION.md, "Parametric reduced model"), built by the Campbell stage from its march
//! and written to `results/<case>/parametric/` (format and library API:
//! [`nlmodes_modal::parametric`]).
//!
//! - Basis: the Craig-Bampton basis T of K(Omega_ref) onto the contact nodes (`[model]
//!   fixed_interface_modes`, as the reduced model at speed of the `speed` stage) at the
//!   reference speed Omega_ref, the middle of the range (a speed of the march: the middle basis
//!   speed of the Ritz model), with the contact geometry of that speed.
//! - Samples: K_r(Omega) = T^T K(Omega) T at every speed of the march (the Campbell speeds and
//!   the Ritz basis speeds), and the contact nodes' static displacements there.
//! - Accuracy, measured: at `[rotation] parametric_checks` speeds midway between samples
//!   (static states solved on the side of the march), the model's frequencies against the true
//!   K(Omega) projected on T (the interpolation's error) and against the full model (the Ritz
//!   model of the Campbell diagram, within 1e-7 of direct eigen-solves), its running gaps
//!   against the true static state's; at the samples, its frequencies against the full model
//!   (the basis's error).

use anyhow::{Context, Result};
use faer::Mat;
use nlmodes_fem::rotation::RotorAxis;
use nlmodes_modal::{Accuracy, AccuracyCheck, ParametricContact, ParametricModel, ReducedModel};
use sprs::CsMat;

use std::path::Path;

use serde::{Deserialize, Serialize};

use crate::campbell::campbell_march::SpeedPoint;
use crate::mesh::fe_model::FeModel;
use crate::reduce::{ReduceSettings, RunningContact};

/// What `campbell.json` says of the parametric model (`parametric/parametric.json` holds it
/// all).
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct ParametricSummary {
    /// Order of the reduced model.
    pub n: usize,
    /// The speed of the basis, rpm.
    pub reference_speed_rpm: f64,
    /// The sample speeds, rpm (the first and last bound the range of validity).
    pub sample_speeds_rpm: Vec<f64>,
    /// The measured errors (speeds in rad/s, as in `parametric.json`).
    pub accuracy: Accuracy,
}

impl ParametricSummary {
    pub fn of(model: &ParametricModel) -> Self {
        let rpm = crate::rotation::rotation_settings::RPM_TO_RAD_S;
        Self {
            n: model.mass().nrows(),
            reference_speed_rpm: model.reference_speed() / rpm,
            sample_speeds_rpm: model.speeds().iter().map(|w| w / rpm).collect(),
            accuracy: model.accuracy().cloned().unwrap_or(Accuracy {
                modes: 0,
                checks: Vec::new(),
            }),
        }
    }
}

/// Writes the model to `dir`, its recovery basis compact as the other reduced models' (the
/// mid-edge rows of `msh` predicted).
pub fn write(model: &ParametricModel, dir: &Path, msh: &Path) -> Result<()> {
    let predictions = match &model.reference().mesh {
        Some(reference) => crate::post::output::mid_edge_predictions(msh, reference)?,
        None => Vec::new(),
    };
    let storage = nlmodes_modal::RecoveryStorage::Fixed24 { predictions };
    model
        .write(dir, &storage)
        .with_context(|| format!("writing the parametric model to {}", dir.display()))
}

/// The speeds (rad/s) midway (in rpm) between `count` of the consecutive `samples` (rad/s,
/// ascending): the first, the last and evenly between.
pub fn check_speeds(samples: &[f64], count: usize) -> Vec<f64> {
    let intervals = samples.len().saturating_sub(1);
    if intervals == 0 || count == 0 {
        return Vec::new();
    }
    let count = count.min(intervals);
    let mut picked: Vec<usize> = (0..count)
        .map(|k| {
            if count == 1 {
                intervals / 2
            } else {
                (k * (intervals - 1) + (count - 1) / 2) / (count - 1)
            }
        })
        .collect();
    picked.dedup();
    picked
        .into_iter()
        .map(|i| 0.5 * (samples[i] + samples[i + 1]))
        .collect()
}

/// What the builder collects along the march and the passes after it.
pub struct ParametricBuilder<'a> {
    fe: &'a FeModel,
    /// The reduction's settings (contact group, cold gap, fixed-interface modes, master).
    settings: ReduceSettings<'a>,
    axis: RotorAxis,
    /// Contact nodes (mesh indices), in the order of the reduced models.
    contact: Vec<usize>,
    reference_speed: f64,
    /// The lowest modes compared.
    modes: usize,
    /// The contact nodes' static displacement at each speed visited (rad/s), m.
    displacements: Vec<(f64, Vec<[f64; 3]>)>,
    reference: Option<ReducedModel>,
    /// (speed, K_r, full-model frequencies in Hz) at the samples and at the checks.
    samples: Vec<(f64, Mat<f64>, Vec<f64>)>,
    checks: Vec<(f64, Mat<f64>, Vec<f64>)>,
}

impl<'a> ParametricBuilder<'a> {
    /// A builder of the reduction `settings` (the `[model]` table's) with its basis at
    /// `reference_speed` (rad/s, a speed of the march), comparing the lowest `modes`
    /// frequencies.
    pub fn new(
        fe: &'a FeModel,
        settings: ReduceSettings<'a>,
        axis: RotorAxis,
        reference_speed: f64,
        modes: usize,
    ) -> Result<Self> {
        let contact = crate::reduce::ordered_contact_nodes(fe, settings.contact_group)?;
        Ok(Self {
            fe,
            settings,
            axis,
            contact,
            reference_speed,
            modes,
            displacements: Vec::new(),
            reference: None,
            samples: Vec::new(),
            checks: Vec::new(),
        })
    }

    /// At a speed of the march: the contact nodes' displacement, and at the reference speed the
    /// Craig-Bampton reduction of K(Omega) (the basis).
    pub fn visit(&mut self, point: &SpeedPoint<'_>) -> Result<()> {
        let u = point.displacement;
        let at: Vec<[f64; 3]> = self
            .contact
            .iter()
            .map(|&n| [u[3 * n], u[3 * n + 1], u[3 * n + 2]])
            .collect();
        self.displacements.push((point.omega, at));
        if point.omega == self.reference_speed {
            self.reference = Some(self.reduce_at(point)?);
        }
        Ok(())
    }

    /// The reduced model at the reference speed: Craig-Bampton of K(Omega) with the contact
    /// nodes at their prestressed positions and running gaps (as the `speed` stage's; over the
    /// ranks under mpirun, by the march's solver).
    fn reduce_at(&self, point: &SpeedPoint<'_>) -> Result<ReducedModel> {
        let s = &self.settings;
        let growth = crate::rotation::prestress::radial_growth(
            self.fe,
            &self.axis,
            point.displacement,
            &self.contact,
        );
        let gaps: Vec<f64> = growth.iter().map(|g| s.gap - g).collect();
        let fe = FeModel {
            mesh: self.fe.mesh.clone(),
            dofs: self.fe.dofs.clone(),
            k: point.stiffness.clone(),
            m: self.fe.m.clone(),
            clamp: self.fe.clamp.clone(),
        };
        let settings = ReduceSettings {
            contact_group: s.contact_group,
            axis: s.axis.clone(),
            gap: s.gap,
            modes: s.modes,
            master: s.master,
            check_modes: 0,
            running: Some(RunningContact {
                displacement: point.displacement,
                gaps: &gaps,
            }),
            loads: Vec::new(),
        };
        let (model, _) = point.solver.reduce(&fe, &settings).with_context(|| {
            format!(
                "the basis of the parametric model at {:.1} rpm",
                point.omega / crate::rotation::rotation_settings::RPM_TO_RAD_S
            )
        })?;
        Ok(model)
    }

    /// Adds to the basis the full model's `modes` (free DOFs; the lowest modes at the Ritz
    /// basis speeds): with the nonlinear prestress a Craig-Bampton basis of one speed misses
    /// the modes of the others (docs/ROTATION.md: 19 % on the third frequency of the coarse
    /// blade at rest from a 5000 rpm basis), and with them it holds every mode of the Ritz
    /// model of the Campbell diagram ([`nlmodes_modal::enrich_with_modes`]: each mode's part
    /// beyond the constraint modes, M-orthogonalized twice against the interior columns).
    /// M_r = T^T M T of the enlarged basis replaces the reference model's.
    pub fn enrich(&mut self, modes: &[&Mat<f64>], m: &CsMat<f64>) -> Result<()> {
        let boundary: Vec<usize> = self
            .contact
            .iter()
            .flat_map(|&n| (0..3).map(move |c| 3 * n + c))
            .map(|d| self.fe.dofs.free_index(d).context("a contact DOF is fixed"))
            .collect::<Result<_>>()?;
        let reference = self.reference.as_mut().context("no reference model")?;
        let t = reference.recovery.as_ref().context("no basis")?;
        let modes: Vec<_> = modes.iter().map(|&v| v.as_ref()).collect();
        let enriched = nlmodes_modal::enrich_with_modes(t.as_ref(), &boundary, &modes, m)
            .context("the enriched basis of the parametric model")?;
        let n_b = boundary.len();
        tracing::info!(
            "parametric model: basis of {} vectors ({} constraint modes, {} fixed-interface \
             modes at the reference speed, {} modes of the other speeds)",
            enriched.basis.ncols(),
            n_b,
            t.ncols() - n_b,
            enriched.added
        );
        reference.m = enriched.mass;
        reference.recovery = Some(enriched.basis);
        Ok(())
    }

    /// T^T K T (N/m), symmetrized, T the reference model's basis.
    fn project(&self, k: &CsMat<f64>) -> Result<Mat<f64>> {
        let t = self
            .reference
            .as_ref()
            .and_then(|r| r.recovery.as_ref())
            .context("the parametric model's basis (the reference speed was not visited)")?;
        Ok(nlmodes_modal::project_symmetric(k, t.as_ref()).reduced)
    }

    /// A sample speed's K(Omega) (N/m), with the full model's frequencies there (Hz,
    /// ascending).
    pub fn sample(&mut self, omega: f64, k: &CsMat<f64>, full_hz: Vec<f64>) -> Result<()> {
        let k_r = self.project(k)?;
        self.samples.push((omega, k_r, full_hz));
        Ok(())
    }

    /// A check speed's K(Omega) (N/m), with the full model's frequencies there (Hz).
    pub fn check(&mut self, omega: f64, k: &CsMat<f64>, full_hz: Vec<f64>) -> Result<()> {
        let k_r = self.project(k)?;
        self.checks.push((omega, k_r, full_hz));
        Ok(())
    }

    /// The model and its measured accuracy; `msh` the mesh file its reference points to.
    pub fn finish(self, kinematics: &str, msh: &Path) -> Result<ParametricModel> {
        let mut reference = self.reference.clone().context("no reference model")?;
        if let Some(m) = reference.mesh.as_mut() {
            let abs = std::fs::canonicalize(msh).unwrap_or_else(|_| msh.to_path_buf());
            m.msh_file = abs.to_string_lossy().into_owned();
        }
        let mut samples = self.samples.clone();
        samples.sort_by(|a, b| a.0.total_cmp(&b.0));
        let speeds: Vec<f64> = samples.iter().map(|s| s.0).collect();
        // The directory's K.mtx is the sample at the reference speed (the same projection as
        // the other samples).
        let r = speeds
            .iter()
            .position(|&w| w == self.reference_speed)
            .context("the reference speed is not a sample")?;
        reference.k = samples[r].1.clone();
        let count = reference.linear_frequencies_hz.len();
        reference.linear_frequencies_hz =
            nlmodes_modal::reduced_model::linear_frequencies_hz(&reference.k, &reference.m, count)?;
        let contact = self.contact_samples(&speeds)?;
        let stiffness = samples.iter().map(|s| s.1.clone()).collect();
        let mut model = ParametricModel::new(
            reference,
            self.reference_speed,
            speeds,
            stiffness,
            contact,
            kinematics,
        )?;
        let accuracy = self.accuracy(&model, &samples)?;
        model.set_accuracy(accuracy);
        Ok(model)
    }

    /// The contact nodes with their displacements at the sample `speeds`.
    fn contact_samples(&self, speeds: &[f64]) -> Result<Vec<ParametricContact>> {
        let at = |w: f64| {
            self.displacements
                .iter()
                .find(|d| d.0 == w)
                .map(|d| &d.1)
                .with_context(|| format!("no static state at {w} rad/s"))
        };
        let per_speed: Vec<&Vec<[f64; 3]>> =
            speeds.iter().map(|&w| at(w)).collect::<Result<_>>()?;
        Ok(self
            .contact
            .iter()
            .enumerate()
            .map(|(j, &n)| ParametricContact {
                mesh_node: Some(n as u64 + 1),
                undeformed_position: self.fe.mesh.nodes[n],
                cold_gap: self.settings.gap,
                displacement_m: per_speed.iter().map(|u| u[j]).collect(),
            })
            .collect())
    }

    /// The errors at the samples (basis) and at the checks (interpolation, basis, gaps).
    fn accuracy(
        &self,
        model: &ParametricModel,
        samples: &[(f64, Mat<f64>, Vec<f64>)],
    ) -> Result<Accuracy> {
        let mut checks = Vec::new();
        for (omega, k_r, full) in samples.iter().chain(&self.checks) {
            let between = !samples.iter().any(|s| s.0 == *omega);
            checks.push(self.check_at(model, *omega, k_r, full, between)?);
        }
        checks.sort_by(|a, b| a.speed_rad_s.total_cmp(&b.speed_rad_s));
        Ok(Accuracy {
            modes: self.modes,
            checks,
        })
    }

    fn check_at(
        &self,
        model: &ParametricModel,
        omega: f64,
        k_true: &Mat<f64>,
        full: &[f64],
        between_samples: bool,
    ) -> Result<AccuracyCheck> {
        let hz = |k: &Mat<f64>| {
            nlmodes_modal::reduced_model::linear_frequencies_hz(k, model.mass(), self.modes)
        };
        let (f, f_true) = (hz(&model.stiffness_at(omega)?)?, hz(k_true)?);
        tracing::debug!("parametric check at {omega:.3} rad/s: model {f:?}, projected {f_true:?}, full {full:?}");
        let worst = |a: &[f64], b: &[f64]| {
            a.iter()
                .zip(b)
                .map(|(x, y)| (x - y).abs() / y.abs())
                .fold(0.0, f64::max)
        };
        let (_, u) = self
            .displacements
            .iter()
            .find(|d| d.0 == omega)
            .with_context(|| format!("no static state at {omega} rad/s"))?;
        let u_global = self.contact_global(u);
        let growth = crate::rotation::prestress::radial_growth(
            self.fe,
            &self.axis,
            &u_global,
            &self.contact,
        );
        let nodes = model.contact_nodes_at(omega)?;
        let (mut gap_error_m, mut gap_relative_error) = (0.0_f64, 0.0_f64);
        for (node, g) in nodes.iter().zip(&growth) {
            let g_true = self.settings.gap - g;
            let e = (node.gap - g_true).abs();
            gap_error_m = gap_error_m.max(e);
            gap_relative_error = gap_relative_error.max(e / g_true.abs());
        }
        Ok(AccuracyCheck {
            speed_rad_s: omega,
            between_samples,
            interpolation_frequency_error: worst(&f, &f_true),
            full_model_frequency_error: (full.len() >= f.len()).then(|| worst(&f, full)),
            gap_error_m,
            gap_relative_error,
        })
    }

    /// A global displacement (3 per mesh node) holding `u` at the contact nodes, zero elsewhere
    /// (what the radial growth of the contact nodes reads).
    fn contact_global(&self, u: &[[f64; 3]]) -> Vec<f64> {
        let mut g = vec![0.0; 3 * self.fe.mesh.n_nodes()];
        for (&n, v) in self.contact.iter().zip(u) {
            g[3 * n..3 * n + 3].copy_from_slice(v);
        }
        g
    }
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use crate::campbell::campbell_march::{fixtures, SpeedFamily};
    use crate::campbell::BasisModes;

    /// Sample speeds of the beam's models, rad/s (lambda = Omega sqrt(rho A L^4 / E I) up to
    /// 1.03: 58.5 rad/s is lambda = 1), the basis at 40; checks midway.
    const SAMPLES: [f64; 4] = [0.0, 20.0, 40.0, 60.0];
    const CHECKS: [f64; 3] = [10.0, 30.0, 50.0];

    /// The parametric model of the 10 x 2 x 2 TET10 beam turning about the z axis through its
    /// root-section centre (the Southwell beam of `crates/fem/tests/rotation_southwell.rs`),
    /// reduced onto its tip face (25 nodes, 10 fixed-interface modes, cold gap 1 mm), checked
    /// at `CHECKS` against the full model's lowest 4 frequencies by a direct shift-invert
    /// solve of the true K(Omega).
    pub(crate) fn beam_model(nonlinear: bool) -> ParametricModel {
        let fe = fixtures::beam([10, 2, 2]);
        let axis = RotorAxis::new([0.0, 0.02, 0.02], [0.0, 0.0, 1.0]).unwrap();
        let settings = ReduceSettings {
            contact_group: "xmax",
            axis: nlmodes_modal::RotorAxis::new([0.0, 0.02, 0.02], [0.0, 0.0, 1.0]).unwrap(),
            gap: 1e-3,
            modes: 10,
            master: None,
            check_modes: 0,
            running: None,
            loads: Vec::new(),
        };
        let mut basis = BasisModes::new(&[0.0, 40.0, 60.0], 6);
        let mut builder = ParametricBuilder::new(&fe, settings, axis, 40.0, 4).unwrap();
        let mut family = SpeedFamily::of(
            crate::rotation::rotation_mpi::FullSolver::default(),
            &fe,
            &fixtures::steel(),
            &axis,
            nonlinear,
            (&SAMPLES, &CHECKS),
            &mut |mut p| {
                basis.visit(&mut p, &fe.m)?;
                builder.visit(&p)
            },
        )
        .unwrap();
        builder
            .enrich(&basis.modes().collect::<Vec<_>>(), &fe.m)
            .unwrap();
        let opts = nlmodes_modal::EigenOptions::default();
        for (omega, sample) in SAMPLES
            .iter()
            .map(|w| (*w, true))
            .chain(CHECKS.iter().map(|w| (*w, false)))
        {
            let k = family.at(omega).unwrap();
            let (m, _) = family.mass_and_solver();
            let full = nlmodes_modal::eigs_shift_invert(&k, m, 4, 0.0, &opts).unwrap();
            let hz = full.frequencies_hz();
            if sample {
                builder.sample(omega, &k, hz).unwrap();
            } else {
                builder.check(omega, &k, hz).unwrap();
            }
        }
        let kinematics = if nonlinear { "nonlinear" } else { "linear" };
        builder.finish(kinematics, Path::new("beam.msh")).unwrap()
    }

    /// The Southwell coefficient of the first flapwise mode from the model, mixing-proof: the
    /// first two modes are the flapwise (S) and chordwise (S - 1, spin softening in the plane
    /// of rotation) bending of the square beam, so S = Delta(w1^2 + w2^2) / (2 Omega^2) + 1/2.
    fn southwell(model: &ParametricModel, omega: f64) -> f64 {
        let sum = |w: f64| {
            let f = model.at(w).unwrap().linear_frequencies_hz;
            (f[0] * f[0] + f[1] * f[1]) * (2.0 * std::f64::consts::PI).powi(2)
        };
        (sum(omega) - sum(0.0)) / (2.0 * omega * omega) + 0.5
    }

    /// Against independent solutions, for both prestress kinematics:
    /// - the rotating Euler-Bernoulli cantilever: its Southwell coefficient 1.1933 (first
    ///   flapwise mode, zero hub; docs/ROTATION.md) from the model's frequencies between the
    ///   samples (30 rad/s) and near lambda = 1 (58.5 rad/s), within 1 %: the tolerance of the
    ///   FE Southwell test (this mesh's own discretization error is +0.40 %; the exact rotating
    ///   beam's secant stays within 0.1 % of 1.1933 up to lambda = 1);
    /// - direct shift-invert solves of the full model's true K(Omega) at the checks, between the
    ///   samples: the lowest 4 frequencies within 1e-6 (the error the builder measures and
    ///   records; linear kinematics: the spline is exact, what is left is the basis's error;
    ///   nonlinear: strains of 7e-5 keep K(Omega) within round-off of affine in Omega^2).
    #[test]
    fn parametric_beam_against_the_rotating_beam_and_direct_solves() {
        for nonlinear in [false, true] {
            let model = beam_model(nonlinear);
            let accuracy = model.accuracy().unwrap();
            for c in &accuracy.checks {
                println!(
                    "nonlinear {nonlinear} Omega {:5.1}: between {} interpolation {:.1e} full \
                     {:.1e} gap {:.1e} m",
                    c.speed_rad_s,
                    c.between_samples,
                    c.interpolation_frequency_error,
                    c.full_model_frequency_error.unwrap(),
                    c.gap_error_m
                );
                assert!(c.full_model_frequency_error.unwrap() < 1e-6, "{c:?}");
                assert!(c.interpolation_frequency_error < 1e-6, "{c:?}");
            }
            assert_eq!(
                accuracy.checks.iter().filter(|c| c.between_samples).count(),
                3
            );
            for omega in [30.0, 58.5] {
                let s = southwell(&model, omega);
                println!("nonlinear {nonlinear}: Southwell S at {omega} rad/s = {s:.5}");
                assert!(
                    (s - 1.1933).abs() < 0.01 * 1.1933,
                    "S = {s} at {omega} rad/s"
                );
            }
        }
    }

    #[test]
    fn check_speeds_are_midpoints_of_spread_intervals() {
        let s: Vec<f64> = (0..11).map(|i| 100.0 * i as f64).collect();
        assert_eq!(check_speeds(&s, 3), vec![50.0, 550.0, 950.0]);
        assert_eq!(check_speeds(&s, 1), vec![550.0]);
        assert_eq!(check_speeds(&s, 0), Vec::<f64>::new());
        assert_eq!(check_speeds(&s, 50).len(), 10);
        assert_eq!(check_speeds(&s[..1], 3), Vec::<f64>::new());
        assert_eq!(check_speeds(&s[..3], 2), vec![50.0, 150.0]);
    }
}
