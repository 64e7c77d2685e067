//! The exact flow of the damped, driven massless boundary (`driven_model`; DESIGN §10.6): its
//! pieces of constant active set solved in closed form, the contact switches between them and
//! the orbit sampled in time.
//!
//! On a piece of constant active set a, lambda_a = R_aa^-1 (B_a q + D_a(t) - g_a), a linear
//! system with constant coefficients driven by the harmonics of f. In the augmented state
//! x = (q, q', cos(h W t), sin(h W t) for each h, 1) it is x' = X_a x, solved exactly in the
//! eigenvectors of X_a (diagonalizable: the damped modes' eigenvalues lie off the imaginary axis,
//! the drive's at +-i h W and the constant's at 0). A closed row opens when lambda_j falls to 0,
//! an open row closes when its penetration rises to 0 (`switch_scan`); lambda_j = 0 at both, so
//! the vector field is continuous and the monodromy is the product of the pieces' (q, q') blocks
//! (no saltation).

use std::collections::HashMap;

use faer::linalg::solvers::Solve;
use faer::{c64, Mat, MatRef, Side};

use crate::driven_model::DrivenBoundary;
use crate::structure_modes::{fingerprint, StructureModes};
use crate::switch_scan::{next_switch, settle_active_set, EventPath, RowsAt};
use nlmodes_hb::HbError;

/// Most switches over one period before the contact set is declared chattering.
const MAX_SWITCHES: usize = 100_000;
/// A row switches when its event function (m) passes this fraction of the largest gap: a
/// penetration or force 1e-9 of the gap is below any physical meaning and above the round-off of
/// the event functions through the (non-orthogonal) eigenvectors of a piece.
const EVENT_THRESHOLD: f64 = 1e-9;
/// The error of an active set that does not settle.
const UNSETTLED: &str = "the contact set of the massless boundary did not settle";

/// The exact solution on one active set: X_a = V diag(l) V^-1, the event functionals
/// (c x size) through V, and the fastest frequency.
struct Piece {
    values: Vec<c64>,
    vectors: Mat<c64>,
    inverse: Mat<c64>,
    events: Mat<c64>,
    /// |E_jk| (c x size), for the curvature bounds.
    magnitudes: Mat<f64>,
    /// The event functionals split for the scan ([`RowTerms`]).
    row_terms: RowTerms,
    fastest: f64,
}

/// The event functionals E (c x size, through V) of a piece and E diag(l) for the rates as one
/// real matrix [[Re E, -Im E], [Re E l, -Im E l]] (2c x 2 size): every row's event function
/// Re(E e) and rate Re(E diag(l) e) at once are its product with [Re e; Im e], one
/// matrix-vector product (the scan's inner loop; faer's kernels, session 25: the loop over
/// columns it replaces was the boundary's largest cost on the blade).
struct RowTerms {
    stacked: Mat<f64>,
}

impl RowTerms {
    fn new(events: &Mat<c64>, values: &[c64]) -> Self {
        let (c, m) = (events.nrows(), events.ncols());
        let entry = |i: usize, k: usize| match i < c {
            true => events[(i, k)],
            false => events[(i - c, k)] * values[k],
        };
        Self {
            stacked: Mat::from_fn(2 * c, 2 * m, |i, k| match k < m {
                true => entry(i, k).re,
                false => -entry(i, k - m).im,
            }),
        }
    }

    /// Re(E e) and Re(E diag(l) e) for the mode terms e (size).
    fn rows(&self, e: &[c64]) -> (Vec<f64>, Vec<f64>) {
        let m = e.len();
        let x = faer::Col::from_fn(2 * m, |k| match k < m {
            true => e[k].re,
            false => e[k - m].im,
        });
        let y = &self.stacked * &x;
        let c = self.stacked.nrows() / 2;
        let (events, rates) = (
            (0..c).map(|j| y[j]).collect(),
            (c..2 * c).map(|j| y[j]).collect(),
        );
        (events, rates)
    }
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

    /// Row j's event function and its first two time derivatives at tau (one exponential per
    /// term).
    fn event_jet(&self, j: usize, w0: &[c64], tau: f64) -> [f64; 3] {
        let mut jet = [0.0; 3];
        for (k, w) in w0.iter().enumerate() {
            let l = self.values[k];
            let term = self.events[(j, k)] * (l * tau).exp() * w;
            let rate = term * l;
            jet[0] += term.re;
            jet[1] += rate.re;
            jet[2] += (rate * l).re;
        }
        jet
    }

    /// Every row's event function and its rate at tau, and the per-mode curvature terms
    /// |l_k|^2 |e_k| of a bound on its second derivative (one exponential per eigenvalue, shared
    /// by the rows).
    fn rows_at(&self, w0: &[c64], tau: f64) -> RowsAt {
        let e: Vec<c64> = (0..w0.len())
            .map(|k| (self.values[k] * tau).exp() * w0[k])
            .collect();
        self.rows_of_terms(e)
    }

    /// [`Self::rows_at`] from the mode terms e_k = exp(l_k tau) w0_k.
    fn rows_of_terms(&self, e: Vec<c64>) -> RowsAt {
        let curvatures = (self.values.iter().zip(&e))
            .map(|(l, ek)| l.norm_sqr() * ek.norm_sqr().sqrt())
            .collect();
        let (events, rates) = self.row_terms.rows(&e);
        RowsAt {
            events,
            rates,
            curvatures,
            terms: e,
        }
    }

    /// A bound on |f_j''| over [t0, t1] from the mode terms at both ends (|exp(l t)| is monotone
    /// in t, so each term's largest modulus is at one end).
    fn curvature_bound(&self, j: usize, a: &RowsAt, b: &RowsAt) -> f64 {
        (0..a.curvatures.len())
            .map(|k| self.magnitudes[(j, k)] * a.curvatures[k].max(b.curvatures[k]))
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

    /// The (q, q') block (2r x 2r) of the transition over tau: Re(V_q diag(exp(l tau)) W_q),
    /// V_q the first 2r rows of V, W_q the first 2r columns of V^-1, as two real products
    /// Re(V_q) Re(B) - Im(V_q) Im(B), B = diag(exp(l tau)) W_q (the monodromy's product at
    /// every switch; summed term by term in complex arithmetic it was the boundary's largest
    /// cost on the blade, session 25).
    fn transition(&self, r: usize, tau: f64) -> Mat<f64> {
        let (m, n) = (self.values.len(), 2 * r);
        let e: Vec<c64> = (0..m).map(|k| (self.values[k] * tau).exp()).collect();
        let b = |k: usize, j: usize| e[k] * self.inverse[(k, j)];
        let (b_re, b_im) = (
            Mat::from_fn(m, n, |k, j| b(k, j).re),
            Mat::from_fn(m, n, |k, j| b(k, j).im),
        );
        let (v_re, v_im) = (
            Mat::from_fn(n, m, |i, k| self.vectors[(i, k)].re),
            Mat::from_fn(n, m, |i, k| self.vectors[(i, k)].im),
        );
        &v_re * &b_re - &v_im * &b_im
    }
}

/// A piece along the solution from w0 = V^-1 x0: what the switch scan reads.
struct DrivenPath<'p> {
    piece: &'p Piece,
    w0: &'p [c64],
}

impl EventPath for DrivenPath<'_> {
    fn event(&self, j: usize, tau: f64) -> f64 {
        self.piece.event(j, self.w0, tau)
    }

    fn event_rate(&self, j: usize, tau: f64) -> f64 {
        self.piece.event_rate(j, self.w0, tau)
    }

    fn event_jet(&self, j: usize, tau: f64) -> [f64; 3] {
        self.piece.event_jet(j, self.w0, tau)
    }

    fn rows_at(&self, tau: f64) -> RowsAt {
        self.piece.rows_at(self.w0, tau)
    }

    fn step_factors(&self, step: f64) -> Vec<c64> {
        self.piece.values.iter().map(|l| (l * step).exp()).collect()
    }

    fn rows_advanced(&self, before: &RowsAt, factors: &[c64]) -> RowsAt {
        let e = before
            .terms
            .iter()
            .zip(factors)
            .map(|(e, f)| e * f)
            .collect();
        self.piece.rows_of_terms(e)
    }

    fn curvature_bound(&self, j: usize, a: &RowsAt, b: &RowsAt) -> f64 {
        self.piece.curvature_bound(j, a, b)
    }

    fn fastest(&self) -> f64 {
        self.piece.fastest
    }

    fn curvature_bounds(&self, at: &RowsAt) -> Vec<f64> {
        let curvatures = faer::ColRef::from_slice(&at.curvatures);
        let bounds = &self.piece.magnitudes * curvatures;
        bounds.iter().copied().collect()
    }

    fn growth_rate(&self) -> Option<f64> {
        Some(self.piece.values.iter().fold(0.0_f64, |a, l| a.max(l.re)))
    }

    fn rows(&self) -> usize {
        self.piece.events.nrows()
    }
}

/// The exact flow of a [`DrivenBoundary`], pieces cached by active set.
pub struct DrivenFlow<'m> {
    model: &'m DrivenBoundary,
    pieces: HashMap<Vec<bool>, Piece>,
    threshold: f64,
    /// The fingerprint of the model's structure (`structure_fingerprint`), at its first piece.
    fingerprint: Option<u64>,
}

impl<'m> DrivenFlow<'m> {
    pub fn new(model: &'m DrivenBoundary) -> Self {
        let gmax = model.gaps.iter().fold(0.0_f64, |a, &g| a.max(g.abs()));
        Self {
            model,
            pieces: HashMap::new(),
            threshold: EVENT_THRESHOLD * gmax,
            fingerprint: None,
        }
    }

    /// The active set at augmented state x: Murty's least-index pivoting on the event
    /// functions (finite for the positive definite R).
    pub fn active_set_at(&mut self, x: &[f64]) -> Result<Vec<bool>, HbError> {
        let c = self.model.gaps.len();
        let threshold = self.threshold;
        settle_active_set(c, vec![false; c], UNSETTLED, |active| {
            let piece = self.piece(active)?;
            let w0 = solve_in(piece, x);
            Ok((0..c).find(|&j| piece.event(j, &w0, 0.0) > threshold))
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
            let path = DrivenPath { piece, w0: &w0 };
            let event = next_switch(&path, threshold, left, toggled);
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
            let print =
                *(self.fingerprint).get_or_insert_with(|| structure_fingerprint(self.model));
            let piece = build_piece(self.model, active, print)?;
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

/// X_a, its eigen-decomposition and the event functionals of the active set `active`.
fn build_piece(model: &DrivenBoundary, active: &[bool], print: u64) -> Result<Piece, HbError> {
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
    let n = 2 * r;
    let a = x_a.as_ref().submatrix(0, 0, n, n);
    let structure = (model.structure).modes(active, print, a)?;
    let Decomposition {
        values,
        vectors,
        inverse,
    } = completed(model, &structure, x_a.as_ref().submatrix(0, n, n, m - n));
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
    let events = &events_c * &vectors;
    Ok(Piece {
        row_terms: RowTerms::new(&events, &values),
        magnitudes: Mat::from_fn(c, m, |j, k| events[(j, k)].norm_sqr().sqrt()),
        values,
        events,
        vectors,
        inverse,
        fastest,
    })
}

/// The fingerprint of what A_a is made of (`structure_modes`): W^2, C_q, B and R.
fn structure_fingerprint(model: &DrivenBoundary) -> u64 {
    fn entries(m: &Mat<f64>) -> impl Iterator<Item = f64> + '_ {
        (0..m.ncols())
            .flat_map(move |j| (0..m.nrows()).map(move |i| (i, j)))
            .map(move |(i, j)| m[(i, j)])
    }
    fingerprint(
        (model.omega2.iter().copied())
            .chain(entries(&model.damping))
            .chain(entries(&model.contact_modal))
            .chain(entries(&model.flexibility)),
    )
}

/// X_a = V diag(l) V^-1 (size x size).
struct Decomposition {
    values: Vec<c64>,
    vectors: Mat<c64>,
    inverse: Mat<c64>,
}

/// X_a's decomposition from A_a's (`structure`, 2r x 2r) and, in closed form, the drive's
/// block D (`structure_modes` module docs; `f` = F_a, 2r x (2H + 1)): D's eigenvalues mu =
/// +-i h W with the eigenvectors (1, -+i) on harmonic h's (cos, sin) pair, and 0 for the
/// constant; each with its structure part x_mu = (mu - A_a)^-1 F_a w_mu = V diag(1 / (mu - l))
/// V^-1 F_a w_mu, so that, with Y = V^-1 X and W the drive's eigenvectors,
/// V_X = [[V, X], [0, W]] and V_X^-1 = [[V^-1, -Y W^-1], [0, W^-1]].
fn completed(
    model: &DrivenBoundary,
    structure: &StructureModes,
    f: MatRef<'_, f64>,
) -> Decomposition {
    let (n, d) = (structure.values.len(), f.ncols());
    let (i, half) = (c64::new(0.0, 1.0), c64::new(0.5, 0.0));
    let (mut mus, mut w, mut w_inverse) =
        (Vec::with_capacity(d), Mat::zeros(d, d), Mat::zeros(d, d));
    for (h, drive) in model.drive.iter().enumerate() {
        let frequency = drive.harmonic as f64 * model.omega;
        let (ic, is) = (2 * h, 2 * h + 1);
        mus.extend([c64::new(0.0, frequency), c64::new(0.0, -frequency)]);
        (w[(ic, ic)], w[(is, ic)], w[(ic, is)], w[(is, is)]) = (c64::ONE, -i, c64::ONE, i);
        // [[1, 1], [-i, i]]^-1 = [[1, i], [1, -i]] / 2.
        (w_inverse[(ic, ic)], w_inverse[(ic, is)]) = (half, half * i);
        (w_inverse[(is, ic)], w_inverse[(is, is)]) = (half, -half * i);
    }
    mus.push(c64::ZERO);
    (w[(d - 1, d - 1)], w_inverse[(d - 1, d - 1)]) = (c64::ONE, c64::ONE);
    let f = Mat::from_fn(n, d, |k, col| c64::new(f[(k, col)], 0.0));
    let gw = &(&structure.inverse * &f) * &w;
    let y = Mat::from_fn(n, d, |k, col| {
        gw[(k, col)] / (mus[col] - structure.values[k])
    });
    let x = &structure.vectors * &y;
    let top_right = -(&y * &w_inverse);
    let m = n + d;
    let values = structure.values.iter().copied().chain(mus).collect();
    let vectors = Mat::from_fn(m, m, |row, col| match (row < n, col < n) {
        (true, true) => structure.vectors[(row, col)],
        (true, false) => x[(row, col - n)],
        (false, true) => c64::ZERO,
        (false, false) => w[(row - n, col - n)],
    });
    let inverse = Mat::from_fn(m, m, |row, col| match (row < n, col < n) {
        (true, true) => structure.inverse[(row, col)],
        (true, false) => top_right[(row, col - n)],
        (false, true) => c64::ZERO,
        (false, false) => w_inverse[(row - n, col - n)],
    });
    Decomposition {
        values,
        vectors,
        inverse,
    }
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rk4::{integrate, Rk4State};
    use crate::test_models::{driven_three_modes as model, driven_three_modes_moving_gap};

    /// The largest entry of V diag(l) V^-1 - X_a over X_a's largest, for a piece of `m`.
    fn reconstruction_error(m: &DrivenBoundary, active: &[bool]) -> f64 {
        let piece = build_piece(m, active, structure_fingerprint(m)).expect("piece");
        let set: Vec<usize> = (0..active.len()).filter(|&j| active[j]).collect();
        let (r, cols) = (m.r(), m.r() + 2 * m.drive.len() + 1);
        let rhs = Mat::from_fn(set.len(), cols, |i, k| {
            let j = set[i];
            match (k < r, k + 1 < cols) {
                (true, _) => m.contact_modal[(j, k)],
                (false, true) => m.drive[(k - r) / 2].contact[(k - r) % 2][j],
                (false, false) => -m.gaps[j],
            }
        });
        let r_aa = Mat::from_fn(set.len(), set.len(), |i, k| m.flexibility[(set[i], set[k])]);
        let e = match set.is_empty() {
            true => Mat::zeros(0, cols),
            false => r_aa.llt(Side::Lower).expect("R_aa").solve(&rhs),
        };
        let x = generator(m, &set, e.as_ref());
        let size = x.nrows();
        let scaled = Mat::from_fn(size, size, |i, k| piece.vectors[(i, k)] * piece.values[k]);
        let rebuilt = &scaled * &piece.inverse;
        let largest = x.norm_max();
        (0..size)
            .flat_map(|i| (0..size).map(move |k| (i, k)))
            .map(|(i, k)| (rebuilt[(i, k)] - c64::new(x[(i, k)], 0.0)).norm())
            .fold(0.0, f64::max)
            / largest
    }

    /// A piece is X_a = V diag(l) V^-1 with V from the structure's block decomposed once (at
    /// the first W) and the drive's block in closed form at every other W of the model's
    /// copies (`DrivenBoundary::at` shares the decompositions), for every active set of the
    /// three-row model, with and without a moving gap; and a model whose damping is changed
    /// after its first flow gets a new decomposition (the fingerprint), not the old one.
    #[test]
    fn pieces_from_the_structure_decomposed_once_rebuild_the_generator() {
        let sets: Vec<Vec<bool>> = (0..8_usize)
            .map(|bits| (0..3).map(|j| bits >> j & 1 == 1).collect())
            .collect();
        for base in [model(0.9), driven_three_modes_moving_gap(0.9)] {
            for omega in [0.9, 1.7, 0.31, 2.9] {
                let m = base.at(omega);
                for active in &sets {
                    let error = reconstruction_error(&m, active);
                    assert!(error < 1e-12, "W {omega}, {active:?}: {error:e}");
                }
            }
            let held = format!("{:?}", base.structure);
            assert!(held.contains("8 active sets"), "{held}");
        }
        let mut changed = model(0.9);
        assert!(reconstruction_error(&changed, &sets[3]) < 1e-12);
        changed.damping[(0, 0)] = 0.2;
        let error = reconstruction_error(&changed, &sets[3]);
        assert!(error < 1e-12, "after the damping changed: {error:e}");
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

    /// The exact flow over one period from (q0, v0): the end (q, q') and the monodromy.
    fn period_flow(m: &DrivenBoundary, q0: &[f64], v0: &[f64]) -> (Vec<f64>, Mat<f64>) {
        let r = q0.len();
        let period = 2.0 * std::f64::consts::PI / m.omega;
        let mut flow = DrivenFlow::new(m);
        let mut x = m.augmented(q0, v0, 0.0);
        let mut active = flow.active_set_at(&x).expect("set");
        let mut phi = Mat::<f64>::identity(2 * r, 2 * r);
        flow.advance(&mut x, &mut active, period, Some(&mut phi))
            .expect("flow");
        (x[..2 * r].to_vec(), phi)
    }

    /// Under a moving gap (`driven_three_modes_moving_gap`: every row's gap moving at W, the
    /// first's at 2 W too) the exact flow over a period with 8 switches agrees with RK4 (40000
    /// steps, the contact problem solved at every stage with the gap of that instant) as the
    /// constant-gap flow does, keeps Liouville, and its monodromy, the product of the pieces'
    /// blocks without saltation, is the central difference of the flow's end state in its start
    /// (step 1e-6: the perturbed orbits' switch times move with the start, so a jump of the
    /// field at a switch would show as an O(1) difference; truncation O(h^2), rounding
    /// 1e-16 / h: measured 4e-9).
    #[test]
    fn under_a_moving_gap_the_monodromy_is_the_flows_derivative() {
        let m = driven_three_modes_moving_gap(0.9);
        let period = 2.0 * std::f64::consts::PI / m.omega;
        let (q0, v0) = ([2.5, 0.3, -0.2], [0.0, 0.5, 1.0]);
        let (end, phi) = period_flow(&m, &q0, &v0);
        let samples =
            sample_orbit(&m, &[q0.as_slice(), v0.as_slice()].concat(), 4000).expect("samples");
        let switches = samples
            .windows(2)
            .map(|w| {
                let closed =
                    |s: &OrbitSample| s.lambda.iter().map(|l| *l > 0.0).collect::<Vec<_>>();
                (0..3)
                    .filter(|&j| closed(&w[0])[j] != closed(&w[1])[j])
                    .count()
            })
            .sum::<usize>();
        let (rk, rk_phi) = integrate(
            &m,
            &Rk4State {
                q: q0.to_vec(),
                v: v0.to_vec(),
            },
            period,
            40_000,
        )
        .expect("rk4");
        let rk_end: Vec<f64> = rk.q.iter().chain(&rk.v).copied().collect();
        let state_error = (0..6)
            .map(|i| (end[i] - rk_end[i]).abs())
            .fold(0.0, f64::max);
        let largest = |a: &Mat<f64>, b: &Mat<f64>| {
            (0..6)
                .flat_map(|i| (0..6).map(move |j| (i, j)))
                .map(|(i, j)| (a[(i, j)] - b[(i, j)]).abs())
                .fold(0.0, f64::max)
        };
        let h = 1e-6;
        let start: Vec<f64> = q0.iter().chain(&v0).copied().collect();
        let shifted = |k: usize, d: f64| {
            let mut z = start.clone();
            z[k] += d;
            period_flow(&m, &z[..3], &z[3..]).0
        };
        let difference = Mat::from_fn(6, 6, |i, k| {
            (shifted(k, h)[i] - shifted(k, -h)[i]) / (2.0 * h)
        });
        let det = phi.determinant();
        let exact = (-period * 0.15).exp();
        let (rk_error, fd_error) = (largest(&phi, &rk_phi), largest(&phi, &difference));
        println!(
            "moving gap: {switches} switches; state against RK4 {state_error:.1e}, transition \
             {rk_error:.1e}; monodromy against its central difference {fd_error:.1e}; det \
             {det:.12} vs {exact:.12}"
        );
        assert!(switches >= 4, "{switches}");
        assert!(state_error < 1e-8, "{state_error}");
        assert!(rk_error < 1e-7, "{rk_error}");
        assert!(fd_error < 1e-7, "{fd_error}");
        assert!((det / exact - 1.0).abs() < 1e-10);
    }
}
