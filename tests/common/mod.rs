//! Helpers shared by the workspace integration tests (`tests/*.rs`): gmsh meshing of the
//! project's geometry files (each mesh generated once per test binary), the materials, the
//! clamped finite-element systems and mode-shape measures.
//!
//! gmsh (>= 4.8) is required: the project's set-up script installs it, so a missing gmsh is a
//! test failure with an explanation, never a silent skip.

// Every test binary compiles this module and uses a different subset of it.
#![allow(dead_code)]

use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::process::Command;
use std::sync::{Arc, Mutex, OnceLock};

use nlmodes_fem::{assemble, fixed_dofs, read_msh, DofMap, Isotropic, Mesh};
use nlmodes_modal::sparse_ops::spmv;
use sprs::CsMat;

/// Steel for the beam tests: E = 210 GPa, nu = 0.3, rho = 7800 kg/m^3.
pub fn steel() -> Isotropic {
    Isotropic::new(210e9, 0.3, 7800.0).expect("steel constants are valid")
}

/// Titanium (Ti-6Al-4V) for the blade: E = 113.8 GPa, nu = 0.342, rho = 4430 kg/m^3.
pub fn titanium() -> Isotropic {
    Isotropic::new(113.8e9, 0.342, 4430.0).expect("titanium constants are valid")
}

/// `tests/data/beam.geo`: box cantilever L = 1 m (x), b = 0.1 m (y), h = 0.05 m (z);
/// groups `beam` (volume), `clamp` (x = 0), `free` (x = L); size parameter `h_mesh` (m).
pub fn beam_geo() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/beam.geo")
}

/// `meshes/blade.geo`: the blade; groups `blade`, `root`, `tip`, `tip_edge` (24 points);
/// parameters `mesh_size` (m) and `order` (1 = TET4, 2 = TET10).
pub fn blade_geo() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("meshes/blade.geo")
}

/// Beam dimensions in beam.geo's defaults (m).
pub const BEAM_L: f64 = 1.0;
pub const BEAM_B: f64 = 0.1;
pub const BEAM_H: f64 = 0.05;

/// Blade hub radius and span in blade.geo's defaults (m): the tip face is z = 0.37 m.
pub const BLADE_HUB_RADIUS: f64 = 0.25;
pub const BLADE_SPAN: f64 = 0.12;

/// Runs `gmsh -3 -order ORDER -format FORMAT [-setnumber NAME VALUE]... GEO -o OUT`.
/// Panics with gmsh's output when gmsh is missing or fails.
pub fn run_gmsh(geo: &Path, order: usize, format: &str, settings: &[(&str, f64)], out: &Path) {
    let mut cmd = Command::new("gmsh");
    cmd.arg("-3")
        .arg("-order")
        .arg(order.to_string())
        .arg("-format")
        .arg(format);
    for (name, value) in settings {
        cmd.arg("-setnumber").arg(name).arg(value.to_string());
    }
    cmd.arg(geo).arg("-o").arg(out);
    without_aslr(&mut cmd);
    let output = match cmd.output() {
        Ok(o) => o,
        Err(e) => panic!(
            "cannot run gmsh ({e}): the integration tests mesh {} with the gmsh CLI (>= 4.8); \
             install it (Debian: apt-get install gmsh, as the project's set-up script does)",
            geo.display()
        ),
    };
    let tail = |bytes: &[u8]| {
        let text = String::from_utf8_lossy(bytes);
        let lines: Vec<&str> = text.lines().collect();
        lines[lines.len().saturating_sub(15)..].join("\n")
    };
    assert!(
        output.status.success() && out.is_file(),
        "gmsh failed on {} (order {order}, {settings:?}) with {}:\n{}\n{}",
        geo.display(),
        output.status,
        tail(&output.stdout),
        tail(&output.stderr)
    );
}

/// Runs gmsh without address-space layout randomization, as the binary's mesh stage does
/// (`src/child.rs`, `without_aslr`): gmsh orders some work by pointer addresses, and with ASLR
/// the coarse blade's node coordinates differ in their last bit from run to run (session 29:
/// 5 different meshes in 10 runs; one in four of them met a faer eigenvalue failure in
/// `blade_stability`). Best effort where a sandbox refuses the call.
fn without_aslr(cmd: &mut Command) {
    #[cfg(target_os = "linux")]
    {
        use std::os::unix::process::CommandExt;
        // SAFETY: runs in the forked child before exec, calls only the async-signal-safe
        // personality and allocates nothing.
        unsafe {
            cmd.pre_exec(|| {
                let current = libc::personality(0xffff_ffff);
                if current != -1 {
                    libc::personality(
                        current as libc::c_ulong | libc::ADDR_NO_RANDOMIZE as libc::c_ulong,
                    );
                }
                Ok(())
            });
        }
    }
}

/// A per-test-binary memo: `get(key, init)` runs `init` once per key, even when tests ask
/// concurrently (the others wait for that one computation); different keys run in parallel.
pub struct Memo<V>(OnceLock<Mutex<HashMap<String, MemoCell<V>>>>);

/// One memoized value, computed at most once.
type MemoCell<V> = Arc<OnceLock<Arc<V>>>;

impl<V> Memo<V> {
    pub const fn new() -> Self {
        Memo(OnceLock::new())
    }

    pub fn get(&self, key: String, init: impl FnOnce() -> V) -> Arc<V> {
        let cell = {
            let mut map = self
                .0
                .get_or_init(Default::default)
                .lock()
                .expect("memo lock (poisoned by a panicking test)");
            map.entry(key).or_default().clone()
        };
        cell.get_or_init(|| Arc::new(init())).clone()
    }
}

impl<V> Default for Memo<V> {
    fn default() -> Self {
        Self::new()
    }
}

static MESHES: Memo<Mesh> = Memo::new();

/// The MSH 4.1 mesh of `geo` at element `order` with the given `-setnumber` settings, read
/// by `nlmodes_fem::read_msh`. Generated once per test binary (the .msh file lives in a
/// temporary directory removed after reading).
pub fn gmsh_mesh(geo: &Path, order: usize, settings: &[(&str, f64)]) -> Arc<Mesh> {
    let key = format!("{}|{order}|{settings:?}", geo.display());
    MESHES.get(key, || {
        let dir = tempfile::tempdir().expect("temporary directory for gmsh");
        let out = dir.path().join("mesh.msh");
        let start = std::time::Instant::now();
        run_gmsh(geo, order, "msh41", settings, &out);
        let mesh = read_msh(&out)
            .unwrap_or_else(|e| panic!("reading the gmsh output of {}: {e}", geo.display()));
        eprintln!(
            "meshed {} order {order} {settings:?}: {} nodes, {} tets, {:.2} s",
            geo.file_name()
                .map_or_else(String::new, |f| f.to_string_lossy().into_owned()),
            mesh.n_nodes(),
            mesh.n_elements(),
            start.elapsed().as_secs_f64()
        );
        mesh
    })
}

/// The beam at element `order` (1 = TET4, 2 = TET10) and target size `h_mesh` (m).
pub fn beam_mesh(order: usize, h_mesh: f64) -> Arc<Mesh> {
    gmsh_mesh(&beam_geo(), order, &[("h_mesh", h_mesh)])
}

/// The blade at element `order` and `mesh_size` (m). blade.geo sets Mesh.ElementOrder from
/// its `order` variable, so the order goes through `-setnumber order` as well.
pub fn blade_mesh(order: usize, mesh_size: f64) -> Arc<Mesh> {
    gmsh_mesh(
        &blade_geo(),
        order,
        &[("mesh_size", mesh_size), ("order", order as f64)],
    )
}

/// A finite-element model with the DOFs of some groups fixed (eliminated).
pub struct FeSystem {
    pub mesh: Arc<Mesh>,
    /// Map between the 3 n global DOFs (3 node + component) and the free ones.
    pub dofs: DofMap,
    /// Stiffness on the free DOFs (N/m).
    pub k: CsMat<f64>,
    /// Consistent mass on the free DOFs (kg).
    pub m: CsMat<f64>,
}

/// Assembles K and M of `mesh` and eliminates every DOF of the groups in `clamped` (none:
/// the unconstrained model).
pub fn fe_system(mesh: Arc<Mesh>, material: &Isotropic, clamped: &[&str]) -> FeSystem {
    let (k, m) = assemble(&mesh, material).expect("assembly");
    let fixed = fixed_dofs(&mesh, clamped).expect("clamped groups exist");
    let dofs = DofMap::new(mesh.n_nodes(), &fixed).expect("fixed DOFs in range");
    let k = dofs.try_restrict(&k).expect("K is 3n x 3n");
    let m = dofs.try_restrict(&m).expect("M is 3n x 3n");
    FeSystem { mesh, dofs, k, m }
}

/// y = A x.
pub fn mul(a: &CsMat<f64>, x: &[f64]) -> Vec<f64> {
    let mut y = vec![0.0; a.rows()];
    spmv(a, x, &mut y).expect("sizes match");
    y
}

pub fn dot(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| x * y).sum()
}

pub fn norm(a: &[f64]) -> f64 {
    dot(a, a).sqrt()
}

pub fn max_abs(a: &[f64]) -> f64 {
    a.iter().fold(0.0_f64, |acc, v| acc.max(v.abs()))
}

/// Mass-weighted modal assurance criterion (a^T M b)^2 / ((a^T M a)(b^T M b)), in [0, 1]:
/// 1 for identical shapes up to scale, independent of the mesh's node density.
pub fn mac_mass(m: &CsMat<f64>, a: &[f64], b: &[f64]) -> f64 {
    let mb = mul(m, b);
    let ma = mul(m, a);
    dot(a, &mb).powi(2) / (dot(a, &ma) * dot(b, &mb))
}

/// f = sqrt(lambda) / (2 pi) (Hz) for lambda >= 0 in rad^2/s^2.
pub fn hz(lambda: f64) -> f64 {
    lambda.max(0.0).sqrt() / (2.0 * std::f64::consts::PI)
}

/// Runs `f`, prints its wall time under `label` (shown with `--nocapture`).
pub fn timed<T>(label: &str, f: impl FnOnce() -> T) -> T {
    let start = std::time::Instant::now();
    let out = f();
    eprintln!("{label}: {:.2} s", start.elapsed().as_secs_f64());
    out
}

/// The coarse blade (meshes/blade.geo at mesh_size 0.012, about 8k DOFs) reduced onto its tip
/// edge with 20 fixed-interface modes, through the command a user runs: `nlmodes mesh` and
/// `nlmodes reduce` into `dir`; returns the reduced-model directory. About 2 s.
pub fn coarse_blade_model(dir: &Path) -> PathBuf {
    let run = nlmodes_ok;
    let (mesh, model) = (dir.join("coarse.msh"), dir.join("model"));
    let geo = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("meshes/blade.geo");
    let (geo, mesh_s, model_s) = (
        geo.to_str().unwrap(),
        mesh.to_str().unwrap(),
        model.to_str().unwrap(),
    );
    run(&["mesh", geo, "-o", mesh_s, "--set", "mesh_size=0.012"]);
    run(&[
        "reduce",
        mesh_s,
        "--modes",
        "20",
        "--compare",
        "0",
        "-o",
        model_s,
    ]);
    model
}

/// Runs the nlmodes binary with `--quiet` and `args`.
pub fn nlmodes(args: &[&str]) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_nlmodes"))
        .arg("--quiet")
        .args(args)
        .output()
        .expect("cannot start nlmodes")
}

/// Runs the nlmodes binary and fails the test, with its output, unless it succeeds.
pub fn nlmodes_ok(args: &[&str]) {
    let out = nlmodes(args);
    assert!(
        out.status.success(),
        "nlmodes {args:?} failed:\n{}{}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
}

/// How far the reduced model's static response to its load `fr` (the column of F.mtx, whose
/// last coordinate is the load's static correction) is from the full model's K^-1 `f` (`f` on
/// the free DOFs of `fe`), relative 2-norms: ([at the contact nodes, over the whole blade] with
/// the correction coordinate, the same without it).
pub fn reduced_static_errors(
    model: &nlmodes_modal::ReducedModel,
    fr: &faer::Mat<f64>,
    fe: &FeSystem,
    f: &[f64],
) -> ([f64; 2], [f64; 2]) {
    use faer::linalg::solvers::Solve;
    let nr = model.k.nrows();
    let chol = nlmodes_modal::SparseCholesky::new(&fe.k).unwrap();
    let mut u = faer::Mat::from_fn(f.len(), 1, |i, _| f[i]);
    chol.solve_many(u.as_mut()).unwrap();
    let contact_dofs: Vec<(usize, usize)> = model
        .contact_nodes
        .iter()
        .flat_map(|c| {
            let node = c.mesh_node.unwrap() as usize - 1;
            (0..3).map(move |k| (c.dofs[k], 3 * node + k))
        })
        .map(|(reduced, global)| (reduced, fe.dofs.free_index(global).unwrap()))
        .collect();
    let recovery = model.recovery.as_ref().unwrap();
    let solve = |keep: usize| {
        let k = faer::Mat::from_fn(keep, keep, |i, j| model.k[(i, j)]);
        let rhs = faer::Mat::from_fn(keep, 1, |i, _| fr[(i, 0)]);
        k.partial_piv_lu().solve(&rhs)
    };
    let relative = |pairs: &mut dyn Iterator<Item = (f64, f64)>| {
        let (d2, u2) = pairs.fold((0.0, 0.0), |(d, n), (a, b)| {
            (d + (a - b).powi(2), n + b * b)
        });
        (d2 / u2).sqrt()
    };
    let errors = |q: &faer::Mat<f64>| {
        let at_contacts = relative(&mut contact_dofs.iter().map(|&(r, g)| (q[(r, 0)], u[(g, 0)])));
        let keep = q.nrows();
        let everywhere = relative(&mut (0..recovery.nrows()).map(|i| {
            let v: f64 = (0..keep).map(|j| recovery[(i, j)] * q[(j, 0)]).sum();
            (v, u[(i, 0)])
        }));
        [at_contacts, everywhere]
    };
    (errors(&solve(nr)), errors(&solve(nr - 1)))
}

fn write_symmetric4(path: &Path, a: &[[f64; 4]; 4]) {
    use std::fmt::Write as _;
    let mut s = String::from("%%MatrixMarket matrix coordinate real symmetric\n4 4 10\n");
    for j in 0..4 {
        for (i, row) in a.iter().enumerate().skip(j) {
            let _ = writeln!(s, "{} {} {:.17e}", i + 1, j + 1, row[j]);
        }
    }
    std::fs::write(path, s).unwrap();
}

/// The 2-DOF chain's reduced-model directory (M = I, K = [[2, -1], [-1, 2]], w = 1 and sqrt(3)
/// rad/s, the stop on DOF 1 at gap 1 m): DOFs 0, 1 the chain, 2, 3 two uncoupled pad
/// coordinates at 5 rad/s that make DOF 1 a 3-coordinate contact node; the master is DOF 0.
pub fn chain_model(dir: &Path) {
    std::fs::create_dir_all(dir).unwrap();
    let pad = 25.0;
    let mass = [
        [1.0, 0.0, 0.0, 0.0],
        [0.0, 1.0, 0.0, 0.0],
        [0.0, 0.0, 1.0, 0.0],
        [0.0, 0.0, 0.0, 1.0],
    ];
    let stiffness = [
        [2.0, -1.0, 0.0, 0.0],
        [-1.0, 2.0, 0.0, 0.0],
        [0.0, 0.0, pad, 0.0],
        [0.0, 0.0, 0.0, pad],
    ];
    write_symmetric4(&dir.join("M.mtx"), &mass);
    write_symmetric4(&dir.join("K.mtx"), &stiffness);
    write_chain_json(dir, &[1.0, 3f64.sqrt(), 5.0, 5.0], "the first mass");
}

/// model.json of a 4-coordinate model whose contact node is DOFs 1, 2, 3 (radial x, gap 1 m),
/// master DOF 0, with the linear circular frequencies `omega` (rad/s).
fn write_chain_json(dir: &Path, omega: &[f64], master: &str) {
    let hz: Vec<f64> = omega
        .iter()
        .map(|w| w / (2.0 * std::f64::consts::PI))
        .collect();
    let model = serde_json::json!({
        "format": "nlmodes-reduced-model",
        "format_version": 1,
        "units": "SI: m, kg, s; K in N/m, M in kg",
        "n": 4,
        "contact_nodes": [{"dofs": [1, 2, 3], "position": [1.0, 0.0, 0.0],
                           "radial": [1.0, 0.0, 0.0], "gap": 1.0}],
        "rotor_axis": {"point": [0.0, 0.0, 0.0], "direction": [0.0, 0.0, 1.0]},
        "master": {"dof": 0, "description": master},
        "linear_frequencies_hz": hz,
    });
    std::fs::write(dir.join("model.json"), model.to_string()).unwrap();
}

/// A one-mode oscillator whose contact coordinate is nearly massless: the master x_0 (unit mass,
/// spring 1 to the ground) holds the contact coordinate x_1 (mass `eps`) by a spring `ks`; the
/// stop is on x_1 at gap 1 m; DOFs 2, 3 are two uncoupled unit pads at 5 rad/s that make x_1 a
/// 3-coordinate contact node. M = diag(1, eps, 1, 1), K = [[1 + ks, -ks], [-ks, ks]] + pads.
/// Its second mode, sqrt(ks / eps)-ish, lies far above the harmonics of the first: on the
/// massless contact boundary the first mode alone is dynamic and the model is a bilinear
/// oscillator (tests/backbone_exact_cli.rs).
pub fn light_contact_model(dir: &Path, eps: f64, ks: f64) {
    std::fs::create_dir_all(dir).unwrap();
    let pad = 25.0;
    let mass = [
        [1.0, 0.0, 0.0, 0.0],
        [0.0, eps, 0.0, 0.0],
        [0.0, 0.0, 1.0, 0.0],
        [0.0, 0.0, 0.0, 1.0],
    ];
    let stiffness = [
        [1.0 + ks, -ks, 0.0, 0.0],
        [-ks, ks, 0.0, 0.0],
        [0.0, 0.0, pad, 0.0],
        [0.0, 0.0, 0.0, pad],
    ];
    write_symmetric4(&dir.join("M.mtx"), &mass);
    write_symmetric4(&dir.join("K.mtx"), &stiffness);
    let (w1, w2) = two_dof_frequencies(eps, ks);
    write_chain_json(dir, &[w1, 5.0, 5.0, w2], "the master mass");
}

/// The two circular frequencies (rad/s, ascending) of `light_contact_model`'s (x_0, x_1) block:
/// det(K - w^2 M) = 0 with M = diag(1, eps), K = [[1 + ks, -ks], [-ks, ks]].
pub fn two_dof_frequencies(eps: f64, ks: f64) -> (f64, f64) {
    // eps l^2 - (eps (1 + ks) + ks) l + ks = 0.
    let b = eps * (1.0 + ks) + ks;
    let disc = (b * b - 4.0 * eps * ks).sqrt();
    let (l1, l2) = ((b - disc) / (2.0 * eps), (b + disc) / (2.0 * eps));
    (l1.sqrt(), l2.sqrt())
}

/// Writes the symmetric matrix `a` (n x n) as a Matrix Market coordinate file (lower triangle,
/// 17 significant digits).
pub fn write_symmetric(path: &Path, a: &[Vec<f64>]) {
    use std::fmt::Write as _;
    let n = a.len();
    let mut s = format!(
        "%%MatrixMarket matrix coordinate real symmetric\n{n} {n} {}\n",
        n * (n + 1) / 2
    );
    for j in 0..n {
        for (i, row) in a.iter().enumerate().skip(j) {
            let _ = writeln!(s, "{} {} {:.17e}", i + 1, j + 1, row[j]);
        }
    }
    std::fs::write(path, s).unwrap();
}

/// Stiffness (N/m) of the two coordinates that complete a small system's contact node in
/// `padded_contact_model`; with their unit mass they lie at 1000 rad/s.
pub const PAD_STIFFNESS: f64 = 1e6;

/// The reduced-model directory of a small system with one unilateral contact, laid out as an FE
/// code's model would be: coordinates 0..n are the system (`mass` in kg, `stiffness` in N/m,
/// n x n, symmetric), the contact node is the coordinate `contact` (radial direction, gap 1 m)
/// completed by two decoupled pads n, n + 1 (m = 1 kg, k = `PAD_STIFFNESS`), the master is
/// `master`. `omega` are the system's circular frequencies (rad/s, ascending), written to
/// model.json with the pads'.
pub fn padded_contact_model(
    dir: &Path,
    mass: &[Vec<f64>],
    stiffness: &[Vec<f64>],
    (contact, master): (usize, usize),
    omega: &[f64],
) {
    std::fs::create_dir_all(dir).unwrap();
    let n = mass.len();
    let padded = |a: &[Vec<f64>], pad: f64| -> Vec<Vec<f64>> {
        (0..n + 2)
            .map(|i| {
                (0..n + 2)
                    .map(|j| match (i < n && j < n, i == j) {
                        (true, _) => a[i][j],
                        (false, true) => pad,
                        (false, false) => 0.0,
                    })
                    .collect()
            })
            .collect()
    };
    write_symmetric(&dir.join("M.mtx"), &padded(mass, 1.0));
    write_symmetric(&dir.join("K.mtx"), &padded(stiffness, PAD_STIFFNESS));
    let pad_omega = PAD_STIFFNESS.sqrt();
    let hz: Vec<f64> = omega
        .iter()
        .chain([pad_omega, pad_omega].iter())
        .map(|w| w / (2.0 * std::f64::consts::PI))
        .collect();
    let model = serde_json::json!({
        "format": "nlmodes-reduced-model",
        "format_version": 1,
        "units": "SI: m, kg, s; K in N/m, M in kg",
        "n": n + 2,
        "contact_nodes": [{"dofs": [contact, n, n + 1], "position": [1.0, 0.0, 0.0],
                           "radial": [1.0, 0.0, 0.0], "gap": 1.0}],
        "rotor_axis": {"point": [0.0, 0.0, 0.0], "direction": [0.0, 0.0, 1.0]},
        "master": {"dof": master, "description": "the exact system's master"},
        "linear_frequencies_hz": hz,
    });
    std::fs::write(dir.join("model.json"), model.to_string()).unwrap();
}

/// The named columns of a CSV text (header line first, comma-separated, no quoting), one
/// `Vec<String>` per row; panics naming a missing column.
pub fn csv_columns(csv: &str, names: &[&str]) -> Vec<Vec<String>> {
    let mut lines = csv.lines();
    let header: Vec<&str> = lines.next().expect("a header line").split(',').collect();
    let at: Vec<usize> = names
        .iter()
        .map(|n| {
            header
                .iter()
                .position(|h| h == n)
                .unwrap_or_else(|| panic!("no column {n} in {header:?}"))
        })
        .collect();
    lines
        .map(|l| {
            let v: Vec<&str> = l.split(',').collect();
            at.iter().map(|&i| v[i].to_string()).collect()
        })
        .collect()
}
