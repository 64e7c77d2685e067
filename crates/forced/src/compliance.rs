//! The contact compliance G(W) of the forced harmonic balance (DESIGN §10.4), stored as what
//! it is: block-diagonal over harmonics.
//!
//! y = y_F(W) - G(W) Lambda couples only the same harmonic of two contact rows, so G is kept as
//! one dense block per harmonic n: c x c for the mean (n = 0), 2c x 2c for n >= 1 with the local
//! index 2 j + part (part 0: cos, 1: sin) of row j. In the signal-major layout y[j (2N + 1) + p]
//! harmonic n of row j holds the coefficients p = 2n - 1 (cos) and 2n (sin) of `FullBasis`.
//! Stored densely, G would be L x L (L = c (2N + 1)) with one entry in N + 1 nonzero: 7.7 MB on
//! the default blade at N = 20, 30 MB at N = 40, rewritten at every W of a continuation and read
//! with a stride in every Newton matrix; the blocks are (N + 1) times smaller.

use faer::{Mat, MatMut};
use nlmodes_hb::FullBasis;

/// The condensed linear response at one excitation frequency W (see module docs), in the
/// signal-major layout y[j (2N + 1) + p] of the contact coordinates.
#[derive(Clone, Debug)]
pub struct ContactCompliance {
    /// W (rad/s).
    pub omega: f64,
    /// G's harmonic blocks: `blocks[n]` is (w c) x (w c), w = 1 for n = 0 and 2 otherwise.
    blocks: Vec<Mat<f64>>,
    /// y_F, the contact response to the load alone (L).
    pub y_load: Vec<f64>,
    /// Contact rows c (L = c (2N + 1)).
    pub contacts: usize,
}

/// Coefficients of harmonic n in one signal (1 for the mean, 2 otherwise).
pub(crate) fn width(n: usize) -> usize {
    if n == 0 {
        1
    } else {
        2
    }
}

/// The index of harmonic n's first coefficient in one signal (the mean, or a_n).
pub(crate) fn first(n: usize) -> usize {
    if n == 0 {
        0
    } else {
        FullBasis::cos_index(n)
    }
}

impl ContactCompliance {
    /// Zero compliance of `contacts` rows and `terms` = 2N + 1 coefficients per row at W.
    pub fn zeros(omega: f64, contacts: usize, terms: usize) -> Self {
        Self {
            omega,
            blocks: (0..=terms / 2)
                .map(|n| Mat::zeros(width(n) * contacts, width(n) * contacts))
                .collect(),
            y_load: vec![0.0; contacts * terms],
            contacts,
        }
    }

    /// Coefficients per signal 2N + 1.
    pub fn terms(&self) -> usize {
        2 * self.blocks.len() - 1
    }

    /// L = c (2N + 1), the length of y.
    pub fn len(&self) -> usize {
        self.y_load.len()
    }

    /// Whether there are no contact coordinates.
    pub fn is_empty(&self) -> bool {
        self.y_load.is_empty()
    }

    /// Whether this holds `contacts` rows of `terms` coefficients.
    pub fn has_shape(&self, contacts: usize, terms: usize) -> bool {
        self.contacts == contacts && self.terms() == terms
    }

    /// This compliance moved by `shift` times its difference to `other` (of the same shape, at
    /// the same W): G + shift (G_other - G), y_F likewise. The compliance of a structure
    /// linearized between two (`following::Following`).
    pub(crate) fn blend(&self, other: &ContactCompliance, shift: f64) -> ContactCompliance {
        let mix = |a: f64, b: f64| a + shift * (b - a);
        ContactCompliance {
            omega: self.omega,
            blocks: (self.blocks.iter().zip(&other.blocks))
                .map(|(a, b)| Mat::from_fn(a.nrows(), a.ncols(), |i, j| mix(a[(i, j)], b[(i, j)])))
                .collect(),
            y_load: (self.y_load.iter().zip(&other.y_load))
                .map(|(&a, &b)| mix(a, b))
                .collect(),
            contacts: self.contacts,
        }
    }

    /// G's harmonic blocks in increasing n (see module docs for their indexing).
    pub(crate) fn blocks(&self) -> &[Mat<f64>] {
        &self.blocks
    }

    /// Harmonic n's block, to be written (see module docs for its indexing).
    pub fn block_mut(&mut self, n: usize) -> MatMut<'_, f64> {
        self.blocks[n].as_mut()
    }

    /// G[i, col] in the signal-major layout (0 where the two coefficients are of different
    /// harmonics).
    pub fn entry(&self, i: usize, col: usize) -> f64 {
        let t = self.terms();
        let (pi, pc) = (i % t, col % t);
        let n = FullBasis::harmonic_of(pi);
        if FullBasis::harmonic_of(pc) != n {
            return 0.0;
        }
        let w = width(n);
        let local = |j: usize, p: usize| w * j + p - first(n);
        self.blocks[n][(local(i / t, pi), local(col / t, pc))]
    }

    /// G as a dense L x L matrix (for checks; the solver uses the blocks).
    pub fn dense(&self) -> Mat<f64> {
        let l = self.len();
        Mat::from_fn(l, l, |i, col| self.entry(i, col))
    }

    /// G Lambda for the signal-major `lambda` (L), harmonic block by harmonic block.
    pub fn apply(&self, lambda: &[f64]) -> Vec<f64> {
        let (t, c) = (self.terms(), self.contacts);
        let mut out = vec![0.0; self.len()];
        for (n, block) in self.blocks.iter().enumerate() {
            let (w, p0) = (width(n), first(n));
            for jr in 0..c {
                for part in 0..w {
                    let x = lambda[jr * t + p0 + part];
                    if x == 0.0 {
                        continue;
                    }
                    let column = block.col_as_slice(w * jr + part);
                    for (j, rows) in column.chunks_exact(w).enumerate() {
                        let at = j * t + p0;
                        out[at..at + w]
                            .iter_mut()
                            .zip(rows)
                            .for_each(|(o, g)| *o += g * x);
                    }
                }
            }
        }
        out
    }

    /// (G^T v) on the coefficients of the contact rows `rows` (v on every row, L values):
    /// rows.len() (2N + 1) values, row by row in the order of `rows`.
    pub fn apply_transpose(&self, v: &[f64], rows: &[usize]) -> Vec<f64> {
        let (t, c) = (self.terms(), self.contacts);
        let mut out = vec![0.0; rows.len() * t];
        let mut local = Vec::with_capacity(2 * c);
        for (n, block) in self.blocks.iter().enumerate() {
            let (w, p0) = (width(n), first(n));
            local.clear();
            (0..c).for_each(|j| local.extend_from_slice(&v[j * t + p0..j * t + p0 + w]));
            for (ar, &jr) in rows.iter().enumerate() {
                for part in 0..w {
                    out[ar * t + p0 + part] = block
                        .col_as_slice(w * jr + part)
                        .iter()
                        .zip(&local)
                        .map(|(g, x)| g * x)
                        .sum();
                }
            }
        }
        out
    }
}
