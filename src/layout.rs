//! Where a case's results live: the paths of `results/<case>/` in one place, shared by the
//! stages that write them (`run`) and the ones that read them back (`post`, `report`).
//!
//! ```text
//! results/<case>/
//!   mesh/mesh.msh            gmsh MSH 4.1
//!   modes/                   frequencies.csv, modes.vtu (clamped full-model modes)
//!   model/                   the reduced model (model.json, K.mtx, M.mtx, recovery.q24)
//!   backbone/                backbone.csv, backbone.json, kept.json
//!   amplitude_q<q/g0>/       per kept amplitude: CSV, figures, XDMF + HDF5 series for ParaView
//!   figures/                 mode-shape pictures of the report (Fig. 5)
//!   report.md, *.png, *.svg  the report and the figures of the whole backbone
//!   .stamps/<stage>          content hashes of each stage's inputs
//! ```
//!
//! With several modes (`[continuation] modes = [0, 1, 2]`) the backbone, the amplitude folders,
//! the figures and the report of mode k go to `results/<case>/mode_<k + 1>/`; the mesh, the linear
//! modes, the reduced model and the stamps stay at `results/<case>/`, where `report.md` then links
//! the modes' reports and shows their combined frequency-energy plot.

use std::path::PathBuf;

/// Paths of a case's results: `shared` (`results/<case>`) holds the mesh, the linear modes, the
/// reduced model and the stamps; `root` (the same, or `results/<case>/mode_<k + 1>`) the backbone
/// of one mode and everything drawn from it.
#[derive(Clone)]
pub struct Layout {
    pub root: PathBuf,
    pub shared: PathBuf,
}

impl Layout {
    /// The layout of a case whose results go to `root`.
    pub fn new(root: PathBuf) -> Self {
        Self {
            shared: root.clone(),
            root,
        }
    }
    /// The layout of mode `mode` (0-based) of a several-mode case.
    pub fn for_mode(&self, mode: usize) -> Self {
        Self {
            root: self.shared.join(format!("mode_{}", mode + 1)),
            shared: self.shared.clone(),
        }
    }
    /// The mesh written by the mesh stage.
    pub fn mesh(&self) -> PathBuf {
        self.shared.join("mesh").join("mesh.msh")
    }
    /// The linear modes of the full model.
    pub fn modes(&self) -> PathBuf {
        self.shared.join("modes")
    }
    /// The reduced-model directory.
    pub fn model(&self) -> PathBuf {
        self.shared.join("model")
    }
    /// The backbone directory.
    pub fn backbone(&self) -> PathBuf {
        self.root.join("backbone")
    }
    /// The pictures of the report (mode shapes on the mesh).
    pub fn figures(&self) -> PathBuf {
        self.root.join("figures")
    }
    /// The folder of the kept amplitude tagged `tag` (see [`amplitude_tag`]).
    pub fn amplitude(&self, tag: &str) -> PathBuf {
        self.root.join(format!("amplitude_{tag}"))
    }
    /// The stamp file of a stage.
    pub fn stamp(&self, stage: &str) -> PathBuf {
        self.shared.join(".stamps").join(stage)
    }
}

/// The tag naming a kept amplitude's files: `q` and q / g0 to one decimal (`q9.3`).
pub fn amplitude_tag(q_over_g0: f64) -> String {
    format!("q{q_over_g0:.1}")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_mode_has_its_own_results_and_shares_the_model() {
        let one = Layout::new(PathBuf::from("results/c"));
        let m2 = one.for_mode(1);
        assert_eq!(m2.backbone(), PathBuf::from("results/c/mode_2/backbone"));
        assert_eq!(
            m2.amplitude("q9.3"),
            PathBuf::from("results/c/mode_2/amplitude_q9.3")
        );
        assert_eq!(m2.model(), one.model());
        assert_eq!(m2.mesh(), one.mesh());
        assert_eq!(
            m2.stamp("backbone_mode2"),
            PathBuf::from("results/c/.stamps/backbone_mode2")
        );
        assert_eq!(one.backbone(), PathBuf::from("results/c/backbone"));
    }
}
