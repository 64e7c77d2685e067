//! The exact flow of the free massless boundary (`model`; docs/STABILITY.md Sec. 9) and its
//! transition matrices.
//!
//! On a piece of constant active set a the closed rows sit on the stop, u_a = g_a, so
//! lambda_a = R_aa^-1 (B_a q - g_a) and
//!
//! ```text
//! q'' + K_a q = f_a,   K_a = W^2 + B_a^T R_aa^-1 B_a,   f_a = B_a^T R_aa^-1 g_a,
//! ```
//!
//! a linear oscillator solved exactly in the eigenvectors of K_a (symmetric positive definite).
//! A closed row opens when its force lambda_j falls to 0; an open row closes when its
//! penetration p_j = u_j - g_j rises to 0 (`switch_scan`). At either switch lambda_j = 0, so the
//! contact force and the vector field are continuous: the flow is piecewise linear and
//! Lipschitz, and its transition matrix is the product of the pieces' exact ones (no saltation
//! term).

use std::collections::HashMap;

use faer::linalg::solvers::Solve;
use faer::{Mat, MatRef, Side};

use crate::model::BoundaryModel;
use crate::switch_scan::{next_switch, settle_active_set, EventPath, RowsAt};
use nlmodes_dense::generalized_eigen;
use nlmodes_hb::HbError;

/// Most switches in one call of [`BoundaryFlow::advance`] (a chattering set is an error).
const MAX_SWITCHES: usize = 100_000;
/// A row switches when its event function passes this fraction of the largest gap (the pieces'
/// eigenvectors are orthogonal: their event functions carry the round-off of q itself).
const EVENT_THRESHOLD: f64 = 1e-12;
/// The error of an active set that does not settle.
const UNSETTLED: &str = "the contact set of the massless boundary did not settle";

/// The state (q, q') in the kept modal coordinates.
#[derive(Clone, Debug)]
pub struct FlowState {
    pub q: Vec<f64>,
    pub v: Vec<f64>,
}

/// The exact solution on one active set: K_a = V diag(s^2) V^T, the equilibrium q* and the
/// event functions phi_j = rho_j . q + beta_j written as offset + (rho_j V) . z, z = V^T (q - q*).
/// phi_j is R_jj (-lambda_j) for a closed row and p_j for an open one (both in m): a row
/// switches when its phi_j rises through 0.
struct Piece {
    vecs: Mat<f64>,
    freq: Vec<f64>,
    equilibrium: Vec<f64>,
    event_rows: Mat<f64>,
    event_offset: Vec<f64>,
}

impl Piece {
    /// Modal state (z, z') at time t of the piece from (z0, z0').
    fn modal_at(&self, z0: &[f64], zd0: &[f64], t: f64) -> (Vec<f64>, Vec<f64>) {
        let mut z = vec![0.0; z0.len()];
        let mut zd = vec![0.0; z0.len()];
        for i in 0..z0.len() {
            let s = self.freq[i];
            let (sn, cs) = (s * t).sin_cos();
            z[i] = cs * z0[i] + sn / s * zd0[i];
            zd[i] = -s * sn * z0[i] + cs * zd0[i];
        }
        (z, zd)
    }

    /// Event function of row j at modal state z.
    fn event(&self, j: usize, z: &[f64]) -> f64 {
        self.event_offset[j]
            + (0..z.len())
                .map(|i| self.event_rows[(j, i)] * z[i])
                .sum::<f64>()
    }

    fn to_modal(&self, state: &FlowState) -> (Vec<f64>, Vec<f64>) {
        let r = state.q.len();
        let project = |x: &dyn Fn(usize) -> f64| -> Vec<f64> {
            (0..r)
                .map(|i| (0..r).map(|k| self.vecs[(k, i)] * x(k)).sum())
                .collect()
        };
        let z = project(&|k| state.q[k] - self.equilibrium[k]);
        let zd = project(&|k| state.v[k]);
        (z, zd)
    }

    fn state_of(&self, z: &[f64], zd: &[f64]) -> FlowState {
        let r = z.len();
        let q = (0..r)
            .map(|k| self.equilibrium[k] + (0..r).map(|i| self.vecs[(k, i)] * z[i]).sum::<f64>())
            .collect();
        let v = (0..r)
            .map(|k| (0..r).map(|i| self.vecs[(k, i)] * zd[i]).sum())
            .collect();
        FlowState { q, v }
    }

    /// Transition matrix of the piece over t in (q, q') coordinates (2r x 2r).
    fn transition(&self, t: f64) -> Mat<f64> {
        let r = self.freq.len();
        let mut out = Mat::zeros(2 * r, 2 * r);
        for i in 0..r {
            let s = self.freq[i];
            let (sn, cs) = (s * t).sin_cos();
            let blocks = [[cs, sn / s], [-s * sn, cs]];
            for a in 0..r {
                for b in 0..r {
                    let vv = self.vecs[(a, i)] * self.vecs[(b, i)];
                    for (bi, row) in blocks.iter().enumerate() {
                        for (bj, &x) in row.iter().enumerate() {
                            out[(bi * r + a, bj * r + b)] += x * vv;
                        }
                    }
                }
            }
        }
        out
    }

    /// Acceleration q'' = f_a - K_a q = -V diag(s^2) z at modal state z.
    fn acceleration(&self, z: &[f64]) -> Vec<f64> {
        let r = z.len();
        (0..r)
            .map(|k| {
                -(0..r)
                    .map(|i| self.vecs[(k, i)] * self.freq[i] * self.freq[i] * z[i])
                    .sum::<f64>()
            })
            .collect()
    }
}

/// The exact flow of a [`BoundaryModel`], with the pieces of the active sets met so far cached.
pub struct BoundaryFlow<'m> {
    model: &'m BoundaryModel,
    pieces: HashMap<Vec<bool>, Piece>,
    threshold: f64,
    /// Switches made since construction.
    pub switches: usize,
    /// Time each row has spent closed since construction (s).
    pub closed_time: Vec<f64>,
}

impl<'m> BoundaryFlow<'m> {
    pub fn new(model: &'m BoundaryModel) -> Self {
        let gmax = model.gaps.iter().fold(0.0_f64, |a, &g| a.max(g.abs()));
        Self {
            model,
            pieces: HashMap::new(),
            threshold: EVENT_THRESHOLD * gmax,
            switches: 0,
            closed_time: vec![0.0; model.gaps.len()],
        }
    }

    /// The active set of a state at rest on the contact law: the solution of the linear
    /// complementarity problem lambda = R_aa^-1 (B_a q - g_a) >= 0, p_f <= 0 by Murty's
    /// least-index principal pivoting (finite for the positive definite R).
    pub fn active_set_at(&mut self, q: &[f64]) -> Result<Vec<bool>, HbError> {
        let c = self.model.gaps.len();
        let threshold = self.threshold;
        let state = FlowState {
            q: q.to_vec(),
            v: vec![0.0; q.len()],
        };
        settle_active_set(c, vec![false; c], UNSETTLED, |active| {
            let piece = self.piece(active)?;
            let z = piece.to_modal(&state).0;
            Ok((0..c).find(|&j| piece.event(j, &z) > threshold))
        })
    }

    /// Advances `state` by `duration` (s) on the active set `active` (updated at each switch);
    /// multiplies `transition` (2r x 2r) from the left by the flow's transition matrix when
    /// given. Returns the acceleration at the end.
    pub fn advance(
        &mut self,
        state: &mut FlowState,
        active: &mut [bool],
        duration: f64,
        mut transition: Option<&mut Mat<f64>>,
    ) -> Result<Vec<f64>, HbError> {
        let mut left = duration;
        let mut switches = 0;
        let mut toggled = None;
        loop {
            let threshold = self.threshold;
            let piece = self.piece(active)?;
            let (z0, zd0) = piece.to_modal(state);
            let path = FreePath::new(piece, &z0, &zd0);
            let event = next_switch(&path, threshold, left, toggled);
            let dt = event.map_or(left, |(t, _)| t);
            let (z, zd) = piece.modal_at(&z0, &zd0, dt);
            if let Some(m) = transition.as_deref_mut() {
                *m = piece.transition(dt) * &*m;
            }
            *state = piece.state_of(&z, &zd);
            let accel = piece.acceleration(&z);
            for (j, _) in active.iter().enumerate().filter(|(_, &a)| a) {
                self.closed_time[j] += dt;
            }
            left -= dt;
            match event {
                None => return Ok(accel),
                Some((_, row)) => {
                    active[row] = !active[row];
                    toggled = Some(row);
                    switches += 1;
                    self.switches += 1;
                }
            }
            if switches > MAX_SWITCHES {
                return Err(HbError::StabilityInput {
                    detail: format!(
                        "the contact set of the massless boundary chattered ({MAX_SWITCHES} switches)"
                    ),
                });
            }
        }
    }

    /// The contact forces lambda (N, one per row) of `state` on the active set `active`: a
    /// closed row's event function is -R_jj lambda_j, an open row carries none.
    pub fn contact_force(
        &mut self,
        state: &FlowState,
        active: &[bool],
    ) -> Result<Vec<f64>, HbError> {
        let model = self.model;
        let flex = model.flexibility.as_ref();
        let piece = self.piece(active)?;
        let (z, _) = piece.to_modal(state);
        Ok((0..active.len())
            .map(|j| {
                if active[j] {
                    -piece.event(j, &z) / flex[(j, j)]
                } else {
                    0.0
                }
            })
            .collect())
    }

    /// B q - R lambda (m) of every row for the contact forces `lambda` of `state`
    /// ([`Self::contact_force`]): the contact displacement, at the stop (g0) on a closed row (for
    /// a penalty law, R holds 1 / kc: the stop side of the penalty spring).
    pub fn stop_side_displacement(&self, state: &FlowState, lambda: &[f64]) -> Vec<f64> {
        let (b, flex) = (&self.model.contact_modal, &self.model.flexibility);
        (0..lambda.len())
            .map(|j| {
                let bq: f64 = (0..state.q.len()).map(|k| b[(j, k)] * state.q[k]).sum();
                let rl: f64 = (0..lambda.len()).map(|i| flex[(j, i)] * lambda[i]).sum();
                bq - rl
            })
            .collect()
    }

    fn piece(&mut self, active: &[bool]) -> Result<&Piece, HbError> {
        if !self.pieces.contains_key(active) {
            let piece = build_piece(self.model, active)?;
            self.pieces.insert(active.to_vec(), piece);
        }
        Ok(&self.pieces[active])
    }
}

/// A piece along the solution from the modal state (z0, z0'): what the switch scan reads. Each
/// modal coordinate oscillates with amplitude A_i = (z0_i^2 + (z0'_i / s_i)^2)^1/2, so
/// |f_j''| <= sum_i |rho_ji V| s_i^2 A_i at any time.
struct FreePath<'p> {
    piece: &'p Piece,
    z0: &'p [f64],
    zd0: &'p [f64],
    /// s_i^2 A_i per modal coordinate.
    curvatures: Vec<f64>,
}

impl<'p> FreePath<'p> {
    fn new(piece: &'p Piece, z0: &'p [f64], zd0: &'p [f64]) -> Self {
        let curvatures = (0..z0.len())
            .map(|i| {
                let s = piece.freq[i];
                s * s * z0[i].hypot(zd0[i] / s)
            })
            .collect();
        Self {
            piece,
            z0,
            zd0,
            curvatures,
        }
    }

    fn rate(&self, j: usize, zd: &[f64]) -> f64 {
        (0..zd.len())
            .map(|i| self.piece.event_rows[(j, i)] * zd[i])
            .sum()
    }
}

impl EventPath for FreePath<'_> {
    fn event(&self, j: usize, tau: f64) -> f64 {
        let (z, _) = self.piece.modal_at(self.z0, self.zd0, tau);
        self.piece.event(j, &z)
    }

    fn event_rate(&self, j: usize, tau: f64) -> f64 {
        let (_, zd) = self.piece.modal_at(self.z0, self.zd0, tau);
        self.rate(j, &zd)
    }

    fn rows_at(&self, tau: f64) -> RowsAt {
        let (z, zd) = self.piece.modal_at(self.z0, self.zd0, tau);
        let c = self.rows();
        RowsAt {
            events: (0..c).map(|j| self.piece.event(j, &z)).collect(),
            rates: (0..c).map(|j| self.rate(j, &zd)).collect(),
            curvatures: self.curvatures.clone(),
            terms: Vec::new(),
        }
    }

    fn curvature_bound(&self, j: usize, a: &RowsAt, _: &RowsAt) -> f64 {
        (0..a.curvatures.len())
            .map(|i| self.piece.event_rows[(j, i)].abs() * a.curvatures[i])
            .sum()
    }

    fn fastest(&self) -> f64 {
        self.piece.freq.iter().fold(0.0_f64, |a, &s| a.max(s))
    }

    /// The curvature terms bound the whole piece (undamped: constant modal amplitudes).
    fn growth_rate(&self) -> Option<f64> {
        Some(0.0)
    }

    fn rows(&self) -> usize {
        self.piece.event_offset.len()
    }
}

/// The exact solution data of the active set `active` (module docs).
fn build_piece(model: &BoundaryModel, active: &[bool]) -> Result<Piece, HbError> {
    let r = model.omega2.len();
    let c = model.gaps.len();
    let b = model.contact_modal.as_ref();
    let flex = model.flexibility.as_ref();
    let set: Vec<usize> = (0..c).filter(|&j| active[j]).collect();
    let na = set.len();
    // L = R_aa^-1 B_a (na x r), l = R_aa^-1 g_a: lambda_a = L q - l.
    let (l_mat, l_vec) = if na == 0 {
        (Mat::zeros(0, r), Mat::zeros(0, 1))
    } else {
        let r_aa = Mat::from_fn(na, na, |i, k| flex[(set[i], set[k])]);
        let llt = r_aa.llt(Side::Lower).map_err(|e| HbError::Decomposition {
            what: "Cholesky of the massless boundary's flexibility on the closed rows",
            detail: format!("{e:?}"),
        })?;
        let b_a = Mat::from_fn(na, r, |i, k| b[(set[i], k)]);
        let g_a = Mat::from_fn(na, 1, |i, _| model.gaps[set[i]]);
        (llt.solve(&b_a), llt.solve(&g_a))
    };
    let b_a = Mat::from_fn(na, r, |i, k| b[(set[i], k)]);
    let mut k_a = b_a.transpose() * &l_mat;
    for i in 0..r {
        k_a[(i, i)] += model.omega2[i];
    }
    for i in 0..r {
        for k in 0..i {
            let avg = 0.5 * (k_a[(i, k)] + k_a[(k, i)]);
            k_a[(i, k)] = avg;
            k_a[(k, i)] = avg;
        }
    }
    let f_a = b_a.transpose() * &l_vec;
    let identity = Mat::<f64>::identity(r, r);
    let eig = generalized_eigen(k_a.as_ref(), identity.as_ref()).map_err(HbError::dense("I"))?;
    if eig.values.iter().any(|&s2| s2.is_nan() || s2 <= 0.0) {
        return Err(HbError::NotPositiveDefinite {
            name: "K_a",
            detail: "the massless boundary's stiffness on a contact set is not positive definite"
                .to_string(),
        });
    }
    let freq: Vec<f64> = eig.values.iter().map(|s2| s2.sqrt()).collect();
    let vecs = eig.vectors;
    // q* = V diag(1 / s^2) V^T f_a.
    let modal_force: Vec<f64> = (0..r)
        .map(|i| (0..r).map(|k| vecs[(k, i)] * f_a[(k, 0)]).sum::<f64>() / eig.values[i])
        .collect();
    let equilibrium: Vec<f64> = (0..r)
        .map(|k| (0..r).map(|i| vecs[(k, i)] * modal_force[i]).sum())
        .collect();
    let (rho, beta) = event_functions(b, flex, &model.gaps, &set, l_mat.as_ref(), &l_vec);
    let event_rows = &rho * &vecs;
    let event_offset = (0..c)
        .map(|j| beta[j] + (0..r).map(|k| rho[(j, k)] * equilibrium[k]).sum::<f64>())
        .collect();
    Ok(Piece {
        vecs,
        freq,
        equilibrium,
        event_rows,
        event_offset,
    })
}

/// The event functions phi_j = rho_j . q + beta_j of every row on the active set `set`:
/// R_jj (l_i - L_i q) for a closed row (i its place in the set: -R_jj lambda_j), and
/// B_j q - R_ja (L q - l) - g_j for an open row (its penetration).
fn event_functions(
    b: MatRef<'_, f64>,
    flex: MatRef<'_, f64>,
    gaps: &[f64],
    set: &[usize],
    l_mat: MatRef<'_, f64>,
    l_vec: &Mat<f64>,
) -> (Mat<f64>, Vec<f64>) {
    let (c, r) = (b.nrows(), b.ncols());
    let mut rho = Mat::zeros(c, r);
    let mut beta = vec![0.0; c];
    for j in 0..c {
        if let Some(i) = set.iter().position(|&s| s == j) {
            let rjj = flex[(j, j)];
            for k in 0..r {
                rho[(j, k)] = -rjj * l_mat[(i, k)];
            }
            beta[j] = rjj * l_vec[(i, 0)];
        } else {
            for k in 0..r {
                rho[(j, k)] = b[(j, k)]
                    - (0..set.len())
                        .map(|i| flex[(j, set[i])] * l_mat[(i, k)])
                        .sum::<f64>();
            }
            beta[j] = (0..set.len())
                .map(|i| flex[(j, set[i])] * l_vec[(i, 0)])
                .sum::<f64>()
                - gaps[j];
        }
    }
    (rho, beta)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::test_models::bilinear;

    /// A bilinear oscillator (w = 1, gap 1, R = 0.1) whose cosine peaks 1e-6 above the gap
    /// half-way between two scan points (the scan steps 2 pi / 16): the contact lasts about
    /// 2 (2 (A - 1))^1/2 = 2.8e-3 s, far shorter than a step, and the event function is below
    /// the threshold at both scan points. The scan finds it from the rates and the curvature
    /// bound: two switches, closed for that long.
    #[test]
    fn a_grazing_contact_shorter_than_a_scan_step_is_found() {
        let model = bilinear(0.1);
        let amplitude = 1.0 + 1e-6;
        let peak = std::f64::consts::PI / 16.0;
        let mut state = FlowState {
            q: vec![amplitude * peak.cos()],
            v: vec![amplitude * peak.sin()],
        };
        let mut flow = BoundaryFlow::new(&model);
        let mut active = flow.active_set_at(&state.q).expect("set");
        assert_eq!(active, [false]);
        flow.advance(&mut state, &mut active, 2.0 * peak, None)
            .expect("flow");
        let expected = 2.0 * (2.0 * (amplitude - 1.0)).sqrt();
        println!(
            "{} switches, closed {:.3e} s (free cosine above the gap {expected:.3e} s)",
            flow.switches, flow.closed_time[0]
        );
        assert_eq!(flow.switches, 2);
        assert!((flow.closed_time[0] / expected - 1.0).abs() < 0.1);
    }
}
