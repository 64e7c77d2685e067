//! Global assembly: pattern, symmetry, agreement with a naive dense assembly, rigid-body
//! modes and their eigenvalues, total mass, and the assembly time of a ~100k-DOF TET10 mesh.

// Index loops mirror the index notation of the formulas.
#![allow(clippy::needless_range_loop)]

mod common;

use std::time::Instant;

use common::{curve_mid_edge_nodes, dense, max_abs, mul, norm, rigid_body_modes};
use faer::{Mat, Side};
use nlmodes_fem::element::element_matrices;
use nlmodes_fem::generate::box_mesh;
use nlmodes_fem::{assemble, FemError, Isotropic, Mesh, TetKind};

fn steel() -> Isotropic {
    Isotropic::new(210e9, 0.3, 7800.0).expect("valid")
}

/// Small test meshes: TET4, straight TET10 and curved TET10 (mid-edge nodes moved by 4 % of
/// their edge, in random directions).
fn small_meshes() -> Vec<(&'static str, Mesh)> {
    let tet4 = box_mesh([1.0, 0.6, 0.4], [2, 2, 1], TetKind::Tet4).expect("valid");
    let tet10 = box_mesh([1.0, 0.6, 0.4], [2, 1, 1], TetKind::Tet10).expect("valid");
    let mut curved = tet10.clone();
    curve_mid_edge_nodes(&mut curved, 0.04, 17);
    vec![("TET4", tet4), ("TET10", tet10), ("curved TET10", curved)]
}

/// Naive reference: dense matrices, element by element, serially.
fn dense_reference(mesh: &Mesh, mat: &Isotropic) -> (Vec<Vec<f64>>, Vec<Vec<f64>>) {
    let n = 3 * mesh.n_nodes();
    let npe = mesh.kind.nodes_per_element();
    let ne = 3 * npe;
    let mut k = vec![vec![0.0; n]; n];
    let mut m = vec![vec![0.0; n]; n];
    let (mut ke, mut me) = (vec![0.0; ne * ne], vec![0.0; ne * ne]);
    let mut coords = [[0.0; 3]; 10];
    for e in 0..mesh.n_elements() {
        mesh.element_coords_into(e, &mut coords);
        element_matrices(mesh.kind, &coords[..npe], mat, e, &mut ke, &mut me).expect("valid");
        let nodes = mesh.element(e);
        for p in 0..ne {
            for q in 0..ne {
                let (gp, gq) = (3 * nodes[p / 3] + p % 3, 3 * nodes[q / 3] + q % 3);
                k[gp][gq] += ke[p * ne + q];
                m[gp][gq] += me[p * ne + q];
            }
        }
    }
    (k, m)
}

#[test]
fn sparse_assembly_matches_naive_dense_assembly_and_is_exactly_symmetric() {
    let mat = steel();
    for (name, mesh) in small_meshes() {
        let (k, m) = assemble(&mesh, &mat).expect("valid mesh");
        assert!(k.is_csc() && m.is_csc());
        let n = 3 * mesh.n_nodes();
        assert_eq!(k.shape(), (n, n));
        let (kd, md) = dense_reference(&mesh, &mat);
        let (ks, ms) = (dense(&k), dense(&m));
        let (kmax, mmax) = (max_abs(&k), max_abs(&m));
        for i in 0..n {
            for j in 0..n {
                // Same element matrices summed in a different order: round-off only.
                assert!(
                    (ks[i][j] - kd[i][j]).abs() <= 1e-14 * kmax,
                    "{name} K({i},{j})"
                );
                assert!(
                    (ms[i][j] - md[i][j]).abs() <= 1e-14 * mmax,
                    "{name} M({i},{j})"
                );
                // Exact symmetry, bit for bit.
                assert_eq!(ks[i][j].to_bits(), ks[j][i].to_bits(), "{name} K({i},{j})");
                assert_eq!(ms[i][j].to_bits(), ms[j][i].to_bits(), "{name} M({i},{j})");
            }
        }
        // The pattern is exactly the node adjacency: each stored 3x3 block belongs to a node
        // pair sharing an element (checked via the dense reference: a structurally non-zero
        // block has some non-zero entry in M, whose diagonal blocks are positive).
        for (_, (i, j)) in m.iter() {
            let (a, b) = (i / 3, j / 3);
            let shared = (0..mesh.n_elements())
                .any(|e| mesh.element(e).contains(&a) && mesh.element(e).contains(&b));
            assert!(
                shared,
                "{name}: stored entry ({i},{j}) between unconnected nodes"
            );
        }
        // Deterministic: a second assembly is bitwise identical.
        let (k2, m2) = assemble(&mesh, &mat).expect("valid mesh");
        assert_eq!(k.data(), k2.data());
        assert_eq!(m.data(), m2.data());
    }
}

#[test]
fn rigid_body_modes_are_the_null_space_of_k() {
    let mat = steel();
    for (name, mesh) in small_meshes() {
        let (k, m) = assemble(&mesh, &mat).expect("valid mesh");
        let kmax = max_abs(&k);
        // K r = 0 to round-off: entries of K r are sums of ~100 terms of size kmax |r|,
        // so 1e-13 kmax |r| (with the max-norm of r) is a few hundred eps.
        for (i, r) in rigid_body_modes(&mesh.nodes).iter().enumerate() {
            let kr = mul(&k, r);
            let rmax = r.iter().fold(0.0f64, |a, b| a.max(b.abs()));
            let worst = kr.iter().fold(0.0f64, |a, b| a.max(b.abs()));
            assert!(
                worst < 1e-13 * kmax * rmax,
                "{name} mode {i}: |K r| = {worst:e}, |K| = {kmax:e}"
            );
        }
        // Translations carry the total mass rho V (V from the exact volume integral).
        let rho_v = mat.density * mesh.volume();
        for r in rigid_body_modes(&mesh.nodes).iter().take(3) {
            let mass = common::dot(r, &mul(&m, r));
            assert!(
                (mass - rho_v).abs() < 1e-13 * rho_v,
                "{name}: {mass} vs {rho_v}"
            );
        }
        // Exactly six zero eigenvalues: dense symmetric eigenvalues of K (faer). Round-off
        // of the eigensolver is ~n eps |K| ~ 1e-13 |K|: zero eigenvalues must be below
        // 1e-11 lambda_max; the seventh (the softest deformation mode of a coarse mesh) is
        // orders of magnitude above: require 1e-6 lambda_max (a spurious zero-energy mode
        // would sit at round-off level).
        let n = k.rows();
        let kd = dense(&k);
        let a = Mat::<f64>::from_fn(n, n, |i, j| kd[i][j]);
        let eig = a
            .self_adjoint_eigenvalues(Side::Lower)
            .expect("eigenvalues");
        let lmax = eig[n - 1];
        let zeros = eig.iter().filter(|l| l.abs() < 1e-11 * lmax).count();
        assert_eq!(
            zeros,
            6,
            "{name}: {zeros} near-zero eigenvalues: {:?}",
            &eig[..8]
        );
        assert!(
            eig[6] > 1e-6 * lmax,
            "{name}: seventh eigenvalue {:e}",
            eig[6]
        );
        // and K is positive semi-definite: no eigenvalue below round-off.
        assert!(eig[0] > -1e-11 * lmax);
        let _ = norm(&eig);
    }
}

#[test]
fn inverted_element_in_a_mesh_is_reported_by_tag() {
    let mut mesh = box_mesh([1.0, 1.0, 1.0], [2, 2, 2], TetKind::Tet10).expect("valid");
    mesh.element_tags = (0..mesh.n_elements()).map(|e| 1000 + e).collect();
    // Swap vertices 1 and 2 of element 17 (and the matching mid-edge nodes 4 <-> 6, 9 <-> 8
    // so that the element stays a consistent TET10, merely inverted).
    let npe = 10;
    let c = &mut mesh.connectivity[17 * npe..18 * npe];
    c.swap(1, 2);
    c.swap(4, 6);
    c.swap(8, 9);
    let err = assemble(&mesh, &steel()).expect_err("inverted element");
    assert!(
        matches!(
            err,
            FemError::InvertedElement {
                element_tag: 1017,
                ..
            }
        ),
        "{err}"
    );
    assert!(err.to_string().contains("element 1017"), "{err}");
    let mut orphan = mesh.clone();
    orphan.nodes.push([9.0, 9.0, 9.0]);
    let err = assemble(&orphan, &steel()).expect_err("orphan node");
    assert!(err.to_string().contains("belongs to no element"), "{err}");
    let bad = Isotropic {
        young: 1.0,
        poisson: 0.5,
        density: 1.0,
    };
    let err = assemble(&mesh, &bad).expect_err("bad material");
    assert!(err.to_string().contains("Poisson"), "{err}");
}

#[test]
fn hundred_thousand_dof_tet10_assembly_time() {
    // 16^3 cubes x 6 TET10: 33^3 = 35 937 nodes, 107 811 DOFs, 24 576 elements (affine).
    let mesh = box_mesh([1.0, 1.0, 1.0], [16, 16, 16], TetKind::Tet10).expect("valid");
    assert_eq!(3 * mesh.n_nodes(), 107_811);
    let mat = steel();
    let mut best = f64::INFINITY;
    let mut result = None;
    for _ in 0..2 {
        let t = Instant::now();
        result = Some(assemble(&mesh, &mat).expect("valid"));
        best = best.min(t.elapsed().as_secs_f64());
    }
    let (k, m) = result.expect("assembled");
    println!(
        "107 811-DOF TET10 box: K, M with {} non-zeros each assembled in {best:.3} s ({} threads)",
        k.nnz(),
        rayon::current_num_threads()
    );
    // Total mass and one rigid mode as a sanity check of the big matrices (1e-12 relative:
    // sums of 1e5-1e6 terms).
    let rho_v = mat.density;
    let ones: Vec<f64> = (0..k.rows())
        .map(|i| if i % 3 == 0 { 1.0 } else { 0.0 })
        .collect();
    let mass = common::dot(&ones, &mul(&m, &ones));
    assert!((mass - rho_v).abs() < 1e-12 * rho_v, "{mass}");
    let kr = mul(&k, &ones);
    let kmax = max_abs(&k);
    assert!(kr.iter().all(|v| v.abs() < 1e-12 * kmax));
    // Generous bound (the machine is shared; the target is well under 1 s on 2 idle cores).
    assert!(best < 5.0, "assembly took {best} s");
}

#[test]
fn clamping_a_face_removes_the_rigid_modes() {
    // Clamp the face x = 0 of a TET10 bar (all components) and the face y = 0 in y only:
    // the restricted K must be positive definite (dense Cholesky succeeds, smallest eigenvalue
    // well above round-off) and M as well; DofMap::expand puts zeros on the fixed DOFs.
    use nlmodes_fem::{fixed_dofs, DofMap};
    let mesh = box_mesh([1.0, 0.3, 0.2], [3, 1, 1], TetKind::Tet10).expect("valid");
    let (k, m) = assemble(&mesh, &steel()).expect("valid");
    let fixed = fixed_dofs(&mesh, &["xmin", "ymin:y"]).expect("valid specs");
    let xmin = mesh.group("xmin").expect("face").nodes.len();
    let ymin = mesh.group("ymin").expect("face").nodes.len();
    let both = mesh
        .group("xmin")
        .expect("face")
        .nodes
        .iter()
        .filter(|v| mesh.group("ymin").expect("face").nodes.contains(v))
        .count();
    assert_eq!(fixed.len(), 3 * xmin + ymin - both);
    let map = DofMap::new(mesh.n_nodes(), &fixed).expect("valid");
    assert_eq!(map.n_free(), 3 * mesh.n_nodes() - fixed.len());
    let (kr, mr) = (map.restrict(&k), map.restrict(&m));
    assert_eq!(kr.shape(), (map.n_free(), map.n_free()));
    for (a, name) in [(&kr, "K"), (&mr, "M")] {
        let d = dense(a);
        let n = a.rows();
        let mat = Mat::<f64>::from_fn(n, n, |i, j| d[i][j]);
        assert!(
            mat.llt(Side::Lower).is_ok(),
            "restricted {name} is not positive definite"
        );
        let eig = mat
            .self_adjoint_eigenvalues(Side::Lower)
            .expect("eigenvalues");
        // No zero-energy mode survives the clamp: smallest eigenvalue far above the
        // round-off level 1e-13 lambda_max.
        assert!(
            eig[0] > 1e-8 * eig[n - 1],
            "restricted {name}: {:e} vs {:e}",
            eig[0],
            eig[n - 1]
        );
    }
    let full = map.expand(&vec![1.0; map.n_free()]);
    for &(node, c) in &fixed {
        assert_eq!(full[3 * node + c], 0.0);
    }
    assert_eq!(full.iter().filter(|&&v| v == 1.0).count(), map.n_free());
}
