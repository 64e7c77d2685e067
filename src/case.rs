//! The study case file (TOML), e.g. `cases/blade.toml`. Every key has a default, and
//! [`Case::default`] is the one place the defaults live: a file is read as its keys merged over
//! the serialized defaults, so a key deleted from a table takes the documented value (not the
//! library's). An unknown key is an error that names it (serde `deny_unknown_fields`), and every
//! value is checked before the first stage runs (`validate::check_case`). Units: SI (m, kg, s, Pa).

use anyhow::Result;
use nlmodes_nnm::{ContinuationSettings, SolverSettings};
use serde::de::DeserializeOwned;
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use crate::exit::bad_input;

#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Case {
    /// Case name: results go to `results/<name>/`. Defaults to the case file's stem.
    pub name: Option<String>,
    /// Results root directory (relative to the current directory).
    pub results_dir: PathBuf,
    pub mesh: MeshSection,
    pub material: MaterialSection,
    pub model: ModelSection,
    pub nnm: NnmSection,
    /// Backbone continuation (amplitudes in gaps, q / g0): `nlmodes_nnm::ContinuationSettings`.
    pub continuation: ContinuationSettings,
    /// Algorithm 1 and the inner Newton solver: `nlmodes_nnm::SolverSettings`, one flat table
    /// (the keys of `nlmodes_nnm::AlgorithmParams`, `condensation` and the `newton` sub-table).
    pub algorithm: SolverSettings,
    /// Floquet stability of every backbone point (Hill's method, docs/STABILITY.md).
    pub stability: StabilitySection,
    /// The forced-response study (issue 22): `crate::forced::forced_settings::ForcedSection`.
    pub forced: crate::forced::forced_settings::ForcedSection,
    /// The rotating blade (issue 23): `crate::rotation::rotation_settings::RotationSection`; absent, the
    /// blade is at rest and every stage gives today's results.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub rotation: Option<crate::rotation::rotation_settings::RotationSection>,
    /// The speed sweeps through the Campbell crossings (issue 39):
    /// `crate::speed_sweep::speed_sweep_settings::SpeedSweepSection`; absent, none run. Needs `[rotation]`.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub speed_sweep: Option<crate::speed_sweep::speed_sweep_settings::SpeedSweepSection>,
}

/// `[stability]`: Floquet multipliers of every backbone point by Hill's method.
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct StabilitySection {
    /// Compute the multipliers of every point (adds a few ms per point on the blade).
    pub enabled: bool,
    /// Check every k-th point's shooting verdict (the massless contact boundary,
    /// docs/STABILITY.md Sec. 9) by an independent RK4 integration; a verdict the check does not
    /// confirm becomes `undetermined`. Default 10 (about 0.04 s per checked point on the
    /// default blade); 0: no check.
    pub verify_every: usize,
    /// The analysis: `nlmodes_nnm::FloquetSettings` (mode cutoff, static correction, shooting,
    /// ...).
    pub hill: nlmodes_nnm::FloquetSettings,
}

impl Default for StabilitySection {
    fn default() -> Self {
        Self {
            enabled: true,
            verify_every: 10,
            hill: nlmodes_nnm::FloquetSettings::default(),
        }
    }
}

impl StabilitySection {
    /// The analysis settings with `verify_every` applied.
    pub fn analysis(&self) -> nlmodes_nnm::FloquetSettings {
        let mut out = self.hill.clone();
        out.verify_every = self.verify_every;
        out
    }
}

#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct MeshSection {
    /// The parametric geometry (relative paths are relative to the current directory).
    pub geo: PathBuf,
    /// Element order: 1 (TET4) or 2 (TET10).
    pub order: u32,
    /// `-setnumber` overrides of the .geo parameters (m and degrees, as the .geo documents).
    pub parameters: BTreeMap<String, f64>,
}

#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct MaterialSection {
    /// Young's modulus, Pa.
    pub young: f64,
    /// Poisson's ratio.
    pub poisson: f64,
    /// Density, kg/m^3.
    pub density: f64,
}

#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct ModelSection {
    /// Dirichlet conditions: group names, optionally with components (`root`, `bottom:z`).
    pub clamp: Vec<String>,
    /// The physical group of contact nodes.
    pub contact_group: String,
    /// A point of the rotor axis, m.
    pub rotor_axis_point: [f64; 3],
    /// The rotor axis direction (normalized on use).
    pub rotor_axis_direction: [f64; 3],
    /// Uniform initial radial gap g0 between the contact nodes and the casing, m.
    pub gap: f64,
    /// Number of fixed-interface normal modes of the Craig-Bampton reduction.
    pub fixed_interface_modes: usize,
    /// Number of linear modes of the full model computed and written (for reference and Fig. 5).
    pub linear_modes: usize,
    /// The full model's modes (stage modes: the reference of the reduced frequencies and
    /// `modes/`): "auto" (only up to 200000 DOFs, counted as 3 x the mesh's nodes), "on", "off".
    pub full_check: String,
    /// Master coordinate: `auto` (the contact DOF with the largest first-mode amplitude) or a reduced
    /// DOF index.
    pub master: MasterChoice,
}

#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
#[serde(untagged)]
pub enum MasterChoice {
    Auto(String),
    Index(usize),
}

#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct NnmSection {
    /// Highest harmonic N of the cosine series.
    pub harmonics: usize,
    /// Time samples m per period (m >= 2N + 1).
    pub samples: usize,
    /// Amplitudes (q / g0) kept for detailed output (Figs. 4 and 5).
    pub keep: Vec<f64>,
    /// VTU frames over one period for each kept amplitude.
    pub frames: usize,
    /// The harmonic-truncation estimate (each point re-solved with 2N harmonics) is computed at
    /// the kept amplitudes and at every `truncation_every`-th point of the main branch (0, the
    /// default: only at the kept amplitudes; the main-branch points in contact are held to
    /// their converged orbits instead, docs/STABILITY.md Sec. 9.4).
    pub truncation_every: usize,
    /// A point is trusted when doubling N moves w by at most this (relative) and its contact share
    /// by at most max(this, 2 / m). Also the converged orbits' tolerance on the change of w when
    /// N is doubled, and the largest distance of a point's w from its converged orbit's before
    /// it is flagged "N too small" (docs/STABILITY.md Sec. 9.4).
    pub truncation_tolerance: f64,
    /// Converged orbits: largest change of a contact row's share of the period in contact when N
    /// is doubled (a fraction of the period).
    pub share_tolerance: f64,
    /// Converged orbits: the largest N whose modes (w_k <= shooting_cutoff (N + 1) w) are kept
    /// dynamic; N, 2N, 4N, ... are tried up to it, each only for the points the level below left
    /// unconverged. Default (absent): 4 x `harmonics` (docs/BENCHMARKS.md: what 4N and 8N cost).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub max_harmonics: Option<usize>,
}

impl NnmSection {
    /// The converged orbits' settings (docs/STABILITY.md Sec. 9.4).
    pub fn convergence(&self) -> nlmodes_nnm::ConvergenceSettings {
        nlmodes_nnm::ConvergenceSettings {
            omega_tolerance: self.truncation_tolerance,
            share_tolerance: self.share_tolerance,
            max_harmonics: self.max_harmonics.unwrap_or(4 * self.harmonics),
        }
    }
}

impl Default for Case {
    fn default() -> Self {
        Self {
            name: None,
            results_dir: PathBuf::from("results"),
            mesh: MeshSection::default(),
            material: MaterialSection::default(),
            model: ModelSection::default(),
            nnm: NnmSection::default(),
            // The library defaults are the study's (q_start 0.5, q_max 35 g0, epsilon 1e-4 g0:
            // see nlmodes_nnm::AlgorithmParams::epsilon and docs/VERIFICATION.md).
            continuation: ContinuationSettings::default(),
            algorithm: SolverSettings::default(),
            stability: StabilitySection::default(),
            forced: crate::forced::forced_settings::ForcedSection::default(),
            rotation: None,
            speed_sweep: None,
        }
    }
}

impl Default for MeshSection {
    fn default() -> Self {
        Self {
            geo: PathBuf::from("meshes/blade.geo"),
            order: 2,
            parameters: BTreeMap::new(),
        }
    }
}

impl Default for MaterialSection {
    /// Ti-6Al-4V.
    fn default() -> Self {
        Self {
            young: 113.8e9,
            poisson: 0.342,
            density: 4430.0,
        }
    }
}

impl Default for ModelSection {
    fn default() -> Self {
        Self {
            clamp: vec!["root".into()],
            contact_group: "tip_edge".into(),
            rotor_axis_point: [0.0; 3],
            rotor_axis_direction: [1.0, 0.0, 0.0],
            gap: 2.0e-4,
            fixed_interface_modes: 40,
            linear_modes: 10,
            full_check: "auto".into(),
            master: MasterChoice::Auto("auto".into()),
        }
    }
}

impl Default for NnmSection {
    fn default() -> Self {
        Self {
            harmonics: 10,
            samples: 128,
            keep: vec![5.7, 9.3, 31.3],
            frames: 24,
            truncation_every: 0,
            truncation_tolerance: 1e-3,
            share_tolerance: 0.02,
            max_harmonics: None,
        }
    }
}

impl Case {
    /// Reads `path` and merges it over [`Case::default`]; every failure is bad input naming the
    /// file. The values are checked by `validate::check_case`.
    pub fn load(path: &Path) -> Result<Self> {
        let text = std::fs::read_to_string(path)
            .map_err(|e| bad_input(format!("cannot read the case file {}: {e}", path.display())))?;
        let mut case: Case = with_defaults(&Case::default(), &text, path)?;
        if case.name.is_none() {
            case.name = path.file_stem().map(|s| s.to_string_lossy().into_owned());
        }
        Ok(case)
    }

    pub fn name(&self) -> String {
        self.name.clone().unwrap_or_else(|| "case".into())
    }

    pub fn out_dir(&self) -> PathBuf {
        self.results_dir.join(self.name())
    }
}

/// The `[algorithm]` and `[continuation]` tables of `nlmodes backbone --settings FILE`, over the
/// defaults of a case file (a missing key takes the value [`Case::default`] documents).
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct StudySettings {
    pub algorithm: SolverSettings,
    pub continuation: ContinuationSettings,
    pub stability: StabilitySection,
}

impl Default for StudySettings {
    fn default() -> Self {
        let case = Case::default();
        Self {
            algorithm: case.algorithm,
            continuation: case.continuation,
            stability: case.stability,
        }
    }
}

impl StudySettings {
    /// Reads a settings file (bad input naming the file on any failure).
    pub fn load(path: &Path) -> Result<Self> {
        let text = std::fs::read_to_string(path).map_err(|e| {
            bad_input(format!(
                "cannot read the settings file {}: {e}",
                path.display()
            ))
        })?;
        with_defaults(&StudySettings::default(), &text, path)
    }
}

/// `text` (TOML) merged over the serialized `defaults`, table by table and key by key, then
/// deserialized. The text is first read on its own so that an unknown key or a wrong type is
/// reported with its line (the merged value has no positions).
pub fn with_defaults<T: Serialize + DeserializeOwned>(
    defaults: &T,
    text: &str,
    path: &Path,
) -> Result<T> {
    let invalid =
        |e: &dyn std::fmt::Display| bad_input(format!("invalid TOML file {}: {e}", path.display()));
    toml::from_str::<T>(text).map_err(|e| invalid(&e))?;
    let user: toml::Table = toml::from_str(text).map_err(|e| invalid(&e))?;
    let mut merged = toml::Value::try_from(defaults)
        .map_err(|e| anyhow::anyhow!("serializing the defaults: {e}"))?;
    merge(&mut merged, toml::Value::Table(user));
    merged.try_into().map_err(|e| invalid(&e))
}

/// Overwrites `base` with `over`, recursing into tables present in both.
pub fn merge(base: &mut toml::Value, over: toml::Value) {
    match (base, over) {
        (toml::Value::Table(b), toml::Value::Table(o)) => {
            for (key, value) in o {
                match b.get_mut(&key) {
                    Some(slot) => merge(slot, value),
                    None => {
                        b.insert(key, value);
                    }
                }
            }
        }
        (slot, value) => *slot = value,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn missing_keys_take_defaults_and_unknown_keys_are_named() {
        let c: Case = toml::from_str("[nnm]\nharmonics = 7\n").unwrap();
        assert_eq!(c.nnm.harmonics, 7);
        assert_eq!(c.nnm.samples, NnmSection::default().samples);
        let err = toml::from_str::<Case>("[nnm]\nharmonix = 7\n").unwrap_err();
        assert!(err.to_string().contains("harmonix"), "{err}");
    }

    /// Deleting a key of a present table takes the value `Case::default()` documents (issue 14),
    /// not zero or an error. The case defaults are now the library's (q_max 35, epsilon 1e-4);
    /// the test guards the key-by-key merge, which must keep them if they diverge again.
    #[test]
    fn a_deleted_key_takes_the_case_default() {
        let path = Path::new("test.toml");
        let text = "[continuation]\nstep = 0.5\n[algorithm]\nalpha = 5.0\n";
        let c: Case = with_defaults(&Case::default(), text, path).unwrap();
        let d = Case::default();
        assert_eq!(c.continuation.q_max, d.continuation.q_max);
        assert_eq!(c.continuation.q_max, 35.0);
        assert_eq!(c.algorithm.algorithm.epsilon, 1e-4);
        assert_eq!(
            (c.continuation.step, c.algorithm.algorithm.alpha),
            (0.5, 5.0)
        );
        let s: StudySettings = with_defaults(&StudySettings::default(), text, path).unwrap();
        assert_eq!(
            (s.continuation.q_max, s.algorithm.algorithm.epsilon),
            (35.0, 1e-4)
        );
        let err = with_defaults(&Case::default(), "[continuation]\nqmax = 3\n", path)
            .unwrap_err()
            .to_string();
        assert!(err.contains("qmax") && err.contains("test.toml"), "{err}");
    }

    /// The inner-solver keys stay in the flat `[algorithm]` table (`condensation`, the `newton`
    /// sub-table) although the library keeps them out of `AlgorithmParams`; typos are named.
    #[test]
    fn solver_keys_are_read_from_the_algorithm_table() {
        let path = Path::new("test.toml");
        let text = "[algorithm]\nalpha = 5.0\ncondensation = \"none\"\nnewton.tolerance = 1e-12\n";
        let c: Case = with_defaults(&Case::default(), text, path).unwrap();
        assert_eq!(c.algorithm.algorithm.alpha, 5.0);
        assert_eq!(c.algorithm.condensation, nlmodes_nnm::Condensation::None);
        assert_eq!(c.algorithm.newton.tolerance, 1e-12);
        let default_newton = nlmodes_nnm::NewtonSettings::default();
        assert_eq!(
            c.algorithm.newton.max_iterations,
            default_newton.max_iterations
        );
        for typo in [
            "[algorithm]\ncondensaton = \"none\"\n",
            "[algorithm.newton]\ntolerence = 1.0\n",
        ] {
            let err = with_defaults(&Case::default(), typo, path)
                .unwrap_err()
                .to_string();
            let key = if typo.contains("tolerence") {
                "tolerence"
            } else {
                "condensaton"
            };
            assert!(err.contains(key), "{err}");
        }
    }

    /// The shipped case file states the defaults: reading it equals `Case::default()` (but
    /// for its name and the .geo parameters it spells out), and its `[rotation]` table (absent
    /// from the default case: the blade at rest) states the table's defaults. Its
    /// `[speed_sweep]` table (absent by default too) states the table's defaults but for the
    /// keys that make it the default study's (issue 39, item 6): the one sweep through the
    /// EO 3 crossing next to the operating speed at 2 x grazing (the defaults, every crossing
    /// in the range at every `[forced]` level, would be 18 sweeps of about 90 s each), and the
    /// casing distortion at the operating speed (`[speed_sweep.casing]`, absent by default) up
    /// to 1.5 running gaps on 16 amplitudes. Both converge N by their defaults ("retrace",
    /// "refine"; since session 24, the casing study run beside the sweep).
    #[test]
    fn shipped_case_file_equals_the_defaults() {
        let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("cases/blade.toml");
        let text = std::fs::read_to_string(&path).unwrap();
        let mut c: Case = with_defaults(&Case::default(), &text, &path).unwrap();
        c.name = None;
        c.mesh.parameters.clear();
        assert_eq!(
            c.rotation.take(),
            Some(crate::rotation::rotation_settings::RotationSection::default())
        );
        assert_eq!(
            c.speed_sweep.take(),
            Some(
                crate::speed_sweep::speed_sweep_settings::SpeedSweepSection {
                    engine_orders: vec![3],
                    levels: vec![2.0],
                    casing: Some(crate::speed_sweep::speed_sweep_settings::CasingSection {
                        amplitudes: [0.0, 1.5],
                        points: 16,
                        ..Default::default()
                    }),
                    ..Default::default()
                }
            )
        );
        let as_json = |c: &Case| serde_json::to_string(c).unwrap();
        assert_eq!(as_json(&c), as_json(&Case::default()));
    }
}
