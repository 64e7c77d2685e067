//! Craig-Bampton reduction of the coarse blade (meshes/blade.geo, mesh_size 0.01 m, TET10,
//! titanium E = 113.8 GPa, nu = 0.342, rho = 4430 kg/m^3) clamped on `root`, onto the three
//! DOFs of each of the 24 `tip_edge` contact nodes (72 boundary DOFs), checked against the
//! full clamped model (ARPACK).

mod common;

use std::sync::{Arc, OnceLock};

use common::{blade_mesh, fe_system, hz, mac_mass, max_abs, norm, timed, titanium, FeSystem, Memo};
use faer::Mat;
use nlmodes_modal::{
    craig_bampton, eigs_shift_invert, reduced_eigen, ContactNode, CraigBampton, EigenMethod,
    EigenOptions, MasterCoordinate, MeshReference, ModalError, Modes, ReducedModel, RotorAxis,
    SparseCholesky,
};

/// Number of full-model modes compared.
const N_CHECK: usize = 10;

/// The clamped coarse blade, its boundary and its full-model modes.
struct Blade {
    sys: FeSystem,
    /// `tip_edge` mesh nodes, in the group's (sorted) order.
    edge_nodes: Vec<usize>,
    /// Free-DOF indices of the 3 components of each edge node (node-major, x y z).
    boundary: Vec<usize>,
    /// The N_CHECK lowest modes of the full clamped model (ARPACK, shift 0).
    full: Modes,
}

fn arpack() -> EigenOptions<'static> {
    EigenOptions {
        method: EigenMethod::Arpack,
        ..EigenOptions::default()
    }
}

fn blade() -> &'static Blade {
    static BLADE: OnceLock<Blade> = OnceLock::new();
    BLADE.get_or_init(|| {
        let mesh = blade_mesh(2, 0.01);
        let sys = timed("blade assembly", || {
            fe_system(mesh.clone(), &titanium(), &["root"])
        });
        let edge_nodes = mesh.group("tip_edge").expect("tip_edge").nodes.clone();
        assert_eq!(edge_nodes.len(), 24);
        let boundary: Vec<usize> = edge_nodes
            .iter()
            .flat_map(|&n| (0..3).map(move |c| 3 * n + c))
            .map(|g| {
                sys.dofs
                    .free_index(g)
                    .expect("tip_edge nodes are not on the clamped root")
            })
            .collect();
        let full = timed(&format!("full model, {N_CHECK} modes"), || {
            eigs_shift_invert(&sys.k, &sys.m, N_CHECK, 0.0, &arpack()).expect("full modes")
        });
        eprintln!(
            "blade: {} nodes, {} free DOFs, {} boundary DOFs; full frequencies (Hz) {:.3?}",
            mesh.n_nodes(),
            sys.k.rows(),
            boundary.len(),
            full.frequencies_hz()
        );
        Blade {
            sys,
            edge_nodes,
            boundary,
            full,
        }
    })
}

/// A reduction and its dense reduced eigenpairs.
struct Reduction {
    cb: CraigBampton,
    values: Vec<f64>,
    vectors: Mat<f64>,
}

static REDUCTIONS: Memo<Reduction> = Memo::new();

/// Craig-Bampton with `n_modes` fixed-interface modes (computed once per test binary).
fn reduction(n_modes: usize) -> Arc<Reduction> {
    REDUCTIONS.get(n_modes.to_string(), || {
        let b = blade();
        let cb = timed(&format!("Craig-Bampton, {n_modes} modes"), || {
            craig_bampton(&b.sys.k, &b.sys.m, &b.boundary, n_modes, &arpack())
                .expect("Craig-Bampton reduction")
        });
        let (values, vectors) = reduced_eigen(&cb).expect("reduced eigenpairs");
        Reduction {
            cb,
            values,
            vectors,
        }
    })
}

/// Relative residual ||K x - lambda M x|| / (|lambda| ||M x||) of a dense eigenpair.
fn reduced_residual(k: &Mat<f64>, m: &Mat<f64>, lambda: f64, x: &[f64]) -> f64 {
    let n = x.len();
    let (mut r2, mut mx2) = (0.0, 0.0);
    for i in 0..n {
        let (mut kx, mut mx) = (0.0, 0.0);
        for j in 0..n {
            kx += k[(i, j)] * x[j];
            mx += m[(i, j)] * x[j];
        }
        r2 += (kx - lambda * mx).powi(2);
        mx2 += mx * mx;
    }
    (r2 / mx2).sqrt() / lambda.abs()
}

/// Reduced vs full frequencies for 10, 20, 40 and 60 fixed-interface modes (reduced orders
/// 82, 92, 112, 132: the last one is above 128, where faer's dense symmetric eigensolver
/// switches from QR to divide and conquer, so both paths of `reduced_eigen` are exercised).
///
/// * The reduced eigenpairs solve K_r x = lambda M_r x: relative residual
///   ||K_r x - lambda M_r x|| / (lambda ||M_r x||) < 1e-6. A backward-stable dense solver
///   gives about eps lambda_max(reduced) / lambda_i, printed (1.5e-8 for mode 1, the worst).
/// * Rayleigh-Ritz: the reduced model is the projection of (K, M) on span(T), so each reduced
///   eigenvalue is >= the full one of the same rank. Allowed violation: 1e-9 relative, the
///   round-off of the two eigensolvers (ARPACK ~1e-14; the dense eigenvalue error is about
///   lambda times the squared residual plus eps lambda_max, below 1e-9 here).
/// * The bases are nested (same constraint modes, more fixed-interface modes), so each
///   eigenvalue error is non-increasing as modes are added, to the same 1e-9.
/// * With 40 modes, the first 10 frequencies are within 0.1 % of the full ones (the brief's
///   engineering requirement for the contact model).
#[test]
fn reduced_frequencies_converge_from_above() {
    let b = blade();
    let full = &b.full.eigenvalues;
    let mut previous: Option<Vec<f64>> = None;
    for n_modes in [10, 20, 40, 60] {
        let r = reduction(n_modes);
        let lambda_max = r.values[r.values.len() - 1];
        let errors: Vec<f64> = (0..N_CHECK).map(|i| r.values[i] / full[i] - 1.0).collect();
        let residuals: Vec<f64> = (0..N_CHECK)
            .map(|i| reduced_residual(&r.cb.k_r, &r.cb.m_r, r.values[i], r.vectors.col_as_slice(i)))
            .collect();
        let shown: Vec<String> = residuals.iter().map(|v| format!("{v:.1e}")).collect();
        eprintln!(
            "{n_modes} modes: reduced eigenpair residuals {}",
            shown.join(" ")
        );
        for (i, &res) in residuals.iter().enumerate() {
            assert!(
                res < 1e-6,
                "{n_modes} modes, reduced mode {}: residual {res:e}",
                i + 1
            );
        }
        let freq_errors: Vec<String> = (0..N_CHECK)
            .map(|i| format!("{:.2e}", hz(r.values[i]) / hz(full[i]) - 1.0))
            .collect();
        eprintln!(
            "{n_modes} modes (reduced order {}): eps lambda_max / lambda_1 = {:.1e}; \
             frequency errors {}",
            r.cb.n_reduced(),
            f64::EPSILON * lambda_max / r.values[0],
            freq_errors.join(" ")
        );
        for (i, &e) in errors.iter().enumerate() {
            assert!(
                e > -1e-9,
                "{n_modes} modes, mode {}: reduced {} below full {} (relative {e:e})",
                i + 1,
                r.values[i],
                full[i]
            );
            if let Some(prev) = &previous {
                assert!(
                    e <= prev[i] + 1e-9,
                    "{n_modes} modes, mode {}: error grew from {:e} to {e:e}",
                    i + 1,
                    prev[i]
                );
            }
            if n_modes == 40 {
                let fe = hz(r.values[i]) / hz(full[i]) - 1.0;
                assert!(fe < 1e-3, "mode {}: frequency error {fe:e}", i + 1);
            }
        }
        previous = Some(errors);
    }
}

/// Full-mesh shapes recovered from the reduced eigenvectors (u = T q) against the full
/// modes: mass-weighted MAC (a^T M b)^2 / (a^T M a b^T M b) > 0.999 for the first 10 (the
/// brief's). Mass weighting makes the measure independent of the node density (the mesh is
/// much finer near the tip edge).
#[test]
fn recovered_modes_match_full_modes() {
    let b = blade();
    let r = reduction(40);
    for i in 0..N_CHECK {
        let q = r.vectors.col_as_slice(i);
        let u = r.cb.recover(q).expect("recover");
        let mac = mac_mass(&b.sys.m, &u, b.full.vectors.col_as_slice(i));
        eprintln!("mode {:2}: {:9.3} Hz, MAC {mac:.9}", i + 1, hz(r.values[i]));
        assert!(mac > 0.999, "mode {}: MAC {mac}", i + 1);
    }
}

/// A static load on the boundary DOFs only: the constraint modes span the exact static
/// response (u_i = Psi u_b solves the interior equations with no interior load), so
/// K_r u_r = f_r with f_r = T^T f = [f_b; 0], recovered, equals the full sparse solution.
/// Both are backward-stable Cholesky solves, so they differ by round-off amplified by the
/// conditioning of K (printed: 3e-12 to 4e-11 over runs); tolerance 1e-9 relative (the
/// brief's).
#[test]
fn static_boundary_load_is_reproduced_exactly() {
    let b = blade();
    let r = reduction(40);
    let n_b = b.boundary.len();
    // 1 N along +z on every edge node plus alternating +-1 N along y (a twisting load).
    let loads: Vec<f64> = (0..n_b)
        .map(|j| match j % 3 {
            0 => 0.0,
            1 => {
                if (j / 3) % 2 == 0 {
                    1.0
                } else {
                    -1.0
                }
            }
            _ => 1.0,
        })
        .collect();
    let mut f = vec![0.0; b.sys.k.rows()];
    for (&dof, &v) in b.boundary.iter().zip(&loads) {
        f[dof] = v;
    }
    let mut u_full = f.clone();
    timed("full static solve", || {
        SparseCholesky::new(&b.sys.k)
            .expect("K of the clamped blade is SPD")
            .solve_in_place(&mut u_full)
            .expect("solve")
    });
    let n_r = r.cb.n_reduced();
    let rhs = Mat::<f64>::from_fn(n_r, 1, |i, _| if i < n_b { loads[i] } else { 0.0 });
    let llt = r.cb.k_r.llt(faer::Side::Lower).expect("K_r is SPD");
    let q_mat = faer::prelude::Solve::solve(&llt, &rhs);
    let q: Vec<f64> = (0..n_r).map(|i| q_mat[(i, 0)]).collect();
    let u_red = r.cb.recover(&q).expect("recover");
    let diff: Vec<f64> = u_full.iter().zip(&u_red).map(|(a, c)| a - c).collect();
    let rel = norm(&diff) / norm(&u_full);
    eprintln!(
        "static boundary load: max |u| {:.3e} m, relative difference {rel:.2e}",
        max_abs(&u_full)
    );
    assert!(rel < 1e-9, "{rel:e}");
}

/// Structure of the reduced matrices. K_r = [[K_bb + K_bi Psi, 0], [0, Lambda]] exactly:
/// * coupling block: Phi^T (K_ii Psi + K_ib) is the residual of the constraint-mode solve,
///   round-off; tolerance 1e-10 of max |K_r| (measured value printed);
/// * modal block: Phi^T K_ii Phi = Lambda (the fixed-interface eigenvalues) and
///   Phi^T M_ii Phi = I with ARPACK's M-orthonormal Ritz vectors, relative residuals ~1e-12:
///   off-diagonal entries below 1e-9 of the block's largest eigenvalue (resp. of 1),
///   diagonal to 1e-9 relative.
#[test]
fn reduced_stiffness_is_block_diagonal() {
    let b = blade();
    let r = reduction(40);
    let (k_r, m_r) = (&r.cb.k_r, &r.cb.m_r);
    let n_b = b.boundary.len();
    let n_r = r.cb.n_reduced();
    let scale = (0..n_r)
        .flat_map(|j| (0..n_r).map(move |i| (i, j)))
        .fold(0.0_f64, |acc, ij| acc.max(k_r[ij].abs()));
    let mut coupling = 0.0_f64;
    for i in 0..n_b {
        for j in n_b..n_r {
            coupling = coupling.max(k_r[(i, j)].abs()).max(k_r[(j, i)].abs());
        }
    }
    let lambda = &r.cb.fixed_interface_eigenvalues;
    let lambda_max = lambda[lambda.len() - 1];
    let (mut k_off, mut m_off, mut k_diag, mut m_diag) = (0.0_f64, 0.0_f64, 0.0_f64, 0.0_f64);
    for a in 0..lambda.len() {
        for c in 0..lambda.len() {
            let (kv, mv) = (k_r[(n_b + a, n_b + c)], m_r[(n_b + a, n_b + c)]);
            if a == c {
                k_diag = k_diag.max((kv / lambda[a] - 1.0).abs());
                m_diag = m_diag.max((mv - 1.0).abs());
            } else {
                k_off = k_off.max(kv.abs() / lambda_max);
                m_off = m_off.max(mv.abs());
            }
        }
    }
    eprintln!(
        "K_r: coupling / max|K_r| = {:.1e}; modal block: K off-diagonal {k_off:.1e}, \
         diagonal {k_diag:.1e}; M off-diagonal {m_off:.1e}, diagonal {m_diag:.1e}; \
         asymmetry before symmetrization K {:.1e}, M {:.1e}",
        coupling / scale,
        r.cb.asymmetry_k,
        r.cb.asymmetry_m
    );
    assert!(coupling < 1e-10 * scale, "{:e}", coupling / scale);
    assert!(k_off < 1e-9 && k_diag < 1e-9, "{k_off:e} {k_diag:e}");
    assert!(m_off < 1e-9 && m_diag < 1e-9, "{m_off:e} {m_diag:e}");
}

/// `ReducedModel::write` then `read`: K_r, M_r (Matrix Market, 18 significant digits) and the
/// recovery basis (binary) come back bitwise identical; the metadata unchanged.
#[test]
fn reduced_model_files_round_trip_bitwise() {
    let b = blade();
    let r = reduction(40);
    let mesh = &b.sys.mesh;
    let axis = RotorAxis::new([0.0, 0.0, 0.0], [1.0, 0.0, 0.0]).expect("axis");
    let contact_nodes: Vec<ContactNode> = b
        .edge_nodes
        .iter()
        .enumerate()
        .map(|(j, &n)| ContactNode {
            mesh_node: Some(n as u64 + 1),
            dofs: [3 * j, 3 * j + 1, 3 * j + 2],
            position: mesh.nodes[n],
            radial: axis
                .radial_unit_vector(mesh.nodes[n])
                .expect("tip nodes are off the axis"),
            gap: 1e-4,
        })
        .collect();
    let fixed_dofs: Vec<usize> = (0..3 * mesh.n_nodes())
        .filter(|&g| b.sys.dofs.is_fixed(g))
        .collect();
    let model = ReducedModel {
        k: r.cb.k_r.clone(),
        m: r.cb.m_r.clone(),
        contact_nodes,
        rotor_axis: axis,
        master: MasterCoordinate {
            dof: 2,
            description: "z displacement of the first tip_edge node".to_string(),
        },
        linear_frequencies_hz: r.values[..N_CHECK].iter().map(|&l| hz(l)).collect(),
        recovery: Some(r.cb.recovery_basis()),
        mesh: Some(MeshReference {
            msh_file: "blade.msh".to_string(),
            n_full_dofs: 3 * mesh.n_nodes(),
            fixed_dofs,
        }),
    };
    let dir = tempfile::tempdir().expect("temporary directory");
    let path = dir.path().join("reduced");
    timed("write reduced model", || model.write(&path).expect("write"));
    let back = timed("read reduced model", || {
        ReducedModel::read(&path).expect("read")
    });
    let same_bits = |a: &Mat<f64>, c: &Mat<f64>| {
        a.nrows() == c.nrows()
            && a.ncols() == c.ncols()
            && (0..a.ncols()).all(|j| {
                a.col_as_slice(j)
                    .iter()
                    .zip(c.col_as_slice(j))
                    .all(|(x, y)| x.to_bits() == y.to_bits())
            })
    };
    assert!(
        same_bits(&model.k, &back.k),
        "K_r changed in the round trip"
    );
    assert!(
        same_bits(&model.m, &back.m),
        "M_r changed in the round trip"
    );
    let (rec, rec_back) = (
        model.recovery.as_ref().expect("written"),
        back.recovery.as_ref().expect("read back"),
    );
    assert!(same_bits(rec, rec_back), "recovery basis changed");
    assert_eq!(model.contact_nodes, back.contact_nodes);
    assert_eq!(model.rotor_axis, back.rotor_axis);
    assert_eq!(model.master, back.master);
    assert_eq!(model.linear_frequencies_hz, back.linear_frequencies_hz);
    assert_eq!(model.mesh, back.mesh);
}

/// Contact nodes on the clamped root (the `root` group used as the contact group): every one
/// of their DOFs is fixed, so `DofMap::free_index` has no free index for them (the CLI turns
/// that into "contact node ... has a fixed DOF: it lies on a clamped group"); a caller that
/// drops the fixed DOFs is left with an empty boundary, which `craig_bampton` refuses; a
/// boundary listing a DOF twice is refused with both list positions.
#[test]
fn contact_nodes_on_the_clamped_root_are_rejected() {
    let b = blade();
    let mesh = &b.sys.mesh;
    let root = &mesh.group("root").expect("root").nodes;
    let globals: Vec<usize> = root
        .iter()
        .flat_map(|&n| (0..3).map(move |c| 3 * n + c))
        .collect();
    assert!(globals.iter().all(|&g| b.sys.dofs.is_fixed(g)));
    assert!(globals.iter().all(|&g| b.sys.dofs.free_index(g).is_none()));
    let boundary: Vec<usize> = globals
        .iter()
        .filter_map(|&g| b.sys.dofs.free_index(g))
        .collect();
    let err = craig_bampton(&b.sys.k, &b.sys.m, &boundary, 10, &arpack())
        .expect_err("an empty boundary must be refused");
    eprintln!("root as contact group: {err}");
    assert!(
        matches!(&err, ModalError::InvalidReduction(msg) if msg.contains("empty")),
        "{err:?}"
    );

    let mut duplicated = b.boundary.clone();
    duplicated.push(b.boundary[5]);
    let err = craig_bampton(&b.sys.k, &b.sys.m, &duplicated, 10, &arpack())
        .expect_err("a duplicated boundary DOF must be refused");
    eprintln!("duplicated boundary DOF: {err}");
    let msg = err.to_string();
    assert!(
        msg.contains(&format!("boundary DOF {} appears twice", b.boundary[5]))
            && msg.contains("entries 5 and 72"),
        "{msg}"
    );

    let n = b.sys.k.rows();
    let err = craig_bampton(&b.sys.k, &b.sys.m, &[0, n], 10, &arpack())
        .expect_err("an out-of-range boundary DOF must be refused");
    eprintln!("out-of-range boundary DOF: {err}");
    assert!(
        err.to_string().contains(&format!(
            "boundary DOF {n} (entry 1 of the list) is out of range"
        )),
        "{err}"
    );
}

/// A tiny beam mesh (TET4, h_mesh = 0.5 m: a few nodes), clamped on `clamp`, reduced onto the
/// `free` face: asking for more fixed-interface modes than interior DOFs is an error naming
/// both counts; asking for all of them is allowed and then T is square and invertible, so the
/// reduced spectrum is the full one (1e-9 relative: two dense eigensolutions of ~1e2-DOF
/// problems).
#[test]
fn more_modes_than_interior_dofs_is_rejected() {
    let mesh = common::beam_mesh(1, 0.5);
    let sys = fe_system(mesh.clone(), &common::steel(), &["clamp"]);
    let free = &mesh.group("free").expect("free").nodes;
    let boundary: Vec<usize> = free
        .iter()
        .flat_map(|&n| (0..3).map(move |c| 3 * n + c))
        .map(|g| sys.dofs.free_index(g).expect("free face is not clamped"))
        .collect();
    let n = sys.k.rows();
    let n_i = n - boundary.len();
    eprintln!(
        "tiny beam: {} nodes, {n} free DOFs, {n_i} interior",
        mesh.n_nodes()
    );
    assert!(n_i > 0);
    let err = craig_bampton(&sys.k, &sys.m, &boundary, n_i + 1, &EigenOptions::default())
        .expect_err("more modes than interior DOFs");
    eprintln!("{err}");
    let msg = err.to_string();
    assert!(
        msg.contains(&format!("{} fixed-interface modes requested", n_i + 1))
            && msg.contains(&format!("only {n_i} interior DOFs")),
        "{msg}"
    );

    let cb = craig_bampton(&sys.k, &sys.m, &boundary, n_i, &EigenOptions::default())
        .expect("all interior modes");
    let (reduced, _) = reduced_eigen(&cb).expect("reduced eigen");
    let (full, _) = nlmodes_modal::dense_generalized_eigen(
        nlmodes_modal::csmat_to_dense(&sys.k).as_ref(),
        nlmodes_modal::csmat_to_dense(&sys.m).as_ref(),
    )
    .expect("full dense eigen");
    assert_eq!(reduced.len(), full.len());
    for (i, (a, c)) in reduced.iter().zip(&full).enumerate() {
        assert!((a / c - 1.0).abs() < 1e-9, "mode {}: {a} vs {c}", i + 1);
    }
}
