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
use crate::error::HbError;
use crate::harmonic_block::{BlockInputs, HarmonicBlock, ReducedRows, NOT_IN};
use crate::layout::HarmonicLayout;
use crate::linear_model::{contact_jacobian, JacobianData, LinearModel};
use crate::modal_tail::ModalTail;
use crate::system::System;
use nlmodes_dense::DenseLu;

/// Relative linear residual above which a fast step is redone with the full kept system.
const STEP_CHECK_TOLERANCE: f64 = 1e-9;

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
            fallbacks: 0,
        })
    }

    /// Level 1 for every harmonic: kept blocks, w columns and right-hand sides (each harmonic's
    /// block from shared inputs only).
    fn build_blocks(&mut self, jac: &JacobianData<'_>, rhs: &[f64]) {
        let (wy, wz) = self.frequency_columns(jac);
        let nh = self.layout.count();
        self.blocks.resize_with(nh, HarmonicBlock::default);
        let inputs = BlockInputs {
            basis: &self.basis,
            tail: &self.tail,
            window: self.window,
            layout: self.layout,
            jac,
            rhs,
            wy: &wy,
            wz: &wz,
        };
        for (h, blk) in self.blocks.iter_mut().enumerate() {
            blk.build(&inputs, h);
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
