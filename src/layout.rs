//! Where a case's results live: the paths of `results/<case>/` in one place, shared by the
//! stages that write them (`run`) and the ones that read them back (`post`, `report`).
//!
//! ```text
//! results/<case>/
//!   mesh/mesh.msh            gmsh MSH 4.1
//!   modes/                   frequencies.csv, modes.vtu (clamped full-model modes)
//!   model/                   the reduced model (model.json, K.mtx, M.mtx, recovery.f64)
//!   backbone/                backbone.csv, backbone.json, kept.json
//!   amplitude_q<q/g0>/       per kept amplitude: CSV, figures, VTU frames, PVD
//!   figures/                 mode-shape pictures of the report (Fig. 5)
//!   report.md, *.png, *.svg  the report and the figures of the whole backbone
//!   .stamps/<stage>          content hashes of each stage's inputs
//! ```

use std::path::PathBuf;

/// Paths of a case's results under `root` (`results/<case>`).
pub struct Layout {
    pub root: PathBuf,
}

impl Layout {
    /// The mesh written by the mesh stage.
    pub fn mesh(&self) -> PathBuf {
        self.root.join("mesh").join("mesh.msh")
    }
    /// The linear modes of the full model.
    pub fn modes(&self) -> PathBuf {
        self.root.join("modes")
    }
    /// The reduced-model directory.
    pub fn model(&self) -> PathBuf {
        self.root.join("model")
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
        self.root.join(".stamps").join(stage)
    }
}

/// The tag naming a kept amplitude's files: `q` and q / g0 to one decimal (`q9.3`).
pub fn amplitude_tag(q_over_g0: f64) -> String {
    format!("q{q_over_g0:.1}")
}
