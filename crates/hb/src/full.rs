//! The uncondensed linear model: physical coordinates, dense LU of the whole
//! (n (N+1) + 2)-square Newton matrix. Used for validation of the exact condensation and for small
//! systems (`Condensation::None`).

use faer::linalg::matmul::matmul;
use faer::{Accum, Mat, Par};

use crate::error::HbError;
use crate::layout::HarmonicLayout;
use crate::linear_model::{contact_jacobian, JacobianData, LinearModel};
use crate::system::System;
use nlmodes_dense::DenseLu;

pub struct FullModel {
    layout: HarmonicLayout,
    k: Mat<f64>,
    m: Mat<f64>,
    a: Mat<f64>,
    master_row: Vec<f64>,
    weights: Vec<f64>,
    kx: Mat<f64>,
    mx: Mat<f64>,
    lu: DenseLu,
}

impl FullModel {
    /// The model of `system` for harmonics 0..=`harmonics`.
    pub fn new(system: &System, harmonics: usize) -> Self {
        let n = system.n_dofs();
        let mut master_row = vec![0.0; n];
        master_row[system.master()] = 1.0;
        let weights = (0..n)
            .map(|i| 1.0 / system.stiffness()[(i, i)].sqrt())
            .collect();
        Self {
            layout: HarmonicLayout::new(harmonics, n),
            k: system.stiffness().to_owned(),
            m: system.mass().to_owned(),
            a: system.contact_rows().to_owned(),
            master_row,
            weights,
            kx: Mat::zeros(0, 0),
            mx: Mat::zeros(0, 0),
            lu: DenseLu::default(),
        }
    }
}

impl LinearModel for FullModel {
    fn layout(&self) -> HarmonicLayout {
        self.layout
    }

    fn contact_coefficients(&self, x: &[f64], out: &mut [f64]) {
        let l = self.layout;
        // out (signal-major) = (A X)^T, written through its (N+1) x c view.
        matmul(
            l.signals(self.a.nrows()).view_mut(out),
            Accum::Replace,
            l.view(x).transpose(),
            self.a.transpose(),
            1.0,
            Par::Seq,
        );
    }

    fn master_row(&self) -> &[f64] {
        &self.master_row
    }

    fn harmonic_residual(&mut self, omega: f64, x: &[f64], lambda_coef: &[f64], out: &mut [f64]) {
        let l = self.layout;
        let (n, nh, c) = (l.dim(), l.count(), self.a.nrows());
        let xm = l.view(x);
        if self.kx.nrows() != n || self.kx.ncols() != nh {
            self.kx = Mat::zeros(n, nh);
            self.mx = Mat::zeros(n, nh);
        }
        matmul(
            self.kx.as_mut(),
            Accum::Replace,
            self.k.as_ref(),
            xm,
            1.0,
            Par::Seq,
        );
        matmul(
            self.mx.as_mut(),
            Accum::Replace,
            self.m.as_ref(),
            xm,
            1.0,
            Par::Seq,
        );
        let mut o = l.view_mut(out);
        for h in 0..nh {
            let s = (h as f64 * omega).powi(2);
            for i in 0..n {
                o[(i, h)] = self.kx[(i, h)] - s * self.mx[(i, h)];
            }
        }
        // + A^T lambda_n
        let lam = l.signals(c).view(lambda_coef);
        matmul(
            o.as_mut(),
            Accum::Add,
            self.a.transpose(),
            lam.transpose(),
            1.0,
            Par::Seq,
        );
    }

    fn row_weights(&self) -> &[f64] {
        &self.weights
    }

    fn solve_step(&mut self, jac: &JacobianData<'_>, rhs: &mut [f64]) -> Result<(), HbError> {
        let l = self.layout;
        let (n, nh, np) = (l.dim(), l.count(), l.moments());
        let size = l.newton_len();
        let (iw, iq) = (l.omega_index(), l.omega_index() + 1);
        let w = jac.omega;
        let xm = l.view(jac.x);
        let mx = &self.m * xm;
        let mut a = self.lu.matrix(size);
        for h in 0..nh {
            let s = (h as f64 * w).powi(2);
            let ds = -2.0 * (h * h) as f64 * w;
            for j in 0..n {
                for i in 0..n {
                    a[(l.at(h, i), l.at(h, j))] = self.k[(i, j)] - s * self.m[(i, j)];
                }
            }
            for i in 0..n {
                a[(l.at(h, i), iw)] = ds * mx[(i, h)];
            }
        }
        for (ai, &jrow) in jac.active.iter().enumerate() {
            let mom = &jac.moments[ai * np..(ai + 1) * np];
            for h in 0..nh {
                for hp in 0..nh {
                    let v = contact_jacobian(mom, h, hp);
                    if v == 0.0 {
                        continue;
                    }
                    for j in 0..n {
                        let aj = self.a[(jrow, j)] * v;
                        if aj == 0.0 {
                            continue;
                        }
                        for i in 0..n {
                            a[(l.at(h, i), l.at(hp, j))] += self.a[(jrow, i)] * aj;
                        }
                    }
                }
            }
        }
        for i in 0..n {
            a[(iw, l.at(1, i))] = jac.norm_scale * self.master_row[i];
        }
        a[(iw, iq)] = -jac.norm_scale;
        a[(iq, iw)] = jac.arc_w;
        a[(iq, iq)] = jac.arc_q;
        if !jac.arc_y.is_empty() {
            let kept = l.signals(self.a.nrows() + 1);
            let c = self.a.nrows();
            for h in 0..nh {
                for i in 0..n {
                    let mut v = jac.arc_y[kept.at(c, h)] * self.master_row[i];
                    for j in 0..c {
                        v += jac.arc_y[kept.at(j, h)] * self.a[(j, i)];
                    }
                    a[(iq, l.at(h, i))] = v;
                }
            }
        }
        if !self.lu.factor() {
            return Err(HbError::Decomposition {
                what: "LU of the uncondensed Newton matrix",
                detail: "the matrix is singular".to_string(),
            });
        }
        self.lu.solve_slice(&mut rhs[..size]);
        Ok(())
    }

    fn model_to_physical(&self, x: &[f64], count: usize, u: &mut [f64]) {
        let n = self.dim() * count;
        u[..n].copy_from_slice(&x[..n]);
    }

    fn physical_to_model(&self, u: &[f64], count: usize, x: &mut [f64]) {
        let n = self.dim() * count;
        x[..n].copy_from_slice(&u[..n]);
    }
}
