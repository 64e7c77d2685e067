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
//!
//! A Newton solve needs only G's columns of the rows in contact: the forces Lambda vanish on the
//! others, and the Newton matrix couples the active rows alone (`active_jacobian`). Those
//! columns are written on demand (`written`): at a new W, G's harmonics n >= 1 cost c^2 n
//! products for every row, a c / a-th of that for a rows in contact (2-8 of 24 on the default
//! blade), and a continuation moves W at every Newton iteration.

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
    /// Per contact row: whether its columns of the harmonic blocks n >= 1 hold G at `omega`
    /// (the mean's block and y_F always do).
    written: Vec<bool>,
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
    /// A compliance of `contacts` rows and `terms` = 2N + 1 coefficients per row holding no W
    /// yet (zeros; W is NaN until a writer fills it: `ModalDynamics::compliance_rows_into`).
    pub fn empty(contacts: usize, terms: usize) -> Self {
        Self {
            omega: f64::NAN,
            blocks: (0..=terms / 2)
                .map(|n| Mat::zeros(width(n) * contacts, width(n) * contacts))
                .collect(),
            y_load: vec![0.0; contacts * terms],
            contacts,
            written: vec![false; contacts],
        }
    }

    /// Whether row `j`'s columns of every harmonic block hold G at `omega`.
    pub fn written(&self, j: usize) -> bool {
        self.written[j]
    }

    /// The rows of `rows` whose columns are not written yet, increasing, each once.
    pub(crate) fn missing(&self, rows: &[usize]) -> Vec<usize> {
        let mut out: Vec<usize> = rows.iter().copied().filter(|&j| !self.written[j]).collect();
        out.sort_unstable();
        out.dedup();
        out
    }

    /// Marks row `j`'s columns as written.
    pub(crate) fn mark_written(&mut self, j: usize) {
        self.written[j] = true;
    }

    /// Marks every row's columns as stale, at `omega` (the mean's block and y_F are the
    /// writer's to fill).
    pub(crate) fn forget(&mut self, omega: f64) {
        self.omega = omega;
        self.written.iter_mut().for_each(|w| *w = false);
    }

    /// Panics when a row of `rows` is read before its columns are written: a caller that
    /// skipped `ModalDynamics::compliance_rows_into` would otherwise read G at another W.
    fn require(&self, rows: impl IntoIterator<Item = usize>) {
        for j in rows {
            assert!(
                self.written[j],
                "contact compliance: row {j}'s columns read before they were written"
            );
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
        if !col.is_multiple_of(t) {
            self.require([col / t]);
        }
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
        self.require(0..self.contacts);
        let l = self.len();
        Mat::from_fn(l, l, |i, col| self.entry(i, col))
    }

    /// G Lambda for the signal-major `lambda` (L), harmonic block by harmonic block.
    pub fn apply(&self, lambda: &[f64]) -> Vec<f64> {
        let (t, c) = (self.terms(), self.contacts);
        self.require((0..c).filter(|&j| lambda[j * t + 1..(j + 1) * t].iter().any(|&x| x != 0.0)));
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
        self.require(rows.iter().copied());
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

/// A following structure's compliance between its two structures (`following::Following`):
/// the second structure's at W, and the blend (`ContactCompliance::blend_rows_into`) with the
/// shift it holds, each on its written rows.
#[derive(Clone, Debug)]
pub struct Blended {
    /// G_b at W.
    pub(crate) second: ContactCompliance,
    /// G_a + shift (G_b - G_a).
    pub(crate) compliance: ContactCompliance,
    /// The shift it was blended with.
    shift: f64,
}

impl Default for Blended {
    fn default() -> Self {
        let empty = || ContactCompliance::empty(0, 1);
        Self {
            second: empty(),
            compliance: empty(),
            shift: f64::NAN,
        }
    }
}

impl Blended {
    /// G_a + shift (G_b - G_a), y_F likewise, with G_a = `first` and G_b = the second
    /// structure's (`second`), both at the same W, written on the columns of `rows` (written in
    /// both); reset when it holds another W or shift.
    pub(crate) fn blend(&mut self, first: &ContactCompliance, shift: f64, rows: &[usize]) {
        let (other, out) = (&self.second, &mut self.compliance);
        let mix = |a: f64, b: f64| a + shift * (b - a);
        let (c, terms) = (first.contacts, first.terms());
        if !(out.has_shape(c, terms) && out.omega == first.omega && self.shift == shift) {
            if !out.has_shape(c, terms) {
                *out = ContactCompliance::empty(c, terms);
            }
            out.forget(first.omega);
            (out.y_load
                .iter_mut()
                .zip(first.y_load.iter().zip(&other.y_load)))
            .for_each(|(o, (&a, &b))| *o = mix(a, b));
            let (a, b) = (&first.blocks[0], &other.blocks[0]);
            out.blocks[0] = Mat::from_fn(a.nrows(), a.ncols(), |i, j| mix(a[(i, j)], b[(i, j)]));
            self.shift = shift;
        }
        let missing = out.missing(rows);
        first.require(missing.iter().copied());
        other.require(missing.iter().copied());
        for &jr in &missing {
            for (n, (a, b)) in first.blocks.iter().zip(&other.blocks).enumerate().skip(1) {
                let target = &mut out.blocks[n];
                for col in 2 * jr..2 * jr + 2 {
                    (target.col_as_slice_mut(col).iter_mut())
                        .zip(a.col_as_slice(col).iter().zip(b.col_as_slice(col)))
                        .for_each(|(o, (&x, &y))| *o = mix(x, y));
                }
            }
            out.mark_written(jr);
        }
    }
}
