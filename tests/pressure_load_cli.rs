//! `[forced] load = "pressure"` through `nlmodes run` (issue 22, item 3): a uniform pressure on
//! a surface group, integrated to consistent nodal loads f_i = -p ∫ N_i n dA
//! (`nlmodes_fem::surface_load`), carried exactly in the static limit by the reduced model (the
//! reduce stage adds its static correction to the Craig-Bampton basis and writes T^T f as
//! F.mtx, the path of `load = "group"`).
//!
//! On the coarse TET10 blade, pressure on the flat tip face z = hub_radius + span:
//! * the total of f is -p A e_z, with the face's area A computed here independently of the
//!   library, by Green's theorem on the curved (quadratic) edges of the tip's TRI6 (Simpson's rule
//!   is exact for x y' - y x' on a quadratic edge);
//! * F.mtx is T^T f (the stored basis, 24-bit fixed point, bounds this to about 1e-7);
//! * the reduced static response K_r q = F.mtx equals the full model's K^-1 f at the contact nodes
//!   to 1e-8 and over the whole blade to 1e-6 with the correction (bounded by the stored basis),
//!   and is far from it without the correction's coordinate (the check can fail);
//! * a group that is not a surface (the volume "blade", the points "tip_edge") or that the mesh
//!   does not have is bad input naming the key, the value and the mesh's groups.
//!
//! Cost: mesh + reduction about 3 s, the full model's sparse Cholesky about 1 s.

use std::path::{Path, PathBuf};

mod common;

use common::{nlmodes, nlmodes_ok as ok};

/// A coarse TET10 blade case with the pressure load on `group`.
fn write_case(dir: &Path, group: &str) -> PathBuf {
    let geo = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("meshes/blade.geo");
    let text = format!(
        "name = \"prs\"\nresults_dir = \"{}\"\n[mesh]\ngeo = \"{}\"\n[mesh.parameters]\n\
         mesh_size = 0.012\n[model]\nfixed_interface_modes = 20\nlinear_modes = 6\n\
         full_check = \"off\"\n[forced]\nload = \"pressure\"\nload_group = \"{group}\"\n\
         level_unit = \"N\"\nlevels = [2.0e5]\n",
        dir.join("results").display(),
        geo.display()
    );
    let path = dir.join("prs.toml");
    std::fs::write(&path, text).unwrap();
    path
}

/// Area of a flat surface of TRI6 (plane z = const) from its curved edges: per triangle
/// |1/2 ∮ (x dy - y dx)|, each quadratic edge r(t) = sum of the Lagrange basis on (0, 1/2, 1)
/// integrated by Simpson's rule (x y' - y x' is cubic in t: exact).
fn tri6_area(nodes: &[[f64; 3]], triangles: &[usize]) -> f64 {
    let mut area = 0.0;
    for t in triangles.chunks_exact(6) {
        let mut twice = 0.0;
        for (a, b, m) in [(0, 1, 3), (1, 2, 4), (2, 0, 5)] {
            let (p, q, r) = (nodes[t[a]], nodes[t[b]], nodes[t[m]]);
            let at = |s: f64| {
                let w = [
                    (1.0 - s) * (1.0 - 2.0 * s),
                    s * (2.0 * s - 1.0),
                    4.0 * s * (1.0 - s),
                ];
                let dw = [4.0 * s - 3.0, 4.0 * s - 1.0, 4.0 - 8.0 * s];
                let x = w[0] * p[0] + w[1] * q[0] + w[2] * r[0];
                let y = w[0] * p[1] + w[1] * q[1] + w[2] * r[1];
                let dx = dw[0] * p[0] + dw[1] * q[0] + dw[2] * r[0];
                let dy = dw[0] * p[1] + dw[1] * q[1] + dw[2] * r[1];
                x * dy - y * dx
            };
            twice += (at(0.0) + 4.0 * at(0.5) + at(1.0)) / 6.0;
        }
        area += 0.5 * twice.abs();
    }
    area
}

#[test]
fn a_pressure_load_is_exact_in_the_static_limit() {
    let dir = tempfile::tempdir().unwrap();
    let path = write_case(dir.path(), "tip");
    ok(&["run", path.to_str().unwrap(), "--only", "reduce"]);
    let res = dir.path().join("results/prs");
    let model = nlmodes_modal::ReducedModel::read(&res.join("model")).unwrap();
    let fr =
        nlmodes_modal::matrix_market_general::read_dense_general(&res.join("model/F.mtx")).unwrap();
    let nr = model.k.nrows();
    assert_eq!((fr.nrows(), fr.ncols()), (nr, 1));
    assert_eq!(
        nr,
        3 * model.contact_nodes.len() + 20 + 1,
        "one correction coordinate"
    );

    // The load on the full model, and its total against -p A e_z (p = 1 Pa, the unit of F.mtx).
    let mesh = std::sync::Arc::new(nlmodes_fem::read_msh(&res.join("mesh/mesh.msh")).unwrap());
    assert_eq!(mesh.kind, nlmodes_fem::TetKind::Tet10);
    let tip = mesh.group("tip").unwrap();
    let z_tip = common::BLADE_HUB_RADIUS + common::BLADE_SPAN;
    assert!(tip
        .nodes
        .iter()
        .all(|&n| (mesh.nodes[n][2] - z_tip).abs() < 1e-12));
    let f_all = nlmodes_fem::surface_load::pressure_load(&mesh, "tip", 1.0).unwrap();
    let total: Vec<f64> = (0..3)
        .map(|d| f_all.iter().skip(d).step_by(3).sum())
        .collect();
    let area = tri6_area(&mesh.nodes, &tip.triangles);
    let total_error = (total[0].hypot(total[1]).powi(2) + (total[2] + area).powi(2)).sqrt() / area;
    println!(
        "tip face: A = {area:.9e} m^2 (Green, Simpson), total force of 1 Pa = {total:?} N, \
         relative error {total_error:.1e}"
    );
    assert!(total_error < 1e-12, "{total_error:e}");

    let fe = common::fe_system(mesh.clone(), &common::titanium(), &["root"]);
    let mut f = vec![0.0; fe.k.rows()];
    for (dof, v) in f_all.iter().enumerate() {
        if let Some(i) = fe.dofs.free_index(dof) {
            f[i] = *v;
        }
    }
    // F.mtx against T^T f with the stored basis.
    let recovery = model.recovery.as_ref().unwrap();
    let ttf: Vec<f64> = (0..nr)
        .map(|j| (0..recovery.nrows()).map(|i| recovery[(i, j)] * f[i]).sum())
        .collect();
    let scale = ttf.iter().fold(0.0_f64, |m, v| m.max(v.abs()));
    let f_error = (0..nr)
        .map(|j| (fr[(j, 0)] - ttf[j]).abs())
        .fold(0.0, f64::max)
        / scale;
    println!("F.mtx vs T^T f with the stored basis: {f_error:.1e} of the largest entry");
    assert!(f_error < 1e-6, "{f_error:e}");

    // Full static response K^-1 f against the reduced one.
    let ([c_with, e_with], [c_without, e_without]) =
        common::reduced_static_errors(&model, &fr, &fe, &f);
    println!(
        "static displacement under the tip pressure: contact nodes {c_with:.1e} with the \
         correction, {c_without:.1e} without; whole blade {e_with:.1e} with, {e_without:.1e} without"
    );
    assert!(
        c_with < 1e-8 && c_without < 1e-8,
        "{c_with:e} {c_without:e}"
    );
    assert!(e_with < 1e-6, "{e_with:e}");
    assert!(e_without > 1e-4, "{e_without:e}");
}

#[test]
fn a_pressure_group_must_be_a_surface_of_the_mesh() {
    let dir = tempfile::tempdir().unwrap();
    for (group, expect) in [
        ("blade", "physical group 'blade' (dim 3) is not a surface"),
        (
            "tip_edge",
            "physical group 'tip_edge' (dim 0) is not a surface",
        ),
        ("pressure_side", "no physical group named 'pressure_side'"),
    ] {
        let path = write_case(dir.path(), group);
        let out = nlmodes(&["run", path.to_str().unwrap(), "--only", "reduce"]);
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{group}: {err}");
        let key = format!("forced.load_group = \"{group}\" (forced.load = \"pressure\")");
        assert!(
            err.contains(&key) && err.contains(expect) && err.contains("'tip' (dim 2)"),
            "{group}: {err}"
        );
    }
}
