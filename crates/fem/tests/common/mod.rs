//! Helpers shared by the integration tests.
#![allow(dead_code)]

use nlmodes_fem::{shape::TET10_EDGES, Mesh, TetKind};
use sprs::CsMat;

/// Deterministic pseudo-random numbers in [-1, 1) (64-bit LCG, Knuth's constants).
pub struct Lcg(pub u64);

impl Lcg {
    pub fn next(&mut self) -> f64 {
        self.0 = self
            .0
            .wrapping_mul(6_364_136_223_846_793_005)
            .wrapping_add(1_442_695_040_888_963_407);
        ((self.0 >> 11) as f64) / ((1u64 << 53) as f64) * 2.0 - 1.0
    }

    /// A random unit vector.
    pub fn unit(&mut self) -> [f64; 3] {
        loop {
            let r = [self.next(), self.next(), self.next()];
            let n = (r[0] * r[0] + r[1] * r[1] + r[2] * r[2]).sqrt();
            if n > 0.1 && n <= 1.0 {
                return [r[0] / n, r[1] / n, r[2] / n];
            }
        }
    }
}

/// TET10 node coordinates with straight edges for the given vertices.
pub fn straight_tet10(v: &[[f64; 3]; 4]) -> Vec<[f64; 3]> {
    let mut c = v.to_vec();
    for &(a, b) in &TET10_EDGES {
        c.push([
            0.5 * (v[a][0] + v[b][0]),
            0.5 * (v[a][1] + v[b][1]),
            0.5 * (v[a][2] + v[b][2]),
        ]);
    }
    c
}

/// Moves every mid-edge node of a TET10 mesh by `fraction` x (local edge length) in a
/// pseudo-random direction: a conforming mesh of curved elements.
pub fn curve_mid_edge_nodes(mesh: &mut Mesh, fraction: f64, seed: u64) {
    assert_eq!(mesh.kind, TetKind::Tet10);
    let mut rng = Lcg(seed);
    let mut moved = vec![false; mesh.n_nodes()];
    for e in 0..mesh.n_elements() {
        let v = mesh.element(e).to_vec();
        for (k, &(a, b)) in TET10_EDGES.iter().enumerate() {
            let m = v[4 + k];
            if moved[m] {
                continue;
            }
            moved[m] = true;
            let (p, q) = (mesh.nodes[v[a]], mesh.nodes[v[b]]);
            let len =
                ((p[0] - q[0]).powi(2) + (p[1] - q[1]).powi(2) + (p[2] - q[2]).powi(2)).sqrt();
            let u = rng.unit();
            for d in 0..3 {
                mesh.nodes[m][d] += fraction * len * u[d];
            }
        }
    }
}

/// The six rigid-body modes of a node set: translations x, y, z, rotations about x, y, z
/// (u = omega x r).
pub fn rigid_body_modes(nodes: &[[f64; 3]]) -> Vec<Vec<f64>> {
    let mut modes = vec![vec![0.0; 3 * nodes.len()]; 6];
    for (i, x) in nodes.iter().enumerate() {
        for d in 0..3 {
            modes[d][3 * i + d] = 1.0;
        }
        let rot = [[0.0, -x[2], x[1]], [x[2], 0.0, -x[0]], [-x[1], x[0], 0.0]];
        for (r, u) in rot.iter().enumerate() {
            modes[3 + r][3 * i..3 * i + 3].copy_from_slice(u);
        }
    }
    modes
}

/// y = A x for a CSC matrix.
pub fn mul(a: &CsMat<f64>, x: &[f64]) -> Vec<f64> {
    let mut y = vec![0.0; a.rows()];
    for (v, (i, j)) in a.iter() {
        y[i] += v * x[j];
    }
    y
}

/// Dense row-major copy.
pub fn dense(a: &CsMat<f64>) -> Vec<Vec<f64>> {
    let mut d = vec![vec![0.0; a.cols()]; a.rows()];
    for (v, (i, j)) in a.iter() {
        d[i][j] += v;
    }
    d
}

/// Largest absolute entry.
pub fn max_abs(a: &CsMat<f64>) -> f64 {
    a.data().iter().fold(0.0, |m, v| m.max(v.abs()))
}

pub fn dot(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| x * y).sum()
}

pub fn norm(a: &[f64]) -> f64 {
    dot(a, a).sqrt()
}
