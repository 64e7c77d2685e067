//! The parametric reduced model in the speed: exact for a stiffness affine in Omega^2 (the
//! linear prestress), its contact geometry, its range, the directory round trip and the
//! refusal of inconsistent files.

mod common;

use common::{far_face, spring_grid};
use faer::Mat;
use nlmodes_modal::reduced_model::linear_frequencies_hz;
use nlmodes_modal::sparse_ops::spmm_symmetric;
use nlmodes_modal::{
    craig_bampton, Accuracy, AccuracyCheck, ContactNode, EigenOptions, MasterCoordinate,
    ModalError, ParametricContact, ParametricModel, RecoveryStorage, ReducedModel, RotorAxis,
};
use sprs::CsMat;

/// Sample speeds, rad/s; the basis at 200.
const SPEEDS: [f64; 5] = [0.0, 100.0, 200.0, 300.0, 400.0];
const REFERENCE: f64 = 200.0;
/// Cold gap, m.
const GAP: f64 = 1e-4;
/// Contact nodes at rest (m) and their static displacement per unit Omega^2 (m s^2).
const POSITIONS: [[f64; 3]; 2] = [[0.30, 0.02, 0.10], [0.29, -0.05, 0.12]];
const U1: [[f64; 3]; 2] = [[1.5e-10, 1e-11, -2e-11], [1.2e-10, -3e-11, 1e-11]];

/// K(x) = K0 + x K2 (x = Omega^2) of a spring grid: K2 = 3e-6 (K0 + D), D a positive
/// diagonal, so that K grows by about half between rest and 400 rad/s.
struct Structure {
    k0: CsMat<f64>,
    k2: CsMat<f64>,
    m: CsMat<f64>,
}

impl Structure {
    fn new() -> Self {
        let (k0, m) = spring_grid(12, 3, 3, 4);
        let n = k0.rows();
        let mut d = sprs::TriMat::new((n, n));
        for i in 0..n {
            d.add_triplet(i, i, 0.5 + 0.01 * (i % 7) as f64);
        }
        let d: CsMat<f64> = d.to_csc();
        let k2 = (&k0 + &d).map(|v| 3e-6 * v);
        Self { k0, k2, m }
    }

    fn k(&self, omega: f64) -> CsMat<f64> {
        &self.k0 + &self.k2.map(|v| omega * omega * v)
    }
}

fn project(k: &CsMat<f64>, t: &Mat<f64>) -> Mat<f64> {
    let mut kt = Mat::<f64>::zeros(t.nrows(), t.ncols());
    spmm_symmetric(k, t.as_ref(), kt.as_mut());
    let k_r = t.transpose() * &kt;
    (&k_r + k_r.transpose()) * faer::Scale(0.5)
}

fn axis() -> RotorAxis {
    RotorAxis::new([0.0, 0.0, 0.0], [0.0, 0.0, 1.0]).unwrap()
}

/// The displacement of contact node j at `omega`, m.
fn displacement(j: usize, omega: f64) -> [f64; 3] {
    U1[j].map(|u| omega * omega * u)
}

/// Running gap of contact node j at `omega` computed here (axis z through the origin).
fn running_gap(j: usize, omega: f64) -> f64 {
    let (x, u) = (POSITIONS[j], displacement(j, omega));
    let r = |p: [f64; 3]| p[0].hypot(p[1]);
    GAP - (r([x[0] + u[0], x[1] + u[1], x[2]]) - r(x))
}

/// The reduced model at the reference speed (Craig-Bampton of K(200 rad/s), 6 boundary DOFs
/// read as two contact nodes) and the parametric model on its basis.
fn parametric(structure: &Structure) -> ParametricModel {
    let boundary: Vec<usize> = far_face(12, 3, 3)[..6].to_vec();
    let cb = craig_bampton(
        &structure.k(REFERENCE),
        &structure.m,
        &boundary,
        8,
        &EigenOptions::default(),
    )
    .unwrap();
    let axis = axis();
    let contact_nodes = (0..2)
        .map(|j| {
            let u = displacement(j, REFERENCE);
            let position = std::array::from_fn(|d| POSITIONS[j][d] + u[d]);
            ContactNode {
                mesh_node: Some(j as u64 + 10),
                dofs: [3 * j, 3 * j + 1, 3 * j + 2],
                position,
                radial: axis.radial_unit_vector(position).unwrap(),
                gap: running_gap(j, REFERENCE),
            }
        })
        .collect();
    let t = cb.recovery_basis();
    let k_ref = project(&structure.k(REFERENCE), &t);
    let reference = ReducedModel {
        linear_frequencies_hz: linear_frequencies_hz(&k_ref, &cb.m_r, 5).unwrap(),
        k: k_ref,
        m: cb.m_r.clone(),
        contact_nodes,
        rotor_axis: axis,
        master: MasterCoordinate {
            dof: 0,
            description: "x displacement of contact node 0".to_string(),
        },
        recovery: Some(t.clone()),
        mesh: None,
    };
    let stiffness = SPEEDS
        .iter()
        .map(|&w| project(&structure.k(w), &t))
        .collect();
    let contact = (0..2)
        .map(|j| ParametricContact {
            mesh_node: Some(j as u64 + 10),
            undeformed_position: POSITIONS[j],
            cold_gap: GAP,
            displacement_m: SPEEDS.iter().map(|&w| displacement(j, w)).collect(),
        })
        .collect();
    ParametricModel::new(
        reference,
        REFERENCE,
        SPEEDS.to_vec(),
        stiffness,
        contact,
        "linear",
    )
    .unwrap()
}

fn max_abs(a: &Mat<f64>) -> f64 {
    (0..a.ncols())
        .flat_map(|j| (0..a.nrows()).map(move |i| (i, j)))
        .map(|(i, j)| a[(i, j)].abs())
        .fold(0.0, f64::max)
}

/// Between the samples (and beyond the basis speed) the model equals T^T K(Omega) T of the
/// affine K to 1e-12 of max |K_r| (the spline reproduces what is linear in Omega^2: round-off
/// of weights of order 1), its frequencies to 1e-10, its running gaps the ones computed here
/// to 1e-12 m (the interpolated displacements are exact; the radius loses ~1e-16 of 0.3 m),
/// its contact rows are the radial unit vectors at the deformed positions.
#[test]
fn affine_stiffness_gives_an_exact_model() {
    let structure = Structure::new();
    let model = parametric(&structure);
    let t = model.reference().recovery.clone().unwrap();
    for omega in [0.0, 37.0, 150.0, 200.0, 333.3, 399.9, 400.0] {
        let exact = project(&structure.k(omega), &t);
        let k = model.stiffness_at(omega).unwrap();
        let err = max_abs(&(&k - &exact)) / max_abs(&exact);
        assert!(err < 1e-12, "Omega {omega}: K_r off by {err:e}");
        let at = model.at(omega).unwrap();
        let f = linear_frequencies_hz(&exact, model.mass(), 5).unwrap();
        for (a, b) in at.linear_frequencies_hz.iter().zip(&f) {
            assert!((a - b).abs() < 1e-10 * b, "Omega {omega}: {a} vs {b} Hz");
        }
        let rows = at.contact_rows();
        for (j, node) in at.contact_nodes.iter().enumerate() {
            let gap = running_gap(j, omega);
            assert!(
                (node.gap - gap).abs() < 1e-12,
                "node {j}: {} vs {gap}",
                node.gap
            );
            let u = displacement(j, omega);
            let x = [POSITIONS[j][0] + u[0], POSITIONS[j][1] + u[1]];
            let r = x[0].hypot(x[1]);
            for (d, want) in [x[0] / r, x[1] / r, 0.0].iter().enumerate() {
                assert!((rows[(j, 3 * j + d)] - want).abs() < 1e-15);
            }
        }
        assert_eq!(at.m.nrows(), model.mass().nrows());
        assert!(at.recovery.is_none());
    }
    // The gap shrinks with the speed: the blade grows outward.
    let g = |w: f64| model.at(w).unwrap().gaps()[0];
    assert!(g(400.0) < g(200.0) && g(200.0) < g(0.0) && g(0.0) == GAP);
}

/// Outside [0, 400] rad/s the model refuses, naming the speed and the range.
#[test]
fn speeds_outside_the_range_are_refused() {
    let model = parametric(&Structure::new());
    assert_eq!(model.range(), (0.0, 400.0));
    for omega in [-1.0, 400.0001, f64::NAN] {
        let err = model.at(omega).unwrap_err();
        assert!(matches!(err, ModalError::InvalidArgument(_)), "{err}");
        assert!(
            err.to_string()
                .contains("outside the parametric model's range"),
            "{err}"
        );
    }
}

/// Written and read back: the samples bit for bit, the contact nodes, the speeds and the
/// recorded accuracy.
#[test]
fn directory_round_trip() {
    let mut model = parametric(&Structure::new());
    let accuracy = Accuracy {
        modes: 4,
        checks: vec![AccuracyCheck {
            speed_rad_s: 150.0,
            between_samples: true,
            interpolation_frequency_error: 1.5e-7,
            full_model_frequency_error: Some(2e-7),
            gap_error_m: 3e-12,
            gap_relative_error: 4e-8,
        }],
    };
    model.set_accuracy(accuracy.clone());
    let dir = tempfile::tempdir().unwrap();
    model.write(dir.path(), &RecoveryStorage::Float64).unwrap();
    let back = ParametricModel::read(dir.path()).unwrap();
    assert_eq!(back.speeds(), model.speeds());
    assert_eq!(back.reference_speed(), REFERENCE);
    assert_eq!(back.contact(), model.contact());
    assert_eq!(back.accuracy(), Some(&accuracy));
    assert_eq!(back.kinematics(), "linear");
    for i in 0..SPEEDS.len() {
        let (a, b) = (back.stiffness_sample(i), model.stiffness_sample(i));
        for c in 0..a.ncols() {
            for r in 0..a.nrows() {
                assert_eq!(a[(r, c)].to_bits(), b[(r, c)].to_bits());
            }
        }
    }
    // The directory is also the reduced model at the reference speed.
    let reference = ReducedModel::read(dir.path()).unwrap();
    assert_eq!(reference.contact_nodes, model.reference().contact_nodes);
}

/// A reference speed that is not a sample, a missing stiffness file, a sample of the wrong
/// order and displacements that do not give the reference model's contact geometry are
/// refused, each naming parametric.json or the file.
#[test]
fn inconsistent_directories_are_refused() {
    let model = parametric(&Structure::new());
    let dir = tempfile::tempdir().unwrap();
    model.write(dir.path(), &RecoveryStorage::Float64).unwrap();
    let json_path = dir.path().join("parametric.json");
    let text = std::fs::read_to_string(&json_path).unwrap();
    let edit = |from: &str, to: &str| {
        assert!(text.contains(from), "{from}");
        std::fs::write(&json_path, text.replacen(from, to, 1)).unwrap();
        ParametricModel::read(dir.path()).unwrap_err().to_string()
    };
    let err = edit(
        "\"reference_speed_rad_s\": 200.0",
        "\"reference_speed_rad_s\": 250.0",
    );
    assert!(
        err.contains("parametric.json") && err.contains("not a sample speed"),
        "{err}"
    );
    let err = edit("\"cold_gap\": 0.0001", "\"cold_gap\": 0.0002");
    assert!(
        err.contains("contact node 0 at the reference speed"),
        "{err}"
    );
    let err = edit("\"K_speed_01.mtx\"", "\"K_speed_99.mtx\"");
    assert!(err.contains("K_speed_99.mtx"), "{err}");
    let err = edit("\"K_speed_01.mtx\"", "\"../K_speed_01.mtx\"");
    assert!(err.contains("plain file name"), "{err}");
    std::fs::write(&json_path, &text).unwrap();
    let small = Mat::<f64>::identity(3, 3);
    nlmodes_modal::matrix_market::write_symmetric_dense(
        &dir.path().join("K_speed_02.mtx"),
        small.as_ref(),
        "wrong order",
    )
    .unwrap();
    let err = ParametricModel::read(dir.path()).unwrap_err().to_string();
    assert!(err.contains("K_r at speed 2 is 3 x 3"), "{err}");
}
