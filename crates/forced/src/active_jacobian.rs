//! G J_Lambda on the active contact rows: the products the bordered Newton solve needs
//! (DESIGN §10.4), without forming the L x La matrix G[:, active] J.
//!
//! J_Lambda is block-diagonal over the contact rows and zero on rows that never touch, so
//! dR/dy = I + G J_Lambda has nonzero columns only on the La = a (2N + 1) coefficients of the
//! a active rows. The Newton system is solved on those (`square`: the La x La block, a^2 (2N +
//! 1)^2 harmonic-diagonal products), and the inactive rows follow from products with vectors
//! (`times`, `transpose_times`): G couples the same harmonic of two rows only
//! (`ContactCompliance`), so each costs c a (2N + 1) products instead of the c / a times larger
//! L x La matrix at every Newton iteration (c = 24, a = 2..8 on the default blade).

use faer::Mat;

use crate::compliance::{first, width, ContactCompliance};

/// The active rows of an orbit and their Jacobian blocks J_j = d Lambda_j / d y_j.
pub(crate) struct ActiveJacobian {
    /// Active contact rows, increasing.
    active: Vec<usize>,
    /// J_j per active row ((2N + 1)^2).
    blocks: Vec<Mat<f64>>,
    /// 2N + 1.
    terms: usize,
}

impl ActiveJacobian {
    /// The rows `active` (increasing) with their blocks, in the same order.
    pub fn new(active: Vec<usize>, blocks: Vec<Mat<f64>>, terms: usize) -> Self {
        debug_assert_eq!(active.len(), blocks.len());
        Self {
            active,
            blocks,
            terms,
        }
    }

    /// The active rows.
    pub fn active(&self) -> &[usize] {
        &self.active
    }

    /// La = a (2N + 1).
    pub fn len(&self) -> usize {
        self.active.len() * self.terms
    }

    /// The signal-major index of active coefficient `col` (row active[col / t], coefficient
    /// col % t).
    pub fn global(&self, col: usize) -> usize {
        self.active[col / self.terms] * self.terms + col % self.terms
    }

    /// (G J)[active, active] (La x La), active coefficients in the order of [`Self::global`].
    pub fn square(&self, comp: &ContactCompliance) -> Mat<f64> {
        let t = self.terms;
        let mut out = Mat::zeros(self.len(), self.len());
        for (aj, (&j, block)) in self.active.iter().zip(&self.blocks).enumerate() {
            for q in 0..t {
                let column = out.col_as_slice_mut(aj * t + q);
                for (n, g) in comp.blocks().iter().enumerate() {
                    let (w, p0) = (width(n), first(n));
                    for part in 0..w {
                        let b = block[(p0 + part, q)];
                        if b == 0.0 {
                            continue;
                        }
                        let gcol = g.col_as_slice(w * j + part);
                        for (ai, &i) in self.active.iter().enumerate() {
                            let at = ai * t + p0;
                            column[at..at + w]
                                .iter_mut()
                                .zip(&gcol[w * i..w * i + w])
                                .for_each(|(o, g)| *o += g * b);
                        }
                    }
                }
            }
        }
        out
    }

    /// (G J) x for x on the active coefficients (La): L values, every row.
    pub fn times(&self, comp: &ContactCompliance, x: &[f64]) -> Vec<f64> {
        let t = self.terms;
        let mut spread = vec![0.0; comp.len()];
        for (ai, (&j, block)) in self.active.iter().zip(&self.blocks).enumerate() {
            let xj = &x[ai * t..(ai + 1) * t];
            for (q, &v) in xj.iter().enumerate() {
                if v == 0.0 {
                    continue;
                }
                let column = block.col_as_slice(q);
                spread[j * t..(j + 1) * t]
                    .iter_mut()
                    .zip(column)
                    .for_each(|(o, b)| *o += b * v);
            }
        }
        comp.apply(&spread)
    }

    /// Column `col` of G J (L values): (G J) e_col.
    pub fn column(&self, comp: &ContactCompliance, col: usize) -> Vec<f64> {
        let mut unit = vec![0.0; self.len()];
        unit[col] = 1.0;
        self.times(comp, &unit)
    }

    /// (G J)^T v for v on every row (L): La values, J_j^T (G^T v)_j per active row.
    pub fn transpose_times(&self, comp: &ContactCompliance, v: &[f64]) -> Vec<f64> {
        let t = self.terms;
        let gtv = comp.apply_transpose(v, &self.active);
        let mut out = vec![0.0; self.len()];
        for (ai, block) in self.blocks.iter().enumerate() {
            let u = &gtv[ai * t..(ai + 1) * t];
            for q in 0..t {
                out[ai * t + q] = block
                    .col_as_slice(q)
                    .iter()
                    .zip(u)
                    .map(|(b, x)| b * x)
                    .sum();
            }
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::damping::Damping;
    use crate::dynamics::ModalDynamics;
    use crate::load::Load;
    use faer::linalg::matmul::matmul;
    use faer::{Accum, Par};
    use nlmodes_hb::System;

    /// Three contact rows sharing the modes of a 4-DOF chain (every block of G is full).
    fn compliance(harmonics: usize) -> ContactCompliance {
        let n = 4;
        let m = Mat::from_fn(n, n, |i, j| if i == j { 1.0 + 0.2 * i as f64 } else { 0.0 });
        let k = Mat::from_fn(n, n, |i, j| match i.abs_diff(j) {
            0 => 3.0 + i as f64,
            1 => -1.0,
            _ => 0.0,
        });
        let a = Mat::from_fn(3, n, |i, j| ((i * n + j) as f64 * 0.61).sin());
        let system = System::new(m, k, a, vec![0.5, 0.7, 0.3], harmonics).expect("system");
        let c = Damping::Rayleigh {
            alpha: 0.02,
            beta: 0.01,
        }
        .matrix(&system)
        .expect("damping");
        let load = Load::fundamental(vec![0.1, 0.0, 0.3, -0.2]);
        let dynamics = ModalDynamics::new(&system, &c, &load, harmonics).expect("dynamics");
        dynamics.compliance(1.3).expect("compliance")
    }

    fn dense(a: faer::MatRef<'_, f64>, b: faer::MatRef<'_, f64>) -> Mat<f64> {
        let mut out = Mat::zeros(a.nrows(), b.ncols());
        matmul(out.as_mut(), Accum::Replace, a, b, 1.0, Par::Seq);
        out
    }

    #[test]
    fn products_equal_those_of_the_dense_g_times_the_block_diagonal_j() {
        let nh = 3;
        let t = 2 * nh + 1;
        let comp = compliance(nh);
        let g = comp.dense();
        let l = g.nrows();
        // Rows 0 and 2 active, with full blocks; row 1 out of contact.
        let active = vec![0, 2];
        let blocks: Vec<Mat<f64>> = (0..2)
            .map(|b| Mat::from_fn(t, t, |p, q| ((p * t + q + 31 * b) as f64 * 0.37).cos()))
            .collect();
        let mut j_full = Mat::zeros(l, active.len() * t);
        for (ai, (&row, block)) in active.iter().zip(&blocks).enumerate() {
            j_full.submatrix_mut(row * t, ai * t, t, t).copy_from(block);
        }
        let gj = dense(g.as_ref(), j_full.as_ref());
        let jac = ActiveJacobian::new(active, blocks, t);
        let scale = gj.norm_max();
        let close = |a: f64, b: f64| (a - b).abs() <= 1e-13 * scale;
        let square = jac.square(&comp);
        for (row, col) in (0..jac.len()).flat_map(|r| (0..jac.len()).map(move |c| (r, c))) {
            assert!(
                close(square[(row, col)], gj[(jac.global(row), col)]),
                "{row} {col}"
            );
        }
        let x: Vec<f64> = (0..jac.len()).map(|i| (0.3 * i as f64).sin()).collect();
        let want = dense(
            gj.as_ref(),
            Mat::from_fn(jac.len(), 1, |i, _| x[i]).as_ref(),
        );
        let got = jac.times(&comp, &x);
        (0..l).for_each(|i| assert!(close(got[i], want[(i, 0)]), "times {i}"));
        let v: Vec<f64> = (0..l).map(|i| (0.7 * i as f64 + 0.1).cos()).collect();
        let want = dense(gj.transpose(), Mat::from_fn(l, 1, |i, _| v[i]).as_ref());
        let got = jac.transpose_times(&comp, &v);
        (0..jac.len()).for_each(|i| assert!(close(got[i], want[(i, 0)]), "transpose {i}"));
        let column = jac.column(&comp, t + 2);
        (0..l).for_each(|i| assert!(close(column[i], gj[(i, t + 2)]), "column {i}"));
    }
}
