//! Hill's matrix on the linear modes, its eigenvalues and the Lazarus-Thomas selection (see the
//! module docs of `stability`).

use faer::linalg::solvers::DenseSolveCore;
use faer::{c64, Mat, MatRef, Side};
use nlmodes_dense::eigen_checked;

use super::impact::impact_equivalent_pieces;
use super::modal_basis::{DecoupledModes, ModalBasis};
use super::monodromy::constant_pieces;
use super::{
    sort_multipliers, FloquetSettings, JacobianInTime, Stability, StabilityMethod, UnstableCounts,
};
use crate::point::BackbonePoint;
use crate::NnmError;
use nlmodes_boundary::{check_by_rk4, exponents_of, residual_sum, ModalData};
use nlmodes_hb::system::System;

/// Precomputed modal data of a system for Hill's method; reuse it for every point of a backbone.
/// The modes decoupled from every contact row are left out (`modal_basis`); `every_mode` keeps
/// them all, for an orbit that carries one.
pub struct FloquetAnalysis<'s> {
    system: &'s System,
    settings: FloquetSettings,
    /// The modes coupled to the contact rows: w_k ascending, A Phi, Phi^T M, the master's row.
    modes: ModalBasis,
    /// The modes left out (their pairs exp(+-i w_k T) on the unit circle).
    decoupled: DecoupledModes,
    /// The analysis on every mode, when some are left out.
    every_mode: Option<Box<FloquetAnalysis<'s>>>,
}

/// Cosine and sine moments of the projected contact stiffness, p = 0..=2N (r x r each):
/// C_p = (1/m) sum_k P_k cos(2 pi p k / m), S_p likewise with sines.
struct Moments {
    cos: Vec<Mat<f64>>,
    sin: Vec<Mat<f64>>,
}

impl Moments {
    /// Adds P times the weights (cos, sin) of each order p.
    fn add(&mut self, p_mat: &Mat<f64>, weight: impl Fn(usize) -> (f64, f64)) {
        for p in 0..self.cos.len() {
            let (wc, ws) = weight(p);
            self.cos[p] += faer::Scale(wc) * p_mat;
            self.sin[p] += faer::Scale(ws) * p_mat;
        }
    }

    /// C_{|p|} for a signed p.
    fn c(&self, p: i64) -> MatRef<'_, f64> {
        self.cos[p.unsigned_abs() as usize].as_ref()
    }

    /// S_p for a signed p (S_{-p} = -S_p): (sign, S_|p|).
    fn s(&self, p: i64) -> (f64, MatRef<'_, f64>) {
        (
            p.signum() as f64,
            self.sin[p.unsigned_abs() as usize].as_ref(),
        )
    }
}

/// One function of Hill's orthonormal basis: 1, sqrt2 cos(n w t), sqrt2 sin(n w t).
#[derive(Clone, Copy)]
enum Basis {
    Constant,
    Cos(i64),
    Sin(i64),
}

impl Basis {
    /// Basis function of block index b: 0 -> 1, 2n - 1 -> cos n, 2n -> sin n.
    fn of_block(b: usize) -> Self {
        if b == 0 {
            Basis::Constant
        } else if b % 2 == 1 {
            Basis::Cos(b.div_ceil(2) as i64)
        } else {
            Basis::Sin((b / 2) as i64)
        }
    }
}

impl<'s> FloquetAnalysis<'s> {
    /// Validates the settings and diagonalizes (K, M) once.
    pub fn new(system: &'s System, settings: FloquetSettings) -> Result<Self, NnmError> {
        settings.validate()?;
        let all = ModalBasis::of_system(system)?;
        let (modes, decoupled) = all.clone().split_decoupled();
        let every_mode = (!decoupled.omega.is_empty()).then(|| {
            Box::new(Self {
                system,
                settings: settings.clone(),
                modes: all,
                decoupled: DecoupledModes::none(),
                every_mode: None,
            })
        });
        Ok(Self {
            system,
            settings,
            modes,
            decoupled,
            every_mode,
        })
    }

    /// Linear modes left out of the analysis as decoupled from every contact row.
    pub fn decoupled_modes(&self) -> usize {
        self.decoupled.omega.len()
    }

    /// The coupled modes' data the massless-boundary models are built from.
    pub(super) fn modal_data(&self) -> ModalData<'_> {
        ModalData {
            omega: &self.modes.omega,
            contact_modal: self.modes.contact_modal.as_ref(),
            projection: self.modes.projection.as_ref(),
            master: &self.modes.master,
            gaps: self.system.gaps(),
        }
    }

    /// The coupled modes' basis (the event-based monodromy's).
    pub(super) fn modes(&self) -> &ModalBasis {
        &self.modes
    }

    /// The system analyzed.
    pub(super) fn system(&self) -> &System {
        self.system
    }

    /// The settings in use.
    pub fn settings(&self) -> &FloquetSettings {
        &self.settings
    }

    /// Number of modes kept at circular frequency `omega` with `harmonics` harmonics.
    pub fn modes_kept(&self, omega: f64, harmonics: usize) -> usize {
        let limit = self.settings.mode_cutoff * (harmonics as f64 + 1.0) * omega;
        let r = self.modes.omega.iter().filter(|&&w| w <= limit).count();
        r.max(self.settings.min_modes).min(self.modes.omega.len())
    }

    /// Floquet multipliers of `point`: by the event-based monodromy when the orbit is an
    /// augmented-Lagrangian orbit whose contact phases are all unresolved impacts (and
    /// `saltation` is on), by Hill's method otherwise (see the module docs and
    /// docs/STABILITY.md, Sec. 3).
    pub fn analyze(&self, point: &BackbonePoint) -> Result<Stability, NnmError> {
        self.analyze_checked(point, false)
    }

    /// As [`FloquetAnalysis::analyze`]; with `verify`, a shooting verdict is checked by the
    /// independent RK4 integration ([`super::ShootingCheck`]).
    pub fn analyze_checked(
        &self,
        point: &BackbonePoint,
        verify: bool,
    ) -> Result<Stability, NnmError> {
        let (harmonics, samples) = self.check_point(point)?;
        if let Some(every_mode) = &self.every_mode {
            if self.decoupled.carried_by(point) {
                return every_mode.analyze_checked(point, verify);
            }
        }
        let mut out = self.analyze_coupled(point, harmonics, samples, verify)?;
        out.decoupled_modes = self.decoupled_modes();
        Ok(out)
    }

    /// The analysis on the coupled modes: event-based, shooting or Hill (docs/STABILITY.md).
    fn analyze_coupled(
        &self,
        point: &BackbonePoint,
        harmonics: usize,
        samples: usize,
        verify: bool,
    ) -> Result<Stability, NnmError> {
        if let Some(out) = self.analyze_by_saltation(point, harmonics)? {
            return Ok(out);
        }
        if let Some(out) = self.analyze_by_shooting(point, harmonics, verify)? {
            return Ok(out);
        }
        self.analyze_by_hill(point, harmonics, samples)
    }

    /// The massless-boundary shooting (`nlmodes_boundary`) when it applies and converges.
    fn analyze_by_shooting(
        &self,
        point: &BackbonePoint,
        harmonics: usize,
        verify: bool,
    ) -> Result<Option<Stability>, NnmError> {
        let Some((model, orbit)) = self.shot_orbit(point, harmonics)? else {
            return Ok(None);
        };
        let Some(exponents) = exponents_of(&orbit)? else {
            tracing::debug!(w = point.omega, "massless-boundary monodromy not finite");
            return Ok(None);
        };
        let mut out = stability_from_exponents(&exponents, orbit.period, self.settings.tolerance);
        out.method = StabilityMethod::Shooting;
        out.selection_mean_harmonic_max = 0.0;
        out.rejection_mean_harmonic_min = 0.0;
        out.modes_kept = model.omega2.len();
        out.harmonics = harmonics;
        out.impacts = orbit.switches;
        out.orbit_shift = (point.period() / orbit.period - 1.0).abs();
        out.orbit_omega = 2.0 * std::f64::consts::PI / orbit.period;
        out.contact_shares = orbit.contact_shares.clone();
        if verify {
            out.check = Some(check_by_rk4(&model, &orbit)?);
        }
        Ok(Some(out))
    }

    /// Hill's method (module docs).
    fn analyze_by_hill(
        &self,
        point: &BackbonePoint,
        harmonics: usize,
        samples: usize,
    ) -> Result<Stability, NnmError> {
        let r = self.modes_kept(point.omega, harmonics);
        let moments = self.contact_moments(point, r, harmonics, samples)?;
        let lin = hill_linearization(&self.modes.omega[..r], harmonics, point.omega, &moments);
        let what = "Hill eigen-decomposition";
        let (values, vectors) =
            eigen_checked(lin.as_ref(), what).map_err(|e| NnmError::Decomposition {
                what,
                detail: e.to_string(),
            })?;
        let content = harmonic_content(vectors.as_ref(), r, harmonics);
        let selection = select_exponents(&values, &content, point.omega, 2 * r);
        let exponents: Vec<c64> = selection.chosen.iter().map(|&i| values[i]).collect();
        let mut out = stability_from_exponents(&exponents, point.period(), self.settings.tolerance);
        out.modes_kept = r;
        out.harmonics = harmonics;
        out.selection_mean_harmonic_max = selection.chosen_max;
        out.rejection_mean_harmonic_min = selection.rejected_min;
        out.method = StabilityMethod::Hill;
        Ok(out)
    }

    /// (N, m) of the point after checking its sizes against the system.
    fn check_point(&self, point: &BackbonePoint) -> Result<(usize, usize), NnmError> {
        let (n, c) = (self.system.n_dofs(), self.system.n_contacts());
        let bad = |detail: String| Err(NnmError::StabilityInput { detail });
        if point.coefficients.len() < 2 || point.coefficients.iter().any(|u| u.len() != n) {
            return bad(format!(
                "the point needs N + 1 >= 2 coefficient vectors of {n} DOFs each"
            ));
        }
        if !(point.omega.is_finite() && point.omega > 0.0) {
            return bad(format!("w = {} is not a finite frequency > 0", point.omega));
        }
        let harmonics = point.coefficients.len() - 1;
        let mult = &point.multipliers;
        let m = mult.samples;
        if m < 2 * harmonics + 1 || mult.theta.len() != c * m || mult.kappa.len() != c * m {
            return bad(format!(
                "the contact multipliers must hold {c} rows of m >= 2N + 1 = {} samples (got m = {m}, \
                 {} theta, {} kappa)",
                2 * harmonics + 1,
                mult.theta.len(),
                mult.kappa.len()
            ));
        }
        Ok((harmonics, m))
    }

    /// Residual flexibility of the modes r.. on the contact rows (c x c), zero when all are kept
    /// or the static correction is off.
    fn residual_flexibility(&self, r: usize) -> Mat<f64> {
        if !self.settings.static_correction {
            let c = self.system.n_contacts();
            return Mat::zeros(c, c);
        }
        let omega2: Vec<f64> = self.modes.omega.iter().map(|w| w * w).collect();
        residual_sum(self.modes.contact_modal.as_ref(), &omega2, r)
    }

    /// Moments of P = B_S^T D_eff B_S (B = A Phi_r, S the active set) over the period: the sample
    /// quadrature of the harmonic balance, or exact integrals over the pieces of constant D.
    fn contact_moments(
        &self,
        point: &BackbonePoint,
        r: usize,
        harmonics: usize,
        m: usize,
    ) -> Result<Moments, NnmError> {
        let np = 2 * harmonics + 1;
        let mut moments = Moments {
            cos: (0..np).map(|_| Mat::zeros(r, r)).collect(),
            sin: (0..np).map(|_| Mat::zeros(r, r)).collect(),
        };
        let residual = self.residual_flexibility(r);
        let b = self.modes.contact_modal.subcols(0, r);
        let projected = |kappa: &[f64]| -> Result<Option<Mat<f64>>, NnmError> {
            let active: Vec<usize> = (0..kappa.len()).filter(|&j| kappa[j] > 0.0).collect();
            if active.is_empty() {
                return Ok(None);
            }
            let k_s: Vec<f64> = active.iter().map(|&j| kappa[j]).collect();
            let d_eff = series_stiffness(&active, &k_s, residual.as_ref())?;
            let b_s = Mat::from_fn(active.len(), r, |i, col| b[(active[i], col)]);
            Ok(Some(b_s.transpose() * (&d_eff * &b_s)))
        };
        match self.settings.jacobian {
            JacobianInTime::SampleIntervals => {
                let gaps = point.gap_samples(self.system, m);
                let mult = &point.multipliers;
                for k in 0..m {
                    let kappa: Vec<f64> = (0..gaps.len())
                        .map(|j| {
                            let i = j * m + k;
                            if gaps[j][k] + mult.theta[i] > 0.0 {
                                mult.kappa[i]
                            } else {
                                0.0
                            }
                        })
                        .collect();
                    if let Some(p_k) = projected(&kappa)? {
                        let phase = 2.0 * std::f64::consts::PI * k as f64 / m as f64;
                        let weight = |p: usize| {
                            let x = p as f64 * phase;
                            (x.cos() / m as f64, x.sin() / m as f64)
                        };
                        moments.add(&p_k, weight);
                    }
                }
            }
            JacobianInTime::Continuous => {
                let period = point.period();
                let mut pieces = constant_pieces(self.system, point, JacobianInTime::Continuous);
                if self.settings.impact_width > 0.0 {
                    let contact_mass: Vec<f64> = (0..self.modes.contact_modal.nrows())
                        .map(|j| {
                            let row = self.modes.contact_modal.row(j);
                            1.0 / (0..row.ncols()).map(|k| row[k] * row[k]).sum::<f64>()
                        })
                        .collect();
                    let width = self.settings.impact_width * period / harmonics as f64;
                    pieces = impact_equivalent_pieces(&pieces, period, &contact_mass, width);
                }
                for piece in pieces {
                    if let Some(p_k) = projected(&piece.kappa)? {
                        let (a, b) = (piece.start / period, piece.end / period);
                        moments.add(&p_k, |p| interval_moments(p, a, b));
                    }
                }
            }
        }
        Ok(moments)
    }
}

/// (1/T) int_a^b (cos, sin)(2 pi p t / T) dt for a, b in units of T.
fn interval_moments(p: usize, a: f64, b: f64) -> (f64, f64) {
    if p == 0 {
        return (b - a, 0.0);
    }
    let x = 2.0 * std::f64::consts::PI * p as f64;
    (
        ((x * b).sin() - (x * a).sin()) / x,
        ((x * a).cos() - (x * b).cos()) / x,
    )
}

/// (diag(1 / kappa_S) + R_SS)^-1: the penalty springs in series with the residual flexibility of
/// the discarded modes (diag(kappa_S) when R = 0).
fn series_stiffness(
    active: &[usize],
    kappa: &[f64],
    residual: MatRef<'_, f64>,
) -> Result<Mat<f64>, NnmError> {
    let s = active.len();
    let flex = Mat::from_fn(s, s, |i, j| {
        let diag = if i == j { 1.0 / kappa[i] } else { 0.0 };
        diag + residual[(active[i], active[j])]
    });
    let llt = flex.llt(Side::Lower).map_err(|e| NnmError::Decomposition {
        what: "Cholesky of the contact flexibility",
        detail: format!("{e:?}"),
    })?;
    Ok(llt.inverse())
}

/// The real matrix [[0, I], [-H0, -G]] of size 2 r (2N + 1) whose eigenvalues are Hill's
/// exponents: H0 = diag(w_k^2 - (n w)^2) + contact blocks, G the gyroscopic coupling.
fn hill_linearization(
    modal_omega: &[f64],
    harmonics: usize,
    omega: f64,
    moments: &Moments,
) -> Mat<f64> {
    let r = modal_omega.len();
    let nb = r * (2 * harmonics + 1);
    let mut lin = Mat::<f64>::zeros(2 * nb, 2 * nb);
    for i in 0..nb {
        lin[(i, nb + i)] = 1.0;
    }
    let blocks = 2 * harmonics + 1;
    let sqrt2 = std::f64::consts::SQRT_2;
    for bi in 0..blocks {
        for bl in 0..blocks {
            // Contact block <phi_i phi_l P> as a combination of moments.
            let terms: Vec<(f64, MatRef<'_, f64>)> =
                match (Basis::of_block(bi), Basis::of_block(bl)) {
                    (Basis::Constant, Basis::Constant) => vec![(1.0, moments.c(0))],
                    (Basis::Constant, Basis::Cos(n)) | (Basis::Cos(n), Basis::Constant) => {
                        vec![(sqrt2, moments.c(n))]
                    }
                    (Basis::Constant, Basis::Sin(n)) | (Basis::Sin(n), Basis::Constant) => {
                        let (sg, s) = moments.s(n);
                        vec![(sqrt2 * sg, s)]
                    }
                    (Basis::Cos(n), Basis::Cos(l)) => {
                        vec![(1.0, moments.c(n - l)), (1.0, moments.c(n + l))]
                    }
                    (Basis::Sin(n), Basis::Sin(l)) => {
                        vec![(1.0, moments.c(n - l)), (-1.0, moments.c(n + l))]
                    }
                    (Basis::Cos(n), Basis::Sin(l)) => {
                        let (s1, a) = moments.s(n + l);
                        let (s2, b) = moments.s(n - l);
                        vec![(s1, a), (-s2, b)]
                    }
                    (Basis::Sin(n), Basis::Cos(l)) => {
                        let (s1, a) = moments.s(n + l);
                        let (s2, b) = moments.s(n - l);
                        vec![(s1, a), (s2, b)]
                    }
                };
            for (coef, mat) in terms {
                if coef == 0.0 {
                    continue;
                }
                for a in 0..r {
                    for b in 0..r {
                        lin[(nb + bi * r + a, bl * r + b)] -= coef * mat[(a, b)];
                    }
                }
            }
        }
        // Diagonal (w_k^2 - (n w)^2) and gyroscopic terms.
        let (n, is_cos) = match Basis::of_block(bi) {
            Basis::Constant => (0.0, false),
            Basis::Cos(n) => (n as f64, true),
            Basis::Sin(n) => (n as f64, false),
        };
        for a in 0..r {
            let row = nb + bi * r + a;
            lin[(row, bi * r + a)] -= modal_omega[a].powi(2) - (n * omega).powi(2);
            if n > 0.0 {
                // cos row: + 2 s n w x_sin; sin row: - 2 s n w x_cos (moved to the right: -G).
                let (partner, g) = if is_cos {
                    (bi + 1, 2.0 * n * omega)
                } else {
                    (bi - 1, -2.0 * n * omega)
                };
                lin[(row, nb + partner * r + a)] -= g;
            }
        }
    }
    lin
}

/// Harmonic content of each eigenvector's displacement part on complex harmonics e^{i n w t},
/// n = -N..N, with c_{+-n} = (a_n -+ i b_n) / sqrt2 from the cos / sin coefficients a_n, b_n:
/// |mean| = |sum n |c_n|^2| / sum |c_n|^2 (Lazarus & Thomas's centring) and the rms harmonic
/// (sum n^2 |c_n|^2 / sum |c_n|^2)^1/2, which breaks the ties of real eigenvectors of degenerate
/// real eigenvalues (they mix the copies at +k and -k: mean 0 but rms k).
fn harmonic_content(vectors: MatRef<'_, c64>, r: usize, harmonics: usize) -> Vec<Content> {
    let norm2 = |z: c64| z.re * z.re + z.im * z.im;
    (0..vectors.ncols())
        .map(|col| {
            let x = vectors.col(col);
            let mut total: f64 = (0..r).map(|a| norm2(x[a])).sum();
            let (mut first, mut second) = (0.0, 0.0);
            for n in 1..=harmonics {
                let (cb, sb) = ((2 * n - 1) * r, 2 * n * r);
                let (mut plus, mut minus) = (0.0, 0.0);
                for a in 0..r {
                    let (ca, sa) = (x[cb + a], x[sb + a]);
                    // a - i b and a + i b
                    let p = c64::new(ca.re + sa.im, ca.im - sa.re);
                    let q = c64::new(ca.re - sa.im, ca.im + sa.re);
                    plus += 0.5 * norm2(p);
                    minus += 0.5 * norm2(q);
                }
                total += plus + minus;
                first += n as f64 * (plus - minus);
                second += (n * n) as f64 * (plus + minus);
            }
            if total > 0.0 {
                Content {
                    mean: (first / total).abs(),
                    rms: (second / total).sqrt(),
                }
            } else {
                Content {
                    mean: f64::INFINITY,
                    rms: f64::INFINITY,
                }
            }
        })
        .collect()
}

/// Chosen eigenvalue indices and the margins of the selection.
struct Selection {
    chosen: Vec<usize>,
    chosen_max: f64,
    rejected_min: f64,
}

/// Harmonic content of an eigenvector: |weighted mean harmonic| and rms harmonic.
#[derive(Clone, Copy)]
struct Content {
    mean: f64,
    rms: f64,
}

/// Lazarus-Thomas selection. Hill's spectrum is made of 2 r families of copies s + i k w; the
/// eigenvalues are visited by increasing |mean harmonic| of their eigenvector (ties within 1e-6 by
/// rms harmonic, then by |Im s|), and each visited one is kept and its copies s + i k w
/// (k = +-1..+-2N, the nearest eigenvalue within w / 4) are discarded, so that every family
/// gives one exponent, its best-centred copy. Each kept exponent off the imaginary axis is taken
/// with its Hamiltonian partner -conj(s) (the nearest eigenvalue), so that the set stays closed
/// under mu -> 1/conj(mu) when the copies of a quadruple tie (period doubling: s = sigma +- i w / 2,
/// mean harmonic -+ 1/2).
fn select_exponents(values: &[c64], content: &[Content], omega: f64, count: usize) -> Selection {
    let mut order: Vec<usize> = (0..values.len()).collect();
    // Ties within 1e-6 by quantizing the keys: a comparison "equal within a tolerance" is not a
    // total order (the sort may panic on it), a comparison of rounded keys is.
    let quantized = |x: f64| (x * 1e6).round();
    order.sort_by(|&a, &b| {
        let (ca, cb) = (content[a], content[b]);
        quantized(ca.mean)
            .total_cmp(&quantized(cb.mean))
            .then(quantized(ca.rms).total_cmp(&quantized(cb.rms)))
            .then(values[a].im.abs().total_cmp(&values[b].im.abs()))
    });
    let copies = (values.len() / (2 * count.max(1))) as i64; // 2N + 1 copies: k up to +-2N
    let mut taken = vec![false; values.len()];
    let mut chosen = Vec::with_capacity(count);
    let nearest_free = |taken: &[bool], target: c64, allow: Option<usize>| {
        let dist = |j: usize| (values[j] - target).norm();
        (0..values.len())
            .filter(|&j| !taken[j] || Some(j) == allow)
            .min_by(|&a, &b| dist(a).total_cmp(&dist(b)))
            .map(|j| (j, dist(j)))
    };
    let keep = |i: usize, taken: &mut [bool], chosen: &mut Vec<usize>| {
        taken[i] = true;
        chosen.push(i);
        for k in -copies..=copies {
            let target = values[i] + c64::new(0.0, k as f64 * omega);
            if k == 0 {
                continue;
            }
            if let Some((j, d)) = nearest_free(taken, target, None) {
                if d < 0.25 * omega {
                    taken[j] = true;
                }
            }
        }
    };
    for &i in &order {
        if chosen.len() >= count {
            break;
        }
        if taken[i] {
            continue;
        }
        keep(i, &mut taken, &mut chosen);
        let target = c64::new(-values[i].re, values[i].im);
        if let Some((j, _)) = nearest_free(&taken, target, Some(i)) {
            if j != i && chosen.len() < count {
                keep(j, &mut taken, &mut chosen);
            }
        }
    }
    let chosen_max = chosen.iter().map(|&i| content[i].mean).fold(0.0, f64::max);
    let rejected_min = (0..values.len())
        .filter(|&i| !chosen.contains(&i))
        .map(|i| content[i].mean)
        .fold(f64::INFINITY, f64::min);
    Selection {
        chosen,
        chosen_max,
        rejected_min,
    }
}

/// Whether multiplier `i` belongs to a complex quadruple: another selected multiplier lies within
/// |Im mu| / 4 of conj(mu). A real pair (mu, 1/mu) leaving through -1 has exponents
/// sigma +- i w / 2 whose imaginary parts the truncation shifts by a small epsilon, so mu carries
/// a small spurious imaginary part (observed 6e-5 |mu| at N = 20, 5e-7 at N = 40) but its
/// conjugate is a discarded copy, not a selected exponent; a Krein quadruple (s, conj s, -s,
/// -conj s) has all four selected.
fn has_conjugate_partner(mus: &[[f64; 2]], i: usize) -> bool {
    let mu = mus[i];
    let threshold = 0.25 * mu[1].abs();
    mus.iter()
        .enumerate()
        .any(|(j, nu)| j != i && (nu[0] - mu[0]).hypot(nu[1] + mu[1]) < threshold)
}

/// Multipliers, trivial pair and stability flags from the selected exponents (the trivial pair:
/// the two multipliers closest to +1).
pub(crate) fn stability_from_exponents(
    exponents: &[c64],
    period: f64,
    tolerance: f64,
) -> Stability {
    stability_with_trivial(exponents, None, period, tolerance)
}

/// As [`stability_from_exponents`], with the trivial pair given by its indices in `exponents`
/// when known (`None`: the two multipliers closest to +1).
pub(crate) fn stability_with_trivial(
    exponents: &[c64],
    trivial_of_exponents: Option<[usize; 2]>,
    period: f64,
    tolerance: f64,
) -> Stability {
    let multiplier = |s: &c64| {
        let (modulus, angle) = ((s.re * period).exp(), s.im * period);
        [modulus * angle.cos(), modulus * angle.sin()]
    };
    let all: Vec<[f64; 2]> = exponents.iter().map(multiplier).collect();
    // Sort indices like `sort_multipliers` sorts values.
    let mut sorted = all.clone();
    sort_multipliers(&mut sorted);
    let mut order: Vec<usize> = Vec::with_capacity(all.len());
    for mu in &sorted {
        let pos = (0..all.len())
            .find(|i| !order.contains(i) && all[*i] == *mu)
            .unwrap_or(0);
        order.push(pos);
    }
    let mus: Vec<[f64; 2]> = order.iter().map(|&i| all[i]).collect();
    let exps: Vec<[f64; 2]> = order
        .iter()
        .map(|&i| [exponents[i].re, exponents[i].im])
        .collect();
    let dist_one = |m: &[f64; 2]| (m[0] - 1.0).hypot(m[1]);
    let trivial = match trivial_of_exponents {
        Some(t) => t.map(|i| order.iter().position(|&o| o == i).unwrap_or(0)),
        None => {
            let mut by_one: Vec<usize> = (0..mus.len()).collect();
            by_one.sort_by(|&a, &b| dist_one(&mus[a]).total_cmp(&dist_one(&mus[b])));
            [by_one[0], by_one.get(1).copied().unwrap_or(by_one[0])]
        }
    };
    let trivial_pair_error = trivial
        .iter()
        .map(|&i| dist_one(&mus[i]))
        .fold(0.0, f64::max);
    let mut unstable = UnstableCounts::default();
    let mut max_abs: f64 = 1.0;
    let mut any = false;
    for (i, mu) in mus.iter().enumerate() {
        if trivial.contains(&i) {
            continue;
        }
        let modulus = mu[0].hypot(mu[1]);
        max_abs = if any { max_abs.max(modulus) } else { modulus };
        any = true;
        if modulus > 1.0 + tolerance {
            if has_conjugate_partner(&mus, i) {
                unstable.complex += 1;
            } else if mu[0] > 0.0 {
                unstable.real_positive += 1;
            } else {
                unstable.real_negative += 1;
            }
        }
    }
    let reciprocal_pair_error = mus
        .iter()
        .map(|mu| {
            let m2 = mu[0] * mu[0] + mu[1] * mu[1];
            let target = [mu[0] / m2, mu[1] / m2]; // 1 / conj(mu)
            let best = mus
                .iter()
                .map(|nu| (nu[0] - target[0]).hypot(nu[1] - target[1]))
                .fold(f64::INFINITY, f64::min);
            best / m2.sqrt()
        })
        .fold(0.0, f64::max);
    Stability {
        stable: max_abs <= 1.0 + tolerance,
        multipliers: mus,
        exponents: exps,
        trivial,
        trivial_pair_error,
        max_multiplier_abs: max_abs,
        reciprocal_pair_error,
        unstable,
        modes_kept: 0,
        harmonics: 0,
        selection_mean_harmonic_max: 0.0,
        rejection_mean_harmonic_min: f64::INFINITY,
        method: StabilityMethod::Hill,
        impacts: 0,
        orbit_shift: 0.0,
        orbit_omega: 0.0,
        contact_shares: Vec::new(),
        check: None,
        decoupled_modes: 0,
        unresolved: Vec::new(),
        unresolved_acceleration: 0.0,
    }
}
