//! The linear part of the forced harmonic balance in modal coordinates, and its exact
//! condensation onto the contact coordinates (DESIGN §10.4).
//!
//! With the mass-normalized modes Phi of (K, M) (every mode of the reduced model: no
//! truncation), z = Phi^T M u, and the full basis u = u_0 + sum_n (a_n cos nWt + b_n sin nWt),
//! harmonic n >= 1 of M u'' + C u' + K u = f - A^T lambda reads
//!
//!   Z_n [z^c; z^s] = [r^c; r^s],  Z_n = [[D_n, E_n], [-E_n, D_n]],
//!   D_n = diag(w_k^2) - (n W)^2 I,  E_n = n W Phi^T C Phi,  r = Phi^T (f_n - A^T Lambda_n),
//!
//! and D_0 z_0 = r_0 for the mean. The contact coordinates y = A u = Psi z (Psi = A Phi) of the
//! linear response to the load and the contact forces are y = y_F(W) - G(W) Lambda with the
//! contact compliance G = Psi Z^-1 Psi^T, block-diagonal over harmonics: the exact condensation.
//! Rayleigh and modal damping make Phi^T C Phi diagonal and Z_n^-1 a 2 x 2 block per mode; a
//! general C is solved per harmonic with a dense LU of Z_n.

use faer::linalg::matmul::matmul;
use faer::{Accum, Mat, MatRef, Par};

use crate::compliance::ContactCompliance;
use nlmodes_dense::DenseLu;
use nlmodes_hb::{FullBasis, HbError, System};

use crate::error::ForcedError;
use crate::load::Load;

/// A B on the calling thread: the products of a forced solve are small (tens to hundreds of
/// rows) and many, and the levels of a study run in parallel instead (threads spinning on
/// 100 x 100 products cost more than the products).
pub(crate) fn product(a: MatRef<'_, f64>, b: MatRef<'_, f64>) -> Mat<f64> {
    let mut out = Mat::zeros(a.nrows(), b.ncols());
    matmul(out.as_mut(), Accum::Replace, a, b, 1.0, Par::Seq);
    out
}

/// Phi^T C Phi, diagonal when it is (to 1e-12 of its largest entry).
#[derive(Clone, Debug)]
enum ModalDamping {
    Diagonal(Vec<f64>),
    Full(Mat<f64>),
}

/// The linear structure in modal coordinates, with its load.
#[derive(Clone, Debug)]
pub struct ModalDynamics {
    eigenvalues: Vec<f64>,
    phi: Mat<f64>,
    psi: Mat<f64>,
    damping: ModalDamping,
    /// Modal load Phi^T f per coefficient index of the full basis (n x (2N + 1)).
    load: Mat<f64>,
    /// The rows' modal products, (c c) x n: row j c + jr holds psi_jk psi_jr,k
    /// (`diagonal_columns`; empty under a general damping). Held, not made per call: the speed
    /// sweep evaluates G on every residual, and making them there cost 15 % of its time
    /// (session 26). Its size, c^2 n, is that of one compliance's blocks, 4 c^2 (N + 1), when
    /// n is 4 (N + 1).
    outer: Mat<f64>,
}

impl ModalDynamics {
    /// Modal data of `system` with damping matrix `c` and `load` on harmonics 1..=`harmonics`
    /// (its sizes and harmonics checked; a zero load is the solver's to refuse, since a casing
    /// distortion alone drives the structure without one, DESIGN §10.11).
    pub fn new(
        system: &System,
        c: &Mat<f64>,
        load: &Load,
        harmonics: usize,
    ) -> Result<Self, ForcedError> {
        let n = system.n_dofs();
        load.validate_shape(n, harmonics)?;
        let phi = system.modes().to_owned();
        if let Some(k) = system.eigenvalues().iter().position(|&l| l <= 0.0) {
            return Err(HbError::NotPositiveDefinite {
                name: "K",
                detail: format!(
                    "mode {k} has w^2 = {:e}: the mean term needs K > 0",
                    system.eigenvalues()[k]
                ),
            }
            .into());
        }
        let psi = system.contact_rows() * &phi;
        let cm = phi.transpose() * c * &phi;
        let largest = (0..n)
            .flat_map(|i| (0..n).map(move |j| (i, j)))
            .fold(0.0_f64, |a, (i, j)| a.max(cm[(i, j)].abs()));
        let off = (0..n)
            .flat_map(|i| (0..n).map(move |j| (i, j)))
            .filter(|(i, j)| i != j)
            .fold(0.0_f64, |a, (i, j)| a.max(cm[(i, j)].abs()));
        let damping = if off <= 1e-12 * largest {
            ModalDamping::Diagonal((0..n).map(|k| cm[(k, k)]).collect())
        } else {
            ModalDamping::Full(cm)
        };
        let terms = 2 * harmonics + 1;
        let mut modal_load = Mat::zeros(n, terms);
        for h in 1..=harmonics {
            let (fc, fs) = load.at(h, n);
            for (p, f) in [(FullBasis::cos_index(h), fc), (FullBasis::sin_index(h), fs)] {
                let column = modal_load.col_as_slice_mut(p);
                for (k, out) in column.iter_mut().enumerate() {
                    *out = (phi.col_as_slice(k).iter().zip(&f))
                        .map(|(a, b)| a * b)
                        .sum();
                }
            }
        }
        let c = psi.nrows();
        let outer = match damping {
            ModalDamping::Diagonal(_) => {
                Mat::from_fn(c * c, n, |row, k| psi[(row / c, k)] * psi[(row % c, k)])
            }
            ModalDamping::Full(_) => Mat::zeros(0, n),
        };
        Ok(Self {
            eigenvalues: system.eigenvalues().to_vec(),
            phi,
            psi,
            damping,
            load: modal_load,
            outer,
        })
    }

    /// Number of coordinates n.
    pub fn dofs(&self) -> usize {
        self.eigenvalues.len()
    }

    /// Number of contact rows c.
    pub fn contacts(&self) -> usize {
        self.psi.nrows()
    }

    /// Coefficients per signal 2N + 1.
    pub fn terms(&self) -> usize {
        self.load.ncols()
    }

    /// Mass-normalized modes (columns).
    pub fn modes(&self) -> &Mat<f64> {
        &self.phi
    }

    /// A Phi (c x n).
    pub fn contact_modes(&self) -> &Mat<f64> {
        &self.psi
    }

    /// Solves Z_n z = r for harmonic n at W: `r` is (n x 1) for n = 0, else (n x 2) [cos, sin]
    /// per column pair; several right-hand sides side by side (columns 2i, 2i + 1 for n >= 1).
    pub fn solve_harmonic(
        &self,
        n: usize,
        omega: f64,
        r: &mut Mat<f64>,
    ) -> Result<(), ForcedError> {
        let nd = self.dofs();
        if n == 0 {
            for col in 0..r.ncols() {
                for k in 0..nd {
                    r[(k, col)] /= self.eigenvalues[k];
                }
            }
            return Ok(());
        }
        let nw = n as f64 * omega;
        match &self.damping {
            ModalDamping::Diagonal(cd) => {
                for pair in 0..r.ncols() / 2 {
                    self.diagonal_pair(nw, cd, r, [2 * pair, 2 * pair + 1]);
                }
                Ok(())
            }
            ModalDamping::Full(cm) => self.solve_full(nw, cm, r),
        }
    }

    /// Z_n^-1 under diagonal modal damping on the cosine and sine `columns` of `r`, in place
    /// (`nw` = n W): mode k's 2 x 2 block [[d, e], [-e, d]], d = w_k^2 - (n W)^2, e = n W c_k.
    fn diagonal_pair(&self, nw: f64, cd: &[f64], r: &mut Mat<f64>, [ic, is]: [usize; 2]) {
        // On the columns as slices (the sine's copied out and back: two columns of one matrix
        // cannot be borrowed at once), the arithmetic of the 2 x 2 solve unchanged.
        let mut sine = r.col_as_slice(is).to_vec();
        let cosine = r.col_as_slice_mut(ic);
        let modes = self.eigenvalues.iter().zip(cd);
        for ((&lambda, &ck), (rc, rs)) in modes.zip(cosine.iter_mut().zip(sine.iter_mut())) {
            let (d, e) = (lambda - nw * nw, nw * ck);
            let inverse = 1.0 / (d * d + e * e);
            let (c0, s0) = (*rc, *rs);
            *rc = (d * c0 - e * s0) * inverse;
            *rs = (e * c0 + d * s0) * inverse;
        }
        r.col_as_slice_mut(is).copy_from_slice(&sine);
    }

    /// The general-damping path of [`Self::solve_harmonic`]: a dense LU of the 2n x 2n Z_n.
    fn solve_full(&self, nw: f64, cm: &Mat<f64>, r: &mut Mat<f64>) -> Result<(), ForcedError> {
        let nd = self.dofs();
        let mut lu = DenseLu::default();
        {
            let mut z = lu.matrix(2 * nd);
            for i in 0..nd {
                z[(i, i)] = self.eigenvalues[i] - nw * nw;
                z[(nd + i, nd + i)] = self.eigenvalues[i] - nw * nw;
                for j in 0..nd {
                    z[(i, nd + j)] = nw * cm[(i, j)];
                    z[(nd + i, j)] = -nw * cm[(i, j)];
                }
            }
        }
        if !lu.factor() {
            return Err(HbError::Decomposition {
                what: "dynamic stiffness Z_n",
                detail: format!("singular at n W = {nw:e} rad/s"),
            }
            .into());
        }
        let pairs = r.ncols() / 2;
        let mut rhs = Mat::from_fn(2 * nd, pairs, |i, q| {
            if i < nd {
                r[(i, 2 * q)]
            } else {
                r[(i - nd, 2 * q + 1)]
            }
        });
        lu.solve_in_place(rhs.as_mut());
        for q in 0..pairs {
            for i in 0..nd {
                r[(i, 2 * q)] = rhs[(i, q)];
                r[(i, 2 * q + 1)] = rhs[(nd + i, q)];
            }
        }
        Ok(())
    }

    /// The contact compliance and the load's contact response at W (see [`ContactCompliance`]).
    pub fn compliance(&self, omega: f64) -> Result<ContactCompliance, ForcedError> {
        let mut out = ContactCompliance::empty(self.contacts(), self.terms());
        self.compliance_into(omega, &mut out)?;
        Ok(out)
    }

    /// [`Self::compliance`] written into `out`, which holds the compliance of this model at
    /// another W (or zeros): every entry of its harmonic blocks is overwritten, nothing is
    /// allocated. A Newton iteration of the continuation moves W and needs G anew.
    pub fn compliance_into(
        &self,
        omega: f64,
        out: &mut ContactCompliance,
    ) -> Result<(), ForcedError> {
        let every: Vec<usize> = (0..self.contacts()).collect();
        self.compliance_rows_into(omega, &every, out)
    }

    /// The compliance at W on the columns of the contact rows `rows` (`ContactCompliance`'s
    /// written rows; the mean's block and y_F in full): when `out` holds W already, only the
    /// rows not written yet are added, else it is reset to W first. Under diagonal modal
    /// damping a row costs a c-th of the whole G (the rows in contact are 2-8 of 24 on the
    /// default blade); a general damping writes every row at once.
    pub fn compliance_rows_into(
        &self,
        omega: f64,
        rows: &[usize],
        out: &mut ContactCompliance,
    ) -> Result<(), ForcedError> {
        let (c, terms) = (self.contacts(), self.terms());
        if !out.has_shape(c, terms) {
            *out = ContactCompliance::empty(c, terms);
        }
        if out.omega != omega || out.omega.is_nan() {
            // Marked stale until written: an error leaves it at no W, not half written.
            out.forget(f64::NAN);
            self.general_block(0, omega, out)?;
            match &self.damping {
                ModalDamping::Diagonal(cd) => self.diagonal_load(omega, cd, out),
                ModalDamping::Full(_) => {
                    for n in 1..=terms / 2 {
                        self.general_block(n, omega, out)?;
                    }
                    (0..c).for_each(|j| out.mark_written(j));
                }
            }
            out.omega = omega;
        }
        let missing = out.missing(rows);
        if let (false, ModalDamping::Diagonal(cd)) = (missing.is_empty(), &self.damping) {
            self.diagonal_columns(omega, cd, &missing, out);
        }
        Ok(())
    }

    /// y_F's harmonics n >= 1 under diagonal modal damping: the load's modal response, then
    /// its contact coordinates as one product with Psi.
    fn diagonal_load(&self, omega: f64, cd: &[f64], out: &mut ContactCompliance) {
        let (c, terms) = (self.contacts(), self.terms());
        let mut z = self.load.clone();
        for n in 1..=terms / 2 {
            let columns = [FullBasis::cos_index(n), FullBasis::sin_index(n)];
            self.diagonal_pair(n as f64 * omega, cd, &mut z, columns);
        }
        let yl = product(self.psi.as_ref(), z.as_ref());
        for j in 0..c {
            for p in 1..terms {
                out.y_load[j * terms + p] = yl[(j, p)];
            }
        }
    }

    /// G's columns of the contact rows `rows` in harmonics n >= 1 under diagonal modal damping,
    /// from two modal sums per harmonic, C_n = Psi diag(d / det) Psi^T and S_n = Psi diag(e /
    /// det) Psi^T (d = lambda_k - (n W)^2, e = n W c_k, det = d^2 + e^2): a unit cosine force
    /// on row jr gives C_n e_jr in the cosine part and S_n e_jr in the sine part, a unit sine
    /// force -S_n e_jr and C_n e_jr (the pairs of [`Self::solve_harmonic`]). Every harmonic's
    /// sums at once, as one product of the rows' modal products `outer` with the modal
    /// factors: a Newton iteration of the speed sweep evaluates G at a new W on every
    /// residual, and 2N small products cost twice the large one. Equal to
    /// [`Self::general_block`] to round-off.
    fn diagonal_columns(
        &self,
        omega: f64,
        cd: &[f64],
        rows: &[usize],
        out: &mut ContactCompliance,
    ) {
        let (nd, c, terms) = (self.dofs(), self.contacts(), self.terms());
        let nh = terms / 2;
        // Column 2 (n - 1) + part of the factors is harmonic n's cosine (part 0) or sine
        // (part 1) factor.
        let mut factors = Mat::zeros(nd, 2 * nh);
        for n in 1..=nh {
            let nw = n as f64 * omega;
            for k in 0..nd {
                let (d, e) = (self.eigenvalues[k] - nw * nw, nw * cd[k]);
                let inverse = 1.0 / (d * d + e * e);
                factors[(k, 2 * (n - 1))] = d * inverse;
                factors[(k, 2 * (n - 1) + 1)] = e * inverse;
            }
        }
        // Row jr c + j of `outer` holds psi_jr,k psi_jk: each row's c products are contiguous.
        let picked = Mat::from_fn(rows.len() * c, nd, |i, k| {
            self.outer[(rows[i / c] * c + i % c, k)]
        });
        let sums = product(picked.as_ref(), factors.as_ref());
        for (at, &jr) in rows.iter().enumerate() {
            for n in 1..=nh {
                let (pc, ps) = (2 * (n - 1), 2 * (n - 1) + 1);
                let mut g = out.block_mut(n);
                for j in 0..c {
                    let (cm, sm) = (sums[(at * c + j, pc)], sums[(at * c + j, ps)]);
                    g[(2 * j, 2 * jr)] = cm;
                    g[(2 * j + 1, 2 * jr)] = sm;
                    g[(2 * j, 2 * jr + 1)] = -sm;
                    g[(2 * j + 1, 2 * jr + 1)] = cm;
                }
            }
            out.mark_written(jr);
        }
    }

    /// Harmonic n of G and y_F for any damping: Z_n^-1 applied to Psi^T e_j in each part of
    /// the harmonic and to the load ([`Self::unit_responses`]), then their contact coordinates.
    fn general_block(
        &self,
        n: usize,
        omega: f64,
        out: &mut ContactCompliance,
    ) -> Result<(), ForcedError> {
        let (c, terms) = (self.contacts(), self.terms());
        let parts: Vec<usize> = if n == 0 {
            vec![0]
        } else {
            vec![FullBasis::cos_index(n), FullBasis::sin_index(n)]
        };
        let z = self.unit_responses(n, omega, &parts)?;
        let w = parts.len();
        // Contact coordinates of every response at once (c x columns of z).
        let yz = product(self.psi.as_ref(), z.as_ref());
        // Column block q = w jr + part: the response to a unit Lambda of row jr in that part;
        // block q = w c: the response to the load.
        // In harmonic n's block, row j's part a is the local index w j + a.
        for q in 0..=w * c {
            for (out_part, &p) in parts.iter().enumerate() {
                for j in 0..c {
                    let y = yz[(j, w * q + out_part)];
                    if q < w * c {
                        out.block_mut(n)[(w * j + out_part, q)] = y;
                    } else {
                        out.y_load[j * terms + p] = y;
                    }
                }
            }
        }
        Ok(())
    }

    /// Z_n^-1 applied to Psi^T e_j in each part of harmonic n (contact row j, part), then to the
    /// load: n x w (w c + 1) with w = 1 (mean) or 2 (cos, sin) columns per right-hand side.
    fn unit_responses(
        &self,
        n: usize,
        omega: f64,
        parts: &[usize],
    ) -> Result<Mat<f64>, ForcedError> {
        let (nd, c, w) = (self.dofs(), self.contacts(), parts.len());
        let mut r = Mat::zeros(nd, w * (w * c + 1));
        for jr in 0..c {
            for part in 0..w {
                let col = w * (w * jr + part) + part;
                for k in 0..nd {
                    r[(k, col)] = self.psi[(jr, k)];
                }
            }
        }
        for (part, &p) in parts.iter().enumerate() {
            for k in 0..nd {
                r[(k, w * w * c + part)] = self.load[(k, p)];
            }
        }
        self.solve_harmonic(n, omega, &mut r)?;
        Ok(r)
    }

    /// Modal coefficients z (n x (2N + 1)) of the linear response to `level` times the load
    /// minus the contact forces `lambda` (signal-major c (2N + 1)) at W.
    pub fn response(
        &self,
        omega: f64,
        level: f64,
        lambda: &[f64],
    ) -> Result<Mat<f64>, ForcedError> {
        let (nd, c, terms) = (self.dofs(), self.contacts(), self.terms());
        let lam = Mat::from_fn(c, terms, |j, p| lambda[j * terms + p]);
        let contact = product(self.psi.transpose(), lam.as_ref());
        let mut z = Mat::from_fn(nd, terms, |k, p| {
            level * self.load[(k, p)] - contact[(k, p)]
        });
        self.solve_every_harmonic(omega, &mut z)?;
        Ok(z)
    }

    /// Z^-1 applied in place to `r` (n x (2N + 1), the full basis' columns), harmonic by
    /// harmonic ([`Self::solve_harmonic`] on each harmonic's columns).
    fn solve_every_harmonic(&self, omega: f64, r: &mut Mat<f64>) -> Result<(), ForcedError> {
        let nd = self.dofs();
        if let ModalDamping::Diagonal(cd) = &self.damping {
            // In place on the columns: a Newton iteration of the speed sweep evaluates two
            // responses per residual.
            let mean = r.col_as_slice_mut(0);
            for (v, l) in mean.iter_mut().zip(&self.eigenvalues) {
                *v /= l;
            }
            for n in 1..=r.ncols() / 2 {
                let columns = [FullBasis::cos_index(n), FullBasis::sin_index(n)];
                self.diagonal_pair(n as f64 * omega, cd, r, columns);
            }
            return Ok(());
        }
        for n in 0..=r.ncols() / 2 {
            let parts: Vec<usize> = if n == 0 {
                vec![0]
            } else {
                vec![FullBasis::cos_index(n), FullBasis::sin_index(n)]
            };
            let mut block = Mat::from_fn(nd, parts.len(), |k, col| r[(k, parts[col])]);
            self.solve_harmonic(n, omega, &mut block)?;
            for (col, &p) in parts.iter().enumerate() {
                for k in 0..nd {
                    r[(k, p)] = block[(k, col)];
                }
            }
        }
        Ok(())
    }

    /// d y / d W at fixed Lambda for the modal response `z` at W: -Psi Z^-1 (dZ/dW) z (L values),
    /// with dZ_n/dW = [[-2 n^2 W I, n C_m], [-n C_m, -2 n^2 W I]].
    pub fn response_rate(&self, omega: f64, z: &Mat<f64>) -> Result<Vec<f64>, ForcedError> {
        let (nd, c, terms) = (self.dofs(), self.contacts(), self.terms());
        let mut r = Mat::zeros(nd, terms);
        for n in 1..=terms / 2 {
            let (pc, ps) = (FullBasis::cos_index(n), FullBasis::sin_index(n));
            let nf = n as f64;
            for k in 0..nd {
                let (cz_c, cz_s) = self.damping_times(k, z, pc, ps);
                r[(k, pc)] = -2.0 * nf * nf * omega * z[(k, pc)] + nf * cz_s;
                r[(k, ps)] = -nf * cz_c - 2.0 * nf * nf * omega * z[(k, ps)];
            }
        }
        // The mean does not move with W (its column of r is zero).
        self.solve_every_harmonic(omega, &mut r)?;
        let yr = product(self.psi.as_ref(), r.as_ref());
        let mut rate = vec![0.0; c * terms];
        for j in 0..c {
            for p in 1..terms {
                rate[j * terms + p] = -yr[(j, p)];
            }
        }
        Ok(rate)
    }

    /// Row k of (Phi^T C Phi) times the columns `pc` and `ps` of z.
    fn damping_times(&self, k: usize, z: &Mat<f64>, pc: usize, ps: usize) -> (f64, f64) {
        match &self.damping {
            ModalDamping::Diagonal(d) => (d[k] * z[(k, pc)], d[k] * z[(k, ps)]),
            ModalDamping::Full(cm) => (0..self.dofs()).fold((0.0, 0.0), |(a, b), i| {
                (a + cm[(k, i)] * z[(i, pc)], b + cm[(k, i)] * z[(i, ps)])
            }),
        }
    }

    /// Physical coefficients u = Phi z (n x (2N + 1)).
    pub fn physical(&self, z: &Mat<f64>) -> Mat<f64> {
        &self.phi * z
    }
}
