//! Reduced-model directory: round trip and validation errors.

mod common;

use std::path::Path;

use common::{far_face, spring_grid, Lcg};
use nlmodes_modal::matrix_market::write_symmetric_dense;
use nlmodes_modal::reduced_model::linear_frequencies_hz;
use nlmodes_modal::{
    craig_bampton, ContactNode, EigenOptions, MasterCoordinate, MeshReference, ModalError,
    ReducedModel, RotorAxis,
};

/// A Craig-Bampton model of a 12 x 3 x 3 spring grid whose 6 boundary DOFs
/// are read as the x, y, z DOFs of two synthetic "contact nodes".
fn model() -> ReducedModel {
    let (k, m) = spring_grid(12, 3, 3, 4);
    let face = far_face(12, 3, 3);
    let boundary: Vec<usize> = face[..6].to_vec();
    let cb = craig_bampton(&k, &m, &boundary, 10, &EigenOptions::default()).unwrap();
    let axis = RotorAxis::new([0.0, 0.0, 0.0], [0.0, 0.0, 1.0]).unwrap();
    let positions = [[0.30, 0.02, 0.10], [0.29, -0.05, 0.12]];
    let contact_nodes = positions
        .iter()
        .enumerate()
        .map(|(j, &p)| ContactNode {
            mesh_node: if j == 0 { Some(812) } else { None },
            dofs: [3 * j, 3 * j + 1, 3 * j + 2],
            position: p,
            radial: axis.radial_unit_vector(p).unwrap(),
            gap: 1e-4,
        })
        .collect();
    let freqs = linear_frequencies_hz(&cb.k_r, &cb.m_r, 5).unwrap();
    let n_free = k.rows();
    ReducedModel {
        k: cb.k_r.clone(),
        m: cb.m_r.clone(),
        contact_nodes,
        rotor_axis: axis,
        master: MasterCoordinate {
            dof: 0,
            description: "x displacement of contact node 0".to_string(),
        },
        linear_frequencies_hz: freqs,
        recovery: Some(cb.recovery_basis()),
        mesh: Some(MeshReference {
            msh_file: "blade.msh".to_string(),
            n_full_dofs: n_free + 3,
            fixed_dofs: vec![0, 5, 7],
        }),
    }
}

fn assert_bitwise(a: &faer::Mat<f64>, b: &faer::Mat<f64>) {
    assert_eq!((a.nrows(), a.ncols()), (b.nrows(), b.ncols()));
    for j in 0..a.ncols() {
        for i in 0..a.nrows() {
            assert_eq!(a[(i, j)].to_bits(), b[(i, j)].to_bits(), "({i}, {j})");
        }
    }
}

#[test]
fn write_then_read_is_identical() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("reduced");
    let original = model();
    original.write(&path).unwrap();
    for name in ["K.mtx", "M.mtx", "model.json", "recovery.f64"] {
        assert!(path.join(name).exists(), "{name} missing");
        assert!(
            !path.join(format!("{name}.tmp")).exists(),
            "{name}.tmp left behind"
        );
    }
    let back = ReducedModel::read(&path).unwrap();
    assert_bitwise(&original.k, &back.k);
    assert_bitwise(&original.m, &back.m);
    assert_bitwise(
        original.recovery.as_ref().unwrap(),
        back.recovery.as_ref().unwrap(),
    );
    assert_eq!(original.contact_nodes, back.contact_nodes);
    assert_eq!(original.rotor_axis, back.rotor_axis);
    assert_eq!(original.master, back.master);
    assert_eq!(original.linear_frequencies_hz, back.linear_frequencies_hz);
    assert_eq!(original.mesh, back.mesh);
}

/// A q equals, node by node, the radial vector dotted with the node's
/// displacement (computed here directly; exact up to summation order, 1e-15).
#[test]
fn contact_rows_give_radial_displacements() {
    let model = model();
    let a = model.contact_rows();
    assert_eq!((a.nrows(), a.ncols()), (2, model.n()));
    let q = Lcg::new(3).vector(model.n());
    for (j, node) in model.contact_nodes.iter().enumerate() {
        let direct: f64 = (0..3).map(|c| node.radial[c] * q[node.dofs[c]]).sum();
        let row: f64 = (0..model.n()).map(|i| a[(j, i)] * q[i]).sum();
        assert!((direct - row).abs() < 1e-15);
    }
    assert_eq!(model.gaps(), vec![1e-4, 1e-4]);
}

/// The free-to-full map skips the fixed DOFs.
#[test]
fn mesh_reference_expands_free_dofs() {
    let mesh = MeshReference {
        msh_file: "m.msh".into(),
        n_full_dofs: 6,
        fixed_dofs: vec![0, 4],
    };
    assert_eq!(mesh.free_to_full(), vec![1, 2, 3, 5]);
    assert_eq!(
        mesh.expand_to_full(&[1.0, 2.0, 3.0, 4.0]).unwrap(),
        vec![0.0, 1.0, 2.0, 3.0, 0.0, 4.0]
    );
    assert!(mesh.expand_to_full(&[1.0]).is_err());
}

fn write_err(mutate: impl FnOnce(&mut ReducedModel)) -> String {
    let dir = tempfile::tempdir().unwrap();
    let mut m = model();
    mutate(&mut m);
    let err = m.write(dir.path()).unwrap_err().to_string();
    assert!(
        !dir.path().join("model.json").exists(),
        "an invalid model was written"
    );
    err
}

#[test]
fn invalid_models_are_not_written() {
    let e = write_err(|m| m.contact_nodes.clear());
    assert!(e.contains("contact node list is empty"), "{e}");
    let e = write_err(|m| m.contact_nodes[1].gap = 0.0);
    assert!(
        e.contains("contact node 1") && e.contains("gap 0 m must be finite and > 0"),
        "{e}"
    );
    let e = write_err(|m| m.contact_nodes[0].gap = -1e-3);
    assert!(e.contains("mesh node 812") && e.contains("gap"), "{e}");
    let e = write_err(|m| m.contact_nodes[0].dofs[2] = 99);
    assert!(e.contains("DOF index 99 is out of range"), "{e}");
    let e = write_err(|m| m.contact_nodes[1].dofs[0] = 0);
    assert!(e.contains("already used by contact node 0"), "{e}");
    let e = write_err(|m| m.contact_nodes[0].radial = [1.0, 1.0, 0.0]);
    assert!(e.contains("unit vector"), "{e}");
    let e = write_err(|m| m.master.dof = 16);
    assert!(e.contains("master coordinate 16 is out of range"), "{e}");
    let e = write_err(|m| m.m = faer::Mat::zeros(3, 3));
    assert!(e.contains("same order"), "{e}");
    let e = write_err(|m| m.mesh.as_mut().unwrap().fixed_dofs = vec![5, 0]);
    assert!(e.contains("strictly increasing"), "{e}");
    let e = write_err(|m| m.mesh.as_mut().unwrap().n_full_dofs += 1);
    assert!(e.contains("free DOFs"), "{e}");
    let e = write_err(|m| m.linear_frequencies_hz = vec![2.0, 1.0]);
    assert!(e.contains("ascending"), "{e}");
}

/// Edits model.json as a JSON value and rewrites it.
fn edit_json(dir: &Path, edit: impl FnOnce(&mut serde_json::Value)) {
    let path = dir.join("model.json");
    let mut v: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&path).unwrap()).unwrap();
    edit(&mut v);
    std::fs::write(&path, serde_json::to_string_pretty(&v).unwrap()).unwrap();
}

fn read_err_after(edit: impl FnOnce(&Path)) -> ModalError {
    let dir = tempfile::tempdir().unwrap();
    model().write(dir.path()).unwrap();
    edit(dir.path());
    ReducedModel::read(dir.path()).unwrap_err()
}

#[test]
fn inconsistent_directories_are_rejected_on_read() {
    // K.mtx and M.mtx of different sizes: the error names both files and sizes.
    let err = read_err_after(|d| {
        let small = faer::Mat::<f64>::identity(4, 4);
        write_symmetric_dense(&d.join("M.mtx"), small.as_ref(), "").unwrap();
    })
    .to_string();
    assert!(
        err.contains("K.mtx is 16 x 16") && err.contains("M.mtx is 4 x 4"),
        "{err}"
    );

    let err = read_err_after(|d| {
        edit_json(d, |v| {
            v["contact_nodes"][0]["gap"] = serde_json::json!(-2e-4)
        });
    })
    .to_string();
    assert!(err.contains("gap") && err.contains("model.json"), "{err}");

    let err = read_err_after(|d| {
        edit_json(d, |v| {
            v["contact_nodes"][1]["dofs"] = serde_json::json!([3, 4, 40])
        });
    })
    .to_string();
    assert!(err.contains("DOF index 40 is out of range"), "{err}");

    let err = read_err_after(|d| edit_json(d, |v| v["contact_nodes"] = serde_json::json!([])));
    assert!(err.to_string().contains("empty"), "{err}");

    let err = read_err_after(|d| edit_json(d, |v| v["n"] = serde_json::json!(15)));
    assert!(err.to_string().contains("n = 15"), "{err}");

    let err = read_err_after(|d| edit_json(d, |v| v["format_version"] = serde_json::json!(2)));
    assert!(err.to_string().contains("format_version 2"), "{err}");

    let err = read_err_after(|d| edit_json(d, |v| v["colour"] = serde_json::json!("red")));
    assert!(matches!(err, ModalError::Json { .. }), "{err}");
    assert!(err.to_string().contains("colour"), "{err}");

    let err = read_err_after(|d| {
        edit_json(d, |v| {
            v["recovery"]["file"] = serde_json::json!("../elsewhere.f64")
        });
    });
    assert!(err.to_string().contains("plain file name"), "{err}");

    // Truncated recovery file: the length check catches it.
    let err = read_err_after(|d| {
        let p = d.join("recovery.f64");
        let bytes = std::fs::read(&p).unwrap();
        std::fs::write(&p, &bytes[..bytes.len() - 8]).unwrap();
    });
    assert!(err.to_string().contains("bytes"), "{err}");

    // Asymmetric K.mtx written as a general file.
    let err = read_err_after(|d| {
        std::fs::write(
            d.join("K.mtx"),
            "%%MatrixMarket matrix coordinate real general\n2 2 3\n1 1 1\n2 1 1\n2 2 1\n",
        )
        .unwrap();
    });
    assert!(err.to_string().contains("not symmetric"), "{err}");

    // Missing files.
    let err = read_err_after(|d| std::fs::remove_file(d.join("M.mtx")).unwrap());
    assert!(
        matches!(err, ModalError::Io { .. }) && err.to_string().contains("M.mtx"),
        "{err}"
    );
}

/// The physical checks of `model_checks` (issue 14): each damaged model is refused with a
/// message naming the file and the entry; a clamped model passes with no rigid mode.
#[test]
fn physically_invalid_models_are_refused() {
    let good = model();
    let dir = tempfile::tempdir().unwrap();
    let points: Vec<nlmodes_modal::model_checks::ContactPoint> = good
        .contact_nodes
        .iter()
        .map(|c| nlmodes_modal::model_checks::ContactPoint {
            label: "contact node".to_string(),
            position: c.position,
            gap: c.gap,
        })
        .collect();
    let rigid = nlmodes_modal::model_checks::check_physics(
        &good.k,
        &good.m,
        &points,
        &good.rotor_axis,
        [dir.path(), dir.path(), dir.path()],
    )
    .unwrap();
    assert!(rigid.is_empty(), "{rigid:?}");
    // A singular M whose diagonal stays positive: rows/columns 2 and 3 made proportional to
    // each other (the 2 x 2 minor on them is exactly singular).
    let e = write_err(|m| {
        let (a, b) = (m.m[(2, 2)], m.m[(3, 3)]);
        let s = (b / a).sqrt();
        for i in 0..m.n() {
            let v = m.m[(i, 2)] * s;
            m.m[(i, 3)] = v;
            m.m[(3, i)] = v;
        }
        m.m[(3, 3)] = a * s * s;
    });
    assert!(
        e.contains("M.mtx") && e.contains("positive definite"),
        "{e}"
    );
    assert!(e.contains("M is"), "{e}");
    let e = write_err(|m| m.k = m.k.clone() * faer::Scale(1e150));
    assert!(
        e.contains("K.mtx") && e.contains("largest entry of K"),
        "{e}"
    );
    let e = write_err(|m| m.m = m.m.clone() * faer::Scale(1e-250));
    assert!(
        e.contains("M.mtx") && e.contains("largest entry of M"),
        "{e}"
    );
    let e = write_err(|m| m.contact_nodes[1].gap = 1e-300);
    assert!(e.contains("contact node 1") && e.contains("1e-300"), "{e}");
    let e = write_err(|m| {
        m.contact_nodes[1].position = m.contact_nodes[0].position;
        m.contact_nodes[1].radial = m.contact_nodes[0].radial;
    });
    assert!(e.contains("same position"), "{e}");
    // K made indefinite: its first diagonal entry negated.
    let e = write_err(|m| {
        m.k[(0, 0)] = -m.k[(0, 0)];
    });
    assert!(
        e.contains("K.mtx") && e.contains("not positive semi-definite"),
        "{e}"
    );
}
