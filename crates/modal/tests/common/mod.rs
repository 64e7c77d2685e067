//! Synthetic sparse test problems shared by the integration tests.
#![allow(dead_code)]

use faer::Mat;
use sprs::{CsMat, TriMat};

/// Deterministic pseudo-random numbers in [0, 1) (64-bit LCG, top 53 bits).
pub struct Lcg(u64);

impl Lcg {
    pub fn new(seed: u64) -> Self {
        Self(
            seed.wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407),
        )
    }
    pub fn next_f64(&mut self) -> f64 {
        self.0 = self
            .0
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (self.0 >> 11) as f64 / (1u64 << 53) as f64
    }
    pub fn vector(&mut self, n: usize) -> Vec<f64> {
        (0..n).map(|_| 2.0 * self.next_f64() - 1.0).collect()
    }
}

fn grid_index(nx: usize, ny: usize, i: usize, j: usize, k: usize) -> usize {
    i + nx * (j + ny * k)
}

/// Grid edges (p, q) between neighbouring nodes of an nx x ny x nz grid.
pub fn grid_edges(nx: usize, ny: usize, nz: usize) -> Vec<(usize, usize)> {
    let mut edges = Vec::new();
    for k in 0..nz {
        for j in 0..ny {
            for i in 0..nx {
                let p = grid_index(nx, ny, i, j, k);
                if i + 1 < nx {
                    edges.push((p, grid_index(nx, ny, i + 1, j, k)));
                }
                if j + 1 < ny {
                    edges.push((p, grid_index(nx, ny, i, j + 1, k)));
                }
                if k + 1 < nz {
                    edges.push((p, grid_index(nx, ny, i, j, k + 1)));
                }
            }
        }
    }
    edges
}

/// 7-point Laplacian of an nx x ny x nz grid with Dirichlet boundary
/// (diagonal 6, neighbours -1) plus `shift` times the identity. SPD.
pub fn laplacian_3d(nx: usize, ny: usize, nz: usize, shift: f64) -> CsMat<f64> {
    let n = nx * ny * nz;
    let mut t = TriMat::new((n, n));
    for p in 0..n {
        t.add_triplet(p, p, 6.0 + shift);
    }
    for (p, q) in grid_edges(nx, ny, nz) {
        t.add_triplet(p, q, -1.0);
        t.add_triplet(q, p, -1.0);
    }
    t.to_csc()
}

/// Scalar spring-mass grid, one DOF per node: springs of stiffness 1 + 0.5 r
/// (N/m) along the grid edges, the face i = 0 tied to the ground by springs of
/// the same kind (clamped, so K is SPD), and a consistent "bar" mass
/// (m_e / 6) [[2, 1], [1, 2]] per edge with m_e = 1 + 0.3 r (kg). Returns (K, M).
pub fn spring_grid(nx: usize, ny: usize, nz: usize, seed: u64) -> (CsMat<f64>, CsMat<f64>) {
    let n = nx * ny * nz;
    let mut rng = Lcg::new(seed);
    let mut k = TriMat::new((n, n));
    let mut m = TriMat::new((n, n));
    for (p, q) in grid_edges(nx, ny, nz) {
        let ke = 1.0 + 0.5 * rng.next_f64();
        k.add_triplet(p, p, ke);
        k.add_triplet(q, q, ke);
        k.add_triplet(p, q, -ke);
        k.add_triplet(q, p, -ke);
        let me = (1.0 + 0.3 * rng.next_f64()) / 6.0;
        m.add_triplet(p, p, 2.0 * me);
        m.add_triplet(q, q, 2.0 * me);
        m.add_triplet(p, q, me);
        m.add_triplet(q, p, me);
    }
    for kk in 0..nz {
        for j in 0..ny {
            let p = grid_index(nx, ny, 0, j, kk);
            k.add_triplet(p, p, 1.0 + 0.5 * rng.next_f64());
        }
    }
    (k.to_csc(), m.to_csc())
}

/// Indices of the nodes on the face i = nx - 1 of the grid.
pub fn far_face(nx: usize, ny: usize, nz: usize) -> Vec<usize> {
    let mut out = Vec::new();
    for k in 0..nz {
        for j in 0..ny {
            out.push(grid_index(nx, ny, nx - 1, j, k));
        }
    }
    out
}

/// Free-free chain of n unit masses joined by unit springs: K tridiagonal
/// (1, 2, ..., 2, 1; -1), M = I. Eigenvalues 4 sin^2(j pi / (2 n)), j = 0..n-1.
pub fn free_chain(n: usize) -> (CsMat<f64>, CsMat<f64>) {
    let mut k = TriMat::new((n, n));
    let mut m = TriMat::new((n, n));
    for p in 0..n {
        m.add_triplet(p, p, 1.0);
    }
    for p in 0..n - 1 {
        k.add_triplet(p, p, 1.0);
        k.add_triplet(p + 1, p + 1, 1.0);
        k.add_triplet(p, p + 1, -1.0);
        k.add_triplet(p + 1, p, -1.0);
    }
    (k.to_csc(), m.to_csc())
}

/// y = A x for a sparse A.
pub fn mul(a: &CsMat<f64>, x: &[f64]) -> Vec<f64> {
    let mut y = vec![0.0; a.rows()];
    nlmodes_modal::sparse_ops::spmv(a, x, &mut y).unwrap();
    y
}

pub fn norm(x: &[f64]) -> f64 {
    x.iter().map(|v| v * v).sum::<f64>().sqrt()
}

pub fn dot(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| x * y).sum()
}

/// Modal assurance criterion of two real vectors.
pub fn mac(a: &[f64], b: &[f64]) -> f64 {
    dot(a, b).powi(2) / (dot(a, a) * dot(b, b))
}

/// Column j of a dense matrix as a Vec.
pub fn column(a: &Mat<f64>, j: usize) -> Vec<f64> {
    a.col_as_slice(j).to_vec()
}

/// Checks `modes` (the first nev pairs, by the solver named `label`) against the dense
/// reference: eigenvalues to 1e-8 relative, residuals below 1e-9, MAC against the dense vectors
/// above 1 - 1e-8, and Phi^T M Phi = I to 1e-10 (the tolerances are justified in the callers).
/// Prints each mode's relative difference, relative gap and residual.
pub fn assert_matches_dense(
    label: &str,
    modes: &nlmodes_modal::Modes,
    dense_values: &[f64],
    dense_vectors: &Mat<f64>,
    m: &CsMat<f64>,
) {
    let nev = modes.eigenvalues.len();
    for j in 0..nev {
        let (a, d) = (modes.eigenvalues[j], dense_values[j]);
        let gap = (dense_values[j + 1] - d).min(if j > 0 {
            d - dense_values[j - 1]
        } else {
            f64::MAX
        });
        println!(
            "mode {j}: {label} {a:.15e} dense {d:.15e} rel diff {:.1e} gap {:.1e} residual {:.1e}",
            (a - d).abs() / d,
            gap / d,
            modes.residuals[j]
        );
        assert!((a - d).abs() <= 1e-8 * d.abs(), "mode {j}: {a} vs {d}");
        assert!(
            modes.residuals[j] < 1e-9,
            "mode {j}: residual {}",
            modes.residuals[j]
        );
        let mac_value = mac(&column(&modes.vectors, j), &column(dense_vectors, j));
        assert!(mac_value > 1.0 - 1e-8, "mode {j}: MAC {mac_value}");
    }
    // Phi^T M Phi = I.
    for i in 0..nev {
        let m_phi = mul(m, &column(&modes.vectors, i));
        for j in 0..nev {
            let g = dot(&column(&modes.vectors, j), &m_phi);
            let expected = if i == j { 1.0 } else { 0.0 };
            assert!((g - expected).abs() < 1e-10, "({i}, {j}): {g}");
        }
    }
}
