//! An exact oracle for the forced piecewise-linear system
//!
//!   M x'' + C x' + K x + kc a (a.x - g)_+ = fc cos(W t) + fs sin(W t),
//!
//! independent of the crates under test (plain `Vec<f64>` matrices, its own exponential, its
//! own linear solves and eigenvalues).
//!
//! In either regime (open: a.x < g, closed: a.x > g) the flow is linear and, with the state
//! augmented by (cos W t, sin W t, 1), autonomous: w = (x, v, c, s, 1),
//!
//!   w' = G_r w,  G_r = [[0, I, 0, 0, 0],
//!                       [-M^-1 K_r, -M^-1 C, M^-1 fc, M^-1 fs, M^-1 b_r],
//!                       [0, 0, 0, -W, 0], [0, 0, W, 0, 0], [0, 0, 0, 0, 0]],
//!
//! K_open = K, b_open = 0, K_closed = K + kc a a^T, b_closed = kc g a. So w(t) = exp(G_r t) w(0)
//! exactly within a regime. A period is integrated on a uniform grid of `steps` sub-steps
//! (exp(G_r h) computed once per regime); a change of sign of a.x - g within a sub-step (or a
//! touch-and-leave detected by the sign change of a.v, its extremum found the same way) is
//! located by safeguarded Newton to 1e-15 T on the exact flow's Taylor series in time (`taylor`:
//! a.x(t) = sum a.(G^k w)_x t^k / k!, truncated below 1e-24 and rounded to about 1e-13 of |w|
//! over a sub-step; one exponential per Newton iterate where the sub-step is too long for it),
//! and the flow continues from the event in the other regime. The sign tests see every event
//! when a.x - g has at most one extremum per sub-step, i.e. a sub-step shorter than half the
//! period of the fastest regime (on the stiffest system of the tests, the light chain of
//! tests/forced_oracle_cli.rs with kc = 1500 N/m: T / 256 <= 0.027 s against 0.081 s).
//!
//! The monodromy (derivative of z(T) = (x, v)(T) with respect to z(0)) is the ordered product of
//! the upper-left 2n x 2n blocks of the exponentials: the vector field is continuous across the
//! switch surface (the contact force kc (a.x - g) vanishes on it), so the saltation matrix
//! S = I + (f+ - f-) n^T / (n . f-) is the identity. The jump |f+ - f-| at every located event is
//! recorded (`Flow::largest_jump`) so the tests can check it.
//!
//! A casing distortion (`Pwl::distortion`, docs/DESIGN.md §10.11) makes the gap time-varying,
//! g(t) = g - delta cos(h W t + phi): the state gains (cos h W t, sin h W t) (two more rows
//! rotating at h W), the closed regime's force kc a (a.x - g(t)) gains the harmonic term
//! kc a delta (cos phi cos h W t - sin phi sin h W t), and the switch surface is
//! L(w) - g = 0 with the linear functional L(w) = a.x + delta (cos phi c_h - sin phi s_h) of the
//! augmented state, whose rate along the flow is L(G w) (the same in both regimes). Without a
//! distortion every quantity is the one above, to the bit.

#![allow(dead_code)]

pub mod trace;

use std::f64::consts::PI;

/// A dense square matrix, row-major.
#[derive(Clone, Debug, PartialEq)]
pub struct Dense {
    pub n: usize,
    pub a: Vec<f64>,
}

impl Dense {
    pub fn zeros(n: usize) -> Self {
        Self {
            n,
            a: vec![0.0; n * n],
        }
    }

    pub fn identity(n: usize) -> Self {
        let mut m = Self::zeros(n);
        for i in 0..n {
            m.a[i * n + i] = 1.0;
        }
        m
    }

    pub fn from_fn(n: usize, f: impl Fn(usize, usize) -> f64) -> Self {
        let mut m = Self::zeros(n);
        for i in 0..n {
            for j in 0..n {
                m.a[i * n + j] = f(i, j);
            }
        }
        m
    }

    #[inline]
    pub fn at(&self, i: usize, j: usize) -> f64 {
        self.a[i * self.n + j]
    }

    pub fn mul(&self, b: &Dense) -> Dense {
        let n = self.n;
        let mut out = Dense::zeros(n);
        for i in 0..n {
            for k in 0..n {
                let aik = self.a[i * n + k];
                if aik == 0.0 {
                    continue;
                }
                for j in 0..n {
                    out.a[i * n + j] += aik * b.a[k * n + j];
                }
            }
        }
        out
    }

    pub fn apply(&self, x: &[f64]) -> Vec<f64> {
        let n = self.n;
        (0..n)
            .map(|i| (0..n).map(|j| self.a[i * n + j] * x[j]).sum())
            .collect()
    }

    pub fn scaled(&self, s: f64) -> Dense {
        Dense {
            n: self.n,
            a: self.a.iter().map(|v| v * s).collect(),
        }
    }

    pub fn norm1(&self) -> f64 {
        (0..self.n)
            .map(|j| (0..self.n).map(|i| self.at(i, j).abs()).sum::<f64>())
            .fold(0.0, f64::max)
    }

    /// The upper-left k x k block.
    pub fn block(&self, k: usize) -> Dense {
        Dense::from_fn(k, |i, j| self.at(i, j))
    }

    /// Determinant by Gaussian elimination with partial pivoting.
    pub fn det(&self) -> f64 {
        let n = self.n;
        let mut a = self.a.clone();
        let mut det = 1.0;
        for col in 0..n {
            let p = (col..n)
                .max_by(|&i, &j| a[i * n + col].abs().total_cmp(&a[j * n + col].abs()))
                .unwrap();
            if p != col {
                for j in 0..n {
                    a.swap(col * n + j, p * n + j);
                }
                det = -det;
            }
            let piv = a[col * n + col];
            det *= piv;
            if piv == 0.0 {
                return 0.0;
            }
            for i in col + 1..n {
                let f = a[i * n + col] / piv;
                for j in col..n {
                    a[i * n + j] -= f * a[col * n + j];
                }
            }
        }
        det
    }

    /// Solves self x = b (Gaussian elimination with partial pivoting).
    pub fn solve(&self, b: &[f64]) -> Vec<f64> {
        let n = self.n;
        let mut a = self.a.clone();
        let mut x = b.to_vec();
        for col in 0..n {
            let p = (col..n)
                .max_by(|&i, &j| a[i * n + col].abs().total_cmp(&a[j * n + col].abs()))
                .unwrap();
            if p != col {
                for j in 0..n {
                    a.swap(col * n + j, p * n + j);
                }
                x.swap(col, p);
            }
            let piv = a[col * n + col];
            for i in col + 1..n {
                let f = a[i * n + col] / piv;
                for j in col..n {
                    a[i * n + j] -= f * a[col * n + j];
                }
                x[i] -= f * x[col];
            }
        }
        for i in (0..n).rev() {
            let s: f64 = (i + 1..n).map(|j| a[i * n + j] * x[j]).sum();
            x[i] = (x[i] - s) / a[i * n + i];
        }
        x
    }

    pub fn inverse(&self) -> Dense {
        let n = self.n;
        let mut inv = Dense::zeros(n);
        for j in 0..n {
            let e: Vec<f64> = (0..n).map(|i| f64::from(u8::from(i == j))).collect();
            let col = self.solve(&e);
            for (i, v) in col.into_iter().enumerate() {
                inv.a[i * n + j] = v;
            }
        }
        inv
    }

    /// Eigenvalues (re, im): roots of the characteristic polynomial (Faddeev-LeVerrier) by the
    /// Weierstrass (Durand-Kerner) iteration, polished by Newton. Meant for n <= 6.
    pub fn eigenvalues(&self) -> Vec<(f64, f64)> {
        let n = self.n;
        // p(l) = l^n + c[1] l^(n-1) + ... + c[n].
        let mut c = vec![0.0; n + 1];
        c[0] = 1.0;
        let mut mk = Dense::zeros(n);
        for k in 1..=n {
            // M_k = A M_{k-1} + c_{k-1} I, c_k = -tr(A M_k) / k.
            let mut next = self.mul(&mk);
            for i in 0..n {
                next.a[i * n + i] += c[k - 1];
            }
            mk = next;
            let am = self.mul(&mk);
            c[k] = -(0..n).map(|i| am.at(i, i)).sum::<f64>() / k as f64;
        }
        let eval = |z: (f64, f64)| {
            // Horner in complex arithmetic: p(z) and p'(z).
            let (mut p, mut dp) = ((1.0, 0.0), (0.0, 0.0));
            for &ck in &c[1..] {
                dp = cadd(cmul(dp, z), p);
                p = cadd(cmul(p, z), (ck, 0.0));
            }
            (p, dp)
        };
        let radius = 1.0 + c[1..].iter().fold(0.0_f64, |a, v| a.max(v.abs()));
        let mut roots: Vec<(f64, f64)> = (0..n)
            .map(|k| {
                let ang = 2.0 * PI * k as f64 / n as f64 + 0.4;
                (0.5 * radius * ang.cos(), 0.5 * radius * ang.sin())
            })
            .collect();
        for _ in 0..500 {
            let mut change = 0.0_f64;
            for i in 0..n {
                let (p, _) = eval(roots[i]);
                let mut den = (1.0, 0.0);
                for j in 0..n {
                    if j != i {
                        den = cmul(den, csub(roots[i], roots[j]));
                    }
                }
                let d = cdiv(p, den);
                roots[i] = csub(roots[i], d);
                change = change.max(d.0.hypot(d.1));
            }
            if change < 1e-16 * radius {
                break;
            }
        }
        for r in roots.iter_mut() {
            for _ in 0..3 {
                let (p, dp) = eval(*r);
                if dp.0.hypot(dp.1) > 0.0 {
                    *r = csub(*r, cdiv(p, dp));
                }
            }
        }
        roots.sort_by(|a, b| b.0.hypot(b.1).total_cmp(&a.0.hypot(a.1)));
        roots
    }
}

fn cadd(a: (f64, f64), b: (f64, f64)) -> (f64, f64) {
    (a.0 + b.0, a.1 + b.1)
}
fn csub(a: (f64, f64), b: (f64, f64)) -> (f64, f64) {
    (a.0 - b.0, a.1 - b.1)
}
fn cmul(a: (f64, f64), b: (f64, f64)) -> (f64, f64) {
    (a.0 * b.0 - a.1 * b.1, a.0 * b.1 + a.1 * b.0)
}
fn cdiv(a: (f64, f64), b: (f64, f64)) -> (f64, f64) {
    let d = b.0 * b.0 + b.1 * b.1;
    ((a.0 * b.0 + a.1 * b.1) / d, (a.1 * b.0 - a.0 * b.1) / d)
}

/// exp(a) by scaling and squaring with a degree-20 Taylor polynomial (Horner): a / 2^s has
/// 1-norm <= 1/4, where the truncation error is below 0.25^21 / 21! ~ 1e-32 relative.
pub fn expm(a: &Dense) -> Dense {
    const DEGREE: usize = 20;
    let norm = a.norm1();
    let squarings = if norm > 0.25 {
        (norm / 0.25).log2().ceil() as i32
    } else {
        0
    };
    let x = a.scaled(0.5_f64.powi(squarings));
    let n = a.n;
    let mut p = Dense::identity(n);
    for k in (1..=DEGREE).rev() {
        // p = I + x p / k
        let mut next = x.mul(&p).scaled(1.0 / k as f64);
        for i in 0..n {
            next.a[i * n + i] += 1.0;
        }
        p = next;
    }
    for _ in 0..squarings {
        p = p.mul(&p);
    }
    p
}

/// Gauss-Legendre nodes on (0, 1) and weights (summing to 1), by Newton on P_q.
pub fn gauss_legendre(q: usize) -> Vec<(f64, f64)> {
    (0..q)
        .map(|i| {
            let mut x = (PI * (i as f64 + 0.75) / (q as f64 + 0.5)).cos();
            let mut dp = 0.0;
            for _ in 0..100 {
                let (mut p0, mut p1) = (1.0, x);
                for k in 2..=q {
                    let p2 = ((2 * k - 1) as f64 * x * p1 - (k - 1) as f64 * p0) / k as f64;
                    p0 = p1;
                    p1 = p2;
                }
                dp = q as f64 * (x * p1 - p0) / (x * x - 1.0);
                let dx = p1 / dp;
                x -= dx;
                if dx.abs() < 1e-16 {
                    break;
                }
            }
            let w = 2.0 / ((1.0 - x * x) * dp * dp);
            (0.5 * (1.0 - x), 0.5 * w)
        })
        .collect()
}

/// The piecewise-linear system (n DOFs, one unilateral spring on the row `a`).
#[derive(Clone, Debug)]
pub struct Pwl {
    pub n: usize,
    pub m: Dense,
    pub c: Dense,
    pub k: Dense,
    pub a: Vec<f64>,
    pub gap: f64,
    pub kc: f64,
    pub fc: Vec<f64>,
    pub fs: Vec<f64>,
    /// A casing distortion: the gap g - delta cos(h W t + phi) (module docs); `None`: constant.
    pub distortion: Option<GapWave>,
}

/// The gap's variation g(t) = g - delta cos(h W t + phi) of a distorted casing.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GapWave {
    /// h >= 1, the harmonic of W.
    pub harmonic: usize,
    /// delta (length).
    pub amplitude: f64,
    /// phi (rad).
    pub phase: f64,
}

impl Pwl {
    /// The system M, C, K (faer matrices, copied) with one contact row `a`, the gap `gap`
    /// under the casing wave `wave`, the penalty `kc` and the load `fc cos(W t)` (no sine
    /// part): the moving-gap tests' oracle.
    pub fn with_gap_wave(
        [m, c, k]: [faer::MatRef<'_, f64>; 3],
        a: Vec<f64>,
        (gap, kc): (f64, f64),
        fc: Vec<f64>,
        wave: GapWave,
    ) -> Self {
        let n = m.nrows();
        let dense = |x: faer::MatRef<'_, f64>| Dense::from_fn(n, |i, j| x[(i, j)]);
        Pwl {
            n,
            m: dense(m),
            c: dense(c),
            k: dense(k),
            a,
            gap,
            kc,
            fs: vec![0.0; fc.len()],
            fc,
            distortion: Some(wave),
        }
    }

    /// Size of the augmented state: (x, v, cos W t, sin W t, 1), then (cos h W t, sin h W t)
    /// under a distortion.
    pub fn state_size(&self) -> usize {
        2 * self.n + 3 + if self.distortion.is_some() { 2 } else { 0 }
    }

    /// The augmented state at t = 0 of z = (x, v).
    pub fn augmented(&self, z: &[f64]) -> Vec<f64> {
        let mut w = z.to_vec();
        w.extend([1.0, 0.0, 1.0]);
        if self.distortion.is_some() {
            w.extend([1.0, 0.0]);
        }
        w
    }

    /// L(w) = a.x (+ the casing's intrusion delta cos(h W t + phi)): the row measured from the
    /// casing, a linear functional of the augmented state.
    pub fn switch_functional(&self, w: &[f64]) -> f64 {
        let ax = self.a.iter().zip(w).map(|(a, x)| a * x).sum::<f64>();
        match self.distortion {
            Some(d) => {
                let i = 2 * self.n + 3;
                let (s, c) = d.phase.sin_cos();
                ax + d.amplitude * (c * w[i] - s * w[i + 1])
            }
            None => ax,
        }
    }

    /// tr(M^-1 C): det(monodromy) = exp(-T tr(M^-1 C)) (Liouville).
    pub fn trace_minv_c(&self) -> f64 {
        let mc = self.m.inverse().mul(&self.c);
        (0..self.n).map(|i| mc.at(i, i)).sum()
    }

    /// The generator G_r at W (see module docs), size `state_size`.
    pub fn generator(&self, closed: bool, omega: f64) -> Dense {
        let n = self.n;
        let d = self.state_size();
        let minv = self.m.inverse();
        let kr = Dense::from_fn(n, |i, j| {
            self.k.at(i, j)
                + if closed {
                    self.kc * self.a[i] * self.a[j]
                } else {
                    0.0
                }
        });
        let mk = minv.mul(&kr);
        let mc = minv.mul(&self.c);
        let b: Vec<f64> = self
            .a
            .iter()
            .map(|ai| if closed { self.kc * self.gap * ai } else { 0.0 })
            .collect();
        let (mfc, mfs, mb) = (minv.apply(&self.fc), minv.apply(&self.fs), minv.apply(&b));
        let mut g = Dense::zeros(d);
        for i in 0..n {
            g.a[i * d + n + i] = 1.0;
            for j in 0..n {
                g.a[(n + i) * d + j] = -mk.at(i, j);
                g.a[(n + i) * d + n + j] = -mc.at(i, j);
            }
            g.a[(n + i) * d + 2 * n] = mfc[i];
            g.a[(n + i) * d + 2 * n + 1] = mfs[i];
            g.a[(n + i) * d + 2 * n + 2] = mb[i];
        }
        g.a[2 * n * d + 2 * n + 1] = -omega;
        g.a[(2 * n + 1) * d + 2 * n] = omega;
        if let Some(wave) = self.distortion {
            // -kc a (a.x - g(t)) = ... - kc a delta (cos phi c_h - sin phi s_h).
            let i = 2 * n + 3;
            let (s, c) = wave.phase.sin_cos();
            if closed {
                let ma = minv.apply(&self.a);
                for (r, v) in ma.iter().enumerate() {
                    g.a[(n + r) * d + i] = -self.kc * wave.amplitude * c * v;
                    g.a[(n + r) * d + i + 1] = self.kc * wave.amplitude * s * v;
                }
            }
            let hw = wave.harmonic as f64 * omega;
            g.a[i * d + i + 1] = -hw;
            g.a[(i + 1) * d + i] = hw;
        }
        g
    }

    /// a.x - g(t) of an augmented state (the row measured from the casing less g).
    pub fn gap_of(&self, w: &[f64]) -> f64 {
        self.switch_functional(w) - self.gap
    }

    /// d(a.x - g(t))/dt of an augmented state along the flow of generator `gen`: L(G w) (a.v
    /// without a distortion).
    pub fn switch_rate(&self, gen: &Dense, w: &[f64]) -> f64 {
        if self.distortion.is_none() {
            return self.rate_of(w);
        }
        self.switch_functional(&gen.apply(w))
    }

    /// a.v of an augmented state.
    pub fn rate_of(&self, w: &[f64]) -> f64 {
        self.a.iter().zip(&w[self.n..]).map(|(a, v)| a * v).sum()
    }
}

/// One stretch of the period in one regime: start time, duration, regime, augmented state.
#[derive(Clone, Debug)]
pub struct Piece {
    pub t0: f64,
    pub dt: f64,
    pub closed: bool,
    pub w0: Vec<f64>,
}

/// One period of the exact flow.
#[derive(Clone, Debug)]
pub struct Flow {
    /// z(T) = (x, v)(T).
    pub end: Vec<f64>,
    /// d z(T) / d z(0) (2n x 2n).
    pub monodromy: Dense,
    /// Switching instants.
    pub events: Vec<f64>,
    /// Largest |f+ - f-| / |f-| over the events (the saltation matrix is I when it is 0).
    pub largest_jump: f64,
    /// The pieces (for the Fourier coefficients).
    pub pieces: Vec<Piece>,
}

/// The exact period map at one W.
pub struct Integrator<'a> {
    pub sys: &'a Pwl,
    pub omega: f64,
    pub period: f64,
    pub steps: usize,
    gen: [Dense; 2],
    step_exp: [Dense; 2],
}

/// Event time accuracy as a fraction of the period.
const EVENT_TOL: f64 = 1e-15;

impl<'a> Integrator<'a> {
    pub fn new(sys: &'a Pwl, omega: f64, steps: usize) -> Self {
        let period = 2.0 * PI / omega;
        let h = period / steps as f64;
        let gen = [sys.generator(false, omega), sys.generator(true, omega)];
        let step_exp = [expm(&gen[0].scaled(h)), expm(&gen[1].scaled(h))];
        Self {
            sys,
            omega,
            period,
            steps,
            gen,
            step_exp,
        }
    }

    fn flow(&self, closed: bool, tau: f64) -> Dense {
        expm(&self.gen[usize::from(closed)].scaled(tau))
    }

    /// Wrong side of the switch surface for the regime: the state should switch.
    fn wrong_side(&self, closed: bool, w: &[f64]) -> bool {
        let g = self.sys.gap_of(w);
        if closed {
            g < 0.0
        } else {
            g > 0.0
        }
    }

    /// The first time in (0, dt] where the flow from `w` in the regime crosses the switch
    /// surface, if it does (`w_end` the state at dt).
    fn crossing(&self, closed: bool, w: &[f64], w_end: &[f64], dt: f64) -> Option<f64> {
        let sys = self.sys;
        // The sign of a.x - g on the regime's own side.
        let own = if closed { 1.0 } else { -1.0 };
        if self.wrong_side(closed, w_end) {
            let along = GapAlong::new(self, closed, w, dt);
            Some(self.root(&along, 0, dt, dt, own))
        } else {
            // Touch and leave within the step: a.x - g has an extremum inside (a.v changes sign
            // the way that turns it towards the surface); check its value there.
            let gen = &self.gen[usize::from(closed)];
            let (r0, r1) = (sys.switch_rate(gen, w), sys.switch_rate(gen, w_end));
            let towards = if closed {
                r0 < 0.0 && r1 > 0.0
            } else {
                r0 > 0.0 && r1 < 0.0
            };
            if !towards {
                return None;
            }
            let along = GapAlong::new(self, closed, w, dt);
            let t_ext = self.root(&along, 1, dt, 0.5 * dt, r0.signum());
            if along.at(t_ext)[0] * own >= 0.0 {
                return None;
            }
            Some(self.root(&along, 0, t_ext, t_ext, own))
        }
    }

    /// The root in (0, hi) of the `order`-th derivative of a.x - g along the flow (0: the
    /// switch, 1: an extremum), of the sign `sign_lo` before it: Newton with the next derivative
    /// from `t`, safeguarded by bisection, to EVENT_TOL T.
    fn root(&self, along: &GapAlong, order: usize, hi: f64, t: f64, sign_lo: f64) -> f64 {
        let (mut lo, mut hi, mut t) = (0.0, hi, t);
        for _ in 0..200 {
            let d = along.at(t);
            let (f, slope) = (d[order], d[order + 1]);
            if f * sign_lo >= 0.0 {
                lo = t;
            } else {
                hi = t;
            }
            let newton = t - f / slope;
            let next = if slope != 0.0 && newton > lo && newton < hi {
                newton
            } else {
                0.5 * (lo + hi)
            };
            let done =
                (next - t).abs() < EVENT_TOL * self.period || hi - lo < EVENT_TOL * self.period;
            t = next;
            if done {
                break;
            }
        }
        t
    }

    /// One period from z0 = (x, v)(0).
    pub fn run(&self, z0: &[f64]) -> Flow {
        self.run_with(z0, true)
    }

    /// z(T) alone from z0: `run` without the monodromy product (the flow's `monodromy` is left
    /// the identity), for the finite differences in W that need only the end state.
    pub fn end_state(&self, z0: &[f64]) -> Vec<f64> {
        self.run_with(z0, false).end
    }

    fn run_with(&self, z0: &[f64], monodromy: bool) -> Flow {
        let sys = self.sys;
        let n = sys.n;
        let d = sys.state_size();
        let mut w: Vec<f64> = sys.augmented(z0);
        let rate0 = sys.switch_rate(&self.gen[0], &w);
        let mut closed = sys.gap_of(&w) > 0.0 || (sys.gap_of(&w) == 0.0 && rate0 > 0.0);
        let mut phi = Dense::identity(d);
        let mut events = Vec::new();
        let mut pieces = Vec::new();
        let mut largest_jump = 0.0_f64;
        let h = self.period / self.steps as f64;
        for step in 0..self.steps {
            let mut t = step as f64 * h;
            let end = (step + 1) as f64 * h;
            loop {
                let dt = end - t;
                let full = step_is_full(dt, h);
                let partial;
                let e = if full {
                    &self.step_exp[usize::from(closed)]
                } else {
                    partial = self.flow(closed, dt);
                    &partial
                };
                let w_end = e.apply(&w);
                match self.crossing(closed, &w, &w_end, dt) {
                    None => {
                        pieces.push(Piece {
                            t0: t,
                            dt,
                            closed,
                            w0: w.clone(),
                        });
                        if monodromy {
                            phi = e.mul(&phi);
                        }
                        w = w_end;
                        break;
                    }
                    Some(tau) => {
                        let et = self.flow(closed, tau);
                        pieces.push(Piece {
                            t0: t,
                            dt: tau,
                            closed,
                            w0: w.clone(),
                        });
                        if monodromy {
                            phi = et.mul(&phi);
                        }
                        w = et.apply(&w);
                        // The vector field on both sides at the event: equal up to kc |a.x - g|.
                        let f_old = self.gen[usize::from(closed)].apply(&w);
                        let f_new = self.gen[usize::from(!closed)].apply(&w);
                        let jump = f_old
                            .iter()
                            .zip(&f_new)
                            .map(|(a, b)| (a - b).powi(2))
                            .sum::<f64>()
                            .sqrt();
                        let size = f_old.iter().map(|v| v * v).sum::<f64>().sqrt();
                        largest_jump = largest_jump.max(jump / size);
                        closed = !closed;
                        t += tau;
                        events.push(t);
                        if end - t <= 1e-15 * self.period {
                            break;
                        }
                    }
                }
            }
        }
        Flow {
            end: w[..2 * n].to_vec(),
            monodromy: phi.block(2 * n),
            events,
            largest_jump,
            pieces,
        }
    }

    /// Fourier coefficients [mean, a_1, b_1, ..., a_H, b_H] of x_j(t) = e_j . x over one flow,
    /// by 12-point Gauss-Legendre on every piece (x is analytic within a piece).
    pub fn fourier(&self, flow: &Flow, coord: &[f64], harmonics: usize) -> Vec<f64> {
        self.fourier_nodes(flow, coord, harmonics, 12)
    }

    /// `fourier` with `nodes`-point Gauss-Legendre on every piece.
    pub fn fourier_nodes(
        &self,
        flow: &Flow,
        coord: &[f64],
        harmonics: usize,
        nodes: usize,
    ) -> Vec<f64> {
        let gl = gauss_legendre(nodes);
        let h = self.period / self.steps as f64;
        let cached: Vec<Vec<Dense>> = [false, true]
            .iter()
            .map(|&c| gl.iter().map(|(s, _)| self.flow(c, s * h)).collect())
            .collect();
        let mut out = vec![0.0; 2 * harmonics + 1];
        let value = |u: &[f64]| -> f64 { coord.iter().zip(u).map(|(c, v)| c * v).sum() };
        for p in &flow.pieces {
            let full = step_is_full(p.dt, h);
            let series = if full {
                None
            } else {
                taylor(&self.gen[usize::from(p.closed)], &p.w0, p.dt, value)
            };
            for (q, (s, wq)) in gl.iter().enumerate() {
                let x = match &series {
                    _ if full => value(&cached[usize::from(p.closed)][q].apply(&p.w0)),
                    Some(c) => series_derivative(c, 0, s * p.dt),
                    None => value(&self.flow(p.closed, s * p.dt).apply(&p.w0)),
                };
                let t = p.t0 + s * p.dt;
                let weight = wq * p.dt / self.period;
                out[0] += weight * x;
                // cos(k W t), sin(k W t) by angle addition from k = 1.
                let (s1, c1) = (self.omega * t).sin_cos();
                let (mut sn, mut cs) = (s1, c1);
                for k in 1..=harmonics {
                    out[2 * k - 1] += 2.0 * weight * x * cs;
                    out[2 * k] += 2.0 * weight * x * sn;
                    (sn, cs) = (sn * c1 + cs * s1, cs * c1 - sn * s1);
                }
            }
        }
        out
    }
}

/// Terms of the Taylor series of a linear functional l of the state along one regime's flow
/// (`taylor`), and the largest ||G tau||_1 over which it is used: the truncation is below
/// 6^49 / 49! ~ 2e-25 of |l|_inf |w|_1, the rounding of the sum about e^6 eps ~ 1e-13 of it
/// (terms grow up to e^||G tau|| before they fall).
const SERIES_TERMS: usize = 49;
const SERIES_REACH: f64 = 6.0;

/// a.x - g and its first two time derivatives along the flow from an augmented state w in one
/// regime, over a sub-step: by the Taylor series (coefficients a.(G^k w)_x / k!, one
/// matrix-vector product each) when the sub-step is within `SERIES_REACH`, else by one
/// exponential per evaluation. Locating an event by the series costs no exponential per
/// Newton iterate.
enum GapAlong<'a> {
    Series(Vec<f64>),
    Exact {
        integ: &'a Integrator<'a>,
        closed: bool,
        w: &'a [f64],
    },
}

impl<'a> GapAlong<'a> {
    fn new(integ: &'a Integrator<'a>, closed: bool, w: &'a [f64], dt: f64) -> Self {
        let sys = integ.sys;
        let a_x = |u: &[f64]| sys.gap_of(u) + sys.gap;
        match taylor(&integ.gen[usize::from(closed)], w, dt, a_x) {
            Some(mut c) => {
                c[0] -= sys.gap;
                Self::Series(c)
            }
            None => Self::Exact { integ, closed, w },
        }
    }

    /// [a.x - g, a.v, a.v'] at tau.
    fn at(&self, tau: f64) -> [f64; 3] {
        match self {
            Self::Series(c) => [
                series_derivative(c, 0, tau),
                series_derivative(c, 1, tau),
                series_derivative(c, 2, tau),
            ],
            Self::Exact { integ, closed, w } => {
                let wt = integ.flow(*closed, tau).apply(w);
                let gen = &integ.gen[usize::from(*closed)];
                let acc = gen.apply(&wt);
                [
                    integ.sys.gap_of(&wt),
                    integ.sys.switch_rate(gen, &wt),
                    integ.sys.switch_rate(gen, &acc),
                ]
            }
        }
    }
}

/// The Taylor coefficients l(G^k w) / k!, k < `SERIES_TERMS`, of a linear functional l of the
/// state along one regime's flow (generator G) from w, if the sub-step dt is within
/// `SERIES_REACH` (||G dt||_1); one matrix-vector product each.
fn taylor(gen: &Dense, w: &[f64], dt: f64, l: impl Fn(&[f64]) -> f64) -> Option<Vec<f64>> {
    if gen.norm1() * dt > SERIES_REACH {
        return None;
    }
    let mut u = w.to_vec();
    let mut c = vec![l(&u)];
    for k in 1..SERIES_TERMS {
        u = gen.apply(&u);
        u.iter_mut().for_each(|v| *v /= k as f64);
        c.push(l(&u));
    }
    Some(c)
}

/// The `order`-th derivative at tau of the series sum c_k tau^k, by Horner.
fn series_derivative(c: &[f64], order: usize, tau: f64) -> f64 {
    let falling = |k: usize| ((k + 1 - order)..=k).map(|j| j as f64).product::<f64>();
    (order..c.len())
        .rev()
        .fold(0.0, |acc, k| acc * tau + falling(k) * c[k])
}

fn step_is_full(dt: f64, h: f64) -> bool {
    (dt - h).abs() <= 1e-12 * h
}

/// Sub-steps per period of the oracle's grid (event search and stored exponentials).
pub const STEPS: usize = 256;

/// A periodic orbit of the exact flow.
#[derive(Clone, Debug)]
pub struct Orbit {
    pub omega: f64,
    pub z0: Vec<f64>,
    pub flow: Flow,
    /// |z(T) - z0| at the end of Newton.
    pub residual: f64,
    pub iterations: usize,
}

/// Shooting at fixed W from `z0`: Newton on z(T) - z0 = 0 with the Jacobian monodromy - I, to
/// |z(T) - z0| <= tol.
pub fn periodic_at(sys: &Pwl, omega: f64, z0: &[f64], tol: f64) -> Option<Orbit> {
    let integ = Integrator::new(sys, omega, STEPS);
    let mut z = z0.to_vec();
    let dim = z.len();
    for it in 0..40 {
        let flow = integ.run(&z);
        let r: Vec<f64> = flow.end.iter().zip(&z).map(|(a, b)| a - b).collect();
        let res = r.iter().map(|v| v * v).sum::<f64>().sqrt();
        if !res.is_finite() {
            return None;
        }
        if res <= tol {
            return Some(Orbit {
                omega,
                z0: z,
                flow,
                residual: res,
                iterations: it,
            });
        }
        let mut jac = flow.monodromy.clone();
        for i in 0..dim {
            jac.a[i * dim + i] -= 1.0;
        }
        let dz = jac.solve(&r.iter().map(|v| -v).collect::<Vec<_>>());
        // Damped step against the kinks of the map (a switch appearing or vanishing).
        let size = dz.iter().map(|v| v * v).sum::<f64>().sqrt();
        let limit = 0.5 * sys.gap * (1.0 + z.iter().map(|v| v * v).sum::<f64>().sqrt());
        let scale = if size > limit { limit / size } else { 1.0 };
        z.iter_mut().zip(&dz).for_each(|(v, d)| *v += scale * d);
    }
    None
}

/// d z(T) / d W at fixed z0, by central differences (step 1e-6 W: the flow is smooth in W
/// away from grazing, the error O(1e-12) relative).
pub fn rate_in_omega(sys: &Pwl, z: &[f64], w: f64) -> Vec<f64> {
    let dw = 1e-6 * w;
    let up = Integrator::new(sys, w + dw, STEPS).end_state(z);
    let down = Integrator::new(sys, w - dw, STEPS).end_state(z);
    up.iter()
        .zip(&down)
        .map(|(a, b)| (a - b) / (2.0 * dw))
        .collect()
}

/// The bordered Jacobian [[monodromy - I, d z(T) / d W], [t / scales]] in the unknowns (z, W).
fn bordered(flow: &Flow, rate: &[f64], tangent: &[f64], scales: (f64, f64)) -> Dense {
    let dim = rate.len();
    let d1 = dim + 1;
    let mut jac = Dense::zeros(d1);
    for i in 0..dim {
        for j in 0..dim {
            jac.a[i * d1 + j] = flow.monodromy.at(i, j) - f64::from(u8::from(i == j));
        }
        jac.a[i * d1 + dim] = rate[i];
        jac.a[dim * d1 + i] = tangent[i] / scales.0;
    }
    jac.a[dim * d1 + dim] = tangent[dim] / scales.1;
    jac
}

/// The periodic orbit on the hyperplane through (z_p, W_p) normal to `tangent` (a unit vector in
/// the scaled variables (z / scales.0, W / scales.1)): Newton on (z(T) - z0, t . (X - X_p)).
pub fn periodic_on_plane(
    sys: &Pwl,
    zp: &[f64],
    wp: f64,
    tangent: &[f64],
    scales: (f64, f64),
    tol: f64,
) -> Option<Orbit> {
    let (zs, ws) = scales;
    let dim = zp.len();
    let (mut z, mut w) = (zp.to_vec(), wp);
    for it in 0..40 {
        let flow = Integrator::new(sys, w, STEPS).run(&z);
        let r: Vec<f64> = flow.end.iter().zip(&z).map(|(a, b)| a - b).collect();
        let res = r.iter().map(|v| v * v).sum::<f64>().sqrt();
        let plane: f64 = (0..dim)
            .map(|i| tangent[i] * (z[i] - zp[i]) / zs)
            .sum::<f64>()
            + tangent[dim] * (w - wp) / ws;
        if !res.is_finite() {
            return None;
        }
        if res <= tol && plane.abs() <= 1e-13 {
            return Some(Orbit {
                omega: w,
                z0: z,
                flow,
                residual: res,
                iterations: it,
            });
        }
        let rate = rate_in_omega(sys, &z, w);
        let jac = bordered(&flow, &rate, tangent, scales);
        let mut rhs: Vec<f64> = r.iter().map(|v| -v).collect();
        rhs.push(-plane);
        let dx = jac.solve(&rhs);
        z.iter_mut().zip(&dx).for_each(|(v, d)| *v += d);
        w += dx[dim];
    }
    None
}

/// The unit tangent of the exact curve at a periodic orbit, in the scaled variables: the null
/// vector of [monodromy - I, d z(T) / d W], oriented like `like`.
pub fn exact_tangent(sys: &Pwl, orbit: &Orbit, like: &[f64], scales: (f64, f64)) -> Vec<f64> {
    let dim = orbit.z0.len();
    let rate = rate_in_omega(sys, &orbit.z0, orbit.omega);
    let jac = bordered(&orbit.flow, &rate, like, scales);
    let mut rhs = vec![0.0; dim + 1];
    rhs[dim] = 1.0;
    let x = jac.solve(&rhs);
    // Back to the scaled variables.
    let mut t: Vec<f64> = (0..dim).map(|i| x[i] / scales.0).collect();
    t.push(x[dim] / scales.1);
    let norm = t.iter().map(|v| v * v).sum::<f64>().sqrt();
    t.iter().map(|v| v / norm).collect()
}

/// The point of the exact curve nearest to (z_p, W_p) in the scaled variables: the orbit on the
/// hyperplane through it normal to the exact curve there (fixed point on the normal, from the
/// normal `tangent`), and the distance.
pub fn nearest_on_curve(
    sys: &Pwl,
    zp: &[f64],
    wp: f64,
    tangent: &[f64],
    scales: (f64, f64),
    tol: f64,
) -> Option<(Orbit, f64)> {
    let mut t = tangent.to_vec();
    let mut orbit = periodic_on_plane(sys, zp, wp, &t, scales, tol)?;
    for _ in 0..8 {
        let next = exact_tangent(sys, &orbit, &t, scales);
        let change = next
            .iter()
            .zip(&t)
            .map(|(a, b)| (a - b).powi(2))
            .sum::<f64>()
            .sqrt();
        t = next;
        orbit = periodic_on_plane(sys, zp, wp, &t, scales, tol)?;
        if change < 1e-7 {
            break;
        }
    }
    let mut d: f64 = zp
        .iter()
        .zip(&orbit.z0)
        .map(|(a, b)| ((a - b) / scales.0).powi(2))
        .sum();
    d += ((wp - orbit.omega) / scales.1).powi(2);
    Some((orbit, d.sqrt()))
}

/// det(monodromy - I) of the flow from z at W.
fn fold_function(sys: &Pwl, z: &[f64], w: f64) -> (Flow, f64) {
    let flow = Integrator::new(sys, w, STEPS).run(z);
    let dim = z.len();
    let mut m = flow.monodromy.clone();
    for i in 0..dim {
        m.a[i * dim + i] -= 1.0;
    }
    let d = m.det();
    (flow, d)
}

/// The fold of the exact curve near the periodic orbit (z, W): Newton on
/// (z(T) - z0, det(monodromy - I)) = 0 (a real multiplier at +1: W turns there), the derivatives
/// of the determinant and of z(T) with respect to W by central differences, steps limited to
/// 0.05 g and 0.2 % of W (the determinant varies like the square root of the penetration near
/// grazing).
pub fn fold_near(sys: &Pwl, z0: &[f64], w0: f64, tol: f64) -> Option<Orbit> {
    let dim = z0.len();
    let (mut z, mut w) = (z0.to_vec(), w0);
    for it in 0..80 {
        let (flow, det) = fold_function(sys, &z, w);
        let r: Vec<f64> = flow.end.iter().zip(&z).map(|(a, b)| a - b).collect();
        let res = r.iter().map(|v| v * v).sum::<f64>().sqrt();
        if !res.is_finite() {
            return None;
        }
        let d1 = dim + 1;
        let mut jac = Dense::zeros(d1);
        for i in 0..dim {
            for j in 0..dim {
                jac.a[i * d1 + j] = flow.monodromy.at(i, j) - f64::from(u8::from(i == j));
            }
        }
        let hz = 1e-7 * sys.gap;
        for j in 0..dim {
            let mut zp = z.clone();
            zp[j] += hz;
            let mut zm = z.clone();
            zm[j] -= hz;
            jac.a[dim * d1 + j] =
                (fold_function(sys, &zp, w).1 - fold_function(sys, &zm, w).1) / (2.0 * hz);
        }
        let hw = 1e-7 * w;
        let (fp, dp) = fold_function(sys, &z, w + hw);
        let (fm, dm) = fold_function(sys, &z, w - hw);
        for i in 0..dim {
            jac.a[i * d1 + dim] = (fp.end[i] - fm.end[i]) / (2.0 * hw);
        }
        jac.a[dim * d1 + dim] = (dp - dm) / (2.0 * hw);
        let mut rhs: Vec<f64> = r.iter().map(|v| -v).collect();
        rhs.push(-det);
        let dx = jac.solve(&rhs);
        let step = dx[..dim].iter().map(|v| v * v).sum::<f64>().sqrt();
        if res <= tol && step <= 1e-9 * sys.gap && (dx[dim] / w).abs() <= 1e-11 {
            return Some(Orbit {
                omega: w,
                z0: z,
                flow,
                residual: res,
                iterations: it,
            });
        }
        let limit = (0.05 * sys.gap / step.max(1e-300))
            .min(0.002 * w / dx[dim].abs().max(1e-300))
            .min(1.0);
        z.iter_mut().zip(&dx).for_each(|(v, d)| *v += limit * d);
        w += limit * dx[dim];
    }
    None
}

/// The largest penalty force kc (a.x - g(t))_+ over a periodic orbit (N): each closed piece of
/// its flow sampled at `samples` instants by the exact step exponential, the largest sample's
/// neighbourhood sampled `samples` times finer (a strike spanning one step is resolved to
/// (pi / 2 / samples^2)^2 / 2 relative, about 1e-12 at 1000).
#[allow(dead_code)]
pub fn largest_penalty_force(sys: &Pwl, orbit: &Orbit, samples: usize) -> f64 {
    let gen = sys.generator(true, orbit.omega);
    let scan = |w0: &[f64], h: f64, count: usize| {
        let step = expm(&gen.scaled(h));
        let mut w = w0.to_vec();
        let mut best = (f64::NEG_INFINITY, w.clone());
        for k in 0..=count {
            if k > 0 {
                w = step.apply(&w);
            }
            let g = sys.gap_of(&w);
            if g > best.0 {
                best = (g, w.clone());
            }
        }
        best
    };
    let mut largest = 0.0_f64;
    for piece in orbit.flow.pieces.iter().filter(|p| p.closed && p.dt > 0.0) {
        let h = piece.dt / samples as f64;
        let (coarse, at) = scan(&piece.w0, h, samples);
        // From one step before the coarse peak (clamped to the piece), two steps finely.
        let back = expm(&gen.scaled(-h)).apply(&at);
        let (fine, _) = scan(&back, 2.0 * h / samples as f64, samples);
        largest = largest.max(coarse.max(fine));
    }
    sys.kc * largest
}
