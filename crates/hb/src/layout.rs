//! Shapes of the harmonic-balance data (docs/DESIGN.md §3.1-3.2).
//!
//! Two flat layouts are used, each owned by a small type so that no caller recomputes N + 1:
//!
//! * [`HarmonicLayout`]: `dim` coordinates over the harmonics 0..=N, harmonic-major,
//!   `x[n * dim + i]` (a column-major dim x (N + 1) matrix: one column per harmonic). The Newton
//!   unknowns of every [`crate::linear_model::LinearModel`] use it, followed by w and q.
//! * [`SignalLayout`]: `rows` scalar signals each given by its N + 1 cosine coefficients,
//!   signal-major, `c[j * (N + 1) + n]` (one contiguous series per signal): what the AFT transforms
//!   (the contact displacements A_j u_n and forces lambda_{j,n}).
//!
//! Time samples of `rows` signals are signal-major too, `g[j * m + k]` (see [`crate::Multipliers`]).

use faer::{MatMut, MatRef};

/// Harmonic-major coefficients of `dim` coordinates over harmonics 0..=N (see module docs).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct HarmonicLayout {
    highest: usize,
    dim: usize,
}

impl HarmonicLayout {
    /// `dim` coordinates per harmonic, harmonics 0..=`highest` (N).
    pub fn new(highest: usize, dim: usize) -> Self {
        Self { highest, dim }
    }

    /// Number of cosine terms N + 1 (the mean included).
    pub fn count(self) -> usize {
        self.highest + 1
    }

    /// Number of cosine moments 2N + 1 of a product of two series (see `Aft::cosine_moments`).
    pub fn moments(self) -> usize {
        2 * self.highest + 1
    }

    /// Coordinates per harmonic.
    pub fn dim(self) -> usize {
        self.dim
    }

    /// Length of the coefficient block, dim (N + 1).
    pub fn len(self) -> usize {
        self.dim * self.count()
    }

    /// Whether the block holds no coefficient (dim = 0).
    pub fn is_empty(self) -> bool {
        self.len() == 0
    }

    /// Length of a Newton vector: the coefficient block, then w, then q.
    pub fn newton_len(self) -> usize {
        self.len() + 2
    }

    /// Index of w in a Newton vector (q follows it).
    pub fn omega_index(self) -> usize {
        self.len()
    }

    /// Flat index of coordinate `i` of harmonic `n`.
    #[inline]
    pub fn at(self, n: usize, i: usize) -> usize {
        n * self.dim + i
    }

    /// The coordinates of harmonic `n`.
    pub fn harmonic(self, x: &[f64], n: usize) -> &[f64] {
        &x[n * self.dim..(n + 1) * self.dim]
    }

    /// The coordinates of harmonic `n`, mutable.
    pub fn harmonic_mut(self, x: &mut [f64], n: usize) -> &mut [f64] {
        &mut x[n * self.dim..(n + 1) * self.dim]
    }

    /// The coefficient block as a dim x (N + 1) matrix (one column per harmonic).
    pub fn view(self, x: &[f64]) -> MatRef<'_, f64> {
        MatRef::from_column_major_slice(&x[..self.len()], self.dim, self.count())
    }

    /// The coefficient block as a mutable dim x (N + 1) matrix.
    pub fn view_mut(self, x: &mut [f64]) -> MatMut<'_, f64> {
        MatMut::from_column_major_slice_mut(&mut x[..self.len()], self.dim, self.count())
    }

    /// The same harmonics for `dim` other coordinates.
    pub fn with_dim(self, dim: usize) -> Self {
        Self { dim, ..self }
    }

    /// The signal-major layout of `rows` signals over the same harmonics.
    pub fn signals(self, rows: usize) -> SignalLayout {
        SignalLayout {
            count: self.count(),
            rows,
        }
    }
}

/// Signal-major cosine coefficients of `rows` scalar signals (see module docs).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct SignalLayout {
    count: usize,
    rows: usize,
}

impl SignalLayout {
    /// Total length rows (N + 1).
    pub fn len(self) -> usize {
        self.rows * self.count
    }

    /// Whether there is no signal (rows = 0).
    pub fn is_empty(self) -> bool {
        self.len() == 0
    }

    /// Flat index of harmonic `n` of signal `j`.
    #[inline]
    pub fn at(self, j: usize, n: usize) -> usize {
        j * self.count + n
    }

    /// The N + 1 coefficients of signal `j`.
    pub fn series(self, c: &[f64], j: usize) -> &[f64] {
        &c[j * self.count..(j + 1) * self.count]
    }

    /// The coefficients as an (N + 1) x rows matrix (one column per signal).
    pub fn view(self, c: &[f64]) -> MatRef<'_, f64> {
        MatRef::from_column_major_slice(&c[..self.len()], self.count, self.rows)
    }

    /// The coefficients as a mutable (N + 1) x rows matrix (one column per signal).
    pub fn view_mut(self, c: &mut [f64]) -> MatMut<'_, f64> {
        MatMut::from_column_major_slice_mut(&mut c[..self.len()], self.count, self.rows)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn layouts_index_as_documented() {
        let l = HarmonicLayout::new(3, 5);
        assert_eq!(
            (l.count(), l.moments(), l.len(), l.newton_len()),
            (4, 7, 20, 22)
        );
        assert_eq!(l.at(2, 3), 13);
        let x: Vec<f64> = (0..20).map(f64::from).collect();
        assert_eq!(l.harmonic(&x, 2), &[10.0, 11.0, 12.0, 13.0, 14.0]);
        assert_eq!(l.view(&x)[(3, 2)], 13.0);
        let s = l.signals(2);
        assert_eq!((s.len(), s.at(1, 2)), (8, 6));
        assert_eq!(s.view(&x)[(2, 1)], 6.0);
        assert_eq!(s.series(&x, 1), &[4.0, 5.0, 6.0, 7.0]);
    }
}
