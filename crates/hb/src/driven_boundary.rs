//! The massless contact boundary of a damped, driven model: its exact flow, the periodic orbit
//! next to a forced harmonic-balance orbit by shooting, and that orbit's monodromy (DESIGN
//! §10.6; docs/STABILITY.md, Sec. 9 for the free modes' version).
//!
//! # Model
//! The linear modes up to a cutoff are the dynamic coordinates q (mass-normalized, K = W^2,
//! damping C_q = Phi_k^T C Phi_k); the others respond statically through the residual
//! flexibility on the contact rows, R = A Phi_d W_d^-2 Phi_d^T A^T (c x c, m/N), and to the load
//! through D(t) = A Phi_d W_d^-2 Phi_d^T f(t) (c, m). The contact displacements carry no mass:
//!
//! ```text
//! q'' + C_q q' + W^2 q = Phi_k^T f(t) - B^T lambda,   u_c = B q + D(t) - R lambda,
//! 0 <= lambda _|_ g0 - u_c >= 0                        (B = A Phi_k)
//! ```
//!
//! A penalty law kc adds 1 / kc to R's diagonal. f(t) = sum_h f_h^c cos(h W t) + f_h^s sin(h W t)
//! (N). On a piece of constant active set a, lambda_a = R_aa^-1 (B_a q + D_a(t) - g_a), a linear
//! system with constant coefficients driven by the harmonics of f. In the augmented state
//! x = (q, q', cos(h W t), sin(h W t) for each h, 1) it is x' = X_a x, solved exactly in the
//! eigenvectors of X_a (diagonalizable: the damped modes' eigenvalues lie off the imaginary axis,
//! the drive's at +-i h W and the constant's at 0). A closed row opens when lambda_j falls to 0,
//! an open row closes when its penetration rises to 0; lambda_j = 0 at both, so the vector field
//! is continuous and the monodromy is the product of the pieces' (q, q') blocks (no saltation).

use std::collections::HashMap;

use faer::linalg::solvers::Solve;
use faer::{c64, Mat, MatRef, Side};

use crate::arc_length::min_norm_step;
use crate::error::HbError;

/// Scan points per shortest period of a piece when looking for a switch.
const SCAN_PER_PERIOD: f64 = 16.0;
/// Bisection steps locating a switch (interval / 2^60).
const BISECTION_STEPS: usize = 60;
/// Most switches over one period before the contact set is declared chattering.
const MAX_SWITCHES: usize = 100_000;
/// A row switches when its event function (m) passes this fraction of the largest gap: a
/// penetration or force 1e-9 of the gap is below any physical meaning and above the round-off of
/// the event functions through the (non-orthogonal) eigenvectors of a piece.
const EVENT_THRESHOLD: f64 = 1e-9;
/// Newton on x(T) = x(0) stops below this scaled residual.
const SHOOTING_TOLERANCE: f64 = 1e-10;
/// Newton iterations before giving up.
const SHOOTING_ITERATIONS: usize = 20;

/// sum_{k >= r} b_k b_k^T / w_k^2 (c x c, m/N): the static flexibility of the modes r.. on the
/// contact rows (`contact_modal` = A Phi, c x n; `eigenvalues` = w_k^2). Zero when r = n.
pub fn residual_sum(contact_modal: MatRef<'_, f64>, eigenvalues: &[f64], r: usize) -> Mat<f64> {
    let c = contact_modal.nrows();
    let b = contact_modal;
    Mat::from_fn(c, c, |i, j| {
        (r..eigenvalues.len())
            .map(|k| b[(i, k)] * b[(j, k)] / eigenvalues[k])
            .sum::<f64>()
    })
}

/// The residual flexibility of the modes r.. on the contact rows, R = sum_{k >= r} b_k b_k^T /
/// w_k^2 (c x c, m/N; `contact_modal` = A Phi, c x n, `eigenvalues` = w_k^2 ascending), plus
/// 1 / kc on the diagonal of a penalty law's rows (`penalty`: one kc per row, N/m). `None` unless
/// it is positive definite with a margin of 1e-10 of its largest diagonal entry: a row the
/// discarded modes barely reach would make a near-rigid contact of a near-massive coordinate
/// (an impact), not a massless boundary.
pub fn residual_flexibility(
    contact_modal: MatRef<'_, f64>,
    eigenvalues: &[f64],
    r: usize,
    penalty: Option<&[f64]>,
) -> Option<Mat<f64>> {
    let c = contact_modal.nrows();
    let mut flexibility = residual_sum(contact_modal, eigenvalues, r);
    if let Some(kc) = penalty {
        for (j, k) in kc.iter().enumerate() {
            flexibility[(j, j)] += 1.0 / k;
        }
    }
    let scale = (0..c).fold(0.0_f64, |a, j| a.max(flexibility[(j, j)]));
    let shifted = Mat::from_fn(c, c, |i, j| {
        flexibility[(i, j)] - if i == j { 1e-10 * scale } else { 0.0 }
    });
    if scale.is_nan() || scale <= 0.0 || shifted.llt(Side::Lower).is_err() {
        return None;
    }
    Some(flexibility)
}

/// One harmonic of the drive in the boundary model's terms.
#[derive(Clone, Debug)]
pub struct BoundaryDrive {
    /// Harmonic h of W.
    pub harmonic: usize,
    /// Phi_k^T f_h^c and Phi_k^T f_h^s (r each, N / sqrt(kg)).
    pub modal: [Vec<f64>; 2],
    /// D_h^c and D_h^s: the discarded modes' static response at the contact rows (c each, m).
    pub contact: [Vec<f64>; 2],
}

/// The damped, driven massless-boundary model at one excitation frequency (module docs).
#[derive(Clone, Debug)]
pub struct DrivenBoundary {
    /// W^2 of the kept modes (rad^2/s^2).
    pub omega2: Vec<f64>,
    /// C_q (r x r, 1/s).
    pub damping: Mat<f64>,
    /// B = A Phi_k (c x r).
    pub contact_modal: Mat<f64>,
    /// R (+ diag(1 / kc)), c x c, m/N.
    pub flexibility: Mat<f64>,
    /// g0 (m).
    pub gaps: Vec<f64>,
    /// The drive's harmonics.
    pub drive: Vec<BoundaryDrive>,
    /// Excitation frequency W (rad/s).
    pub omega: f64,
}

impl DrivenBoundary {
    pub(crate) fn r(&self) -> usize {
        self.omega2.len()
    }

    /// Size of the augmented state: 2r + 2H + 1.
    fn size(&self) -> usize {
        2 * self.r() + 2 * self.drive.len() + 1
    }

    /// The augmented state at time t from (q, q').
    pub fn augmented(&self, q: &[f64], v: &[f64], t: f64) -> Vec<f64> {
        let mut x: Vec<f64> = q.iter().chain(v).copied().collect();
        for d in &self.drive {
            let (s, c) = (d.harmonic as f64 * self.omega * t).sin_cos();
            x.extend([c, s]);
        }
        x.push(1.0);
        x
    }
}

/// Event functions, rates and per-mode curvature terms |l_k|^2 |e_k| at one instant of a piece.
struct RowsAt {
    events: Vec<f64>,
    rates: Vec<f64>,
    curvatures: Vec<f64>,
}

/// The exact solution on one active set: X_a = V diag(l) V^-1, the event functionals
/// (c x size) through V, and the fastest frequency.
struct Piece {
    values: Vec<c64>,
    vectors: Mat<c64>,
    inverse: Mat<c64>,
    events: Mat<c64>,
    fastest: f64,
}

impl Piece {
    /// Event function of row j at time tau from the piece's start, w0 = V^-1 x0.
    fn event(&self, j: usize, w0: &[c64], tau: f64) -> f64 {
        (0..w0.len())
            .map(|k| (self.events[(j, k)] * (self.values[k] * tau).exp() * w0[k]).re)
            .sum()
    }

    /// The time derivative of row j's event function at tau.
    fn event_rate(&self, j: usize, w0: &[c64], tau: f64) -> f64 {
        (0..w0.len())
            .map(|k| {
                let l = self.values[k];
                (self.events[(j, k)] * l * (l * tau).exp() * w0[k]).re
            })
            .sum()
    }

    /// Every row's event function and its rate at tau, and a bound on the modes' contribution
    /// to its second derivative (one exponential per eigenvalue, shared by the rows).
    fn rows_at(&self, w0: &[c64], tau: f64) -> RowsAt {
        let e: Vec<c64> = (0..w0.len())
            .map(|k| (self.values[k] * tau).exp() * w0[k])
            .collect();
        let c = self.events.nrows();
        let mut rows = RowsAt {
            events: vec![0.0; c],
            rates: vec![0.0; c],
            curvatures: vec![0.0; e.len()],
        };
        for (k, ek) in e.iter().enumerate() {
            let l = self.values[k];
            rows.curvatures[k] = l.norm_sqr() * ek.norm_sqr().sqrt();
            for j in 0..c {
                let v = self.events[(j, k)] * ek;
                rows.events[j] += v.re;
                rows.rates[j] += (v * l).re;
            }
        }
        rows
    }

    /// A bound on |f_j''| over [t0, t1] from the mode terms at both ends (|exp(l t)| is monotone
    /// in t, so each term's largest modulus is at one end).
    fn curvature_bound(&self, j: usize, a: &RowsAt, b: &RowsAt) -> f64 {
        (0..a.curvatures.len())
            .map(|k| self.events[(j, k)].norm_sqr().sqrt() * a.curvatures[k].max(b.curvatures[k]))
            .sum()
    }

    fn state_at(&self, w0: &[c64], tau: f64) -> Vec<f64> {
        let m = w0.len();
        let e: Vec<c64> = (0..m)
            .map(|k| (self.values[k] * tau).exp() * w0[k])
            .collect();
        (0..m)
            .map(|i| (0..m).map(|k| (self.vectors[(i, k)] * e[k]).re).sum())
            .collect()
    }

    /// The (q, q') block (2r x 2r) of the transition over tau.
    fn transition(&self, r: usize, tau: f64) -> Mat<f64> {
        let m = self.values.len();
        let e: Vec<c64> = (0..m).map(|k| (self.values[k] * tau).exp()).collect();
        Mat::from_fn(2 * r, 2 * r, |i, j| {
            (0..m)
                .map(|k| (self.vectors[(i, k)] * e[k] * self.inverse[(k, j)]).re)
                .sum()
        })
    }
}

/// The exact flow of a [`DrivenBoundary`], pieces cached by active set.
pub struct DrivenFlow<'m> {
    model: &'m DrivenBoundary,
    pieces: HashMap<Vec<bool>, Piece>,
    threshold: f64,
}

impl<'m> DrivenFlow<'m> {
    pub fn new(model: &'m DrivenBoundary) -> Self {
        let gmax = model.gaps.iter().fold(0.0_f64, |a, &g| a.max(g.abs()));
        Self {
            model,
            pieces: HashMap::new(),
            threshold: EVENT_THRESHOLD * gmax,
        }
    }

    /// The active set at augmented state x: Murty's least-index pivoting on the event
    /// functions (finite for the positive definite R).
    pub fn active_set_at(&mut self, x: &[f64]) -> Result<Vec<bool>, HbError> {
        let c = self.model.gaps.len();
        let mut active = vec![false; c];
        for _ in 0..(4 * c * c + 16) {
            let threshold = self.threshold;
            let piece = self.piece(&active)?;
            let w0 = solve_in(piece, x);
            match (0..c).find(|&j| piece.event(j, &w0, 0.0) > threshold) {
                Some(j) => active[j] = !active[j],
                None => return Ok(active),
            }
        }
        Err(HbError::StabilityInput {
            detail: "the contact set of the massless boundary did not settle".to_string(),
        })
    }

    /// Advances the augmented state x over `duration` on the active set `active` (updated at
    /// each switch); multiplies `transition` (2r x 2r) from the left by the (q, q') block of
    /// the flow when given.
    pub fn advance(
        &mut self,
        x: &mut Vec<f64>,
        active: &mut [bool],
        duration: f64,
        mut transition: Option<&mut Mat<f64>>,
    ) -> Result<(), HbError> {
        let r = self.model.r();
        let mut left = duration;
        let mut toggled = None;
        for _ in 0..MAX_SWITCHES {
            let threshold = self.threshold;
            let piece = self.piece(active)?;
            let w0 = solve_in(piece, x);
            let event = next_switch(piece, threshold, &w0, left, toggled);
            let dt = event.map_or(left, |(t, _)| t);
            *x = piece.state_at(&w0, dt);
            if let Some(m) = transition.as_deref_mut() {
                *m = piece.transition(r, dt) * &*m;
            }
            left -= dt;
            match event {
                None => return Ok(()),
                Some((_, row)) => {
                    active[row] = !active[row];
                    toggled = Some(row);
                }
            }
        }
        Err(HbError::StabilityInput {
            detail: format!(
                "the contact set of the massless boundary chattered ({MAX_SWITCHES} switches)"
            ),
        })
    }

    /// The contact forces lambda (c, N) at augmented state x on the active set `active`:
    /// lambda_j = -(event function of closed row j) / R_jj, 0 on open rows.
    pub fn contact_force(&mut self, x: &[f64], active: &[bool]) -> Result<Vec<f64>, HbError> {
        let model = self.model;
        let piece = self.piece(active)?;
        let w0 = solve_in(piece, x);
        Ok((0..model.gaps.len())
            .map(|j| {
                if active[j] {
                    -piece.event(j, &w0, 0.0) / model.flexibility[(j, j)]
                } else {
                    0.0
                }
            })
            .collect())
    }

    fn piece(&mut self, active: &[bool]) -> Result<&Piece, HbError> {
        if !self.pieces.contains_key(active) {
            let piece = build_piece(self.model, active)?;
            self.pieces.insert(active.to_vec(), piece);
        }
        Ok(&self.pieces[active])
    }
}

/// w0 = V^-1 x.
fn solve_in(piece: &Piece, x: &[f64]) -> Vec<c64> {
    let m = x.len();
    (0..m)
        .map(|k| {
            (0..m)
                .map(|i| piece.inverse[(k, i)] * c64::new(x[i], 0.0))
                .sum()
        })
        .collect()
}

/// The first switch within `horizon`: (time, row); a row already past its boundary at the start
/// switches at once, except the row `toggled` at this very instant (its event function is 0
/// there up to round-off: it switches again only on a crossing found by the scan).
fn next_switch(
    piece: &Piece,
    tol: f64,
    w0: &[c64],
    horizon: f64,
    toggled: Option<usize>,
) -> Option<(f64, usize)> {
    let c = piece.events.nrows();
    if let Some(j) = (0..c).find(|&j| Some(j) != toggled && piece.event(j, w0, 0.0) > tol) {
        return Some((0.0, j));
    }
    let step = 2.0 * std::f64::consts::PI / (SCAN_PER_PERIOD * piece.fastest);
    let mut t0 = 0.0;
    let mut before = piece.rows_at(w0, 0.0);
    while t0 < horizon {
        let t1 = (t0 + step).min(horizon);
        let after = piece.rows_at(w0, t1);
        let crossing = (0..c)
            .filter_map(|j| {
                if after.events[j] > tol {
                    return Some((bisect(piece, w0, j, t0, t1), j));
                }
                // A short excursion past the boundary between two scan points (a grazing
                // contact, shorter than the scan step): the event function rises, then falls;
                // its maximum, where its rate vanishes, is past the threshold. Within the step
                // it stays below f(t0) + f'(t0) h + |f''| h^2 / 2: no excursion when that is
                // below the threshold.
                let h = t1 - t0;
                let reach = || {
                    before.events[j]
                        + before.rates[j] * h
                        + 0.5 * piece.curvature_bound(j, &before, &after) * h * h
                };
                if before.rates[j] > 0.0 && after.rates[j] < 0.0 && reach() > tol {
                    let top = bisect_rate(piece, w0, j, t0, t1);
                    if piece.event(j, w0, top) > tol {
                        return Some((bisect(piece, w0, j, t0, top), j));
                    }
                }
                None
            })
            .min_by(|a, b| a.0.total_cmp(&b.0));
        if crossing.is_some() {
            return crossing;
        }
        (t0, before) = (t1, after);
    }
    None
}

/// The time in (a, b) where row j's event rate falls through 0 (positive at a, negative at b):
/// the event function's maximum.
fn bisect_rate(piece: &Piece, w0: &[c64], j: usize, a: f64, b: f64) -> f64 {
    let (mut lo, mut hi) = (a, b);
    for _ in 0..BISECTION_STEPS {
        let mid = 0.5 * (lo + hi);
        if mid <= lo || mid >= hi {
            break;
        }
        if piece.event_rate(j, w0, mid) > 0.0 {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    0.5 * (lo + hi)
}

/// The time in (a, b] where row j's event function rises through 0 (the positive side).
fn bisect(piece: &Piece, w0: &[c64], j: usize, a: f64, b: f64) -> f64 {
    let (mut lo, mut hi) = (a, b);
    for _ in 0..BISECTION_STEPS {
        let mid = 0.5 * (lo + hi);
        if mid <= lo || mid >= hi {
            break;
        }
        if piece.event(j, w0, mid) > 0.0 {
            hi = mid;
        } else {
            lo = mid;
        }
    }
    hi
}

/// X_a, its eigen-decomposition and the event functionals of the active set `active`.
fn build_piece(model: &DrivenBoundary, active: &[bool]) -> Result<Piece, HbError> {
    let (r, c, m) = (model.r(), model.gaps.len(), model.size());
    let set: Vec<usize> = (0..c).filter(|&j| active[j]).collect();
    let na = set.len();
    let b = model.contact_modal.as_ref();
    let flex = model.flexibility.as_ref();
    // E = R_aa^-1 [B_a | D_a columns | -g_a] (na x (r + 2H + 1)): lambda_a = E (q, z, 1).
    let cols = r + 2 * model.drive.len() + 1;
    let rhs = Mat::from_fn(na, cols, |i, k| {
        let j = set[i];
        if k < r {
            b[(j, k)]
        } else if k + 1 < cols {
            let (h, part) = ((k - r) / 2, (k - r) % 2);
            model.drive[h].contact[part][j]
        } else {
            -model.gaps[j]
        }
    });
    let e = if na == 0 {
        Mat::zeros(0, cols)
    } else {
        let r_aa = Mat::from_fn(na, na, |i, k| flex[(set[i], set[k])]);
        let llt = r_aa
            .llt(Side::Lower)
            .map_err(|err| HbError::Decomposition {
                what: "Cholesky of the massless boundary's flexibility on the closed rows",
                detail: format!("{err:?}"),
            })?;
        llt.solve(&rhs)
    };
    let x_a = generator(model, &set, e.as_ref());
    let events = event_functionals(model, &set, e.as_ref());
    let eig = x_a.eigen().map_err(|err| HbError::Decomposition {
        what: "eigen-decomposition of a piece of the massless boundary",
        detail: format!("{err:?}"),
    })?;
    let values: Vec<c64> = (0..m).map(|k| eig.S()[k]).collect();
    let vectors = eig.U().to_owned();
    let inverse = vectors.partial_piv_lu().solve(Mat::<c64>::identity(m, m));
    if inverse
        .col_iter()
        .any(|col| col.iter().any(|z| !z.is_finite()))
    {
        return Err(HbError::NonFiniteResult {
            what: "eigenvectors of a piece of the massless boundary",
        });
    }
    let fastest = values.iter().map(|l| l.norm()).fold(model.omega, f64::max);
    let events_c = Mat::from_fn(c, m, |i, k| c64::new(events[(i, k)], 0.0));
    Ok(Piece {
        values,
        events: &events_c * &vectors,
        vectors,
        inverse,
        fastest,
    })
}

/// X_a (size x size): q' = v; v' = -W^2 q - C_q v + sum_h P_h z_h - B_a^T lambda_a; z_h rotating
/// at h W; 1' = 0 (module docs).
fn generator(model: &DrivenBoundary, set: &[usize], e: MatRef<'_, f64>) -> Mat<f64> {
    let (r, m) = (model.r(), model.size());
    let hh = model.drive.len();
    let b = model.contact_modal.as_ref();
    let mut x = Mat::zeros(m, m);
    for i in 0..r {
        x[(i, r + i)] = 1.0;
        x[(r + i, i)] -= model.omega2[i];
        for k in 0..r {
            x[(r + i, r + k)] = -model.damping[(i, k)];
        }
        for (h, d) in model.drive.iter().enumerate() {
            x[(r + i, 2 * r + 2 * h)] += d.modal[0][i];
            x[(r + i, 2 * r + 2 * h + 1)] += d.modal[1][i];
        }
        // - B_a^T E over the (q, z, 1) columns.
        for (a, &j) in set.iter().enumerate() {
            for col in 0..e.ncols() {
                let target = if col < r { col } else { r + col };
                x[(r + i, target)] -= b[(j, i)] * e[(a, col)];
            }
        }
    }
    for (h, d) in model.drive.iter().enumerate() {
        let w = d.harmonic as f64 * model.omega;
        let (ic, is) = (2 * r + 2 * h, 2 * r + 2 * h + 1);
        x[(ic, is)] = -w;
        x[(is, ic)] = w;
    }
    debug_assert_eq!(m, 2 * r + 2 * hh + 1);
    x
}

/// The event functions (c x size) on the augmented state: R_jj (-lambda_j) for a closed row,
/// the penetration B_j q + D_j(t) - R_ja lambda_a - g_j for an open one (m).
fn event_functionals(model: &DrivenBoundary, set: &[usize], e: MatRef<'_, f64>) -> Mat<f64> {
    let (r, c, m) = (model.r(), model.gaps.len(), model.size());
    let b = model.contact_modal.as_ref();
    let flex = model.flexibility.as_ref();
    // Column of the augmented state for column `col` of (q, z, 1).
    let target = |col: usize| if col < r { col } else { r + col };
    let mut ev = Mat::zeros(c, m);
    for j in 0..c {
        if let Some(a) = set.iter().position(|&s| s == j) {
            for col in 0..e.ncols() {
                ev[(j, target(col))] = -flex[(j, j)] * e[(a, col)];
            }
            continue;
        }
        for k in 0..r {
            ev[(j, k)] = b[(j, k)];
        }
        for (h, d) in model.drive.iter().enumerate() {
            ev[(j, 2 * r + 2 * h)] = d.contact[0][j];
            ev[(j, 2 * r + 2 * h + 1)] = d.contact[1][j];
        }
        ev[(j, m - 1)] = -model.gaps[j];
        for (a, &s) in set.iter().enumerate() {
            for col in 0..e.ncols() {
                ev[(j, target(col))] -= flex[(j, s)] * e[(a, col)];
            }
        }
    }
    ev
}

/// A periodic orbit of the driven boundary and its monodromy.
#[derive(Clone, Debug)]
pub struct DrivenOrbit {
    /// (q, q') at t = 0.
    pub start: Vec<f64>,
    /// Its excitation frequency W (rad/s).
    pub omega: f64,
    /// Monodromy in (q, q') (2r x 2r).
    pub monodromy: Mat<f64>,
    /// Newton iterations taken.
    pub iterations: usize,
    /// Distance from the guess in the scaled unknowns (q / |q|, q' / (W |q|), W / W_guess).
    pub shift: f64,
}

/// The state of an orbit at one instant.
#[derive(Clone, Debug)]
pub struct OrbitSample {
    /// Time from the orbit's start (s).
    pub time: f64,
    /// Modal coordinates q.
    pub q: Vec<f64>,
    /// Contact forces lambda (c, N).
    pub lambda: Vec<f64>,
}

/// The orbit from (q, q') = `start` at t = 0 at `samples` equally spaced instants of its period
/// 2 pi / `model.omega` (the first at t = 0), by the exact flow.
pub fn sample_orbit(
    model: &DrivenBoundary,
    start: &[f64],
    samples: usize,
) -> Result<Vec<OrbitSample>, HbError> {
    let r = model.r();
    let mut flow = DrivenFlow::new(model);
    let mut x = model.augmented(&start[..r], &start[r..], 0.0);
    let mut active = flow.active_set_at(&x)?;
    let dt = 2.0 * std::f64::consts::PI / model.omega / samples as f64;
    let mut out = Vec::with_capacity(samples);
    for s in 0..samples {
        if s > 0 {
            flow.advance(&mut x, &mut active, dt, None)?;
        }
        out.push(OrbitSample {
            time: s as f64 * dt,
            q: x[..r].to_vec(),
            lambda: flow.contact_force(&x, &active)?,
        });
    }
    Ok(out)
}

/// x(T) - x(0) at (x0, W) in the scaled state, and the monodromy.
fn period_map(
    model: &DrivenBoundary,
    x0: &[f64],
    q_scale: f64,
) -> Result<(Vec<f64>, Mat<f64>), HbError> {
    let r = model.r();
    let scale = |i: usize| {
        if i < r {
            q_scale
        } else {
            q_scale * model.omega
        }
    };
    let mut flow = DrivenFlow::new(model);
    let mut x = model.augmented(&x0[..r], &x0[r..], 0.0);
    let mut active = flow.active_set_at(&x)?;
    let mut phi = Mat::<f64>::identity(2 * r, 2 * r);
    let period = 2.0 * std::f64::consts::PI / model.omega;
    flow.advance(&mut x, &mut active, period, Some(&mut phi))?;
    let residual = (0..2 * r).map(|i| (x[i] - x0[i]) / scale(i)).collect();
    Ok((residual, phi))
}

/// Relative step of W for the finite-difference column d(x(T) - x0) / dW.
const OMEGA_STEP: f64 = 1e-7;

/// The shooting equations of a driven boundary in scaled unknowns z = (q / s, q' / (s W_ref),
/// W / W_ref) (2r + 1 of them; s = `q_scale` in the modal coordinates' units, W_ref in rad/s)
/// and scaled equations x(T) - x(0) (q part / s, q' part / (s W); 2r of them). Shared by the
/// shooting next to a harmonic-balance orbit and the continuation of the exact response curve
/// (`crate::driven_curve`).
pub(crate) struct ShootingEquations<'m> {
    pub model: &'m DrivenBoundary,
    pub q_scale: f64,
    pub w_ref: f64,
}

impl ShootingEquations<'_> {
    fn scale(&self, i: usize) -> f64 {
        if i < self.model.r() {
            self.q_scale
        } else {
            self.q_scale * self.w_ref
        }
    }

    /// z from (q, q') and W.
    pub fn unknowns(&self, x0: &[f64], omega: f64) -> Vec<f64> {
        let mut z: Vec<f64> = x0
            .iter()
            .enumerate()
            .map(|(i, v)| v / self.scale(i))
            .collect();
        z.push(omega / self.w_ref);
        z
    }

    /// ((q, q'), W) from z.
    pub fn state(&self, z: &[f64]) -> (Vec<f64>, f64) {
        let n = z.len() - 1;
        let x0 = (0..n).map(|i| z[i] * self.scale(i)).collect();
        (x0, z[n] * self.w_ref)
    }

    fn at(&self, omega: f64) -> DrivenBoundary {
        let mut m = self.model.clone();
        m.omega = omega;
        m
    }

    /// The scaled residual at z and the monodromy (2r x 2r).
    pub fn residual(&self, z: &[f64]) -> Result<(Vec<f64>, Mat<f64>), HbError> {
        let (x0, omega) = self.state(z);
        period_map(&self.at(omega), &x0, self.q_scale)
    }

    /// The Jacobian (2r x (2r + 1)) at z, from its residual and monodromy: the exact monodromy
    /// for the x0 columns, a finite difference of relative step `OMEGA_STEP` for the W column.
    pub fn jacobian(
        &self,
        z: &[f64],
        residual: &[f64],
        phi: &Mat<f64>,
    ) -> Result<Mat<f64>, HbError> {
        let r = self.model.r();
        let (x0, omega) = self.state(z);
        let (res_w, _) = period_map(&self.at(omega * (1.0 + OMEGA_STEP)), &x0, self.q_scale)?;
        // The residual's velocity part is scaled by the current W, the unknowns by W_ref.
        let vel = |i: usize| if i < r { 1.0 } else { self.w_ref / omega };
        Ok(Mat::from_fn(2 * r, 2 * r + 1, |i, j| {
            if j < 2 * r {
                (phi[(i, j)] - if i == j { 1.0 } else { 0.0 }) * self.scale(j) / self.scale(i)
                    * vel(i)
            } else {
                (res_w[i] - residual[i]) / (OMEGA_STEP * omega / self.w_ref)
            }
        }))
    }
}

/// The periodic orbit of the driven boundary nearest the guess (q, q') at t = 0 and W =
/// `model.omega`. The forced periodic orbits form a curve in (x0, W), so W is an unknown too and
/// the minimum-norm Newton step (scaled unknowns q / |q|, q' / (W |q|), W / W_guess; the exact
/// monodromy for the x0 columns, a finite difference of relative step 1e-7 for the W column)
/// goes to the point of that curve nearest the harmonic-balance orbit: on a steep flank the
/// boundary model's curve is reached by a small change of W, not of the amplitude. `None` when
/// Newton does not converge.
pub fn shoot_driven(model: &DrivenBoundary, guess: &[f64]) -> Result<Option<DrivenOrbit>, HbError> {
    let r = model.r();
    let q_scale = guess[..r].iter().map(|v| v * v).sum::<f64>().sqrt();
    if q_scale.is_nan() || q_scale <= 0.0 {
        return Ok(None);
    }
    let equations = ShootingEquations {
        model,
        q_scale,
        w_ref: model.omega,
    };
    let z_guess = equations.unknowns(guess, model.omega);
    let mut z = z_guess.clone();
    for iteration in 0..=SHOOTING_ITERATIONS {
        let (residual, phi) = equations.residual(&z)?;
        let norm = residual.iter().map(|v| v * v).sum::<f64>().sqrt();
        if norm < SHOOTING_TOLERANCE {
            let shift = z
                .iter()
                .zip(&z_guess)
                .map(|(a, b)| (a - b).powi(2))
                .sum::<f64>();
            let (start, omega) = equations.state(&z);
            return Ok(Some(DrivenOrbit {
                start,
                omega,
                monodromy: phi,
                iterations: iteration,
                shift: shift.sqrt(),
            }));
        }
        if iteration == SHOOTING_ITERATIONS || !norm.is_finite() {
            break;
        }
        let jac = equations.jacobian(&z, &residual, &phi)?;
        let Some(step) = min_norm_step(&jac, &residual) else {
            break;
        };
        z.iter_mut().zip(&step).for_each(|(v, d)| *v += d);
    }
    Ok(None)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::boundary_rk4::{integrate, Rk4State};

    /// Three damped modes on three rows with coupled flexibility, driven at two harmonics.
    fn model(omega: f64) -> DrivenBoundary {
        let r = 3;
        DrivenBoundary {
            omega2: vec![1.0, 6.25, 20.0],
            damping: Mat::from_fn(r, r, |i, k| {
                [[0.02, 0.005, 0.0], [0.005, 0.05, 0.01], [0.0, 0.01, 0.08]][i][k]
            }),
            contact_modal: Mat::from_fn(3, r, |j, k| {
                [[1.0, 0.4, -0.3], [0.8, -0.6, 0.5], [0.5, 0.9, 0.7]][j][k]
            }),
            flexibility: Mat::from_fn(3, 3, |i, j| {
                [[0.30, 0.05, 0.02], [0.05, 0.25, 0.04], [0.02, 0.04, 0.20]][i][j]
            }),
            gaps: vec![1.0, 1.2, 1.5],
            drive: vec![
                BoundaryDrive {
                    harmonic: 1,
                    modal: [vec![0.3, 0.1, 0.0], vec![0.0, 0.05, 0.02]],
                    contact: [vec![0.01, 0.0, 0.02], vec![0.0, 0.01, 0.0]],
                },
                BoundaryDrive {
                    harmonic: 3,
                    modal: [vec![0.0, 0.2, 0.1], vec![0.05, 0.0, 0.0]],
                    contact: [vec![0.0, 0.005, 0.0], vec![0.005, 0.0, 0.0]],
                },
            ],
            omega,
        }
    }

    #[test]
    fn the_driven_flow_agrees_with_rk4_and_keeps_liouville() {
        let m = model(0.9);
        let period = 2.0 * std::f64::consts::PI / m.omega;
        let q0 = [2.5, 0.3, -0.2];
        let v0 = [0.0, 0.5, 1.0];
        let mut flow = DrivenFlow::new(&m);
        let mut x = m.augmented(&q0, &v0, 0.0);
        let mut active = flow.active_set_at(&x).expect("set");
        let mut phi = Mat::<f64>::identity(6, 6);
        flow.advance(&mut x, &mut active, period, Some(&mut phi))
            .expect("flow");
        let start = Rk4State {
            q: q0.to_vec(),
            v: v0.to_vec(),
        };
        let (rk, rk_phi) = integrate(&m, &start, period, 40_000).expect("rk4");
        let state_error = (0..3)
            .map(|i| (x[i] - rk.q[i]).abs().max((x[3 + i] - rk.v[i]).abs()))
            .fold(0.0, f64::max);
        let matrix_error = (0..6)
            .flat_map(|i| (0..6).map(move |j| (i, j)))
            .map(|(i, j)| (phi[(i, j)] - rk_phi[(i, j)]).abs())
            .fold(0.0, f64::max);
        // Liouville: det = exp(-T tr C_q) (the contact terms are a symmetric stiffness).
        let det = phi.determinant();
        let exact = (-period * 0.15).exp();
        println!(
            "state {state_error:.1e}, transition {matrix_error:.1e}, det {det:.12} vs {exact:.12}"
        );
        assert!(state_error < 1e-8, "{state_error}");
        assert!(matrix_error < 1e-7, "{matrix_error}");
        assert!((det / exact - 1.0).abs() < 1e-10);
    }

    #[test]
    fn the_shot_driven_orbit_is_periodic_for_rk4_and_lies_on_the_curve() {
        let m = model(0.9);
        // A start off the periodic orbit: Newton must find the curve nearby.
        let guess = [2.0, 0.2, -0.1, 0.1, 0.3, 0.5];
        let orbit = shoot_driven(&m, &guess)
            .expect("shooting")
            .expect("converges");
        let mut at = m.clone();
        at.omega = orbit.omega;
        let period = 2.0 * std::f64::consts::PI / at.omega;
        let start = Rk4State {
            q: orbit.start[..3].to_vec(),
            v: orbit.start[3..].to_vec(),
        };
        let (end, _) = integrate(&at, &start, period, 40_000).expect("rk4");
        let gap = (0..3)
            .map(|i| {
                (end.q[i] - start.q[i])
                    .abs()
                    .max((end.v[i] - start.v[i]).abs())
            })
            .fold(0.0, f64::max);
        println!(
            "W = {:.6} (guess 0.9), {} iterations, shift {:.3}, RK4 period gap {gap:.1e}",
            orbit.omega, orbit.iterations, orbit.shift
        );
        assert!(gap < 1e-8, "{gap}");
    }
}
