//! The study case file (TOML), e.g. `cases/blade.toml`. Every key has a default; an unknown key is an
//! error that names it (serde `deny_unknown_fields`). Units: SI (m, kg, s, Pa).

use anyhow::{Context, Result};
use nlmodes_nnm::{AlgorithmParams, ContinuationSettings};
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

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
    /// Algorithm 1 and the inner Newton solver: `nlmodes_nnm::AlgorithmParams`.
    pub algorithm: AlgorithmParams,
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
            continuation: ContinuationSettings {
                q_start: 0.5,
                q_max: 35.0,
                ..ContinuationSettings::default()
            },
            // epsilon 1e-3 g0: see AlgorithmParams::epsilon and docs/VERIFICATION.md.
            algorithm: AlgorithmParams {
                epsilon: 1e-3,
                ..AlgorithmParams::default()
            },
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
        }
    }
}

impl Case {
    pub fn load(path: &Path) -> Result<Self> {
        let text = std::fs::read_to_string(path)
            .with_context(|| format!("cannot read case file {}", path.display()))?;
        let mut case: Case = toml::from_str(&text)
            .with_context(|| format!("invalid case file {}", path.display()))?;
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
}
