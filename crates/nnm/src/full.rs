//! The uncondensed linear model: physical coordinates, dense LU of the whole
//! (n (N+1) + 2)-square Newton matrix. Used for validation of the exact condensation and for small
//! systems (`Condensation::None`).

use faer::linalg::matmul::matmul;
use faer::{Accum, Mat, MatMut, MatRef, Par};

use crate::dense::DenseLu;
use crate::error::NnmError;
use crate::newton::{contact_jacobian, JacobianData, LinearModel};
use crate::system::System;

pub(crate) struct FullModel {
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
    pub fn new(system: &System) -> Self {
        let n = system.n_dofs();
        let mut master_row = vec![0.0; n];
        master_row[system.master()] = 1.0;
        let weights = (0..n)
            .map(|i| 1.0 / system.stiffness()[(i, i)].sqrt())
            .collect();
        Self {
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
    fn dim(&self) -> usize {
        self.k.nrows()
    }

    fn contact_coefficients(&self, x: &[f64], harmonics: usize, out: &mut [f64]) {
        let (n, nh, c) = (self.dim(), harmonics + 1, self.a.nrows());
        let xm = MatRef::from_column_major_slice(&x[..n * nh], n, nh);
        // out (c x nh, row-major j * nh + h) = A X, written through a transposed view.
        let mut o = MatMut::from_column_major_slice_mut(&mut out[..c * nh], nh, c);
        matmul(
            o.as_mut(),
            Accum::Replace,
            xm.transpose(),
            self.a.transpose(),
            1.0,
            Par::Seq,
        );
    }

    fn master_row(&self) -> &[f64] {
        &self.master_row
    }

    fn harmonic_residual(
        &mut self,
        omega: f64,
        x: &[f64],
        harmonics: usize,
        lambda_coef: &[f64],
        out: &mut [f64],
    ) {
        let (n, nh, c) = (self.dim(), harmonics + 1, self.a.nrows());
        let xm = MatRef::from_column_major_slice(&x[..n * nh], n, nh);
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
        let mut o = MatMut::from_column_major_slice_mut(&mut out[..n * nh], n, nh);
        for h in 0..nh {
            let s = (h as f64 * omega).powi(2);
            for i in 0..n {
                o[(i, h)] = self.kx[(i, h)] - s * self.mx[(i, h)];
            }
        }
        // + A^T lambda_n
        let lam = MatRef::from_column_major_slice(&lambda_coef[..c * nh], nh, c);
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

    fn solve_step(&mut self, jac: &JacobianData<'_>, rhs: &mut [f64]) -> Result<(), NnmError> {
        let (n, nh) = (self.dim(), jac.harmonics + 1);
        let size = n * nh + 2;
        let (iw, iq) = (n * nh, n * nh + 1);
        let np = 2 * jac.harmonics + 1;
        let w = jac.omega;
        let xm = MatRef::from_column_major_slice(&jac.x[..n * nh], n, nh);
        let mx = &self.m * xm;
        let mut a = self.lu.matrix(size);
        for h in 0..nh {
            let s = (h as f64 * w).powi(2);
            let ds = -2.0 * (h * h) as f64 * w;
            for j in 0..n {
                for i in 0..n {
                    a[(h * n + i, h * n + j)] = self.k[(i, j)] - s * self.m[(i, j)];
                }
            }
            for i in 0..n {
                a[(h * n + i, iw)] = ds * mx[(i, h)];
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
                            a[(h * n + i, hp * n + j)] += self.a[(jrow, i)] * aj;
                        }
                    }
                }
            }
        }
        for i in 0..n {
            a[(iw, n + i)] = jac.norm_scale * self.master_row[i];
        }
        a[(iw, iq)] = -jac.norm_scale;
        a[(iq, iw)] = jac.arc_w;
        a[(iq, iq)] = jac.arc_q;
        if !jac.arc_y.is_empty() {
            let c = self.a.nrows();
            for h in 0..nh {
                for i in 0..n {
                    let mut v = jac.arc_y[c * nh + h] * self.master_row[i];
                    for j in 0..c {
                        v += jac.arc_y[j * nh + h] * self.a[(j, i)];
                    }
                    a[(iq, h * n + i)] = v;
                }
            }
        }
        if !self.lu.factor() {
            return Err(NnmError::Decomposition {
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
