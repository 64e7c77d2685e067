//! # Reduced-model directory (format version 1)
//!
//! A reduced model (typically the Craig-Bampton reduction of a blade onto its
//! contact nodes) is a directory with these files:
//!
//! | file | content |
//! | --- | --- |
//! | `K.mtx` | reduced stiffness, n x n, Matrix Market `coordinate real symmetric` |
//! | `M.mtx` | reduced mass, n x n, same format |
//! | `model.json` | metadata (below) |
//! | `recovery.f64` | optional: recovery basis (below) |
//!
//! Units are SI throughout: m, kg, s; K in N/m and M in kg for physical
//! coordinates (modal coordinates of mass-normalized modes are in m kg^1/2,
//! their rows of K in N/m/kg^1/2, etc.). Indices are 0-based in
//! `model.json`; Matrix Market files are 1-based by definition.
//!
//! ## `K.mtx`, `M.mtx`
//!
//! Header `%%MatrixMarket matrix coordinate real symmetric`, optional `%`
//! comment lines, the size line `n n entries`, then one line `i j value` per
//! lower-triangle entry (i >= j, 1-based). Every lower-triangle entry is
//! written, zeros included, with 18 significant digits (`{:.17e}`), so
//! reading returns bitwise the written matrix. Files with symmetry
//! `general` are accepted on reading if symmetric (see [`crate::matrix_market`]).
//!
//! ## `model.json`
//!
//! A JSON object; unknown fields are rejected. Fields:
//!
//! * `format` (string): `"nlmodes-reduced-model"`.
//! * `format_version` (integer): `1`.
//! * `units` (string): `"SI: m, kg, s; K in N/m, M in kg"`.
//! * `n` (integer): order of K and M (number of reduced coordinates).
//! * `contact_nodes` (array, at least one): for each contact node
//!   * `mesh_node` (integer, optional): the node's tag in the mesh file;
//!   * `dofs` ([ix, iy, iz], integers): reduced coordinates of the node's
//!     x, y, z displacements (m), all distinct across nodes, each < n;
//!   * `position` ([x, y, z], m): undeformed coordinates;
//!   * `radial` ([nx, ny, nz]): outward radial unit vector about the rotor
//!     axis (|r| = 1 within 1e-9), the contact direction;
//!   * `gap` (m, > 0): initial radial clearance g0 to the casing.
//! * `rotor_axis`: `{"point": [x, y, z] (m), "direction": [ax, ay, az]}`
//!   with a unit direction (within 1e-9).
//! * `master`: `{"dof": i, "description": "..."}`: the default master
//!   coordinate (a reduced coordinate index < n) used to normalize the
//!   nonlinear mode amplitude, and a human-readable description of it.
//! * `linear_frequencies_hz` (array of numbers, at most n, finite, ascending):
//!   the lowest natural frequencies of the reduced model (Hz).
//! * `recovery` (optional): `{"file": "recovery.f64", "rows": N_r, "cols": n}`
//!   describing the recovery basis.
//! * `mesh` (optional): `{"msh_file": "...", "n_full_dofs": N, "fixed_dofs": [...]}`:
//!   the mesh the model was reduced from (a relative path is relative to the
//!   model directory), its number of DOFs (3 per node: DOF 3 k + c is
//!   component c = x, y, z of the k-th node of the FE DOF map), and the
//!   strictly increasing list of DOFs fixed by the Dirichlet conditions.
//!
//! ## `recovery.f64` and `recovery.q24`
//!
//! Binary, little-endian: 8 bytes of magic `NLMRCV01`, the number of rows
//! N_r (u64), the number of columns n (u64), then N_r x n f64 values in
//! column-major order. Column j is the displacement of the free (unfixed)
//! mesh DOFs for a unit value of reduced coordinate j: u_free = R q. When
//! `mesh` is given, N_r = n_full_dofs - len(fixed_dofs) and row r is the
//! r-th non-fixed DOF in increasing order, so the full displacement puts
//! zeros on the fixed DOFs ([`MeshReference::expand_to_full`]).
//!
//! [`ReducedModel::write_with`] and [`RecoveryStorage::Fixed24`] write instead the compact
//! `recovery.q24` (magic `NLMRCV02`: each column in 24-bit fixed point, mid-edge rows predicted
//! from their edge's end rows, byte-shuffled and zlib-compressed; layout and accuracy, 2^-24 of
//! the column's largest entry, in `recovery_codec`). The reader tells the two apart by their magic bytes.
//!
//! ## Contact rows
//!
//! The contact matrix A (c x n, paper Eq. 17) has, in row j, the radial unit
//! vector of contact node j on that node's three DOFs and zeros elsewhere,
//! so A q is the vector of radial displacements of the contact nodes (m) and
//! the gap function is g = A q - g0 ([`ReducedModel::contact_rows`]).
//!
//! ## Validation
//!
//! [`ReducedModel::write`] and [`ReducedModel::read`] check: format, version
//! and units strings; K and M square, finite, symmetric, of the same order
//! as each other and as `n` (errors name both files and sizes); positive
//! diagonal of M; a non-empty contact list; DOF indices in range and
//! distinct; unit radial vectors and axis direction; gaps finite and > 0;
//! master coordinate in range; frequencies finite and ascending; recovery
//! basis size consistent with `n`, the mesh and the file length; fixed DOFs
//! in range and strictly increasing. Then the physics
//! ([`crate::model_checks`]): max |K| and max |M| within 1e-30 .. 1e30, M
//! positive definite by a Cholesky factorization and with condition number
//! below 1e12, K positive semi-definite (eigenvalues of (K, M) >= -1e-12
//! lambda_max; rigid-body modes within 1e-12 lambda_max of 0 are logged),
//! contact nodes at distinct positions, gaps at least 1e-9 of the largest
//! distance of a contact node from the rotor axis.

use std::fs::File;
use std::io::{BufReader, BufWriter, Read, Write};
use std::path::{Component, Path};

use faer::Mat;
use serde::{Deserialize, Serialize};

use crate::contact_geometry::{norm, RotorAxis};
use crate::error::ModalError;
use crate::matrix_market::{read_symmetric_dense, write_symmetric_dense};
use crate::matrix_market_io::write_atomic;
use crate::model_checks::{check_physics, ContactPoint};
use crate::modes::dense_generalized_eigen;
use nlmodes_dense::check_symmetric;

/// Value of the `format` field.
pub const FORMAT_NAME: &str = "nlmodes-reduced-model";
/// Value of the `format_version` field written by this crate.
pub const FORMAT_VERSION: u32 = 1;
/// Value of the `units` field.
pub const UNITS: &str = "SI: m, kg, s; K in N/m, M in kg";
/// File name of the reduced stiffness.
pub const STIFFNESS_FILE: &str = "K.mtx";
/// File name of the reduced mass.
pub const MASS_FILE: &str = "M.mtx";
/// File name of the metadata.
pub const MODEL_FILE: &str = "model.json";
/// File name of the recovery basis.
pub const RECOVERY_FILE: &str = "recovery.f64";
/// Magic bytes opening `recovery.f64`.
pub const RECOVERY_MAGIC: &[u8; 8] = b"NLMRCV01";
/// File name of the compact recovery basis ([`RecoveryStorage::Fixed24`]).
pub const RECOVERY_COMPACT_FILE: &str = "recovery.q24";

/// How [`ReducedModel::write_with`] stores the recovery basis.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub enum RecoveryStorage {
    /// `recovery.f64`: Float64, bit for bit.
    #[default]
    Float64,
    /// `recovery.q24`: 24-bit fixed point per column, compressed (module documentation):
    /// enough for output fields written in Float32, about 4 times smaller.
    Fixed24 {
        /// Rows (m, a, b) of R stored as their difference to the mean of rows a and b (e.g.
        /// the DOF of a TET10 mid-edge node and the same DOF of its edge's vertices); a and b
        /// must not be predicted rows themselves. Empty: no prediction.
        predictions: Vec<[usize; 3]>,
    },
}
/// Tolerance on |r| - 1 for radial vectors and the axis direction: vectors
/// normalized in f64 are unit to ~1e-16; 1e-9 allows values written by other
/// tools with ~10 significant digits.
pub const UNIT_VECTOR_TOLERANCE: f64 = 1e-9;

/// |length - 1| <= [`UNIT_VECTOR_TOLERANCE`] (false for NaN).
fn is_unit_length(length: f64) -> bool {
    (length - 1.0).abs() <= UNIT_VECTOR_TOLERANCE
}

/// One contact node of the reduced model.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ContactNode {
    /// Tag of the node in the mesh file, if known.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub mesh_node: Option<u64>,
    /// Reduced coordinates of the node's x, y, z displacements.
    pub dofs: [usize; 3],
    /// Undeformed position, m.
    pub position: [f64; 3],
    /// Radial unit vector (contact direction).
    pub radial: [f64; 3],
    /// Initial gap g0 to the casing, m (> 0).
    pub gap: f64,
}

/// The default master coordinate of the nonlinear-mode normalization.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MasterCoordinate {
    /// Reduced coordinate index.
    pub dof: usize,
    /// Human-readable description (e.g. "radial displacement of tip node 812").
    pub description: String,
}

/// Reference to the mesh the model was reduced from (for VTK output).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MeshReference {
    /// Path of the `.msh` file (relative paths are relative to the model directory).
    pub msh_file: String,
    /// Number of DOFs of the full mesh (3 per node).
    pub n_full_dofs: usize,
    /// DOFs fixed by the Dirichlet conditions, strictly increasing.
    pub fixed_dofs: Vec<usize>,
}

impl MeshReference {
    /// Number of free DOFs (rows of the recovery basis).
    pub fn n_free_dofs(&self) -> usize {
        self.n_full_dofs.saturating_sub(self.fixed_dofs.len())
    }

    /// Full-mesh DOF index of each free DOF (ascending).
    pub fn free_to_full(&self) -> Vec<usize> {
        let mut fixed = self.fixed_dofs.iter().peekable();
        (0..self.n_full_dofs)
            .filter(|d| {
                if fixed.peek() == Some(&d) {
                    fixed.next();
                    false
                } else {
                    true
                }
            })
            .collect()
    }

    /// Full-mesh displacement (zeros on fixed DOFs) from free-DOF values.
    pub fn expand_to_full(&self, free: &[f64]) -> Result<Vec<f64>, ModalError> {
        let map = self.free_to_full();
        if free.len() != map.len() {
            return Err(ModalError::DimensionMismatch {
                what: format!("free-DOF vector for mesh {}", self.msh_file),
                expected: map.len(),
                found: free.len(),
            });
        }
        let mut full = vec![0.0; self.n_full_dofs];
        for (&d, &v) in map.iter().zip(free) {
            full[d] = v;
        }
        Ok(full)
    }
}

/// A reduced model: matrices and metadata (see the module documentation).
#[derive(Clone, Debug)]
pub struct ReducedModel {
    /// Reduced stiffness (n x n).
    pub k: Mat<f64>,
    /// Reduced mass (n x n).
    pub m: Mat<f64>,
    /// Contact nodes (at least one).
    pub contact_nodes: Vec<ContactNode>,
    /// The rotor axis.
    pub rotor_axis: RotorAxis,
    /// Default master coordinate.
    pub master: MasterCoordinate,
    /// Lowest natural frequencies of (K, M), Hz, ascending.
    pub linear_frequencies_hz: Vec<f64>,
    /// Recovery basis R (N_r x n): free mesh DOFs = R q.
    pub recovery: Option<Mat<f64>>,
    /// The mesh the model was reduced from.
    pub mesh: Option<MeshReference>,
}

/// Description of the recovery basis in `model.json`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct RecoveryEntry {
    file: String,
    rows: usize,
    cols: usize,
}

/// The `model.json` document.
#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct ModelFile {
    format: String,
    format_version: u32,
    units: String,
    n: usize,
    contact_nodes: Vec<ContactNode>,
    rotor_axis: RotorAxis,
    master: MasterCoordinate,
    linear_frequencies_hz: Vec<f64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    recovery: Option<RecoveryEntry>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    mesh: Option<MeshReference>,
}

/// The `count` lowest natural frequencies (Hz) of a dense (K, M), ascending;
/// a negative eigenvalue (round-off) gives a negative frequency, never NaN.
pub fn linear_frequencies_hz(
    k: &Mat<f64>,
    m: &Mat<f64>,
    count: usize,
) -> Result<Vec<f64>, ModalError> {
    let (values, _) = dense_generalized_eigen(k.as_ref(), m.as_ref())?;
    Ok(values
        .iter()
        .take(count)
        .map(|&l| l.signum() * l.abs().sqrt() / (2.0 * std::f64::consts::PI))
        .collect())
}

impl ReducedModel {
    /// Order of the reduced model.
    pub fn n(&self) -> usize {
        self.k.nrows()
    }

    /// Contact matrix A (c x n, paper Eq. 17): row j holds contact node j's
    /// radial unit vector on its three DOFs, so A q are the radial
    /// displacements (m) and g = A q - g0 the gaps.
    pub fn contact_rows(&self) -> Mat<f64> {
        let mut a = Mat::<f64>::zeros(self.contact_nodes.len(), self.n());
        for (j, node) in self.contact_nodes.iter().enumerate() {
            for c in 0..3 {
                a[(j, node.dofs[c])] = node.radial[c];
            }
        }
        a
    }

    /// Initial gaps g0 of the contact nodes, m.
    pub fn gaps(&self) -> Vec<f64> {
        self.contact_nodes.iter().map(|c| c.gap).collect()
    }

    /// Checks every rule of the format (module documentation, "Validation").
    /// `dir` only names the directory in error messages.
    pub fn validate(&self, dir: &Path) -> Result<(), ModalError> {
        let k_path = dir.join(STIFFNESS_FILE);
        let m_path = dir.join(MASS_FILE);
        let json = dir.join(MODEL_FILE);
        let bad = |path: &Path, message: String| ModalError::ReducedModel {
            path: path.to_path_buf(),
            message,
        };
        let k_what = format!("K ({})", k_path.display());
        let m_what = format!("M ({})", m_path.display());
        let n = check_symmetric(self.k.as_ref()).map_err(ModalError::symmetry(&k_what))?;
        let n_m = check_symmetric(self.m.as_ref()).map_err(ModalError::symmetry(&m_what))?;
        if n != n_m {
            return Err(bad(
                dir,
                format!(
                    "{} is {n} x {n} but {} is {n_m} x {n_m}: K and M must have the same order",
                    k_path.display(),
                    m_path.display()
                ),
            ));
        }
        if n == 0 {
            return Err(bad(
                &k_path,
                "the reduced model is empty (0 x 0)".to_string(),
            ));
        }
        if let Some(i) = (0..n).find(|&i| self.m[(i, i)].is_nan() || self.m[(i, i)] <= 0.0) {
            return Err(bad(
                &m_path,
                format!(
                    "diagonal entry {i} of M is {:e}: a mass matrix must be positive definite",
                    self.m[(i, i)]
                ),
            ));
        }
        if self.contact_nodes.is_empty() {
            return Err(bad(&json, "the contact node list is empty".to_string()));
        }
        let mut owner = vec![usize::MAX; n];
        for (j, node) in self.contact_nodes.iter().enumerate() {
            let label = match node.mesh_node {
                Some(tag) => format!("contact node {j} (mesh node {tag})"),
                None => format!("contact node {j}"),
            };
            for &d in &node.dofs {
                if d >= n {
                    return Err(bad(
                        &json,
                        format!("{label}: DOF index {d} is out of range (the model has n = {n})"),
                    ));
                }
                if owner[d] != usize::MAX {
                    return Err(bad(
                        &json,
                        format!(
                            "{label}: DOF index {d} is already used by contact node {}",
                            owner[d]
                        ),
                    ));
                }
                owner[d] = j;
            }
            if node.position.iter().any(|v| !v.is_finite()) {
                return Err(bad(
                    &json,
                    format!("{label}: position {:?} is not finite", node.position),
                ));
            }
            let r = norm(node.radial);
            if !is_unit_length(r) {
                return Err(bad(
                    &json,
                    format!(
                        "{label}: radial vector {:?} has length {r} (must be a unit vector)",
                        node.radial
                    ),
                ));
            }
            if !(node.gap > 0.0 && node.gap.is_finite()) {
                return Err(bad(
                    &json,
                    format!("{label}: gap {} m must be finite and > 0", node.gap),
                ));
            }
        }
        let axis = &self.rotor_axis;
        if axis.point.iter().any(|v| !v.is_finite()) {
            return Err(bad(
                &json,
                format!("rotor axis point {:?} is not finite", axis.point),
            ));
        }
        let a = norm(axis.direction);
        if !is_unit_length(a) {
            return Err(bad(
                &json,
                format!(
                    "rotor axis direction {:?} has length {a} (must be a unit vector)",
                    axis.direction
                ),
            ));
        }
        if self.master.dof >= n {
            return Err(bad(
                &json,
                format!(
                    "master coordinate {} is out of range (the model has n = {n})",
                    self.master.dof
                ),
            ));
        }
        let f = &self.linear_frequencies_hz;
        if f.len() > n {
            return Err(bad(
                &json,
                format!("{} linear frequencies for a model of order {n}", f.len()),
            ));
        }
        if f.iter().any(|v| !v.is_finite()) || f.windows(2).any(|w| w[0] > w[1]) {
            return Err(bad(
                &json,
                format!("linear frequencies {f:?} must be finite and ascending"),
            ));
        }
        if let Some(mesh) = &self.mesh {
            if let Some(w) = mesh.fixed_dofs.windows(2).find(|w| w[0] >= w[1]) {
                return Err(bad(
                    &json,
                    format!(
                        "mesh fixed DOFs must be strictly increasing, found {} then {}",
                        w[0], w[1]
                    ),
                ));
            }
            if let Some(&d) = mesh.fixed_dofs.last().filter(|&&d| d >= mesh.n_full_dofs) {
                return Err(bad(
                    &json,
                    format!(
                        "mesh fixed DOF {d} is out of range (the mesh has {} DOFs)",
                        mesh.n_full_dofs
                    ),
                ));
            }
        }
        if let Some(r) = &self.recovery {
            let r_path = dir.join(RECOVERY_FILE);
            if r.ncols() != n {
                return Err(bad(
                    &r_path,
                    format!(
                        "the recovery basis has {} columns but the model has n = {n}",
                        r.ncols()
                    ),
                ));
            }
            if let Some(mesh) = &self.mesh {
                if r.nrows() != mesh.n_free_dofs() {
                    return Err(bad(
                        &r_path,
                        format!(
                            "the recovery basis has {} rows but the mesh has {} free DOFs \
                             ({} DOFs, {} fixed)",
                            r.nrows(),
                            mesh.n_free_dofs(),
                            mesh.n_full_dofs,
                            mesh.fixed_dofs.len()
                        ),
                    ));
                }
            }
            for j in 0..r.ncols() {
                if let Some(i) = r.col_as_slice(j).iter().position(|v| !v.is_finite()) {
                    return Err(bad(
                        &r_path,
                        format!("entry ({i}, {j}) of the recovery basis is not finite"),
                    ));
                }
            }
        }
        let points: Vec<ContactPoint> = self
            .contact_nodes
            .iter()
            .enumerate()
            .map(|(j, node)| ContactPoint {
                label: match node.mesh_node {
                    Some(tag) => format!("contact node {j} (mesh node {tag})"),
                    None => format!("contact node {j}"),
                },
                position: node.position,
                gap: node.gap,
            })
            .collect();
        check_physics(
            &self.k,
            &self.m,
            &points,
            &self.rotor_axis,
            [&k_path, &m_path, &json],
        )?;
        Ok(())
    }

    /// Writes the model into `dir` (created if missing). Every file is
    /// written atomically; the model is validated first. The recovery basis
    /// goes to `recovery.f64`, bit for bit.
    pub fn write(&self, dir: &Path) -> Result<(), ModalError> {
        self.write_with(dir, &RecoveryStorage::Float64)
    }

    /// As [`ReducedModel::write`], the recovery basis stored as `storage` says; a
    /// recovery file of the other kind left in `dir` by an earlier write is removed.
    pub fn write_with(&self, dir: &Path, storage: &RecoveryStorage) -> Result<(), ModalError> {
        self.validate(dir)?;
        std::fs::create_dir_all(dir).map_err(|source| ModalError::Io {
            action: "cannot create the directory",
            path: dir.to_path_buf(),
            source,
        })?;
        let n = self.n();
        write_symmetric_dense(
            &dir.join(STIFFNESS_FILE),
            self.k.as_ref(),
            &format!("nlmodes reduced stiffness K, {n} x {n}, N/m"),
        )?;
        write_symmetric_dense(
            &dir.join(MASS_FILE),
            self.m.as_ref(),
            &format!("nlmodes reduced mass M, {n} x {n}, kg"),
        )?;
        let recovery = match &self.recovery {
            Some(r) => {
                let file = match storage {
                    RecoveryStorage::Float64 => {
                        write_recovery(&dir.join(RECOVERY_FILE), r)?;
                        RECOVERY_FILE
                    }
                    RecoveryStorage::Fixed24 { predictions } => {
                        let path = dir.join(RECOVERY_COMPACT_FILE);
                        write_compact_recovery(&path, r, predictions)?;
                        RECOVERY_COMPACT_FILE
                    }
                };
                Some(RecoveryEntry {
                    file: file.to_string(),
                    rows: r.nrows(),
                    cols: r.ncols(),
                })
            }
            None => None,
        };
        let document = ModelFile {
            format: FORMAT_NAME.to_string(),
            format_version: FORMAT_VERSION,
            units: UNITS.to_string(),
            n,
            contact_nodes: self.contact_nodes.clone(),
            rotor_axis: self.rotor_axis.clone(),
            master: self.master.clone(),
            linear_frequencies_hz: self.linear_frequencies_hz.clone(),
            recovery,
            mesh: self.mesh.clone(),
        };
        let json_path = dir.join(MODEL_FILE);
        let text = serde_json::to_string_pretty(&document).map_err(|source| ModalError::Json {
            path: json_path.clone(),
            source,
        })?;
        write_atomic(&json_path, |w| {
            w.write_all(text.as_bytes())?;
            w.write_all(b"\n")
        })?;
        // The model.json just written names the recovery file in use: another one is stale.
        for stale in [RECOVERY_FILE, RECOVERY_COMPACT_FILE] {
            if document.recovery.as_ref().is_none_or(|e| e.file != stale) {
                let path = dir.join(stale);
                if path.exists() {
                    std::fs::remove_file(&path).map_err(|source| ModalError::Io {
                        action: "cannot remove the stale recovery file",
                        path,
                        source,
                    })?;
                }
            }
        }
        Ok(())
    }

    /// Reads and validates the model in `dir`.
    pub fn read(dir: &Path) -> Result<Self, ModalError> {
        let json_path = dir.join(MODEL_FILE);
        let text = std::fs::read_to_string(&json_path).map_err(|source| ModalError::Io {
            action: "cannot read",
            path: json_path.clone(),
            source,
        })?;
        let document: ModelFile =
            serde_json::from_str(&text).map_err(|source| ModalError::Json {
                path: json_path.clone(),
                source,
            })?;
        let bad = |message: String| ModalError::ReducedModel {
            path: json_path.clone(),
            message,
        };
        if document.format != FORMAT_NAME {
            return Err(bad(format!(
                "format is {:?}, expected {FORMAT_NAME:?}",
                document.format
            )));
        }
        if document.format_version != FORMAT_VERSION {
            return Err(bad(format!(
                "format_version {} is not supported (this program reads version {FORMAT_VERSION})",
                document.format_version
            )));
        }
        if document.units != UNITS {
            return Err(bad(format!(
                "units are {:?}, expected {UNITS:?}",
                document.units
            )));
        }
        let k_path = dir.join(STIFFNESS_FILE);
        let m_path = dir.join(MASS_FILE);
        let k = read_symmetric_dense(&k_path)?;
        let m = read_symmetric_dense(&m_path)?;
        if k.nrows() != m.nrows() {
            return Err(ModalError::ReducedModel {
                path: dir.to_path_buf(),
                message: format!(
                    "{} is {} x {} but {} is {} x {}: K and M must have the same order",
                    k_path.display(),
                    k.nrows(),
                    k.ncols(),
                    m_path.display(),
                    m.nrows(),
                    m.ncols()
                ),
            });
        }
        if k.nrows() != document.n {
            return Err(bad(format!(
                "n = {} but {} and {} are {} x {}",
                document.n,
                k_path.display(),
                m_path.display(),
                k.nrows(),
                k.ncols()
            )));
        }
        let recovery = match &document.recovery {
            Some(entry) => {
                let mut components = Path::new(&entry.file).components();
                let plain = matches!(components.next(), Some(Component::Normal(_)))
                    && components.next().is_none();
                if !plain {
                    return Err(bad(format!(
                        "recovery file {:?} must be a plain file name inside the model directory",
                        entry.file
                    )));
                }
                let r = read_recovery(&dir.join(&entry.file))?;
                if (r.nrows(), r.ncols()) != (entry.rows, entry.cols) {
                    return Err(bad(format!(
                        "the recovery entry announces {} x {} but {} holds {} x {}",
                        entry.rows,
                        entry.cols,
                        entry.file,
                        r.nrows(),
                        r.ncols()
                    )));
                }
                Some(r)
            }
            None => None,
        };
        let model = Self {
            k,
            m,
            contact_nodes: document.contact_nodes,
            rotor_axis: document.rotor_axis,
            master: document.master,
            linear_frequencies_hz: document.linear_frequencies_hz,
            recovery,
            mesh: document.mesh,
        };
        model.validate(dir)?;
        Ok(model)
    }
}

/// Writes the recovery basis in the binary format of the module documentation.
fn write_recovery(path: &Path, r: &Mat<f64>) -> Result<(), ModalError> {
    write_atomic(path, |w: &mut BufWriter<File>| {
        w.write_all(RECOVERY_MAGIC)?;
        w.write_all(&(r.nrows() as u64).to_le_bytes())?;
        w.write_all(&(r.ncols() as u64).to_le_bytes())?;
        for j in 0..r.ncols() {
            for v in r.col_as_slice(j) {
                w.write_all(&v.to_le_bytes())?;
            }
        }
        Ok(())
    })
}

/// Writes the recovery basis as `recovery.q24` (`recovery_codec`).
fn write_compact_recovery(
    path: &Path,
    r: &Mat<f64>,
    predictions: &[[usize; 3]],
) -> Result<(), ModalError> {
    crate::recovery_codec::check_predictions(r.nrows(), predictions).map_err(|message| {
        ModalError::ReducedModel {
            path: path.to_path_buf(),
            message: format!("row predictions of the recovery basis: {message}"),
        }
    })?;
    let columns: Vec<&[f64]> = (0..r.ncols()).map(|j| r.col_as_slice(j)).collect();
    let bytes = crate::recovery_codec::encode(r.nrows(), &columns, predictions);
    write_atomic(path, |w: &mut BufWriter<File>| w.write_all(&bytes))
}

/// Reads a recovery basis of either kind (by its magic), checking the sizes and the length.
fn read_recovery(path: &Path) -> Result<Mat<f64>, ModalError> {
    let mut magic = [0u8; 8];
    let compact = File::open(path)
        .and_then(|mut f| f.read_exact(&mut magic))
        .is_ok()
        && &magic == crate::recovery_codec::MAGIC;
    if !compact {
        return read_float64_recovery(path);
    }
    let bytes = std::fs::read(path).map_err(|source| ModalError::Io {
        action: "cannot read",
        path: path.to_path_buf(),
        source,
    })?;
    let (rows, columns) =
        crate::recovery_codec::decode(&bytes).map_err(|message| ModalError::ReducedModel {
            path: path.to_path_buf(),
            message,
        })?;
    Ok(Mat::from_fn(rows, columns.len(), |i, j| columns[j][i]))
}

/// Reads a `recovery.f64`, checking the magic, the sizes and the file length.
fn read_float64_recovery(path: &Path) -> Result<Mat<f64>, ModalError> {
    let io = |source| ModalError::Io {
        action: "cannot read",
        path: path.to_path_buf(),
        source,
    };
    let bad = |message: String| ModalError::ReducedModel {
        path: path.to_path_buf(),
        message,
    };
    let file = File::open(path).map_err(io)?;
    let length = file.metadata().map_err(io)?.len();
    let mut reader = BufReader::new(file);
    let mut header = [0u8; 24];
    reader.read_exact(&mut header).map_err(|_| {
        bad(format!(
            "{length} bytes is too short for the 24-byte header"
        ))
    })?;
    if &header[..8] != RECOVERY_MAGIC {
        return Err(bad(
            "missing the NLMRCV01 magic bytes: not a recovery basis file".to_string(),
        ));
    }
    let word = |i: usize| {
        let mut b = [0u8; 8];
        b.copy_from_slice(&header[i..i + 8]);
        u64::from_le_bytes(b)
    };
    let (rows, cols) = (word(8), word(16));
    let expected = rows
        .checked_mul(cols)
        .and_then(|c| c.checked_mul(8))
        .and_then(|b| b.checked_add(24));
    if expected != Some(length) {
        return Err(bad(format!(
            "the header announces {rows} x {cols} values but the file has {length} bytes \
             (expected 24 + 8 x rows x cols)"
        )));
    }
    let (rows, cols) = (rows as usize, cols as usize);
    let mut r = Mat::<f64>::zeros(rows, cols);
    let mut buf = [0u8; 8];
    for j in 0..cols {
        for v in r.col_as_slice_mut(j) {
            reader.read_exact(&mut buf).map_err(io)?;
            *v = f64::from_le_bytes(buf);
        }
    }
    Ok(r)
}
