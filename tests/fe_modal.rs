//! Finite-element and modal checks on small gmsh meshes: ARPACK against the dense generalized
//! eigensolver, rigid-body modes and mass of the unconstrained beam, the MSH reader's groups
//! (beam faces, blade contact edge) and its rejection of MSH 2.2 files.

mod common;

use common::{
    beam_mesh, blade_mesh, dot, fe_system, hz, mac_mass, max_abs, mul, norm, run_gmsh, steel,
    timed, BEAM_B, BEAM_H, BEAM_L, BLADE_HUB_RADIUS, BLADE_SPAN,
};
use nlmodes_fem::{read_msh, FemError, TetKind};
use nlmodes_modal::{
    csmat_to_dense, dense_generalized_eigen, eigs_shift_invert, EigenMethod, EigenOptions,
};
use sprs::CsMat;

/// Target element size of the small beam mesh (m): about one TET10 across the width
/// b = 0.1 m, ~1.3k DOFs, small enough for the dense O(n^3) eigensolver (~1 s).
const COARSE_H_MESH: f64 = 0.1;

/// All eigenpairs of the sparse (K, M) by `nlmodes_modal::dense_generalized_eigen`.
fn dense_eigen(k: &CsMat<f64>, m: &CsMat<f64>) -> (Vec<f64>, faer::Mat<f64>) {
    dense_generalized_eigen(csmat_to_dense(k).as_ref(), csmat_to_dense(m).as_ref())
        .expect("dense eigen")
}

/// Maximum absolute row sum ||A||_inf.
fn norm_inf(a: &CsMat<f64>) -> f64 {
    let mut rows = vec![0.0; a.rows()];
    for (&v, (i, _)) in a.iter() {
        rows[i] += v.abs();
    }
    max_abs(&rows)
}

/// ARPACK (shift-invert Lanczos at sigma = 0) against faer's dense generalized eigensolver on
/// the clamped coarse beam (1284 DOFs), first 10 eigenpairs.
///
/// Tolerance 1e-8 relative on the eigenvalues (the brief's). Error budget: ARPACK with its
/// default tol = 1e-10 gives eigenvalues to ~1e-14 (quadratic convergence of Ritz values);
/// a backward-stable dense solver has an absolute eigenvalue error of at most a modest
/// multiple of eps lambda_max, i.e. a relative error eps lambda_max / lambda_1 on the lowest
/// eigenvalue: 1.0e-8 on this mesh (printed), a worst case that the actual error stays well
/// below (the two eigensolutions differ by ~1e-9 on mode 1, less on the others).
/// Shapes: mass-weighted MAC > 1 - 1e-8 (eigenvector angle ~ residual / relative gap; the
/// first 10 modes are separated by > 2 %).
#[test]
fn arpack_matches_dense_eigensolver_on_clamped_beam() {
    let sys = fe_system(beam_mesh(2, COARSE_H_MESH), &steel(), &["clamp"]);
    let n = sys.k.rows();
    let opts = EigenOptions {
        method: EigenMethod::Arpack,
        ..EigenOptions::default()
    };
    let arpack = timed(&format!("ARPACK, 10 modes of {n} DOFs"), || {
        eigs_shift_invert(&sys.k, &sys.m, 10, 0.0, &opts).expect("ARPACK")
    });
    let (dense_values, dense_vectors) = timed(&format!("dense eigen, {n} DOFs"), || {
        dense_eigen(&sys.k, &sys.m)
    });
    let lambda_max = dense_values[n - 1];
    eprintln!(
        "eps lambda_max / lambda_1 = {:.2e}",
        f64::EPSILON * lambda_max / dense_values[0]
    );
    for (j, (&a, &d)) in arpack.eigenvalues.iter().zip(&dense_values).enumerate() {
        let err = (a - d).abs() / d;
        let mac = mac_mass(
            &sys.m,
            arpack.vectors.col_as_slice(j),
            dense_vectors.col_as_slice(j),
        );
        eprintln!(
            "mode {:2}: {:10.4} Hz, relative eigenvalue difference {err:.1e}, 1 - MAC {:.1e}",
            j + 1,
            hz(a),
            1.0 - mac
        );
        assert!(err < 1e-8, "mode {}: ARPACK {a} vs dense {d}", j + 1);
        assert!(mac > 1.0 - 1e-8, "mode {}: MAC {mac}", j + 1);
    }
}

/// Rigid-body motions of the unconstrained beam, built from the node coordinates:
/// translations e_x, e_y, e_z and rotations e_k x (p - c) about the centroid c.
fn rigid_modes(nodes: &[[f64; 3]]) -> Vec<Vec<f64>> {
    let c = [BEAM_L / 2.0, BEAM_B / 2.0, BEAM_H / 2.0];
    let mut modes = Vec::new();
    for k in 0..3 {
        let mut t = vec![0.0; 3 * nodes.len()];
        for i in 0..nodes.len() {
            t[3 * i + k] = 1.0;
        }
        modes.push(t);
    }
    for k in 0..3 {
        let mut r = vec![0.0; 3 * nodes.len()];
        for (i, p) in nodes.iter().enumerate() {
            let d = [p[0] - c[0], p[1] - c[1], p[2] - c[2]];
            // e_k x d
            let (a, b) = ((k + 1) % 3, (k + 2) % 3);
            r[3 * i + b] = d[a];
            r[3 * i + a] = -d[b];
        }
        modes.push(r);
    }
    modes
}

/// The unconstrained beam: exactly six near-zero eigenvalues, K annihilates the rigid-body
/// motions, and the mass matrix carries the right mass and rotational inertia.
///
/// * Dense eigenvalues: a rigid mode's computed eigenvalue is round-off, |lambda| ~ eps
///   lambda_max (~1e-16 relative); the first elastic mode (free-free bending in z, ~265 Hz)
///   is ~1e-6 of lambda_max on this mesh. Threshold 1e-11 lambda_max separates them with
///   about five decades on each side: six below, the 7th above.
/// * The 7th eigenvalue is the free-free bending in z: within 2 % of Euler-Bernoulli,
///   f = 4.7300407448^2 / (2 pi L^2) sqrt(E I / (rho A)) with I = b h^3 / 12 (shear and
///   rotary inertia lower it by about 1 % at L/h = 20, the coarse TET10 mesh raises it by
///   less than that).
/// * The six computed rigid modes span the coordinate-built ones: M-orthogonal projection
///   residual < 1e-8 (subspace angle ~ eps lambda_max / lambda_7 ~ 3e-10).
/// * ||K r||_inf <= 1e-12 ||K||_inf ||r||_inf for each rigid motion r: the TET10 and TET4
///   fields contain every linear displacement, so element by element B r = 0 up to the
///   round-off of J^-1 (~1e-15 relative on these well-shaped elements) and of the sums
///   (~100 terms per row of K).
/// * r^T M r = rho V for a unit translation (V = L b h, exact for the box's planar faces) and
///   rho V (b^2 + h^2) / 12 for a unit rotation about the beam axis through the centroid: the
///   integrands are polynomials the consistent mass quadrature integrates exactly (degree 4
///   for TET10 on straight elements), so 1e-12 relative (round-off of the sums).
#[test]
fn free_beam_has_six_rigid_modes_and_exact_mass() {
    let mesh = beam_mesh(2, COARSE_H_MESH);
    let mat = steel();
    let sys = fe_system(mesh.clone(), &mat, &[]);
    let n = sys.k.rows();
    assert_eq!(n, 3 * mesh.n_nodes());
    let (values, vectors) = timed(&format!("dense eigen, free beam, {n} DOFs"), || {
        dense_eigen(&sys.k, &sys.m)
    });
    let lambda_max = values[n - 1];
    let ratios: Vec<String> = values[..8]
        .iter()
        .map(|v| format!("{:.2e}", v / lambda_max))
        .collect();
    let ratios = ratios.join(", ");
    eprintln!("lambda_1..8 / lambda_max = {ratios}");
    let near_zero = values
        .iter()
        .filter(|v| v.abs() < 1e-11 * lambda_max)
        .count();
    assert_eq!(near_zero, 6, "{ratios}");
    assert!(values[6] > 1e-11 * lambda_max);
    let free_free = 4.7300407448_f64.powi(2) / (2.0 * std::f64::consts::PI * BEAM_L.powi(2))
        * (mat.young * BEAM_B * BEAM_H.powi(3) / 12.0 / (mat.density * BEAM_B * BEAM_H)).sqrt();
    let f7 = hz(values[6]);
    eprintln!("first elastic frequency {f7:.3} Hz, Euler-Bernoulli free-free {free_free:.3} Hz");
    assert!((f7 / free_free - 1.0).abs() < 0.02, "{f7} vs {free_free}");

    let k_norm = norm_inf(&sys.k);
    let volume = BEAM_L * BEAM_B * BEAM_H;
    let computed: Vec<&[f64]> = (0..6).map(|j| vectors.col_as_slice(j)).collect();
    for (idx, r) in rigid_modes(&mesh.nodes).iter().enumerate() {
        let kr = mul(&sys.k, r);
        let residual = max_abs(&kr) / (k_norm * max_abs(r));
        // Projection onto the computed rigid modes (M-orthonormal).
        let mut rest = r.clone();
        for phi in &computed {
            let c = dot(phi, &mul(&sys.m, r));
            rest.iter_mut().zip(*phi).for_each(|(x, p)| *x -= c * p);
        }
        let m_r = mul(&sys.m, r);
        let projection = (dot(&rest, &mul(&sys.m, &rest)) / dot(r, &m_r)).sqrt();
        eprintln!(
            "rigid mode {idx}: ||K r|| / (||K|| ||r||) = {residual:.1e}, \
             outside the computed zero-frequency subspace {projection:.1e}"
        );
        assert!(residual < 1e-12, "rigid mode {idx}: {residual:e}");
        assert!(projection < 1e-8, "rigid mode {idx}: {projection:e}");
        let inertia = dot(r, &m_r);
        let expected = match idx {
            0..=2 => mat.density * volume,
            // Rotation about x: rho integral of (y - y_c)^2 + (z - z_c)^2.
            3 => mat.density * volume * (BEAM_B.powi(2) + BEAM_H.powi(2)) / 12.0,
            4 => mat.density * volume * (BEAM_H.powi(2) + BEAM_L.powi(2)) / 12.0,
            _ => mat.density * volume * (BEAM_L.powi(2) + BEAM_B.powi(2)) / 12.0,
        };
        eprintln!("  r^T M r = {inertia:.10e}, expected {expected:.10e}");
        assert!(
            (inertia - expected).abs() < 1e-12 * expected,
            "rigid mode {idx}: {inertia} vs {expected}"
        );
    }
    assert!((mesh.volume() - volume).abs() < 1e-12 * volume);
}

/// The reader's groups on the beam (TET10 and TET4): `clamp` and `free` are exactly the nodes
/// on the planes x = 0 and x = L (coordinates as gmsh writes them, 17 significant digits;
/// tolerance 1e-9 L, far below the element size), `beam` holds every node.
#[test]
fn beam_groups_are_the_end_faces() {
    for (order, kind) in [(2, TetKind::Tet10), (1, TetKind::Tet4)] {
        let mesh = beam_mesh(order, COARSE_H_MESH);
        assert_eq!(mesh.kind, kind);
        let tol = 1e-9 * BEAM_L;
        for (name, x) in [("clamp", 0.0), ("free", BEAM_L)] {
            let group = mesh.group(name).expect("end face group");
            assert_eq!(group.dim, 2, "{name}");
            let on_plane: Vec<usize> = (0..mesh.n_nodes())
                .filter(|&i| (mesh.nodes[i][0] - x).abs() < tol)
                .collect();
            eprintln!(
                "{kind:?}: group {name}: {} nodes, {} nodes on x = {x}",
                group.nodes.len(),
                on_plane.len()
            );
            assert!(group.nodes.len() >= 4, "{name}");
            assert_eq!(group.nodes, on_plane, "{kind:?} group {name}");
        }
        let beam = mesh.group("beam").expect("volume group");
        assert_eq!(beam.dim, 3);
        assert_eq!(beam.nodes, (0..mesh.n_nodes()).collect::<Vec<_>>());
    }
}

/// The blade's contact edge: `tip_edge` has exactly 24 nodes (the 24 geometry points of
/// blade.geo) for TET10 and TET4, all on the tip face z = hub_radius + span (tolerance 1e-9 m:
/// they are geometry vertices, written with 17 digits) and members of the `tip` group.
#[test]
fn blade_tip_edge_has_24_nodes_for_tet10_and_tet4() {
    for (order, kind) in [(2, TetKind::Tet10), (1, TetKind::Tet4)] {
        let mesh = blade_mesh(order, 0.01);
        assert_eq!(mesh.kind, kind);
        let edge = mesh.group("tip_edge").expect("tip_edge group");
        let tip = mesh.group("tip").expect("tip group");
        eprintln!(
            "blade {kind:?}: {} nodes, tip_edge {} nodes, tip {} nodes, root {} nodes",
            mesh.n_nodes(),
            edge.nodes.len(),
            tip.nodes.len(),
            mesh.group("root").map_or(0, |g| g.nodes.len())
        );
        assert_eq!(edge.dim, 0);
        assert_eq!(edge.nodes.len(), 24, "{kind:?}");
        for &n in &edge.nodes {
            let z = mesh.nodes[n][2];
            assert!(
                (z - (BLADE_HUB_RADIUS + BLADE_SPAN)).abs() < 1e-9,
                "{kind:?}: tip_edge node {n} at z = {z}"
            );
            assert!(tip.nodes.binary_search(&n).is_ok(), "{kind:?}: node {n}");
        }
        assert_eq!(mesh.group("blade").expect("volume").dim, 3);
    }
}

/// A gmsh MSH 2.2 file is refused with an error naming the file and the version found.
#[test]
fn msh22_file_gives_a_version_error() {
    let dir = tempfile::tempdir().expect("temporary directory");
    let path = dir.path().join("beam22.msh");
    run_gmsh(&common::beam_geo(), 2, "msh22", &[("h_mesh", 0.1)], &path);
    let err = read_msh(&path).expect_err("MSH 2.2 must be rejected");
    let msg = err.to_string();
    eprintln!("{msg}");
    assert!(
        matches!(&err, FemError::UnsupportedMshVersion { found, .. } if found == "2.2"),
        "{err:?}"
    );
    assert!(msg.contains("2.2") && msg.contains("4.1"), "{msg}");
    assert!(msg.contains("beam22.msh"), "{msg}");
}

/// The rigid-motion helper itself: unit translations, and e_z x (p - c) for the z rotation.
#[test]
fn rigid_modes_helper_builds_unit_translations() {
    let nodes = [[0.0, 0.0, 0.0], [1.0, 2.0, 3.0]];
    let modes = rigid_modes(&nodes);
    assert_eq!(modes.len(), 6);
    assert!((norm(&modes[0]) - 2f64.sqrt()).abs() < 1e-15);
    // Rotation about z (k = 2) of node 1: e_z x (d) with d = p - c.
    let c = [BEAM_L / 2.0, BEAM_B / 2.0, BEAM_H / 2.0];
    let d = [1.0 - c[0], 2.0 - c[1], 3.0 - c[2]];
    assert_eq!(&modes[5][3..6], &[-d[1], d[0], 0.0]);
}
