//! Timing of the sparse Cholesky and the ARPACK shift-invert solver on a
//! synthetic 3-D "elasticity-like" problem: 3 DOFs per node, 27-point
//! (trilinear hexahedron) stencil, clamped on the face z = 0.
//!
//! Usage: `cargo run --release -p nlmodes-modal --example bench_modal -- NX NY NZ NEV [rayon]`
//! (defaults 20 20 80 40: about 95k DOFs). The eigensolver runs after the
//! METIS factorization; AMD is factorized for comparison of fill and time.

use std::time::Instant;

use faer::Par;
use nlmodes_modal::{
    eigs_shift_invert_factored, CholeskyOptions, EigenMethod, EigenOptions, FillOrdering,
    SparseCholesky,
};
use sprs::CsMat;

/// Number of grid cells shared by nodes a and b along one axis of n nodes.
fn shared_cells_1d(a: usize, b: usize, n: usize) -> usize {
    let lo = a.max(b).saturating_sub(1);
    let hi = a.min(b).min(n - 2);
    if a.abs_diff(b) > 1 || hi < lo {
        0
    } else {
        hi - lo + 1
    }
}

fn build(nx: usize, ny: usize, nz: usize) -> (CsMat<f64>, CsMat<f64>) {
    // Free nodes: z >= 1 (z = 0 clamped). Node (i, j, k) -> free index.
    let node = |i: usize, j: usize, k: usize| i + nx * (j + ny * (k - 1));
    let n_nodes = nx * ny * (nz - 1);
    let n = 3 * n_nodes;
    let b = [[2.0, 0.5, 0.3], [0.5, 2.0, 0.4], [0.3, 0.4, 2.0]];
    let mut kp = vec![0usize];
    let mut ki = Vec::new();
    let mut kd = Vec::new();
    let mut mp = vec![0usize];
    let mut mi = Vec::new();
    let mut md = Vec::new();
    for k in 1..nz {
        for j in 0..ny {
            for i in 0..nx {
                // Neighbours in increasing free index: dz, dy, dx ascending.
                let mut neighbours = Vec::with_capacity(27);
                let mut diag_weight = 0.0;
                for dk in -1i64..=1 {
                    for dj in -1i64..=1 {
                        for di in -1i64..=1 {
                            let (qi, qj, qk) = (i as i64 + di, j as i64 + dj, k as i64 + dk);
                            if qi < 0
                                || qj < 0
                                || qk < 0
                                || qi >= nx as i64
                                || qj >= ny as i64
                                || qk >= nz as i64
                            {
                                continue;
                            }
                            let (qi, qj, qk) = (qi as usize, qj as usize, qk as usize);
                            let w = (shared_cells_1d(i, qi, nx)
                                * shared_cells_1d(j, qj, ny)
                                * shared_cells_1d(k, qk, nz))
                                as f64;
                            if (di, dj, dk) != (0, 0, 0) {
                                diag_weight += w;
                            }
                            if qk >= 1 {
                                neighbours.push((node(qi, qj, qk), w, (di, dj, dk) == (0, 0, 0)));
                            }
                        }
                    }
                }
                let cells = shared_cells_1d(i, i, nx)
                    * shared_cells_1d(j, j, ny)
                    * shared_cells_1d(k, k, nz);
                // b is symmetric: row c is column c.
                for (c, b_col) in b.iter().enumerate() {
                    for &(q, w, is_self) in &neighbours {
                        for (r, &b_rc) in b_col.iter().enumerate() {
                            let kv = if is_self {
                                diag_weight * b_rc
                            } else {
                                -w * b_rc
                            };
                            ki.push(3 * q + r);
                            kd.push(kv);
                            if r == c {
                                mi.push(3 * q + r);
                                md.push(if is_self {
                                    cells as f64 + 0.05 * diag_weight
                                } else {
                                    0.05 * w
                                });
                            }
                        }
                    }
                    kp.push(ki.len());
                    mp.push(mi.len());
                }
            }
        }
    }
    (
        CsMat::new_csc((n, n), kp, ki, kd),
        CsMat::new_csc((n, n), mp, mi, md),
    )
}

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let get = |i: usize, d: usize| args.get(i).and_then(|s| s.parse().ok()).unwrap_or(d);
    let (nx, ny, nz, nev) = (get(0, 20), get(1, 20), get(2, 80), get(3, 40));
    let rayon = args.get(4).is_some_and(|s| s == "rayon");
    let t = Instant::now();
    let (k, m) = build(nx, ny, nz);
    println!(
        "n = {}, nnz(K) = {}, assembly {:.2} s",
        k.rows(),
        k.nnz(),
        t.elapsed().as_secs_f64()
    );
    for ordering in [FillOrdering::Metis, FillOrdering::Amd] {
        let t = Instant::now();
        let chol = SparseCholesky::with_options(
            &k,
            "K",
            CholeskyOptions {
                ordering,
                factorization_par: if rayon { Par::rayon(2) } else { Par::Seq },
            },
        )
        .expect("factorization");
        println!(
            "{ordering:?}: nnz(L) = {}, supernodal {}, factorization {:.2} s",
            chol.nnz_l(),
            chol.is_supernodal(),
            t.elapsed().as_secs_f64()
        );
        if ordering == FillOrdering::Metis {
            let mut x = vec![1.0; k.rows()];
            let t = Instant::now();
            for _ in 0..10 {
                chol.solve_in_place(&mut x).expect("solve");
            }
            println!("solve: {:.1} ms each", t.elapsed().as_secs_f64() * 100.0);
            let count = std::cell::Cell::new(0usize);
            let callback = |c: usize| count.set(c);
            let t = Instant::now();
            let opts = EigenOptions {
                method: EigenMethod::Arpack,
                on_iteration: Some(&callback),
                ..Default::default()
            };
            let modes = eigs_shift_invert_factored(&k, &m, 0.0, &chol, nev, &opts).expect("eigs");
            let worst = modes.residuals.iter().copied().fold(0.0, f64::max);
            println!(
                "{nev} modes: {:.2} s, {} solves, lambda {:.6e} .. {:.6e}, worst residual {worst:.1e}",
                t.elapsed().as_secs_f64(),
                count.get(),
                modes.eigenvalues[0],
                modes.eigenvalues[nev - 1]
            );
        }
    }
}
