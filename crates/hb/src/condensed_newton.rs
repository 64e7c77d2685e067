//! The condensed linear model: Newton in the (y, z) coordinates of [`CondensedBasis`], with the
//! "others" eliminated inside the linear algebra of each step.
//!
//! A Newton step is solved in two exact levels:
//! 1. per harmonic n, every other-mode z_i away from resonance (|Lambda_i - s| >= window Lambda_i,
//!    s = (n w)^2) is eliminated through the diagonal D_oo: the Schur complement
//!    S_n = D_kk - D_ko D_oo^-1 D_ok costs O(r^2 n_o) summed term by term; the high modes
//!    (Lambda_i >= 4 s) are summed by a precomputed series exact to round-off (`modal_tail`), so
//!    only the modes below the cut cost O(r^2) each, plus O(r n_o) for the w column and the
//!    right-hand side. Modes near resonance stay explicit unknowns of the small per-harmonic block.
//! 2. per harmonic, the coordinates that carry no active contact and are not the master are
//!    eliminated from that block by a small LU; what remains (active contact coordinates and the
//!    master, for all harmonics, plus w and q) is the only system coupling harmonics and is solved
//!    by a dense LU of size about (c_active + 1)(N + 1) + 2. If a per-harmonic block is nearly
//!    singular (n w at an eigenfrequency of the structure with those coordinates held), or if the
//!    step fails a residual check, the step is redone with every kept coordinate in the coupled
//!    system (dense LU of size about (c + 1)(N + 1) + 2) - still exact, only slower.

use faer::linalg::matmul::matmul;
use faer::{Accum, Mat, MatMut, MatRef, Par};

use crate::condensation_basis::CondensedBasis;
use crate::dense::DenseLu;
use crate::error::HbError;
use crate::layout::HarmonicLayout;
use crate::linear_model::{contact_jacobian, JacobianData, LinearModel};
use crate::modal_tail::ModalTail;
use crate::system::System;

/// Pivot ratio of a per-harmonic interior block below which the step is redone without it.
const INTERIOR_PIVOT_RATIO: f64 = 1e-12;
/// Relative linear residual above which a fast step is redone with the full kept system.
const STEP_CHECK_TOLERANCE: f64 = 1e-9;
const NOT_IN: usize = usize::MAX;

#[derive(Default)]
struct HarmonicBlock {
    near: Vec<usize>,
    size: usize,
    /// Kept block (size x size, column-major).
    a: Vec<f64>,
    cw: Vec<f64>,
    b: Vec<f64>,
    /// Parameter-row coefficients on the kept coordinates of this harmonic.
    arc: Vec<f64>,
    /// 1 / (Lambda_i - s) for eliminated modes, 0 for near ones.
    wt: Vec<f64>,
    border: Vec<usize>,
    interior: Vec<usize>,
    /// Position of a kept coordinate in `border` (or NOT_IN).
    border_pos: Vec<usize>,
    lu: DenseLu,
    /// A_II^-1 [A_IB | cw_I | b_I] (n_I x (n_B + 2), column-major).
    xs: Vec<f64>,
    /// Solved kept-block step.
    delta: Vec<f64>,
}

/// Adds the contact coupling between harmonics on the active contact coordinates to the reduced
/// matrix (the blocks' borders placed at `offsets`).
fn add_contact_coupling(
    blocks: &[HarmonicBlock],
    offsets: &[usize],
    layout: HarmonicLayout,
    jac: &JacobianData<'_>,
    mut red: MatMut<'_, f64>,
) {
    let (nh, np) = (layout.count(), layout.moments());
    for (ai, &j) in jac.active.iter().enumerate() {
        let mom = &jac.moments[ai * np..(ai + 1) * np];
        for h in 0..nh {
            let row = offsets[h] + blocks[h].border_pos[j];
            for hp in 0..nh {
                let col = offsets[hp] + blocks[hp].border_pos[j];
                red[(row, col)] += contact_jacobian(mom, h, hp);
            }
        }
    }
}

/// Where a block's rows go in the reduced system: its border starts at `offset`; `iw` and `iq`
/// are the w column (and normalization row) and the parameter row.
#[derive(Clone, Copy)]
struct ReducedRows {
    offset: usize,
    iw: usize,
    iq: usize,
}

impl HarmonicBlock {
    /// Factors the interior block A_II and solves A_II^-1 [A_IB | cw_I | b_I] into `xs`. Returns
    /// false if A_II is too close to singular.
    fn eliminate_interior(&mut self) -> bool {
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
    fn add_to_reduced(
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
    fn recover_step(&mut self, border_step: &[f64], dw: f64) {
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

pub struct CondensedModel {
    layout: HarmonicLayout,
    basis: CondensedBasis,
    tail: ModalTail,
    weights: Vec<f64>,
    window: f64,
    blocks: Vec<HarmonicBlock>,
    reduced: DenseLu,
    reduced_rhs: Vec<f64>,
    offsets: Vec<usize>,
    dt: Mat<f64>,
    dw: Mat<f64>,
    s_mat: Mat<f64>,
    /// Scratch: [wz, rhs_z] of one harmonic and [cw, b] of its kept block.
    wzb: Vec<f64>,
    cwb: Vec<f64>,
    /// Number of steps redone with the full kept system (diagnostics).
    pub fallbacks: usize,
}

impl CondensedModel {
    /// The condensed model of `system` for harmonics 0..=`harmonics`, with the resonance window
    /// of [`crate::NewtonSettings::resonance_window`].
    pub fn new(system: &System, window: f64, harmonics: usize) -> Result<Self, HbError> {
        let basis = CondensedBasis::new(system)?;
        let mut weights = Vec::with_capacity(basis.r + basis.n_o);
        for i in 0..basis.r {
            weights.push(1.0 / basis.k_kk[(i, i)].sqrt());
        }
        for &l in &basis.lambda {
            weights.push(1.0 / l.sqrt());
        }
        let (r, n_o) = (basis.r, basis.n_o);
        // Series ratio: s <= rho Lambda also keeps the tail modes out of the resonance window
        // (|Lambda - s| < window Lambda needs s > (1 - window) Lambda).
        let rho = (0.5 * (1.0 - window)).min(0.25);
        let tail = ModalTail::new(&basis.lambda, &basis.kt, &basis.mt, rho);
        Ok(Self {
            layout: HarmonicLayout::new(harmonics, r + n_o),
            basis,
            tail,
            weights,
            window,
            blocks: Vec::new(),
            reduced: DenseLu::default(),
            reduced_rhs: Vec::new(),
            offsets: Vec::new(),
            dt: Mat::zeros(r, n_o),
            dw: Mat::zeros(r, n_o),
            s_mat: Mat::zeros(r, r),
            wzb: Vec::new(),
            cwb: Vec::new(),
            fallbacks: 0,
        })
    }

    /// Level 1 for every harmonic: kept blocks, w columns and right-hand sides.
    fn build_blocks(&mut self, jac: &JacobianData<'_>, rhs: &[f64]) {
        let (wy, wz) = self.frequency_columns(jac);
        let nh = self.layout.count();
        self.blocks.resize_with(nh, HarmonicBlock::default);
        for h in 0..nh {
            let s = (h as f64 * jac.omega).powi(2);
            let split = self.select_near(h, s);
            self.schur_complement(h, s, split);
            self.assemble_kept_block(h, s);
            self.condense_columns(h, &wy, &wz, rhs);
            self.parameter_row(h, jac);
        }
    }

    /// The w-derivative columns of every harmonic n, -2 n^2 w [M_kk y + Mt z; Mt^T y + z]:
    /// (kept part, other-mode part), one column per harmonic.
    fn frequency_columns(&self, jac: &JacobianData<'_>) -> (Mat<f64>, Mat<f64>) {
        let bs = &self.basis;
        let l = self.layout;
        let (r, n_o, nh) = (bs.r, bs.n_o, l.count());
        let w = jac.omega;
        let xm = l.view(jac.x);
        let (y, z) = (xm.get(..r, ..), xm.get(r.., ..));
        let mut wy = &bs.m_kk * y;
        matmul(wy.as_mut(), Accum::Add, bs.mt.as_ref(), z, 1.0, Par::Seq);
        let mut wz = bs.mt.transpose() * y;
        for h in 0..nh {
            let f = -2.0 * (h * h) as f64 * w;
            for i in 0..r {
                wy[(i, h)] *= f;
            }
            for i in 0..n_o {
                wz[(i, h)] = f * (wz[(i, h)] + z[(i, h)]);
            }
        }
        (wy, wz)
    }

    /// Sorts the other modes of harmonic h at s = (n w)^2 into those near resonance (explicit in
    /// the block) and the eliminated ones (weight 1 / (Lambda_i - s)). Returns the modal-tail
    /// split: modes from the cut on are summed by the precomputed series (`modal_tail`).
    fn select_near(&mut self, h: usize, s: f64) -> (usize, Option<usize>) {
        let bs = &self.basis;
        let blk = &mut self.blocks[h];
        blk.near.clear();
        blk.wt.resize(bs.n_o, 0.0);
        let (cut, tail) = self.tail.split(&bs.lambda, s);
        for i in 0..bs.n_o {
            let lam_i = bs.lambda[i];
            if i < cut && (lam_i - s).abs() < self.window * lam_i {
                blk.near.push(i);
                blk.wt[i] = 0.0;
            } else {
                blk.wt[i] = 1.0 / (lam_i - s);
            }
        }
        (cut, tail)
    }

    /// Dt = Kt - s Mt, DW = Dt diag(wt) and the Schur complement S = K_kk - s M_kk - DW Dt^T of
    /// harmonic h's eliminated modes (those past the cut by the series).
    fn schur_complement(&mut self, h: usize, s: f64, (cut, tail): (usize, Option<usize>)) {
        let bs = &self.basis;
        let r = bs.r;
        let wts = &self.blocks[h].wt;
        for (jcol, &wt) in wts.iter().enumerate() {
            let (kt, mt) = (bs.kt.col_as_slice(jcol), bs.mt.col_as_slice(jcol));
            let dt = self.dt.col_as_slice_mut(jcol);
            for i in 0..r {
                dt[i] = kt[i] - s * mt[i];
            }
            let dw = self.dw.col_as_slice_mut(jcol);
            for i in 0..r {
                dw[i] = (kt[i] - s * mt[i]) * wt;
            }
        }
        for jcol in 0..r {
            let (kk, mk) = (bs.k_kk.col_as_slice(jcol), bs.m_kk.col_as_slice(jcol));
            let sm = self.s_mat.col_as_slice_mut(jcol);
            for i in 0..r {
                sm[i] = kk[i] - s * mk[i];
            }
        }
        if cut > 0 {
            matmul(
                self.s_mat.as_mut(),
                Accum::Add,
                self.dw.get(.., ..cut),
                self.dt.get(.., ..cut).transpose(),
                -1.0,
                Par::Seq,
            );
        }
        if let Some(which) = tail {
            self.tail.subtract(which, s, self.s_mat.as_mut());
        }
    }

    /// Harmonic h's kept block [S, Dt_near; Dt_near^T, diag(Lambda_near - s)].
    fn assemble_kept_block(&mut self, h: usize, s: f64) {
        let (bs, blk) = (&self.basis, &mut self.blocks[h]);
        let r = bs.r;
        let size = r + blk.near.len();
        blk.size = size;
        blk.a.clear();
        blk.a.resize(size * size, 0.0);
        let mut a = MatMut::from_column_major_slice_mut(&mut blk.a[..], size, size);
        for jcol in 0..r {
            for i in 0..r {
                a[(i, jcol)] = self.s_mat[(i, jcol)];
            }
        }
        for (t, &mode) in blk.near.iter().enumerate() {
            for i in 0..r {
                a[(i, r + t)] = self.dt[(i, mode)];
                a[(r + t, i)] = self.dt[(i, mode)];
            }
            a[(r + t, r + t)] = bs.lambda[mode] - s;
        }
    }

    /// Harmonic h's condensed w column and right-hand side:
    /// cw = [wy - DW wz; wz_near], b = [rhs_y - DW rhs_z; rhs_z_near].
    fn condense_columns(&mut self, h: usize, wy: &Mat<f64>, wz: &Mat<f64>, rhs: &[f64]) {
        let (bs, l) = (&self.basis, self.layout);
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
            matmul(out, Accum::Add, self.dw.as_ref(), rhs2, -1.0, Par::Seq);
        }
        let blk = &mut self.blocks[h];
        blk.cw.clear();
        blk.b.clear();
        blk.cw.extend_from_slice(&self.cwb[..r]);
        blk.b.extend_from_slice(&self.cwb[r..2 * r]);
        for &mode in &blk.near {
            blk.cw.push(wz[(mode, h)]);
            blk.b.push(rz[mode]);
        }
    }

    /// The parameter row's coefficients on harmonic h's kept coordinates (the contact
    /// displacements and the master, through its row in the kept coordinates).
    fn parameter_row(&mut self, h: usize, jac: &JacobianData<'_>) {
        let (bs, blk) = (&self.basis, &mut self.blocks[h]);
        blk.arc.clear();
        blk.arc.resize(blk.size, 0.0);
        if jac.arc_y.is_empty() {
            return;
        }
        let kept = self.layout.signals(bs.c + 1);
        let am = jac.arc_y[kept.at(bs.c, h)];
        for i in 0..bs.r {
            let mut v = am * bs.master_row[i];
            if i < bs.c {
                v += jac.arc_y[kept.at(i, h)];
            }
            blk.arc[i] = v;
        }
    }

    /// Level 2 with the given border choice. Returns false if an interior block is too close to
    /// singular or the reduced matrix is singular.
    fn solve_reduced(&mut self, jac: &JacobianData<'_>, rhs: &[f64], full_border: bool) -> bool {
        let total = self.select_border(jac, full_border);
        let size = total + 2;
        let (iw, iq) = (total, total + 1);
        self.reduced_rhs.clear();
        self.reduced_rhs.resize(size, 0.0);
        let mut red = self.reduced.matrix(size);
        // Fill of the parameter row's w entry and right-hand side from the eliminated interiors.
        let mut arc_fill = [0.0_f64; 2];
        for (h, blk) in self.blocks.iter_mut().enumerate() {
            if !blk.eliminate_interior() {
                return false;
            }
            let rows = ReducedRows {
                offset: self.offsets[h],
                iw,
                iq,
            };
            blk.add_to_reduced(rows, red.as_mut(), &mut self.reduced_rhs, &mut arc_fill);
        }
        add_contact_coupling(&self.blocks, &self.offsets, self.layout, jac, red.as_mut());
        let bs = &self.basis;
        for &i in &bs.master_support {
            red[(iw, self.offsets[1] + self.blocks[1].border_pos[i])] =
                jac.norm_scale * bs.master_row[i];
        }
        red[(iw, iq)] = -jac.norm_scale;
        red[(iq, iw)] = jac.arc_w + arc_fill[0];
        red[(iq, iq)] = jac.arc_q;
        let l = self.layout;
        self.reduced_rhs[iw] = rhs[l.omega_index()];
        self.reduced_rhs[iq] = rhs[l.omega_index() + 1] + arc_fill[1];
        if !self.reduced.factor() {
            return false;
        }
        self.reduced.solve_slice(&mut self.reduced_rhs);
        let dw = self.reduced_rhs[iw];
        for (h, blk) in self.blocks.iter_mut().enumerate() {
            blk.recover_step(&self.reduced_rhs[self.offsets[h]..], dw);
        }
        true
    }

    /// Splits each block's kept coordinates into the border (active contact coordinates and the
    /// master support, or all of them with `full_border`) and the interior; sets the offsets of
    /// the blocks' borders in the reduced system and returns their total size.
    fn select_border(&mut self, jac: &JacobianData<'_>, full_border: bool) -> usize {
        let bs = &self.basis;
        let mut total = 0;
        self.offsets.clear();
        for blk in self.blocks.iter_mut() {
            blk.border.clear();
            blk.interior.clear();
            blk.border_pos.clear();
            blk.border_pos.resize(blk.size, NOT_IN);
            for i in 0..blk.size {
                let keep = full_border
                    || (i < bs.c && jac.active.binary_search(&i).is_ok())
                    || bs.master_support.contains(&i);
                if keep {
                    blk.border_pos[i] = blk.border.len();
                    blk.border.push(i);
                } else {
                    blk.interior.push(i);
                }
            }
            self.offsets.push(total);
            total += blk.border.len();
        }
        total
    }

    /// Relative residual of the kept system for the solved step (independent of the elimination).
    fn kept_residual(&self, jac: &JacobianData<'_>, rhs: &[f64]) -> f64 {
        let bs = &self.basis;
        let l = self.layout;
        let (nh, np) = (l.count(), l.moments());
        let dw = self.reduced_rhs[self.reduced_rhs.len() - 2];
        let dq = self.reduced_rhs[self.reduced_rhs.len() - 1];
        let (mut num, mut den) = (0.0_f64, 0.0_f64);
        let mut contact = vec![0.0; bs.c * nh];
        for (ai, &j) in jac.active.iter().enumerate() {
            let mom = &jac.moments[ai * np..(ai + 1) * np];
            for h in 0..nh {
                let mut v = 0.0;
                for hp in 0..nh {
                    v += contact_jacobian(mom, h, hp) * self.blocks[hp].delta[j];
                }
                contact[j * nh + h] = v;
            }
        }
        for (h, blk) in self.blocks.iter().enumerate() {
            let sz = blk.size;
            let a = MatRef::from_column_major_slice(&blk.a[..], sz, sz);
            for i in 0..sz {
                let mut v = blk.cw[i] * dw;
                let mut mag = (blk.cw[i] * dw).abs() + blk.b[i].abs();
                for l in 0..sz {
                    let t = a[(i, l)] * blk.delta[l];
                    v += t;
                    mag += t.abs();
                }
                if i < bs.c {
                    v += contact[i * nh + h];
                    mag += contact[i * nh + h].abs();
                }
                num = num.max((v - blk.b[i]).abs());
                den = den.max(mag);
            }
        }
        let mut vn = -jac.norm_scale * dq;
        for &i in &bs.master_support {
            vn += jac.norm_scale * bs.master_row[i] * self.blocks[1].delta[i];
        }
        num = num.max((vn - rhs[l.omega_index()]).abs());
        let mut va = jac.arc_w * dw + jac.arc_q * dq;
        for blk in &self.blocks {
            va += blk
                .arc
                .iter()
                .zip(&blk.delta)
                .map(|(a, b)| a * b)
                .sum::<f64>();
        }
        num = num.max((va - rhs[l.omega_index() + 1]).abs());
        if den > 0.0 {
            num / den
        } else {
            num
        }
    }
}

impl LinearModel for CondensedModel {
    fn layout(&self) -> HarmonicLayout {
        self.layout
    }

    fn contact_coefficients(&self, x: &[f64], out: &mut [f64]) {
        // The first c kept coordinates are the contact displacements A_j u.
        let (l, c) = (self.layout, self.basis.c);
        let signals = l.signals(c);
        for j in 0..c {
            for h in 0..l.count() {
                out[signals.at(j, h)] = x[l.at(h, j)];
            }
        }
    }

    fn master_row(&self) -> &[f64] {
        &self.basis.master_row
    }

    fn harmonic_residual(&mut self, omega: f64, x: &[f64], lambda_coef: &[f64], out: &mut [f64]) {
        let (bs, l) = (&self.basis, self.layout);
        let (r, n_o, nh, c) = (bs.r, bs.n_o, l.count(), bs.c);
        let signals = l.signals(c);
        let xm = l.view(x);
        let (y, z) = (xm.get(..r, ..), xm.get(r.., ..));
        let mut ky = &bs.k_kk * y;
        matmul(ky.as_mut(), Accum::Add, bs.kt.as_ref(), z, 1.0, Par::Seq);
        let mut my = &bs.m_kk * y;
        matmul(my.as_mut(), Accum::Add, bs.mt.as_ref(), z, 1.0, Par::Seq);
        let kty = bs.kt.transpose() * y;
        let mty = bs.mt.transpose() * y;
        for h in 0..nh {
            let s = (h as f64 * omega).powi(2);
            let o = l.harmonic_mut(out, h);
            for i in 0..r {
                o[i] = ky[(i, h)] - s * my[(i, h)];
            }
            for i in 0..c {
                o[i] += lambda_coef[signals.at(i, h)];
            }
            for i in 0..n_o {
                o[r + i] = kty[(i, h)] - s * mty[(i, h)] + (bs.lambda[i] - s) * z[(i, h)];
            }
        }
    }

    fn row_weights(&self) -> &[f64] {
        &self.weights
    }

    fn solve_step(&mut self, jac: &JacobianData<'_>, rhs: &mut [f64]) -> Result<(), HbError> {
        let (r, n_o) = (self.basis.r, self.basis.n_o);
        let l = self.layout;
        let nh = l.count();
        self.build_blocks(jac, rhs);
        let fast_ok = self.solve_reduced(jac, rhs, false)
            && self.kept_residual(jac, rhs) <= STEP_CHECK_TOLERANCE;
        if !fast_ok {
            self.fallbacks += 1;
            if !self.solve_reduced(jac, rhs, true) {
                return Err(HbError::Decomposition {
                    what: "LU of the condensed Newton matrix",
                    detail: "the matrix is singular".to_string(),
                });
            }
        }
        let dw = self.reduced_rhs[self.reduced_rhs.len() - 2];
        let dq = self.reduced_rhs[self.reduced_rhs.len() - 1];
        // Recover the eliminated modes: dz = wt (rhs_z - Dt^T dy - wz dw).
        let bs = &self.basis;
        let dy = Mat::from_fn(r, nh, |i, h| self.blocks[h].delta[i]);
        let kty = bs.kt.transpose() * &dy;
        let mty = bs.mt.transpose() * &dy;
        let xm = l.view(jac.x);
        let (y, z) = (xm.get(..r, ..), xm.get(r.., ..));
        let mtyx = bs.mt.transpose() * y;
        for h in 0..nh {
            let s = (h as f64 * jac.omega).powi(2);
            let f = -2.0 * (h * h) as f64 * jac.omega;
            let blk = &self.blocks[h];
            let (dy, dz) = l.harmonic_mut(rhs, h).split_at_mut(r);
            dy.copy_from_slice(&blk.delta[..r]);
            for i in 0..n_o {
                let wz = f * (mtyx[(i, h)] + z[(i, h)]);
                dz[i] = blk.wt[i] * (dz[i] - (kty[(i, h)] - s * mty[(i, h)]) - wz * dw);
            }
            for (t, &mode) in blk.near.iter().enumerate() {
                dz[mode] = blk.delta[r + t];
            }
        }
        rhs[l.omega_index()] = dw;
        rhs[l.omega_index() + 1] = dq;
        Ok(())
    }

    fn model_to_physical(&self, x: &[f64], count: usize, u: &mut [f64]) {
        self.basis.model_to_physical(x, count, u);
    }

    fn physical_to_model(&self, u: &[f64], count: usize, x: &mut [f64]) {
        self.basis.physical_to_model(u, count, x);
    }
}
