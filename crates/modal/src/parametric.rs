//! # Parametric reduced model in the rotation speed (format version 1)
//!
//! A reduced model of a rotating structure over a speed range [Omega_0, Omega_{s-1}] (rad/s),
//! for studies that move along the speed (an engine-order sweep W = e Omega through the
//! Campbell crossings): at any Omega of the range, the reduced stiffness K_r(Omega), the mass
//! M_r, the contact rows and the running gaps, each for the cost of a weighted sum of a few
//! small matrices ([`ParametricModel::at`]).
//!
//! ## What it is
//!
//! - One reduction basis T for every speed (the Craig-Bampton basis of the structure at a
//!   reference speed, the contact DOFs kept physical), so that the reduced coordinates mean the
//!   same at every speed; M_r = T^T M T (the mass does not depend on the speed).
//! - K_r(Omega) = T^T K(Omega) T at sample speeds Omega_0 < ... < Omega_{s-1}, exact there,
//!   and between them the cubic spline with not-a-knot ends in x = Omega^2 through the
//!   samples, entry by entry ([`crate::spline`]).
//! - The static displacement u_j(Omega) (m) of each contact node j at the same samples and by
//!   the same spline; the node's position X_j + u_j, its contact direction (the radial unit
//!   vector at that position, about the rotor axis) and its running gap
//!   g_j = g0_j - (|P (X_j + u_j - p)| - |P (X_j - p)|) (g0_j the cold gap) follow, as in the
//!   reduced model at speed of the `speed` stage.
//!
//! Exactness: with linear prestress kinematics, K(Omega) = K_0 + Omega^2 (K_sigma1 - M_spin)
//! and u_j = Omega^2 u_j1 are linear in x, which the spline reproduces to round-off (it
//! reproduces every cubic in x): the model is exact in Omega on its basis. With the nonlinear prestress (total Lagrangian) they are
//! smooth in x but not polynomial; the builder measures the error against direct solves between
//! the samples and records it (`accuracy`).
//!
//! ## Directory
//!
//! A reduced-model directory ([`crate::reduced_model`], read by [`ReducedModel::read`] as the
//! model at the reference speed: `K.mtx` = K_r(Omega_ref), `M.mtx`, `model.json` with the
//! contact nodes at that speed, the recovery basis T), and:
//!
//! | file | content |
//! | --- | --- |
//! | `parametric.json` | below |
//! | `K_speed_<i>.mtx` | K_r at sample speed i (`K_speed_00.mtx`, ...), Matrix Market as `K.mtx`, N/m |
//!
//! `parametric.json` (unknown fields rejected):
//!
//! * `format`: `"nlmodes-parametric-model"`; `format_version`: `1`;
//!   `units`: `"SI: m, kg, s, rad/s; K in N/m, M in kg"`;
//!   `interpolation`: `"not-a-knot cubic spline in Omega^2"`;
//! * `kinematics` (string): the prestress the samples come from (`"nonlinear"`, `"linear"`);
//! * `speeds_rad_s` (at least 2, finite, >= 0, strictly increasing): the sample speeds, whose
//!   first and last bound the range of validity; `speeds_rpm` the same in rpm (informative);
//! * `reference_speed_rad_s`: one of the sample speeds, the speed of the basis and of
//!   `model.json`;
//! * `stiffness_files`: one plain file name per sample speed;
//! * `contact_nodes`: in the order of `model.json`'s, for each: `mesh_node` (optional, as in
//!   `model.json`), `undeformed_position` ([x, y, z], m), `cold_gap` (m, > 0) and
//!   `displacement_m` (one [ux, uy, uz] per sample speed, m). At the reference speed the
//!   position and gap they give must be `model.json`'s (to 1e-9 of the gap);
//! * `accuracy` (optional): the error measured by the builder ([`Accuracy`]).

use std::path::{Component, Path};

use faer::Mat;
use serde::{Deserialize, Serialize};

use crate::contact_geometry::{norm, RotorAxis};
use crate::error::ModalError;
use crate::matrix_market::{read_symmetric_dense, write_symmetric_dense};
use crate::matrix_market_io::write_atomic;
use crate::reduced_model::{linear_frequencies_hz, ContactNode, RecoveryStorage, ReducedModel};
use crate::spline::CubicSpline;

/// Value of the `format` field of `parametric.json`.
pub const PARAMETRIC_FORMAT: &str = "nlmodes-parametric-model";
/// Value of its `format_version` field.
pub const PARAMETRIC_VERSION: u32 = 1;
/// Value of its `units` field.
pub const PARAMETRIC_UNITS: &str = "SI: m, kg, s, rad/s; K in N/m, M in kg";
/// Value of its `interpolation` field.
pub const INTERPOLATION: &str = "not-a-knot cubic spline in Omega^2";
/// File name of the metadata.
pub const PARAMETRIC_FILE: &str = "parametric.json";

/// A contact node of the parametric model: where it is at rest and how it moves with the speed.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ParametricContact {
    /// Tag of the node in the mesh file, if known.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub mesh_node: Option<u64>,
    /// Position at rest, m.
    pub undeformed_position: [f64; 3],
    /// Radial gap to the casing at rest, m (> 0).
    pub cold_gap: f64,
    /// Static displacement at each sample speed, m.
    pub displacement_m: Vec<[f64; 3]>,
}

/// The error of the model measured by its builder at one speed.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct AccuracyCheck {
    /// Speed, rad/s.
    pub speed_rad_s: f64,
    /// Whether the speed lies strictly between two sample speeds (else it is a sample speed,
    /// where the interpolation is exact and only the basis errs).
    pub between_samples: bool,
    /// Largest |f - f_ref| / f_ref over the compared modes, f the model's frequencies at this
    /// speed and f_ref those of the true K(Omega) projected on the same basis: the error of
    /// the interpolation alone.
    pub interpolation_frequency_error: f64,
    /// Largest |f - f_full| / f_full over the compared modes, f_full the full model's
    /// frequencies at this speed: the basis's error and the interpolation's together.
    pub full_model_frequency_error: Option<f64>,
    /// Largest |g - g_true| over the contact nodes (m), g_true the running gap of the true
    /// static state at this speed.
    pub gap_error_m: f64,
    /// Largest |g - g_true| / g_true over the contact nodes.
    pub gap_relative_error: f64,
}

/// The error of the model measured by its builder (`accuracy` of `parametric.json`).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Accuracy {
    /// The number of lowest modes whose frequencies are compared.
    pub modes: usize,
    /// The speeds checked.
    pub checks: Vec<AccuracyCheck>,
}

impl Accuracy {
    /// The largest interpolation error in frequency between the samples (0 without checks
    /// there).
    pub fn worst_interpolation(&self) -> f64 {
        self.checks
            .iter()
            .filter(|c| c.between_samples)
            .map(|c| c.interpolation_frequency_error)
            .fold(0.0, f64::max)
    }

    /// The largest error in frequency against the full model, anywhere checked.
    pub fn worst_full_model(&self) -> Option<f64> {
        self.checks
            .iter()
            .filter_map(|c| c.full_model_frequency_error)
            .reduce(f64::max)
    }

    /// The largest relative gap error between the samples.
    pub fn worst_gap(&self) -> f64 {
        self.checks
            .iter()
            .filter(|c| c.between_samples)
            .map(|c| c.gap_relative_error)
            .fold(0.0, f64::max)
    }
}

/// The `parametric.json` document.
#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct ParametricFile {
    format: String,
    format_version: u32,
    units: String,
    interpolation: String,
    kinematics: String,
    speeds_rad_s: Vec<f64>,
    speeds_rpm: Vec<f64>,
    reference_speed_rad_s: f64,
    stiffness_files: Vec<String>,
    contact_nodes: Vec<ParametricContact>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    accuracy: Option<Accuracy>,
}

/// A parametric reduced model (module documentation).
#[derive(Clone, Debug)]
pub struct ParametricModel {
    /// The model at the reference speed (its recovery basis is T).
    reference: ReducedModel,
    reference_speed: f64,
    speeds: Vec<f64>,
    stiffness: Vec<Mat<f64>>,
    contact: Vec<ParametricContact>,
    kinematics: String,
    spline: CubicSpline,
    accuracy: Option<Accuracy>,
}

/// rad/s per rpm.
const RPM: f64 = std::f64::consts::PI / 30.0;

impl ParametricModel {
    /// The model of the samples `stiffness` (K_r at each of `speeds`, rad/s) and `contact`
    /// on the basis of `reference`, the model at `reference_speed` (one of `speeds`). Errors
    /// name what does not fit: speeds (at least 2, finite, >= 0, strictly increasing), sizes,
    /// symmetry, the contact nodes and their agreement with `reference` at its speed.
    pub fn new(
        reference: ReducedModel,
        reference_speed: f64,
        speeds: Vec<f64>,
        stiffness: Vec<Mat<f64>>,
        contact: Vec<ParametricContact>,
        kinematics: &str,
    ) -> Result<Self, ModalError> {
        let invalid = |m: String| ModalError::InvalidArgument(format!("parametric model: {m}"));
        if speeds.iter().any(|w| !w.is_finite() || *w < 0.0) {
            return Err(invalid(format!(
                "speeds {speeds:?} rad/s must be finite and >= 0"
            )));
        }
        let x: Vec<f64> = speeds.iter().map(|w| w * w).collect();
        let spline = CubicSpline::new(&x).ok_or_else(|| {
            invalid(format!(
                "{} sample speeds {speeds:?} rad/s: at least 2, strictly increasing, expected",
                speeds.len()
            ))
        })?;
        let model = Self {
            reference,
            reference_speed,
            speeds,
            stiffness,
            contact,
            kinematics: kinematics.to_string(),
            spline,
            accuracy: None,
        };
        model.check().map_err(invalid)?;
        Ok(model)
    }

    /// The consistency of the parts (module documentation); the message names the culprit.
    fn check(&self) -> Result<(), String> {
        let (n, s) = (self.reference.n(), self.speeds.len());
        let r = self.reference_index().ok_or_else(|| {
            format!(
                "the reference speed {} rad/s is not a sample speed {:?}",
                self.reference_speed, self.speeds
            )
        })?;
        if self.stiffness.len() != s {
            return Err(format!(
                "{} stiffness samples for {s} sample speeds",
                self.stiffness.len()
            ));
        }
        for (i, k) in self.stiffness.iter().enumerate() {
            nlmodes_dense::check_symmetric(k.as_ref())
                .map_err(ModalError::symmetry(&format!("K_r at speed {i}")))
                .map_err(|e| e.to_string())?;
            if k.nrows() != n {
                return Err(format!(
                    "K_r at speed {i} is {0} x {0}, the model's order is {n}",
                    k.nrows()
                ));
            }
        }
        if self.contact.len() != self.reference.contact_nodes.len() {
            return Err(format!(
                "{} parametric contact nodes for the reference model's {}",
                self.contact.len(),
                self.reference.contact_nodes.len()
            ));
        }
        for (j, c) in self.contact.iter().enumerate() {
            if c.displacement_m.len() != s || !(c.cold_gap > 0.0 && c.cold_gap.is_finite()) {
                return Err(format!(
                    "contact node {j}: {} displacements for {s} speeds, cold gap {} m (> 0 \
                     expected)",
                    c.displacement_m.len(),
                    c.cold_gap
                ));
            }
            let finite = c
                .undeformed_position
                .iter()
                .chain(c.displacement_m.iter().flatten());
            if finite.into_iter().any(|v| !v.is_finite()) {
                return Err(format!(
                    "contact node {j}: a position or displacement is not finite"
                ));
            }
        }
        let at_reference = self
            .contact_nodes_from(&self.sample_weights(r))
            .map_err(|e| e.to_string())?;
        for (j, (a, b)) in at_reference
            .iter()
            .zip(&self.reference.contact_nodes)
            .enumerate()
        {
            let offset = norm(std::array::from_fn(|d| a.position[d] - b.position[d]));
            let tolerance = 1e-9 * b.gap;
            if offset > tolerance || (a.gap - b.gap).abs() > tolerance || a.dofs != b.dofs {
                return Err(format!(
                    "contact node {j} at the reference speed: position {:?} m and gap {:e} m \
                     from the displacements, {:?} m and {:e} m in the reference model (DOFs {:?} \
                     and {:?})",
                    a.position, a.gap, b.position, b.gap, a.dofs, b.dofs
                ));
            }
        }
        Ok(())
    }

    fn reference_index(&self) -> Option<usize> {
        self.speeds.iter().position(|&w| w == self.reference_speed)
    }

    /// Weights that pick sample `i`.
    fn sample_weights(&self, i: usize) -> Vec<f64> {
        let mut c = vec![0.0; self.speeds.len()];
        c[i] = 1.0;
        c
    }

    /// The spline weights at `omega` (rad/s); an error outside the range.
    fn weights(&self, omega: f64) -> Result<Vec<f64>, ModalError> {
        if let Some(i) = self.speeds.iter().position(|&w| w == omega) {
            return Ok(self.sample_weights(i));
        }
        let (lo, hi) = self.range();
        self.spline
            .weights(omega * omega)
            .filter(|_| omega >= 0.0)
            .ok_or_else(|| {
                ModalError::InvalidArgument(format!(
                    "speed {omega} rad/s ({:.1} rpm) is outside the parametric model's range \
                 [{lo}, {hi}] rad/s ([{:.1}, {:.1}] rpm)",
                    omega / RPM,
                    lo / RPM,
                    hi / RPM
                ))
            })
    }

    /// The range of validity [first, last sample speed], rad/s.
    pub fn range(&self) -> (f64, f64) {
        (self.speeds[0], self.speeds[self.speeds.len() - 1])
    }

    /// The sample speeds, rad/s.
    pub fn speeds(&self) -> &[f64] {
        &self.speeds
    }

    /// The speed of the basis, rad/s.
    pub fn reference_speed(&self) -> f64 {
        self.reference_speed
    }

    /// The model at the reference speed (with the recovery basis T, when it has one).
    pub fn reference(&self) -> &ReducedModel {
        &self.reference
    }

    /// The prestress kinematics of the samples.
    pub fn kinematics(&self) -> &str {
        &self.kinematics
    }

    /// The reduced mass M_r (kg for physical coordinates), the same at every speed.
    pub fn mass(&self) -> &Mat<f64> {
        &self.reference.m
    }

    /// K_r at sample speed `i` (N/m for physical coordinates).
    pub fn stiffness_sample(&self, i: usize) -> &Mat<f64> {
        &self.stiffness[i]
    }

    /// The contact nodes as given (rest positions, cold gaps, displacements at the samples).
    pub fn contact(&self) -> &[ParametricContact] {
        &self.contact
    }

    /// The measured error, when recorded.
    pub fn accuracy(&self) -> Option<&Accuracy> {
        self.accuracy.as_ref()
    }

    /// Records the measured error (written to `parametric.json`).
    pub fn set_accuracy(&mut self, accuracy: Accuracy) {
        self.accuracy = Some(accuracy);
    }

    /// K_r(Omega) (N/m) at `omega` rad/s: a sample at a sample speed, the spline between.
    pub fn stiffness_at(&self, omega: f64) -> Result<Mat<f64>, ModalError> {
        let c = self.weights(omega)?;
        let n = self.reference.n();
        let mut k = Mat::<f64>::zeros(n, n);
        for (ck, kk) in c.iter().zip(&self.stiffness) {
            if *ck != 0.0 {
                k += kk * faer::Scale(*ck);
            }
        }
        Ok(k)
    }

    /// The contact nodes at `omega` rad/s: position (m), contact direction and running gap
    /// (m) of the static state there (module documentation).
    pub fn contact_nodes_at(&self, omega: f64) -> Result<Vec<ContactNode>, ModalError> {
        self.contact_nodes_from(&self.weights(omega)?)
    }

    fn contact_nodes_from(&self, c: &[f64]) -> Result<Vec<ContactNode>, ModalError> {
        let axis = &self.reference.rotor_axis;
        self.contact
            .iter()
            .zip(&self.reference.contact_nodes)
            .map(|(p, node)| {
                let u: [f64; 3] = std::array::from_fn(|d| {
                    c.iter()
                        .zip(&p.displacement_m)
                        .map(|(ck, u)| ck * u[d])
                        .sum()
                });
                let x0 = p.undeformed_position;
                let position = std::array::from_fn(|d| x0[d] + u[d]);
                let growth = radius(axis, position) - radius(axis, x0);
                Ok(ContactNode {
                    mesh_node: node.mesh_node,
                    dofs: node.dofs,
                    position,
                    radial: axis.radial_unit_vector(position)?,
                    gap: p.cold_gap - growth,
                })
            })
            .collect()
    }

    /// The reduced model at `omega` rad/s: K_r(Omega), M_r, the contact nodes at that speed
    /// (contact rows and running gaps through [`ReducedModel::contact_rows`] and
    /// [`ReducedModel::gaps`]), the reference model's master coordinate and mesh reference, its
    /// lowest frequencies; no recovery basis (that of [`ParametricModel::reference`] serves
    /// every speed). Errors: `omega` outside the range, a gap closed at that speed.
    pub fn at(&self, omega: f64) -> Result<ReducedModel, ModalError> {
        let mut model = self.structure_at(omega)?;
        let count = self.reference.linear_frequencies_hz.len();
        model.linear_frequencies_hz = linear_frequencies_hz(&model.k, &model.m, count)?;
        Ok(model)
    }

    /// [`ParametricModel::at`] without the lowest frequencies (`linear_frequencies_hz` empty):
    /// the model a forced solve at `omega` builds its own modes of. A speed sweep makes one at
    /// every speed its Newton iterations visit, and the dense eigen-decomposition of the
    /// frequencies was 4 % of its time.
    pub fn structure_at(&self, omega: f64) -> Result<ReducedModel, ModalError> {
        let k = self.stiffness_at(omega)?;
        let contact_nodes = self.contact_nodes_at(omega)?;
        if let Some((j, c)) = contact_nodes
            .iter()
            .enumerate()
            .find(|(_, c)| c.gap.is_nan() || c.gap <= 0.0)
        {
            return Err(ModalError::InvalidArgument(format!(
                "at {omega} rad/s ({:.1} rpm) the running gap of contact node {j} is {:e} m: \
                 the clearance is closed statically",
                omega / RPM,
                c.gap
            )));
        }
        Ok(ReducedModel {
            k,
            m: self.reference.m.clone(),
            contact_nodes,
            rotor_axis: self.reference.rotor_axis.clone(),
            master: self.reference.master.clone(),
            linear_frequencies_hz: Vec::new(),
            recovery: None,
            mesh: self.reference.mesh.clone(),
        })
    }

    /// Writes the directory (module documentation): the reference model (recovery basis
    /// stored as `storage` says), `parametric.json` and the stiffness samples; every file
    /// atomically.
    pub fn write(&self, dir: &Path, storage: &RecoveryStorage) -> Result<(), ModalError> {
        self.reference.write_with(dir, storage)?;
        let n = self.reference.n();
        let mut files = Vec::with_capacity(self.speeds.len());
        for (i, (k, w)) in self.stiffness.iter().zip(&self.speeds).enumerate() {
            let file = format!("K_speed_{i:02}.mtx");
            let comment = format!(
                "nlmodes parametric model: reduced stiffness at {w} rad/s ({} rpm), {n} x {n}, N/m",
                w / RPM
            );
            write_symmetric_dense(&dir.join(&file), k.as_ref(), &comment)?;
            files.push(file);
        }
        let document = ParametricFile {
            format: PARAMETRIC_FORMAT.to_string(),
            format_version: PARAMETRIC_VERSION,
            units: PARAMETRIC_UNITS.to_string(),
            interpolation: INTERPOLATION.to_string(),
            kinematics: self.kinematics.clone(),
            speeds_rad_s: self.speeds.clone(),
            speeds_rpm: self.speeds.iter().map(|w| w / RPM).collect(),
            reference_speed_rad_s: self.reference_speed,
            stiffness_files: files,
            contact_nodes: self.contact.clone(),
            accuracy: self.accuracy.clone(),
        };
        let path = dir.join(PARAMETRIC_FILE);
        let text = serde_json::to_string_pretty(&document).map_err(|source| ModalError::Json {
            path: path.clone(),
            source,
        })?;
        write_atomic(&path, |w| {
            use std::io::Write;
            w.write_all(text.as_bytes())?;
            w.write_all(b"\n")
        })
    }

    /// Reads and checks the directory `dir`; errors name the file and what is wrong.
    pub fn read(dir: &Path) -> Result<Self, ModalError> {
        let reference = ReducedModel::read(dir)?;
        let path = dir.join(PARAMETRIC_FILE);
        let bad = |message: String| ModalError::ReducedModel {
            path: path.clone(),
            message,
        };
        let text = std::fs::read_to_string(&path).map_err(|source| ModalError::Io {
            action: "cannot read",
            path: path.clone(),
            source,
        })?;
        let d: ParametricFile = serde_json::from_str(&text).map_err(|source| ModalError::Json {
            path: path.clone(),
            source,
        })?;
        let expected = [
            ("format", d.format.as_str(), PARAMETRIC_FORMAT),
            ("units", d.units.as_str(), PARAMETRIC_UNITS),
            ("interpolation", d.interpolation.as_str(), INTERPOLATION),
        ];
        for (key, found, want) in expected {
            if found != want {
                return Err(bad(format!("{key} is {found:?}, expected {want:?}")));
            }
        }
        if d.format_version != PARAMETRIC_VERSION {
            return Err(bad(format!(
                "format_version {} is not supported (this program reads version \
                 {PARAMETRIC_VERSION})",
                d.format_version
            )));
        }
        if d.stiffness_files.len() != d.speeds_rad_s.len() {
            return Err(bad(format!(
                "{} stiffness files for {} sample speeds",
                d.stiffness_files.len(),
                d.speeds_rad_s.len()
            )));
        }
        let mut stiffness = Vec::with_capacity(d.stiffness_files.len());
        for file in &d.stiffness_files {
            let mut parts = Path::new(file).components();
            let plain =
                matches!(parts.next(), Some(Component::Normal(_))) && parts.next().is_none();
            if !plain {
                return Err(bad(format!(
                    "stiffness file {file:?} must be a plain file name inside the model directory"
                )));
            }
            stiffness.push(read_symmetric_dense(&dir.join(file))?);
        }
        let mut model = Self::new(
            reference,
            d.reference_speed_rad_s,
            d.speeds_rad_s,
            stiffness,
            d.contact_nodes,
            &d.kinematics,
        )
        .map_err(|e| bad(e.to_string()))?;
        model.accuracy = d.accuracy;
        Ok(model)
    }
}

/// Distance of `x` from the rotor axis, m.
fn radius(axis: &RotorAxis, x: [f64; 3]) -> f64 {
    let a = axis.direction;
    let d: [f64; 3] = std::array::from_fn(|i| x[i] - axis.point[i]);
    let along = d[0] * a[0] + d[1] * a[1] + d[2] * a[2];
    norm(std::array::from_fn(|i| d[i] - along * a[i]))
}
