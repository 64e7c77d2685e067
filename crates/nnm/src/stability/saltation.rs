//! Event-based monodromy of augmented-Lagrangian (rigid-contact) orbits whose contact phases are
//! unresolved impacts: free linear flow between the impacts, the saltation matrix of the elastic
//! impact at each of them (Leine & Nijmeijer, "Dynamics and Bifurcations of Non-smooth Mechanical
//! Systems", Springer 2004, Sec. 7.2; di Bernardo, Budd, Champneys & Kowalczyk, "Piecewise-smooth
//! Dynamical Systems", Springer 2008, Sec. 2.5). docs/STABILITY.md, Sec. 3.
//!
//! # Model
//! Between impacts the perturbation obeys the free equation M y'' + K y = 0, integrated exactly in
//! the mass-normalized linear modes (u = Phi eta, K Phi = M Phi W^2): each mode is a rotation of
//! (eta_k, eta_k'). At an impact of row j (normal a = A_j, gap a.u - g0 reaching 0 with normal
//! velocity a.v- > 0), the elastic impact v+ = R v-, R = I - 2 M^-1 a a^T / c, c = a^T M^-1 a,
//! has the saltation matrix
//!
//! ```text
//! S = [[R, 0], [2 M^-1 a (a.acc) a^T / (c a.v-), R]],   a.acc = -a^T M^-1 K u(t_i),
//! ```
//!
//! (the oracle's formula, docs/oracle_impact.md), in modal coordinates R = I - 2 b b^T / c,
//! M^-1 a -> b = Phi^T a^T, c = b . b, a.acc = -b^T W^2 eta(t_i). S is symplectic for any
//! a.acc and a.v-, so the multipliers come in reciprocal pairs exactly.
//!
//! # Data taken from the harmonic-balance orbit
//! * impact instants t_i: the force-weighted mean time of the phase's samples;
//! * a.v-: from the impulse of the phase, P = (T / m) sum_k lambda_{j,k} (the sample quadrature
//!   of the harmonic balance, so that P / T is exactly the mean contact force that balances the
//!   orbit's mean u_0): the elastic impact reverses the normal velocity, a.v+ = a.v- - c P =
//!   -a.v-, hence a.v- = c P / 2. The series' own velocity is useless there (its Fourier series
//!   jumps at the impact and converges to the mean of v- and v+);
//! * u(t_i): the cosine series (continuous at the impact, coefficients O(1/n^2));
//! * the flight times from t_i and w.
//!
//! Restitution 1 is that of a conservative periodic orbit: energy lost at an impact could not be
//! regained over the period.

use faer::linalg::solvers::Solve;
use faer::{c64, Mat, MatRef};
use nlmodes_dense::eigenvalues_checked;

use crate::point::BackbonePoint;
use crate::NnmError;

/// One unresolved impact of the orbit.
#[derive(Clone, Debug)]
pub(crate) struct Impact {
    /// Contact row.
    pub row: usize,
    /// Impact instant in [0, T) (s).
    pub time: f64,
    /// Impulse of the phase, sum of lambda over its samples times T / m (N s).
    pub impulse: f64,
}

/// The impacts of `point` if every contact phase is an unresolved rigid impact: a run of
/// consecutive samples with a positive contact force, lasting at most `max_duration` (s), with a
/// positive augmented-Lagrangian multiplier theta on some sample (the rigid law; penalty orbits
/// have theta = 0), and no other row's phase overlapping or touching it (simultaneous impacts
/// have no unique impact law). `None` when the orbit has no contact or any phase fails a test:
/// the caller then uses Hill's method.
pub(crate) fn unresolved_impacts(point: &BackbonePoint, max_duration: f64) -> Option<Vec<Impact>> {
    let m = point.multipliers.samples;
    let c = point.contact_force.len();
    if m == 0 || point.contact_force.iter().any(|f| f.len() != m) {
        return None;
    }
    let period = point.period();
    let dt = period / m as f64;
    let mut impacts = Vec::new();
    let mut occupied = vec![false; m];
    for j in 0..c {
        let force = &point.contact_force[j];
        let theta = &point.multipliers.theta[j * m..(j + 1) * m];
        for run in positive_runs(force) {
            if run.len() as f64 * dt > max_duration || !run.iter().any(|&k| theta[k] > 0.0) {
                return None;
            }
            // No other row active on the run's samples or next to them.
            let neighbourhood = [(run[0] + m - 1) % m, (run[run.len() - 1] + 1) % m];
            if run.iter().chain(&neighbourhood).any(|&k| occupied[k]) {
                return None;
            }
            let total: f64 = run.iter().map(|&k| force[k]).sum();
            // Unwrapped sample times: the run may cross t = 0.
            let start = run[0];
            let moment: f64 = run
                .iter()
                .map(|&k| force[k] * (((k + m - start) % m + start) as f64 * dt))
                .sum();
            impacts.push(Impact {
                row: j,
                time: (moment / total).rem_euclid(period),
                impulse: total * dt,
            });
        }
        for run in positive_runs(force) {
            run.iter().for_each(|&k| occupied[k] = true);
        }
    }
    if impacts.is_empty() {
        return None;
    }
    impacts.sort_by(|a, b| a.time.total_cmp(&b.time));
    Some(impacts)
}

/// Maximal cyclic runs of consecutive indices with values > 0 (each run in time order; a run
/// through the end of the period continues at index 0).
fn positive_runs(values: &[f64]) -> Vec<Vec<usize>> {
    let m = values.len();
    if values.iter().all(|&v| v > 0.0) {
        return vec![(0..m).collect()];
    }
    // Start scanning right after a sample without force, so no run is split at the wrap.
    let first_off = values.iter().position(|&v| v <= 0.0).unwrap_or(0);
    let mut runs: Vec<Vec<usize>> = Vec::new();
    let mut current: Vec<usize> = Vec::new();
    for i in 1..=m {
        let k = (first_off + i) % m;
        if values[k] > 0.0 {
            current.push(k);
        } else if !current.is_empty() {
            runs.push(std::mem::take(&mut current));
        }
    }
    runs
}

/// Modal data for the event-based monodromy.
pub(crate) struct ModalFlow<'a> {
    /// Circular frequencies w_k (rad/s).
    pub omega: &'a [f64],
    /// B = A Phi (c x n).
    pub contact_modal: MatRef<'a, f64>,
    /// Phi^T M (n x n): modal coordinates of a displacement.
    pub projection: MatRef<'a, f64>,
    /// Modes 0..resolved take their state from the orbit's cosine series; the modes above, which
    /// its harmonics do not resolve, from their exact periodic response to the orbit's impulses
    /// ([`ModalFlow::impulse_response`]).
    pub resolved: usize,
}

impl ModalFlow<'_> {
    /// Monodromy (2n x 2n, modal state (eta, eta')) over one period starting just before the
    /// first impact: F(t_0 + T - t_{E-1}) S_{E-1} ... F(t_1 - t_0) S_0. `None` if a normal
    /// velocity is not positive and finite (no impulse) or a state is not finite.
    pub fn monodromy(&self, point: &BackbonePoint, impacts: &[Impact]) -> Option<Mat<f64>> {
        let n = self.omega.len();
        let mut x = Mat::<f64>::identity(2 * n, 2 * n);
        let period = point.period();
        for (e, impact) in impacts.iter().enumerate() {
            let (eta, _) = self.modal_state(point, impacts, impact.time);
            self.apply_saltation(impact, &eta, &mut x)?;
            let next = impacts
                .get(e + 1)
                .map_or(impacts[0].time + period, |i| i.time);
            self.apply_flow(next - impact.time, &mut x);
        }
        Some(x)
    }

    /// Flow direction f(x0) = (eta', -W^2 eta) of the orbit just before the first impact, in modal
    /// coordinates: eta(t_0) and the mean of the velocities before and after the jump from
    /// [`ModalFlow::modal_state`], plus b P / 2 (half the velocity jump -b P).
    pub fn flow_direction(&self, point: &BackbonePoint, impacts: &[Impact]) -> Vec<f64> {
        let first = &impacts[0];
        let (eta, rate) = self.modal_state(point, impacts, first.time);
        (0..self.omega.len())
            .map(|k| rate[k] + 0.5 * first.impulse * self.contact_modal[(first.row, k)])
            .chain((0..self.omega.len()).map(|k| -self.omega[k] * self.omega[k] * eta[k]))
            .collect()
    }

    /// Modal displacement and velocity at `t` (at an impact instant: the mean of the velocities
    /// before and after it): the resolved modes from the cosine series, the others from
    /// [`ModalFlow::impulse_response`].
    fn modal_state(
        &self,
        point: &BackbonePoint,
        impacts: &[Impact],
        t: f64,
    ) -> (Vec<f64>, Vec<f64>) {
        let modal = |x: &[f64]| -> Vec<f64> {
            (0..self.resolved)
                .map(|k| (0..x.len()).map(|i| self.projection[(k, i)] * x[i]).sum())
                .collect()
        };
        let mut eta = modal(&point.displacement_at(t));
        let mut rate = modal(&point.velocity_at(t));
        for k in self.resolved..self.omega.len() {
            let (e, r) = self.impulse_response(k, impacts, point.period(), t);
            eta.push(e);
            rate.push(r);
        }
        (eta, rate)
    }

    /// The T-periodic response of mode k to the orbit's impulse train, eta_k'' + w_k^2 eta_k =
    /// -sum_i b_{j_i k} P_i delta_T(t - t_i): eta_k(t) = -sum_i b_{j_i k} P_i G_k((t - t_i) mod T)
    /// with the periodic Green's function G(s) = cos(w (s - T/2)) / (2 w sin(w T / 2)),
    /// G'(s) = -sin(w (s - T/2)) / (2 sin(w T / 2)) on (0, T) (a velocity jump of 1 at s = 0,
    /// where the mean G'(0) = 0 is taken). Exact for a mode the impacts drive and nothing else
    /// resolves; it diverges at the internal resonances w_k T = 2 pi m. (displacement, velocity).
    fn impulse_response(&self, k: usize, impacts: &[Impact], period: f64, t: f64) -> (f64, f64) {
        let w = self.omega[k];
        let denominator = 2.0 * (0.5 * w * period).sin();
        let (mut eta, mut rate) = (0.0, 0.0);
        for impact in impacts {
            let s = (t - impact.time).rem_euclid(period);
            let strength = -self.contact_modal[(impact.row, k)] * impact.impulse;
            let phase = w * (s - 0.5 * period);
            eta += strength * phase.cos() / (w * denominator);
            if s != 0.0 {
                rate -= strength * phase.sin() / denominator;
            }
        }
        (eta, rate)
    }

    /// Largest relative error of the contact displacement at an impact that the orbit's series
    /// makes in the modes it does not resolve: |sum_{k unresolved} b_jk (eta_k - eta_k^series)|
    /// / g0_j at each impact of row j, eta_k the exact impulse response (0 when every mode is
    /// resolved). The orbit whose monodromy is taken lies this far from the harmonic-balance one.
    pub fn unresolved_gap_error(
        &self,
        point: &BackbonePoint,
        impacts: &[Impact],
        gaps: &[f64],
    ) -> f64 {
        impacts
            .iter()
            .map(|impact| {
                let u = point.displacement_at(impact.time);
                let error: f64 = (self.resolved..self.omega.len())
                    .map(|k| {
                        let series: f64 =
                            (0..u.len()).map(|i| self.projection[(k, i)] * u[i]).sum();
                        let (exact, _) =
                            self.impulse_response(k, impacts, point.period(), impact.time);
                        self.contact_modal[(impact.row, k)] * (exact - series)
                    })
                    .sum();
                error.abs() / gaps[impact.row]
            })
            .fold(0.0, f64::max)
    }

    /// Largest share of the normal acceleration at an impact, a.acc = -sum_k b_jk w_k^2 eta_k,
    /// that the modes above the orbit's harmonics carry, |a.acc_unresolved| / (|a.acc_resolved| +
    /// |a.acc_unresolved|) (0 when every mode is resolved). Their response to the impulses goes
    /// like cot(w_k T / 2) / w_k in displacement but like w_k cot(w_k T / 2) in acceleration: next
    /// to an internal resonance w_k T = 2 pi m it dominates the impact's timing term of the
    /// saltation matrix, and its phase w_k T then moves by w_k T times the orbit's own frequency
    /// error, which the harmonic balance does not resolve.
    pub fn unresolved_acceleration_share(&self, point: &BackbonePoint, impacts: &[Impact]) -> f64 {
        if self.resolved == self.omega.len() {
            return 0.0;
        }
        impacts
            .iter()
            .map(|impact| {
                let (eta, _) = self.modal_state(point, impacts, impact.time);
                let part = |range: std::ops::Range<usize>| -> f64 {
                    range
                        .map(|k| {
                            self.contact_modal[(impact.row, k)] * self.omega[k].powi(2) * eta[k]
                        })
                        .sum::<f64>()
                        .abs()
                };
                let (resolved, unresolved) = (
                    part(0..self.resolved),
                    part(self.resolved..self.omega.len()),
                );
                unresolved / (resolved + unresolved)
            })
            .fold(0.0, f64::max)
    }

    /// x <- F(dt) x, F the free flow of the modes over dt (exact rotations; w_k = 0 drifts).
    fn apply_flow(&self, dt: f64, x: &mut Mat<f64>) {
        let n = self.omega.len();
        for (k, &w) in self.omega.iter().enumerate() {
            let (cos, sin) = ((w * dt).cos(), (w * dt).sin());
            let sin_over_w = if w * dt.abs() > 1e-12 { sin / w } else { dt };
            for col in 0..x.ncols() {
                let (eta, rate) = (x[(k, col)], x[(n + k, col)]);
                x[(k, col)] = cos * eta + sin_over_w * rate;
                x[(n + k, col)] = -w * sin * eta + cos * rate;
            }
        }
    }

    /// x <- S x for the impact (module docs), `eta` the modal displacement at its instant.
    fn apply_saltation(&self, impact: &Impact, eta: &[f64], x: &mut Mat<f64>) -> Option<()> {
        let n = self.omega.len();
        let b: Vec<f64> = (0..n)
            .map(|k| self.contact_modal[(impact.row, k)])
            .collect();
        let c: f64 = b.iter().map(|v| v * v).sum();
        let normal_velocity = 0.5 * c * impact.impulse;
        let normal_acceleration: f64 = -(0..n)
            .map(|k| b[k] * self.omega[k] * self.omega[k] * eta[k])
            .sum::<f64>();
        let alpha = 2.0 * normal_acceleration / (c * normal_velocity);
        if !(normal_velocity > 0.0 && alpha.is_finite()) {
            return None;
        }
        for col in 0..x.ncols() {
            let top: f64 = (0..n).map(|k| b[k] * x[(k, col)]).sum();
            let bottom: f64 = (0..n).map(|k| b[k] * x[(n + k, col)]).sum();
            for k in 0..n {
                x[(k, col)] -= 2.0 / c * b[k] * top;
                x[(n + k, col)] += b[k] * (alpha * top - 2.0 / c * bottom);
            }
        }
        Some(())
    }
}

/// Multipliers of a symplectic monodromy `phi` (modal state (eta, eta'), form J = [[0, I],
/// [-I, 0]]) of an autonomous conservative orbit whose flow direction at the start is `flow`.
///
/// Returns (non-trivial, trivial pair). The trivial pair is a Jordan block at +1 (time shift and
/// family direction) that an O(delta) inconsistency of the orbit data splits by O(sqrt(delta)),
/// enough to collide with a non-trivial pair near a +1 transition. So the non-trivial
/// multipliers are those of the reduced monodromy: phi on E = {x : Omega(f, x) = Omega(J^T f, x)
/// = 0}, the symplectic complement of span(f, J^T f) (the Poincare section within the energy
/// surface; Meyer, Hall & Offin, "Introduction to Hamiltonian Dynamical Systems", Sec. 8.5), in
/// an orthonormal basis Z of E: phi_E = Z^T phi Z (Z^T kills the components along f and J^T f).
/// Its stability is read through rho = (mu + 1/mu) / 2, the eigenvalues (each double) of the
/// skew-Hamiltonian part (phi_E + Omega_E^-1 phi_E^T Omega_E) / 2, Omega_E = Z^T J Z, which is
/// (phi_E + phi_E^-1) / 2 when phi_E is symplectic: a real rho in [-1, 1] gives |mu| = 1 exactly
/// (an O(delta) loss of symplecticity of phi_E cannot push an elliptic pair off the circle),
/// rho > 1 a real pair, rho < -1 a period doubling, a complex rho a Krein quadruple. The trivial
/// pair is reported as the eigenvalues of phi restricted to span(f, J^T f).
pub(crate) fn reduced_multipliers(
    phi: &Mat<f64>,
    flow: &[f64],
) -> Result<(Vec<c64>, [c64; 2]), NnmError> {
    let dim = phi.nrows();
    let n = dim / 2;
    let norm2: f64 = flow.iter().map(|x| x * x).sum();
    if !(norm2 > 0.0 && norm2.is_finite()) {
        return Err(NnmError::NonFiniteResult {
            what: "flow direction of the orbit",
        });
    }
    // J^T x = (-x_2, x_1) for x = (x_1, x_2).
    let jt = |x: &[f64]| -> Vec<f64> {
        (0..dim)
            .map(|i| if i < n { -x[n + i] } else { x[i - n] })
            .collect()
    };
    let partner: Vec<f64> = jt(flow).iter().map(|x| x / norm2).collect();
    let omega =
        |x: &[f64], y: &[f64]| -> f64 { (0..n).map(|i| x[i] * y[n + i] - x[n + i] * y[i]).sum() };
    let apply = |x: &[f64]| -> Vec<f64> {
        (0..dim)
            .map(|i| (0..dim).map(|j| phi[(i, j)] * x[j]).sum())
            .collect()
    };
    // Trivial block: coordinates (Omega(y, w), -Omega(y, f)) of y = phi f, phi w.
    let (pf, pw) = (apply(flow), apply(&partner));
    let block = [
        [omega(&pf, &partner), omega(&pw, &partner)],
        [-omega(&pf, flow), -omega(&pw, flow)],
    ];
    let trivial = two_by_two_eigenvalues(block);
    if n < 2 {
        return Ok((Vec::new(), trivial));
    }
    let spanning = Mat::from_fn(dim, 2, |i, j| if j == 0 { flow[i] } else { partner[i] });
    let q = spanning.qr().compute_Q();
    let z = q.subcols(2, dim - 2);
    let phi_e = z.transpose() * phi * z;
    let j_mat = Mat::from_fn(dim, dim, |i, j| {
        if i < n && j == n + i {
            1.0
        } else if i >= n && j + n == i {
            -1.0
        } else {
            0.0
        }
    });
    let omega_e = z.transpose() * &j_mat * z;
    let back = omega_e.partial_piv_lu().solve(phi_e.transpose() * &omega_e);
    let psi = faer::Scale(0.5) * (&phi_e + &back);
    let what = "reduced monodromy eigenvalues";
    let rhos = eigenvalues_checked(psi.as_ref(), what).map_err(|e| NnmError::Decomposition {
        what,
        detail: e.to_string(),
    })?;
    Ok((multipliers_from_rho(&rhos), trivial))
}

/// Eigenvalues of a real 2 x 2 matrix.
fn two_by_two_eigenvalues(m: [[f64; 2]; 2]) -> [c64; 2] {
    let half_trace = 0.5 * (m[0][0] + m[1][1]);
    let det = m[0][0] * m[1][1] - m[0][1] * m[1][0];
    let disc = c64::new(half_trace * half_trace - det, 0.0).sqrt();
    [
        c64::new(half_trace, 0.0) + disc,
        c64::new(half_trace, 0.0) - disc,
    ]
}

/// From the eigenvalues rho of the skew-Hamiltonian part (each double; paired greedily by
/// nearness), the multipliers rho +- sqrt(rho^2 - 1) of each pair. A real rho (|Im rho| <= 1e-10
/// max(1, |rho|): round-off) is taken real, so that |rho| <= 1 gives |mu| = 1 exactly. The pair's
/// product is 1: the smaller is taken as the inverse of the larger, which rho - sqrt(rho^2 - 1)
/// would cancel to 0 for a large |rho| (a multiplier of 1e9 near an internal resonance).
fn multipliers_from_rho(rhos: &[c64]) -> Vec<c64> {
    let mut free: Vec<c64> = rhos.to_vec();
    let mut out = Vec::with_capacity(rhos.len());
    while let Some(first) = free.pop() {
        let partner = (0..free.len()).min_by(|&a, &b| {
            (free[a] - first)
                .norm()
                .total_cmp(&(free[b] - first).norm())
        });
        let rho = match partner {
            Some(i) => 0.5 * (first + free.swap_remove(i)),
            None => first,
        };
        let rho = if rho.im.abs() <= 1e-10 * rho.norm().max(1.0) {
            c64::new(rho.re, 0.0)
        } else {
            rho
        };
        let root = (rho * rho - c64::new(1.0, 0.0)).sqrt();
        let (plus, minus) = (rho + root, rho - root);
        let large = if plus.norm() >= minus.norm() {
            plus
        } else {
            minus
        };
        out.push(large);
        out.push(c64::new(1.0, 0.0) / large);
    }
    out
}

#[cfg(test)]
mod tests {
    use super::{positive_runs, reduced_multipliers, Impact, ModalFlow};
    use faer::linalg::solvers::Solve;
    use faer::{c64, Mat};

    /// 2-DOF modal state (eta1, eta2, eta1', eta2'): a shear on mode 1 (the trivial Jordan block,
    /// eigenvector f = e_eta1, eigenvalue +1 twice) and `pair` (2 x 2, det 1) on mode 2, mixed by
    /// the symplectic change of variables Sigma = [[A, 0], [0, A^-T]] [[I, B], [0, I]] (B
    /// symmetric). Returns (Sigma phi Sigma^-1, Sigma f).
    fn mixed(pair: [[f64; 2]; 2], perturbation: f64) -> (Mat<f64>, Vec<f64>) {
        let mut phi = Mat::<f64>::identity(4, 4);
        phi[(0, 2)] = 0.7;
        phi[(1, 1)] = pair[0][0];
        phi[(1, 3)] = pair[0][1];
        phi[(3, 1)] = pair[1][0];
        phi[(3, 3)] = pair[1][1];
        let a = [[1.2, 0.3], [-0.4, 0.9]];
        let det = a[0][0] * a[1][1] - a[0][1] * a[1][0];
        let a_inv_t = [
            [a[1][1] / det, -a[1][0] / det],
            [-a[0][1] / det, a[0][0] / det],
        ];
        let b = [[0.5, -0.2], [-0.2, 0.8]];
        let scale = Mat::from_fn(4, 4, |i, j| match (i < 2, j < 2) {
            (true, true) => a[i][j],
            (false, false) => a_inv_t[i - 2][j - 2],
            _ => 0.0,
        });
        let shear = Mat::from_fn(4, 4, |i, j| {
            let id = f64::from(u8::from(i == j));
            if i < 2 && j >= 2 {
                b[i][j - 2]
            } else {
                id
            }
        });
        let sigma = &scale * &shear;
        let sigma_inv = sigma.partial_piv_lu().solve(Mat::<f64>::identity(4, 4));
        let mut out = &sigma * &phi * &sigma_inv;
        // A non-symplectic perturbation, as an O(delta) inconsistency of the orbit data.
        for i in 0..4 {
            for j in 0..4 {
                out[(i, j)] += perturbation * ((3 * i + j) as f64).sin();
            }
        }
        let f: Vec<f64> = (0..4).map(|i| sigma[(i, 0)]).collect();
        (out, f)
    }

    fn nearest(values: &[c64], target: c64) -> f64 {
        values
            .iter()
            .map(|v| (v - target).norm())
            .fold(f64::INFINITY, f64::min)
    }

    #[test]
    fn reduction_recovers_the_nontrivial_pair_and_deflates_the_jordan_block() {
        let theta: f64 = 0.9;
        let rotation = [[theta.cos(), theta.sin()], [-theta.sin(), theta.cos()]];
        let (phi, f) = mixed(rotation, 0.0);
        let (nontrivial, trivial) = reduced_multipliers(&phi, &f).expect("reduction");
        let expected = c64::new(theta.cos(), theta.sin());
        assert_eq!(nontrivial.len(), 2);
        // Exact data: round-off only (the mixing has condition number ~10).
        assert!(nearest(&nontrivial, expected) < 1e-12, "{nontrivial:?}");
        assert!(
            nearest(&nontrivial, expected.conj()) < 1e-12,
            "{nontrivial:?}"
        );
        assert!(trivial
            .iter()
            .all(|mu| (mu - c64::new(1.0, 0.0)).norm() < 1e-6));
        // Period doubling: mu = -2, -1/2.
        let (phi, f) = mixed([[-2.0, 0.0], [0.0, -0.5]], 0.0);
        let (nontrivial, _) = reduced_multipliers(&phi, &f).expect("reduction");
        assert!(
            nearest(&nontrivial, c64::new(-2.0, 0.0)) < 1e-12,
            "{nontrivial:?}"
        );
        assert!(
            nearest(&nontrivial, c64::new(-0.5, 0.0)) < 1e-12,
            "{nontrivial:?}"
        );
        // A 1e-4 inconsistency splits the Jordan block of phi by ~1e-2 (sqrt) but moves the reduced
        // pair by O(1e-4), and keeps it exactly on the unit circle.
        let (phi, f) = mixed(rotation, 1e-4);
        let (nontrivial, trivial) = reduced_multipliers(&phi, &f).expect("reduction");
        assert!(nearest(&nontrivial, expected) < 1e-3, "{nontrivial:?}");
        assert!(nontrivial.iter().all(|mu| (mu.norm() - 1.0).abs() < 1e-12));
        let split = trivial
            .iter()
            .map(|mu| (mu - c64::new(1.0, 0.0)).norm())
            .fold(0.0, f64::max);
        assert!(
            split > 1e-3,
            "the trivial block splits like sqrt(delta): {split}"
        );
    }

    /// The impulse response of a mode above the orbit's harmonics: between impacts a free
    /// oscillation of frequency w, at each impact a velocity jump of -b P, and T-periodic. Two
    /// impacts on two rows; the free flow from just after the second impact over the rest of the
    /// period must land on the state just before the first (1e-12, relative).
    #[test]
    fn impulse_response_is_the_periodic_orbit_of_the_impulse_train() {
        let contact_modal = Mat::from_fn(2, 1, |j, _| [0.3, -0.7][j]);
        let projection = Mat::<f64>::identity(1, 1);
        let omega = [37.3];
        let flow = ModalFlow {
            omega: &omega,
            contact_modal: contact_modal.as_ref(),
            projection: projection.as_ref(),
            resolved: 0,
        };
        let period = 1.0;
        let impacts = [
            Impact {
                row: 0,
                time: 0.1,
                impulse: 2.0,
            },
            Impact {
                row: 1,
                time: 0.55,
                impulse: 0.8,
            },
        ];
        let state = |t: f64| flow.impulse_response(0, &impacts, period, t);
        let w = omega[0];
        // Just before / after an impact: the mean velocity -+ half the jump b P.
        let jump = |i: usize| -contact_modal[(impacts[i].row, 0)] * impacts[i].impulse;
        let (x0, v0_mean) = state(impacts[0].time);
        let v0_before = v0_mean - 0.5 * jump(0);
        let (x1, v1_mean) = state(impacts[1].time);
        let v1_after = v1_mean + 0.5 * jump(1);
        let free = |x: f64, v: f64, dt: f64| {
            let (sn, cs) = (w * dt).sin_cos();
            (x * cs + v * sn / w, -x * w * sn + v * cs)
        };
        // From just after impact 0 to just before impact 1, the free flow.
        let (xa, va) = free(
            x0,
            v0_mean + 0.5 * jump(0),
            impacts[1].time - impacts[0].time,
        );
        let scale = x0.abs() + v0_before.abs() / w;
        assert!((xa - x1).abs() < 1e-12 * scale, "{xa} {x1}");
        assert!((va - (v1_mean - 0.5 * jump(1))).abs() < 1e-12 * scale * w);
        // From just after impact 1 around to just before impact 0 one period later.
        let (xb, vb) = free(x1, v1_after, impacts[0].time + period - impacts[1].time);
        assert!((xb - x0).abs() < 1e-12 * scale, "{xb} {x0}");
        assert!(
            (vb - v0_before).abs() < 1e-12 * scale * w,
            "{vb} {v0_before}"
        );
        // Between impacts it is the same free oscillation.
        let (xm, _) = state(0.3);
        let (xf, _) = free(x0, v0_mean + 0.5 * jump(0), 0.2);
        assert!((xm - xf).abs() < 1e-12 * scale, "{xm} {xf}");
    }

    #[test]
    fn runs_wrap_around_the_period() {
        let v = [1.0, 0.0, 0.0, 2.0, 3.0, 0.0, 4.0];
        assert_eq!(positive_runs(&v), vec![vec![3, 4], vec![6, 0]]);
        assert_eq!(positive_runs(&[0.0; 4]), Vec::<Vec<usize>>::new());
        assert_eq!(positive_runs(&[1.0; 3]), vec![vec![0, 1, 2]]);
    }
}
