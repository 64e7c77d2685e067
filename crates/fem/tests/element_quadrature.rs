//! Justification of the quadrature used for curved TET10 (see the `element` module docs).

// Index loops mirror the index notation of the formulas.
#![allow(clippy::needless_range_loop)]

mod common;

use common::{straight_tet10, Lcg};
use nlmodes_fem::element::{
    curvature, element_matrices, is_affine, mass_with_rule, stiffness_with_rule, ElementRules,
    TabulatedRule, AFFINE_TOLERANCE,
};
use nlmodes_fem::generate::signed_volume6;
use nlmodes_fem::geometry::longest_vertex_edge;
use nlmodes_fem::{Isotropic, TetKind, TetRule};

fn steel() -> Isotropic {
    Isotropic::new(210e9, 0.3, 7800.0).expect("valid")
}

/// The "much higher" reference: conical product of degree 31 (16^3 = 4096 points).
fn reference() -> TabulatedRule {
    TabulatedRule::new(TetKind::Tet10, TetRule::conical_product(31))
}

fn rel_diff(a: &[f64], b: &[f64]) -> f64 {
    let d: f64 = a
        .iter()
        .zip(b)
        .map(|(x, y)| (x - y).powi(2))
        .sum::<f64>()
        .sqrt();
    d / b.iter().map(|x| x * x).sum::<f64>().sqrt()
}

fn with_rule(coords: &[[f64; 3]], tab: &TabulatedRule) -> (Vec<f64>, Vec<f64>) {
    let mat = steel();
    let (mut k, mut m) = (vec![0.0; 900], vec![0.0; 900]);
    stiffness_with_rule(coords, mat.lame(), tab, 1, &mut k).expect("valid element");
    mass_with_rule(coords, mat.density, tab, 1, &mut m).expect("valid element");
    (k, m)
}

fn chosen(coords: &[[f64; 3]]) -> (Vec<f64>, Vec<f64>) {
    let (mut k, mut m) = (vec![0.0; 900], vec![0.0; 900]);
    element_matrices(TetKind::Tet10, coords, &steel(), 1, &mut k, &mut m).expect("valid element");
    (k, m)
}

#[test]
fn mid_edge_nodes_off_their_chords() {
    // Regular tetrahedron (unit edges), node 4 (edge 0-1) and node 8 (the opposite edge 2-3)
    // moved perpendicular to their edges by 1 %, 5 %, 10 %, 20 % of the edge length. (With a
    // single moved node det J stays linear and the 14-point rule would integrate the mass
    // exactly; two nodes make det J quadratic and the mass integrand of degree 6.)
    let s3 = 3f64.sqrt();
    let v = [
        [0.0, 0.0, 0.0],
        [1.0, 0.0, 0.0],
        [0.5, s3 / 2.0, 0.0],
        [0.5, s3 / 6.0, (2.0f64 / 3.0).sqrt()],
    ];
    let reference = reference();
    let four = TabulatedRule::new(TetKind::Tet10, TetRule::four_point());
    let fourteen = TabulatedRule::new(TetKind::Tet10, TetRule::fourteen_point());
    for offset in [0.01, 0.05, 0.1, 0.2] {
        let mut c = straight_tet10(&v);
        c[4][1] -= offset;
        c[8][0] += offset;
        let (k_ref, m_ref) = with_rule(&c, &reference);
        let (k, m) = chosen(&c);
        let used = ElementRules::for_kind(TetKind::Tet10)
            .curved_stiffness_rule(&c)
            .rule
            .len();
        let err_k = rel_diff(&k, &k_ref);
        let err_m = rel_diff(&m, &m_ref);
        println!("offset {offset}: stiffness rule {used} points, error {err_k:.1e}; mass error {err_m:.1e}");
        // The chosen rule is converged: 1e-10 relative to the 4096-point rule.
        assert!(
            err_k < 1e-10,
            "offset {offset}: stiffness error {err_k:e} with {used} points"
        );
        // The mass integrand is a degree-7 polynomial: exact up to round-off.
        assert!(err_m < 1e-13, "offset {offset}: mass error {err_m:e}");
        // The affine rules are not enough once the element is curved (so the test would fail
        // if the curved path were not taken): errors far above the 1e-10 target.
        let (k4, _) = with_rule(&c, &four);
        let (_, m14) = with_rule(&c, &fourteen);
        println!(
            "  affine rules: stiffness error {:.1e}, mass error {:.1e}",
            rel_diff(&k4, &k_ref),
            rel_diff(&m14, &m_ref)
        );
        assert!(rel_diff(&k4, &k_ref) > 1e-6, "offset {offset}");
        assert!(rel_diff(&m14, &m_ref) > 1e-6, "offset {offset}");
    }
}

#[test]
fn curved_tet10_stiffness_rule_is_converged() {
    // Random tetrahedra (vertices of a regular one moved by up to 0.35 edge, shape quality
    // down to slivers) with mid-edge offsets from 1e-8 to 15 % of the longest edge in random
    // directions. Wherever the ladder selects a rule (agreement of the trace functional
    // between consecutive rules), the stiffness must be within 1e-10 of the 4096-point rule.
    let mut rng = Lcg(7);
    let reference = reference();
    let rules = ElementRules::for_kind(TetKind::Tet10);
    let last = rules
        .stiffness_ladder
        .last()
        .map(|t| t.rule.len())
        .unwrap_or(0);
    let offsets = [1e-8, 1e-4, 1e-3, 0.01, 0.03, 0.05, 0.1, 0.15];
    let mut tested = 0;
    let mut converged_small = 0;
    let mut total_small = 0;
    let mut histogram = std::collections::BTreeMap::new();
    for trial in 0..160 {
        let base = [
            [0.0, 0.0, 0.0],
            [1.0, 0.0, 0.0],
            [0.5, 0.866, 0.0],
            [0.5, 0.289, 0.816],
        ];
        let v: [[f64; 3]; 4] = base.map(|p| p.map(|x| x + 0.35 * rng.next()));
        if signed_volume6(v[0], v[1], v[2], v[3]) <= 0.0 {
            continue;
        }
        let mut c = straight_tet10(&v);
        let h = longest_vertex_edge(&c);
        let offset = offsets[trial % offsets.len()];
        for node in c.iter_mut().skip(4) {
            let u = rng.unit();
            for d in 0..3 {
                node[d] += offset * h * u[d];
            }
        }
        let mat = steel();
        let mut k_ref = vec![0.0; 900];
        if stiffness_with_rule(&c, mat.lame(), &reference, 1, &mut k_ref).is_err() {
            continue; // folded by the random offsets: not a valid element
        }
        tested += 1;
        let used = rules.curved_stiffness_rule(&c).rule.len();
        *histogram.entry((offset.to_bits(), used)).or_insert(0) += 1;
        let (k, _) = chosen(&c);
        let err = rel_diff(&k, &k_ref);
        if offset <= 0.05 {
            total_small += 1;
            converged_small += usize::from(used < last);
        }
        if used < last {
            assert!(
                err < 1e-10,
                "offset {offset}: {used}-point rule, error {err:e}"
            );
        }
    }
    for ((bits, used), count) in &histogram {
        println!(
            "offset {:7.1e}: {count:3} elements with the {used}-point rule",
            f64::from_bits(*bits)
        );
    }
    // Enough valid elements, and the ladder converges for nearly all elements with offsets
    // up to 5 % (the range of gmsh's curved boundary elements).
    assert!(tested >= 100, "only {tested} valid random elements");
    assert!(
        converged_small * 100 >= 95 * total_small,
        "{converged_small} / {total_small} converged"
    );
}

#[test]
fn affine_tolerance_keeps_the_affine_rule_converged() {
    // Offsets up to AFFINE_TOLERANCE x h take the affine rules: their error, first order in
    // the offset (about 0.2 x offset / h), must stay below 1e-10.
    let v = [
        [0.1, 0.0, 0.05],
        [1.2, 0.1, 0.0],
        [0.3, 1.1, -0.1],
        [0.2, 0.3, 0.9],
    ];
    let mut c = straight_tet10(&v);
    let h = longest_vertex_edge(&c);
    c[4][2] += 0.99 * AFFINE_TOLERANCE * h;
    c[8][0] -= 0.99 * AFFINE_TOLERANCE * h;
    assert!(
        is_affine(TetKind::Tet10, &c),
        "curvature {}",
        curvature(TetKind::Tet10, &c)
    );
    let (k_ref, m_ref) = with_rule(&c, &reference());
    let (k, m) = chosen(&c);
    assert!(rel_diff(&k, &k_ref) < 1e-10, "{:e}", rel_diff(&k, &k_ref));
    assert!(rel_diff(&m, &m_ref) < 1e-10, "{:e}", rel_diff(&m, &m_ref));
    c[4][2] += 0.02 * AFFINE_TOLERANCE * h;
    assert!(!is_affine(TetKind::Tet10, &c));
}
