//! One harmonic's block of the condensed Newton step (`condensed_newton`, level 1 and the
//! per-harmonic part of level 2): the other modes away from resonance eliminated through the
//! diagonal D_oo (Schur complement on the kept coordinates, the high modes by the series of
//! `modal_tail`), the kept block with the near-resonant modes, its w column, right-hand side and
//! parameter row; then the elimination of its interior (the kept coordinates without active
//! contact) by a small LU, its Schur complement written into the reduced system, and the
//! back-substitution of its step.

use faer::linalg::matmul::matmul;
use faer::{Accum, Mat, MatMut, MatRef, Par};

use crate::condensation_basis::CondensedBasis;
use crate::layout::HarmonicLayout;
use crate::linear_model::JacobianData;
use crate::modal_tail::ModalTail;
use nlmodes_dense::DenseLu;

/// Pivot ratio of a per-harmonic interior block below which the step is redone without it.
const INTERIOR_PIVOT_RATIO: f64 = 1e-12;
/// Marks a kept coordinate that is not on the border (`HarmonicBlock::border_pos`).
pub(crate) const NOT_IN: usize = usize::MAX;

/// One harmonic's share of a condensed Newton step: its kept block and the scratch that builds
/// it. Each harmonic's block is built and its interior eliminated from shared, read-only inputs
/// only, so the blocks of one step are independent of each other (built one after the other:
/// in parallel they cost more than they gain, docs/BENCHMARKS.md "Session 16").
#[derive(Default)]
pub(crate) struct HarmonicBlock {
    pub near: Vec<usize>,
    pub size: usize,
    /// Kept block (size x size, column-major).
    pub a: Vec<f64>,
    pub cw: Vec<f64>,
    pub b: Vec<f64>,
    /// Parameter-row coefficients on the kept coordinates of this harmonic.
    pub arc: Vec<f64>,
    /// 1 / (Lambda_i - s) for eliminated modes, 0 for near ones.
    pub wt: Vec<f64>,
    pub border: Vec<usize>,
    pub interior: Vec<usize>,
    /// Position of a kept coordinate in `border` (or NOT_IN).
    pub border_pos: Vec<usize>,
    lu: DenseLu,
    /// A_II^-1 [A_IB | cw_I | b_I] (n_I x (n_B + 2), column-major).
    xs: Vec<f64>,
    /// Solved kept-block step.
    pub delta: Vec<f64>,
    /// Scratch (column-major): Dt = Kt - s Mt and DW = Dt diag(wt) (r x n_o), the Schur
    /// complement S (r x r), [wz, rhs_z] (n_o x 2) and [cw, b] (r x 2) of the kept block.
    dt: Vec<f64>,
    dw: Vec<f64>,
    s_mat: Vec<f64>,
    wzb: Vec<f64>,
    cwb: Vec<f64>,
}

/// The shared, read-only inputs of every harmonic's level-1 build in one Newton step.
pub(crate) struct BlockInputs<'a, 'j> {
    pub basis: &'a CondensedBasis,
    pub tail: &'a ModalTail,
    /// Resonance window of [`crate::NewtonSettings::resonance_window`].
    pub window: f64,
    pub layout: HarmonicLayout,
    pub jac: &'a JacobianData<'j>,
    /// The Newton right-hand side (layout `layout`, then w and q).
    pub rhs: &'a [f64],
    /// w-derivative columns, one per harmonic: kept part (r x (N + 1)), other-mode part
    /// (n_o x (N + 1)).
    pub wy: &'a Mat<f64>,
    pub wz: &'a Mat<f64>,
}

/// Where a block's rows go in the reduced system: its border starts at `offset`; `iw` and `iq`
/// are the w column (and normalization row) and the parameter row.
#[derive(Clone, Copy)]
pub(crate) struct ReducedRows {
    pub offset: usize,
    pub iw: usize,
    pub iq: usize,
}

impl HarmonicBlock {
    /// Level 1 for harmonic h (s = (h w)^2): near modes, Schur complement of the eliminated
    /// ones, kept block, condensed w column and right-hand side, parameter row.
    pub fn build(&mut self, inputs: &BlockInputs<'_, '_>, h: usize) {
        let s = (h as f64 * inputs.jac.omega).powi(2);
        let split = self.select_near(inputs, s);
        self.schur_complement(inputs, s, split);
        self.assemble_kept_block(inputs, s);
        self.condense_columns(inputs, h);
        self.parameter_row(inputs, h);
    }

    /// Sorts the other modes at s = (n w)^2 into those near resonance (explicit in the block) and
    /// the eliminated ones (weight 1 / (Lambda_i - s)). Returns the modal-tail split: modes from
    /// the cut on are summed by the precomputed series (`modal_tail`).
    fn select_near(&mut self, inputs: &BlockInputs<'_, '_>, s: f64) -> (usize, Option<usize>) {
        let bs = inputs.basis;
        self.near.clear();
        self.wt.resize(bs.n_o, 0.0);
        let (cut, tail) = inputs.tail.split(&bs.lambda, s);
        for i in 0..bs.n_o {
            let lam_i = bs.lambda[i];
            if i < cut && (lam_i - s).abs() < inputs.window * lam_i {
                self.near.push(i);
                self.wt[i] = 0.0;
            } else {
                self.wt[i] = 1.0 / (lam_i - s);
            }
        }
        (cut, tail)
    }

    /// Dt = Kt - s Mt, DW = Dt diag(wt) and the Schur complement S = K_kk - s M_kk - DW Dt^T of
    /// the eliminated modes (those past the cut by the series).
    fn schur_complement(
        &mut self,
        inputs: &BlockInputs<'_, '_>,
        s: f64,
        (cut, tail): (usize, Option<usize>),
    ) {
        let bs = inputs.basis;
        let (r, n_o) = (bs.r, bs.n_o);
        self.dt.resize(r * n_o, 0.0);
        self.dw.resize(r * n_o, 0.0);
        self.s_mat.resize(r * r, 0.0);
        for (jcol, &wt) in self.wt.iter().enumerate() {
            let (kt, mt) = (bs.kt.col_as_slice(jcol), bs.mt.col_as_slice(jcol));
            let dt = &mut self.dt[jcol * r..(jcol + 1) * r];
            for i in 0..r {
                dt[i] = kt[i] - s * mt[i];
            }
            let dw = &mut self.dw[jcol * r..(jcol + 1) * r];
            for i in 0..r {
                dw[i] = (kt[i] - s * mt[i]) * wt;
            }
        }
        for jcol in 0..r {
            let (kk, mk) = (bs.k_kk.col_as_slice(jcol), bs.m_kk.col_as_slice(jcol));
            let sm = &mut self.s_mat[jcol * r..(jcol + 1) * r];
            for i in 0..r {
                sm[i] = kk[i] - s * mk[i];
            }
        }
        let mut s_mat = MatMut::from_column_major_slice_mut(&mut self.s_mat[..], r, r);
        if cut > 0 {
            let dw = MatRef::from_column_major_slice(&self.dw[..], r, n_o);
            let dt = MatRef::from_column_major_slice(&self.dt[..], r, n_o);
            matmul(
                s_mat.as_mut(),
                Accum::Add,
                dw.get(.., ..cut),
                dt.get(.., ..cut).transpose(),
                -1.0,
                Par::Seq,
            );
        }
        if let Some(which) = tail {
            inputs.tail.subtract(which, s, s_mat);
        }
    }

    /// The kept block [S, Dt_near; Dt_near^T, diag(Lambda_near - s)].
    fn assemble_kept_block(&mut self, inputs: &BlockInputs<'_, '_>, s: f64) {
        let bs = inputs.basis;
        let r = bs.r;
        let size = r + self.near.len();
        self.size = size;
        self.a.clear();
        self.a.resize(size * size, 0.0);
        let mut a = MatMut::from_column_major_slice_mut(&mut self.a[..], size, size);
        for jcol in 0..r {
            let sm = &self.s_mat[jcol * r..(jcol + 1) * r];
            for i in 0..r {
                a[(i, jcol)] = sm[i];
            }
        }
        for (t, &mode) in self.near.iter().enumerate() {
            let dt = &self.dt[mode * r..(mode + 1) * r];
            for i in 0..r {
                a[(i, r + t)] = dt[i];
                a[(r + t, i)] = dt[i];
            }
            a[(r + t, r + t)] = bs.lambda[mode] - s;
        }
    }

    /// Harmonic h's condensed w column and right-hand side:
    /// cw = [wy - DW wz; wz_near], b = [rhs_y - DW rhs_z; rhs_z_near].
    fn condense_columns(&mut self, inputs: &BlockInputs<'_, '_>, h: usize) {
        let (bs, l, rhs) = (inputs.basis, inputs.layout, inputs.rhs);
        let (wy, wz) = (inputs.wy, inputs.wz);
        let (r, n_o) = (bs.r, bs.n_o);
        let rz = &l.harmonic(rhs, h)[r..];
        self.wzb.resize(2 * n_o, 0.0);
        for i in 0..n_o {
            self.wzb[i] = wz[(i, h)];
            self.wzb[n_o + i] = rz[i];
        }
        self.cwb.resize(2 * r, 0.0);
        for i in 0..r {
            self.cwb[i] = wy[(i, h)];
            self.cwb[r + i] = rhs[l.at(h, i)];
        }
        if n_o > 0 {
            let rhs2 = MatRef::from_column_major_slice(&self.wzb[..], n_o, 2);
            let out = MatMut::from_column_major_slice_mut(&mut self.cwb[..], r, 2);
            let dw = MatRef::from_column_major_slice(&self.dw[..], r, n_o);
            matmul(out, Accum::Add, dw, rhs2, -1.0, Par::Seq);
        }
        self.cw.clear();
        self.b.clear();
        self.cw.extend_from_slice(&self.cwb[..r]);
        self.b.extend_from_slice(&self.cwb[r..2 * r]);
        for &mode in &self.near {
            self.cw.push(wz[(mode, h)]);
            self.b.push(rz[mode]);
        }
    }

    /// The parameter row's coefficients on harmonic h's kept coordinates (the contact
    /// displacements and the master, through its row in the kept coordinates).
    fn parameter_row(&mut self, inputs: &BlockInputs<'_, '_>, h: usize) {
        let (bs, jac) = (inputs.basis, inputs.jac);
        self.arc.clear();
        self.arc.resize(self.size, 0.0);
        if jac.arc_y.is_empty() {
            return;
        }
        let kept = inputs.layout.signals(bs.c + 1);
        let am = jac.arc_y[kept.at(bs.c, h)];
        for i in 0..bs.r {
            let mut v = am * bs.master_row[i];
            if i < bs.c {
                v += jac.arc_y[kept.at(i, h)];
            }
            self.arc[i] = v;
        }
    }
    /// Factors the interior block A_II and solves A_II^-1 [A_IB | cw_I | b_I] into `xs`. Returns
    /// false if A_II is too close to singular.
    pub fn eliminate_interior(&mut self) -> bool {
        let (nb, ni, sz) = (self.border.len(), self.interior.len(), self.size);
        if ni == 0 {
            return true;
        }
        let a = MatRef::from_column_major_slice(&self.a[..], sz, sz);
        {
            let mut aii = self.lu.matrix(ni);
            for (jj, &jc) in self.interior.iter().enumerate() {
                for (ii, &ic) in self.interior.iter().enumerate() {
                    aii[(ii, jj)] = a[(ic, jc)];
                }
            }
        }
        if !self.lu.factor() || self.lu.min_pivot_ratio < INTERIOR_PIVOT_RATIO {
            return false;
        }
        let ncols = nb + 2;
        self.xs.clear();
        self.xs.resize(ni * ncols, 0.0);
        let mut xs = MatMut::from_column_major_slice_mut(&mut self.xs[..], ni, ncols);
        for (ii, &ic) in self.interior.iter().enumerate() {
            for (bb, &bc) in self.border.iter().enumerate() {
                xs[(ii, bb)] = a[(ic, bc)];
            }
            xs[(ii, nb)] = self.cw[ic];
            xs[(ii, nb + 1)] = self.b[ic];
        }
        self.lu.solve_in_place(xs);
        true
    }

    /// A_II^-1 [A_IB | cw_I | b_I] (after [`HarmonicBlock::eliminate_interior`]).
    fn interior_solution(&self) -> MatRef<'_, f64> {
        let (nb, ni) = (self.border.len(), self.interior.len());
        MatRef::from_column_major_slice(&self.xs[..ni * (nb + 2)], ni, nb + 2)
    }

    /// Writes the block's Schur complement on its border (matrix, w column, right-hand side and
    /// parameter-row entries) into the reduced system, and subtracts the interior's fill of the
    /// parameter row's w entry and right-hand side from `arc_fill`.
    pub fn add_to_reduced(
        &self,
        rows: ReducedRows,
        mut red: MatMut<'_, f64>,
        reduced_rhs: &mut [f64],
        arc_fill: &mut [f64; 2],
    ) {
        let (nb, sz, off) = (self.border.len(), self.size, rows.offset);
        let a = MatRef::from_column_major_slice(&self.a[..], sz, sz);
        let xs = self.interior_solution();
        for (bb, &br) in self.border.iter().enumerate() {
            let row = off + bb;
            for (cc, &bc) in self.border.iter().enumerate() {
                let mut v = a[(br, bc)];
                for (ii, &ic) in self.interior.iter().enumerate() {
                    v -= a[(br, ic)] * xs[(ii, cc)];
                }
                red[(row, off + cc)] = v;
            }
            let mut vw = self.cw[br];
            let mut vb = self.b[br];
            for (ii, &ic) in self.interior.iter().enumerate() {
                vw -= a[(br, ic)] * xs[(ii, nb)];
                vb -= a[(br, ic)] * xs[(ii, nb + 1)];
            }
            red[(row, rows.iw)] = vw;
            reduced_rhs[row] = vb;
        }
        // Parameter row: border entries, minus the fill from the eliminated interior.
        for (cc, &bc) in self.border.iter().enumerate() {
            let mut v = self.arc[bc];
            for (ii, &ic) in self.interior.iter().enumerate() {
                v -= self.arc[ic] * xs[(ii, cc)];
            }
            red[(rows.iq, off + cc)] = v;
        }
        for (ii, &ic) in self.interior.iter().enumerate() {
            arc_fill[0] -= self.arc[ic] * xs[(ii, nb)];
            arc_fill[1] -= self.arc[ic] * xs[(ii, nb + 1)];
        }
    }

    /// The block's step from the reduced solution: `border_step` (the reduced unknowns from the
    /// block's offset on) for the border, back-substitution for the interior.
    pub fn recover_step(&mut self, border_step: &[f64], dw: f64) {
        let nb = self.border.len();
        self.delta.clear();
        self.delta.resize(self.size, 0.0);
        for (bb, &bc) in self.border.iter().enumerate() {
            self.delta[bc] = border_step[bb];
        }
        let ni = self.interior.len();
        let xs = MatRef::from_column_major_slice(&self.xs[..ni * (nb + 2)], ni, nb + 2);
        for (ii, &ic) in self.interior.iter().enumerate() {
            let mut v = xs[(ii, nb + 1)] - xs[(ii, nb)] * dw;
            for bb in 0..nb {
                v -= xs[(ii, bb)] * border_step[bb];
            }
            self.delta[ic] = v;
        }
    }
}
