//! The clamped finite-element model: mesh, material, Dirichlet elimination, assembled K and M.

use anyhow::{Context, Result};
use nlmodes_fem::{assemble, fixed_dofs, read_msh, DofMap, Isotropic, Mesh};
use nlmodes_modal::{eigs_shift_invert_factored, Modes};
use nlmodes_sparse::SparseCholesky;
use sprs::CsMat;
use std::path::Path;

use crate::ui;

/// A mesh with its Dirichlet conditions and the free-DOF stiffness (N/m) and mass (kg) matrices.
pub struct FeModel {
    pub mesh: Mesh,
    pub dofs: DofMap,
    /// Free-DOF stiffness K_ff, N/m.
    pub k: CsMat<f64>,
    /// Free-DOF consistent mass M_ff, kg.
    pub m: CsMat<f64>,
    /// The Dirichlet specifications applied (`root`, `bottom:z`), for messages.
    pub clamp: Vec<String>,
}

/// The mesh of `mesh_path` and its DOF map with the DOFs of the `fix` specs eliminated.
pub fn read_mesh(mesh_path: &Path, fix: &[String]) -> Result<(Mesh, DofMap)> {
    let mesh = read_msh(mesh_path)?;
    let fixed = fixed_dofs(&mesh, fix)
        .with_context(|| format!("Dirichlet conditions on {}", mesh_path.display()))?;
    let dofs = DofMap::new(mesh.n_nodes(), &fixed)?;
    Ok((mesh, dofs))
}

impl FeModel {
    /// Read `mesh_path`, assemble K and M for `material`, eliminate the DOFs of the `fix` specs
    /// (`root`, `bottom:z`).
    pub fn build(mesh_path: &Path, material: &Isotropic, fix: &[String]) -> Result<Self> {
        let stage = ui::Stage::start("assemble");
        let (mesh, dofs) = read_mesh(mesh_path, fix)?;
        let (k, m) = assemble(&mesh, material)
            .with_context(|| format!("assembling {}", mesh_path.display()))?;
        let k = dofs.try_restrict(&k)?;
        let m = dofs.try_restrict(&m)?;
        stage.done(&format!(
            "{} {:?} elements, {} nodes, {} free DOFs ({} fixed), nnz(K) = {}",
            mesh.n_elements(),
            mesh.kind,
            mesh.n_nodes(),
            dofs.n_free(),
            3 * mesh.n_nodes() - dofs.n_free(),
            k.nnz()
        ));
        if fix.is_empty() {
            tracing::warn!(
                "no Dirichlet condition: the model has rigid-body modes; use a negative --sigma"
            );
        }
        Ok(Self {
            mesh,
            dofs,
            k,
            m,
            clamp: fix.to_vec(),
        })
    }

    /// The `n` lowest modes by ARPACK shift-invert about `sigma` (rad^2/s^2), with a progress spinner.
    pub fn modes(&self, n: usize, sigma: f64) -> Result<Modes> {
        if n == 0 {
            return Err(crate::exit::bad_input(
                "the number of modes must be at least 1 (--modes or model.linear_modes)",
            ));
        }
        let stage = ui::Stage::start("modes");
        let t = std::time::Instant::now();
        let shifted = nlmodes_sparse::shifted(&self.k, &self.m, sigma)?;
        let factor = SparseCholesky::new(&shifted)
            .with_context(|| format!("factorizing K - sigma M (sigma = {sigma:e} rad^2/s^2)"))?;
        drop(shifted);
        tracing::info!(
            "factorization of K - sigma M: {} DOFs, nnz(L) = {}, {:.2} s",
            self.dofs.n_free(),
            factor.nnz_l(),
            t.elapsed().as_secs_f64()
        );
        let t = std::time::Instant::now();
        let modes = ui::with_solve_spinner("modes", |opts| {
            eigs_shift_invert_factored(&self.k, &self.m, sigma, &factor, n, opts)
        })
        .with_context(|| {
            format!(
                "computing {n} modes of the {}-DOF model",
                self.dofs.n_free()
            )
        })?;
        tracing::info!(
            "eigensolver: {n} modes in {:.2} s",
            t.elapsed().as_secs_f64()
        );
        let worst = modes.residuals.iter().cloned().fold(0.0, f64::max);
        stage.done(&format!(
            "{} modes, largest relative residual {worst:.2e}",
            modes.len()
        ));
        Ok(modes)
    }
}

/// `frequencies.csv`: columns `mode,frequency_hz,eigenvalue,residual` (eigenvalue in rad^2/s^2).
pub fn frequencies_csv(modes: &Modes) -> String {
    let mut s = String::from("mode,frequency_hz,eigenvalue,residual\n");
    for (i, f) in modes.frequencies_hz().iter().enumerate() {
        s.push_str(&format!(
            "{},{f},{},{}\n",
            i + 1,
            modes.eigenvalues[i],
            modes.residuals[i]
        ));
    }
    s
}

/// The frequency table printed on the terminal.
pub fn frequency_table(modes: &Modes) -> String {
    let mut s = format!(
        "{:>5} {:>14} {:>22} {:>10}\n",
        "mode", "frequency [Hz]", "eigenvalue [rad²/s²]", "residual"
    );
    for (i, f) in modes.frequencies_hz().iter().enumerate() {
        s.push_str(&format!(
            "{:>5} {:>14.4} {:>22.6e} {:>10.2e}\n",
            i + 1,
            f,
            modes.eigenvalues[i],
            modes.residuals[i]
        ));
    }
    s
}

/// Write `frequencies.csv` and `modes.vtu` (one point vector field per mode, m, mass-normalized).
pub fn write_modes(fe: &FeModel, modes: &Modes, dir: &Path) -> Result<()> {
    write_modes_of(&fe.mesh, &fe.dofs, modes, dir)
}

/// [`write_modes`] from the mesh and its DOF map.
pub fn write_modes_of(mesh: &Mesh, dofs: &DofMap, modes: &Modes, dir: &Path) -> Result<()> {
    std::fs::create_dir_all(dir).with_context(|| format!("cannot create {}", dir.display()))?;
    crate::post::output::write_atomic(
        &dir.join("frequencies.csv"),
        frequencies_csv(modes).as_bytes(),
    )?;
    let mut fields = Vec::with_capacity(modes.len());
    for j in 0..modes.len() {
        let free: Vec<f64> = (0..modes.vectors.nrows())
            .map(|i| modes.vectors[(i, j)])
            .collect();
        fields.push((format!("mode_{:02}", j + 1), dofs.try_expand(&free)?));
    }
    crate::post::output::write_mesh_vtu(mesh, &dir.join("modes.vtu"), &fields)
}

/// Frequencies (Hz) read back from a `frequencies.csv`, if present and well formed.
pub fn read_frequencies(path: &Path) -> Option<Vec<f64>> {
    let text = std::fs::read_to_string(path).ok()?;
    text.lines()
        .skip(1)
        .map(|l| l.split(',').nth(1)?.parse::<f64>().ok())
        .collect()
}
