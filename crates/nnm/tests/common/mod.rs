//! Small analytic systems shared by the integration tests.
#![allow(dead_code)]

use faer::Mat;
use nlmodes_nnm::System;

/// Independent references of `nnm_oracles.rs` (own eigensolver, cosine sums, RK4).
pub mod reference;

/// x'' + x = 0 with one contact row on x and gap `g`: M = K = [1], A = [1], master 0.
pub fn one_dof(g: f64) -> System {
    System::new(
        Mat::from_fn(1, 1, |_, _| 1.0),
        Mat::from_fn(1, 1, |_, _| 1.0),
        Mat::from_fn(1, 1, |_, _| 1.0),
        vec![g],
        0,
    )
    .expect("valid 1-DOF system")
}

/// Chain of `n` unit masses, springs of stiffness `k` from a wall to mass 0 and between
/// neighbours (last mass free on the right), contact rows on the masses in `contacts`.
pub fn chain(n: usize, k: f64, contacts: &[usize], gap: f64, master: usize) -> System {
    let m = Mat::from_fn(n, n, |i, j| if i == j { 1.0 } else { 0.0 });
    let kk = Mat::from_fn(n, n, |i, j| {
        if i == j {
            if i + 1 < n {
                2.0 * k
            } else {
                k
            }
        } else if i.abs_diff(j) == 1 {
            -k
        } else {
            0.0
        }
    });
    let a = Mat::from_fn(
        contacts.len(),
        n,
        |r, c| if contacts[r] == c { 1.0 } else { 0.0 },
    );
    System::new(m, kk, a, vec![gap; contacts.len()], master).expect("valid chain")
}

/// Exact period ratio of the 1-DOF rigid stop: w / w0 = pi / (pi - arccos(g / A)).
pub fn rigid_stop_ratio(a_over_g: f64) -> f64 {
    let pi = std::f64::consts::PI;
    pi / (pi - (1.0 / a_over_g).acos())
}

/// Exact frequency of x'' + w0^2 x + kc (x - g)_+ = 0 with free-side amplitude A (docs/DESIGN.md §5).
pub fn penalty_ratio(w0: f64, kc: f64, g: f64, a: f64) -> f64 {
    let w1 = (w0 * w0 + kc).sqrt();
    let xe = kc * g / (w0 * w0 + kc);
    let v = w0 * (a * a - g * g).sqrt();
    let b = ((g - xe).powi(2) + (v / w1).powi(2)).sqrt();
    let t = 2.0 * (std::f64::consts::PI - (g / a).acos()) / w0 + 2.0 * ((g - xe) / b).acos() / w1;
    2.0 * std::f64::consts::PI / t / w0
}

/// Three unit masses: a soft spring (stiffness 1) from the wall to mass 0, stiff springs
/// (stiffness `stiff`) between masses 0-1 and 1-2; contact rows on mass 2 with gap `gap`.
/// The first mode is the soft one; the others are far above it (no internal resonance of low order).
pub fn soft_stiff_chain(stiff: f64, gap: f64, master: usize) -> System {
    let m = Mat::from_fn(3, 3, |i, j| if i == j { 1.0 } else { 0.0 });
    let k = [
        [1.0 + stiff, -stiff, 0.0],
        [-stiff, 2.0 * stiff, -stiff],
        [0.0, -stiff, stiff],
    ];
    let kk = Mat::from_fn(3, 3, |i, j| k[i][j]);
    let a = Mat::from_fn(1, 3, |_, c| if c == 2 { 1.0 } else { 0.0 });
    System::new(m, kk, a, vec![gap], master).expect("valid soft-stiff chain")
}

/// A blade-like reduced model: a lattice plate of `chord` x `span` nodes (3 DOFs each, lumped unit
/// masses, springs to the 8 neighbours, 20 times stiffer in plane than out of plane, with a twist:
/// the out-of-plane axis of span row s is rotated by 0.05 s rad about the span axis), clamped at span row 0, reduced by Craig-Bampton
/// onto the `chord` tip nodes (3 DOFs each) plus `modes` fixed-interface modes. Contact rows: a mix
/// of radial and out-of-plane directions varying along the chord (see below); uniform gap `gap`.
/// Master: the first fixed-interface modal coordinate (the bending of the blade body, which keeps
/// growing when the tip is held by the casing). Master: the out-of-plane DOF of the middle tip node.
pub fn lattice_blade(chord: usize, span: usize, modes: usize, gap: f64) -> System {
    let node = |s: usize, c: usize| (s - 1) * chord + c; // free nodes: span rows 1..span
    let nfree = (span - 1) * chord * 3;
    let mut k = Mat::<f64>::zeros(nfree, nfree);
    // Spring "matrix" between two nodes at mean span position s: R diag(20, 20, 1) R^T kv.
    let spring = |s: f64, kv: f64| {
        let (c, sn) = ((0.05 * s).cos(), (0.05 * s).sin());
        let r = [[1.0, 0.0, 0.0], [0.0, c, -sn], [0.0, sn, c]];
        let d = [20.0, 20.0, 1.0];
        let mut out = [[0.0; 3]; 3];
        for i in 0..3 {
            for j in 0..3 {
                out[i][j] = kv * (0..3).map(|l| r[i][l] * d[l] * r[j][l]).sum::<f64>();
            }
        }
        out
    };
    let mut add_spring = |a: Option<usize>, b: Option<usize>, ks: [[f64; 3]; 3]| {
        for d in 0..3 {
            for e in 0..3 {
                let kv = ks[d][e];
                if let Some(a) = a {
                    k[(3 * a + d, 3 * a + e)] += kv;
                }
                if let Some(b) = b {
                    k[(3 * b + d, 3 * b + e)] += kv;
                }
                if let (Some(a), Some(b)) = (a, b) {
                    k[(3 * a + d, 3 * b + e)] -= kv;
                    k[(3 * b + d, 3 * a + e)] -= kv;
                }
            }
        }
    };
    let id = |s: usize, c: usize| if s == 0 { None } else { Some(node(s, c)) };
    for s in 0..span {
        for c in 0..chord {
            // neighbours to the right (chord), up (span) and the two diagonals upwards
            let sf = s as f64;
            if c + 1 < chord && s > 0 {
                add_spring(id(s, c), id(s, c + 1), spring(sf, 4.0));
            }
            if s + 1 < span {
                add_spring(id(s, c), id(s + 1, c), spring(sf + 0.5, 1.0));
                if c + 1 < chord {
                    add_spring(id(s, c), id(s + 1, c + 1), spring(sf + 0.5, 0.5));
                }
                if c > 0 {
                    add_spring(id(s, c), id(s + 1, c - 1), spring(sf + 0.5, 0.5));
                }
            }
        }
    }
    let m = Mat::<f64>::from_fn(nfree, nfree, |i, j| if i == j { 1.0 } else { 0.0 });
    // Craig-Bampton: boundary = tip row (span - 1).
    let nb = chord * 3;
    let bdofs: Vec<usize> = (0..chord)
        .flat_map(|c| (0..3).map(move |d| 3 * node(span - 1, c) + d))
        .collect();
    let idofs: Vec<usize> = (0..nfree).filter(|i| !bdofs.contains(i)).collect();
    let ni = idofs.len();
    let kii = Mat::from_fn(ni, ni, |a, b| k[(idofs[a], idofs[b])]);
    let kib = Mat::from_fn(ni, nb, |a, b| k[(idofs[a], bdofs[b])]);
    let mii = Mat::from_fn(ni, ni, |a, b| m[(idofs[a], idofs[b])]);
    use faer::linalg::solvers::Solve;
    let llt = kii.llt(faer::Side::Lower).expect("K_II SPD");
    let psi = -llt.solve(&kib);
    let evd = Mat::from_fn(ni, ni, |a, b| kii[(a, b)] / mii[(a, a)])
        .self_adjoint_eigen(faer::Side::Lower)
        .expect("eig");
    let phi = evd.U().get(.., 0..modes).to_owned();
    let nr = nb + modes;
    // T maps reduced (boundary, modal) to full (boundary rows first, then interior).
    let mut t = Mat::<f64>::zeros(nfree, nr);
    for (r, &b) in bdofs.iter().enumerate() {
        t[(b, r)] = 1.0;
    }
    for (a, &i) in idofs.iter().enumerate() {
        for r in 0..nb {
            t[(i, r)] = psi[(a, r)];
        }
        for q in 0..modes {
            t[(i, nb + q)] = phi[(a, q)];
        }
    }
    let kr = t.transpose() * &k * &t;
    let mr = t.transpose() * &m * &t;
    // Contact direction of tip node j: (1, 0, t_j) / |.|, t_j from 0.1 to 0.6 along the chord, so
    // that the normal displacement of the first mode grows along the chord (the last node touches
    // first, as on a twisted blade).
    let a = Mat::from_fn(chord, nr, |j, col| {
        let t = 0.1 + 0.5 * j as f64 / (chord.max(2) - 1) as f64;
        let nrm = (1.0 + t * t).sqrt();
        if col == 3 * j {
            1.0 / nrm
        } else if col == 3 * j + 2 {
            t / nrm
        } else {
            0.0
        }
    });
    System::new(mr, kr, a, vec![gap; chord], nb).expect("valid lattice blade")
}

/// Free-side amplitude A = -min_t x(t) of coordinate `dof` of a point (the cosine series is even
/// about t = 0 and T/2, both turning points; the minimum is searched on 4096 samples, then refined
/// by golden-section search around the best sample).
pub fn free_side_amplitude(p: &nlmodes_nnm::BackbonePoint, dof: usize) -> f64 {
    let coef: Vec<f64> = p.coefficients.iter().map(|u| u[dof]).collect();
    let f = |phase: f64| nlmodes_nnm::cosine_series(&coef, phase);
    let n = 4096;
    let h = 2.0 * std::f64::consts::PI / n as f64;
    let best = (0..n)
        .min_by(|&a, &b| f(a as f64 * h).total_cmp(&f(b as f64 * h)))
        .unwrap_or(0);
    let (mut a, mut b) = ((best as f64 - 1.0) * h, (best as f64 + 1.0) * h);
    let g = 0.5 * (5f64.sqrt() - 1.0);
    for _ in 0..80 {
        let c = b - g * (b - a);
        let d = a + g * (b - a);
        if f(c) < f(d) {
            b = d;
        } else {
            a = c;
        }
    }
    -f(0.5 * (a + b))
}

/// Solves `solver` at the master amplitude giving a free-side amplitude `target` (secant method on
/// q from the starting amplitude `q0`, warm-started), to |A - target| <= 1e-11 target.
pub fn solve_at_free_amplitude(
    solver: &mut nlmodes_nnm::Solver<'_>,
    start: &nlmodes_nnm::BackbonePoint,
    target: f64,
) -> nlmodes_nnm::BackbonePoint {
    use nlmodes_nnm::Start;
    let mut p0 = start.clone();
    let mut a0 = free_side_amplitude(&p0, 0);
    // march q towards the target in small relative steps so that warm starts stay close
    while a0 < 0.9 * target {
        let q = p0.q * (1.0 + 0.25 * (target / a0 - 1.0).min(0.2));
        p0 = solver
            .solve_point(q, Start::Point(&p0))
            .expect("march towards target amplitude");
        a0 = free_side_amplitude(&p0, 0);
    }
    let mut p1 = solver
        .solve_point(p0.q * (1.0 + 0.5 * (target / a0 - 1.0)), Start::Point(&p0))
        .expect("secant start");
    let mut a1 = free_side_amplitude(&p1, 0);
    for _ in 0..60 {
        if (a1 - target).abs() <= 1e-11 * target || a1 == a0 {
            return p1;
        }
        let q = p1.q + (target - a1) * (p1.q - p0.q) / (a1 - a0);
        let next = solver
            .solve_point(q, Start::Point(&p1))
            .expect("secant step");
        p0 = p1;
        a0 = a1;
        a1 = free_side_amplitude(&next, 0);
        p1 = next;
    }
    panic!("secant on q did not reach A = {target}: last A = {a1}");
}

/// A 3-DOF system with a rigid stop that is not the 2-DOF chain: non-diagonal M, a contact row
/// along no coordinate (a = (0.2, 0, 1), gap 0.5), master DOF 3 (w2/w1 = 1.918, w3/w1 = 3.496).
/// Its exact one-impact branch is `oracle::impact` (`impact_oracle.rs`); used by
/// `saltation_oracle.rs`, `passage_guard.rs` and `history_free.rs`.
pub fn three_dof_stop() -> System {
    let m = [[2.0, 0.3, 0.0], [0.3, 1.0, 0.2], [0.0, 0.2, 1.5]];
    let k = [[3.0, -1.0, 0.0], [-1.0, 2.5, -1.0], [0.0, -1.0, 1.2]];
    let a = [0.2, 0.0, 1.0];
    System::new(
        Mat::from_fn(3, 3, |i, j| m[i][j]),
        Mat::from_fn(3, 3, |i, j| k[i][j]),
        Mat::from_fn(1, 3, |_, j| a[j]),
        vec![0.5],
        2,
    )
    .expect("3-DOF system")
}
