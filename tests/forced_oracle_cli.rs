//! Issue 37's acceptance: `nlmodes forced` at the `[forced]` defaults for `harmonics` and
//! `samples`, against exact periodic orbits built here (docs/VERIFICATION.md, "Forced response
//! at its defaults against exact orbits").
//!
//! MEASURED-PLACEHOLDER

mod common;
#[path = "../crates/forced/tests/pwl/mod.rs"]
mod pwl;

use std::path::{Path, PathBuf};
use std::sync::Arc;

use common::{csv_columns, nlmodes, padded_contact_model, Memo};
use pwl::{Dense, Integrator, Orbit, Pwl};

/// The contact's gap (m).
const GAP: f64 = 1.0;

/// Newton tolerance of the oracle's shooting on |z(T) - z(0)| (m, velocities m/s): 1e-10 g,
/// far below every difference compared.
const ORBIT_TOL: f64 = 1e-10 * GAP;

/// Issue 37's bounds: the peak amplitude (relative), its W (relative), every fold's W
/// (relative), a point's first harmonic at its W (relative), the share of points within that.
const PEAK_AMPLITUDE: f64 = 0.02;
const PEAK_OMEGA: f64 = 0.005;
const FOLD_OMEGA: f64 = 0.01;
const POINT_AMPLITUDE: f64 = 0.01;
const POINT_SHARE: f64 = 0.99;

/// Within this relative distance in W of an exact fold a point with no exact orbit within
/// `POINT_AMPLITUDE` at its own W is compared with the exact orbit nearest to it, which must lie
/// within `POINT_AMPLITUDE` in the first harmonic and within this in W (module docs).
const NEAR_FOLD_OMEGA: f64 = 1e-3;

/// One test system: M x'' + C x' + K x + kc (x_c - g)_+ e_c = F cos(W t) e_m, C modal with
/// one ratio, kc = `penalty_factor` x the static contact stiffness 1 / (K^-1)_cc.
struct Spec {
    name: &'static str,
    /// M (kg) and K (N/m), n x n.
    mass: Vec<Vec<f64>>,
    stiffness: Vec<Vec<f64>>,
    /// The contact coordinate c and the master (loaded) coordinate m.
    contact: usize,
    master: usize,
    zeta: f64,
    penalty_factor: f64,
    /// The force F as a multiple of the grazing force (the F whose linear resonant response of
    /// the contact coordinate reaches the gap), or in N.
    level: Level,
    /// [start, end] in W / w1.
    range: (f64, f64),
}

enum Level {
    Newtons(f64),
    TimesGrazing(f64),
}

/// The issue's own example: m = k = 1, 1 % damping, F = 0.1 N, kc = 100 N/m beyond g = 1 m.
fn one_dof() -> Spec {
    Spec {
        name: "one_dof",
        mass: vec![vec![1.0]],
        stiffness: vec![vec![1.0]],
        contact: 0,
        master: 0,
        zeta: 0.01,
        penalty_factor: 100.0,
        level: Level::Newtons(0.1),
        range: (0.8, 2.2),
    }
}

/// The 2-DOF chain M = I, K = [[2, -1], [-1, 2]] (w = 1, sqrt 3 rad/s), the stop on the second
/// mass (kc = 100 x 1.5 N/m), the force on the first, 0.5 % on both modes, 5 x grazing.
fn chain() -> Spec {
    Spec {
        name: "chain",
        mass: vec![vec![1.0, 0.0], vec![0.0, 1.0]],
        stiffness: vec![vec![2.0, -1.0], vec![-1.0, 2.0]],
        contact: 1,
        master: 0,
        zeta: 0.005,
        penalty_factor: 100.0,
        level: Level::TimesGrazing(5.0),
        range: (0.8, 1.6),
    }
}

/// The system's own linear algebra, independent of the crates under test.
struct Linear {
    /// Circular frequencies (rad/s, ascending).
    omega: Vec<f64>,
    /// Mass-normalized mode shapes, one vector per mode.
    shapes: Vec<Vec<f64>>,
    /// C = M Phi diag(2 zeta w) Phi^T M (N s/m).
    damping: Vec<Vec<f64>>,
}

/// Cholesky factor L (lower) of a symmetric positive definite matrix.
fn cholesky(a: &[Vec<f64>]) -> Vec<Vec<f64>> {
    let n = a.len();
    let mut l = vec![vec![0.0; n]; n];
    for i in 0..n {
        for j in 0..=i {
            let s = a[i][j] - (0..j).map(|p| l[i][p] * l[j][p]).sum::<f64>();
            l[i][j] = if i == j { s.sqrt() } else { s / l[j][j] };
        }
    }
    l
}

/// Eigenvalues and eigenvectors (columns of the returned V) of a symmetric matrix by cyclic
/// Jacobi rotations.
fn jacobi(mut a: Vec<Vec<f64>>) -> (Vec<f64>, Vec<Vec<f64>>) {
    let n = a.len();
    let mut v: Vec<Vec<f64>> = (0..n)
        .map(|i| (0..n).map(|j| f64::from(u8::from(i == j))).collect())
        .collect();
    for _ in 0..100 {
        let off: f64 = (0..n)
            .flat_map(|p| (p + 1..n).map(move |q| (p, q)))
            .map(|(p, q)| a[p][q] * a[p][q])
            .sum();
        let scale: f64 = (0..n).map(|p| a[p][p] * a[p][p]).sum();
        if off <= 1e-32 * scale {
            break;
        }
        for p in 0..n {
            for q in p + 1..n {
                if a[p][q] == 0.0 {
                    continue;
                }
                let theta = (a[q][q] - a[p][p]) / (2.0 * a[p][q]);
                let t = theta.signum() / (theta.abs() + (theta * theta + 1.0).sqrt());
                let c = 1.0 / (t * t + 1.0).sqrt();
                let s = t * c;
                let rotate = |x: f64, y: f64| (c * x - s * y, s * x + c * y);
                for row in a.iter_mut() {
                    (row[p], row[q]) = rotate(row[p], row[q]);
                }
                for k in 0..n {
                    (a[p][k], a[q][k]) = rotate(a[p][k], a[q][k]);
                }
                for row in v.iter_mut() {
                    (row[p], row[q]) = rotate(row[p], row[q]);
                }
            }
        }
    }
    ((0..n).map(|i| a[i][i]).collect(), v)
}

/// The modes of (K, M) and the modal damping matrix, checked: |K phi - w^2 M phi| <= 1e-12
/// |K phi| and phi^T M phi = 1.
fn linear(spec: &Spec) -> Linear {
    let (m, k) = (&spec.mass, &spec.stiffness);
    let n = m.len();
    let l = cholesky(m);
    let ld = Dense::from_fn(n, |i, j| l[i][j]);
    let linv = ld.inverse();
    let kd = Dense::from_fn(n, |i, j| k[i][j]);
    let linv_t = Dense::from_fn(n, |i, j| linv.at(j, i));
    let a = linv.mul(&kd).mul(&linv_t);
    let (lambda, v) = jacobi((0..n).map(|i| (0..n).map(|j| a.at(i, j)).collect()).collect());
    let mut order: Vec<usize> = (0..n).collect();
    order.sort_by(|&x, &y| lambda[x].total_cmp(&lambda[y]));
    let omega: Vec<f64> = order.iter().map(|&i| lambda[i].sqrt()).collect();
    let shapes: Vec<Vec<f64>> = order
        .iter()
        .map(|&i| linv_t.apply(&(0..n).map(|r| v[r][i]).collect::<Vec<_>>()))
        .collect();
    let md = Dense::from_fn(n, |i, j| m[i][j]);
    for (w, phi) in omega.iter().zip(&shapes) {
        let (kp, mp) = (kd.apply(phi), md.apply(phi));
        let residual = norm(&sub(&kp, &mp.iter().map(|x| w * w * x).collect::<Vec<_>>()));
        assert!(residual <= 1e-12 * norm(&kp), "{}: mode residual", spec.name);
        assert!((dot(phi, &mp) - 1.0).abs() < 1e-12, "{}: mass norm", spec.name);
    }
    let mphi: Vec<Vec<f64>> = shapes.iter().map(|p| md.apply(p)).collect();
    let damping = (0..n)
        .map(|i| {
            (0..n)
                .map(|j| {
                    (0..n)
                        .map(|r| 2.0 * spec.zeta * omega[r] * mphi[r][i] * mphi[r][j])
                        .sum()
                })
                .collect()
        })
        .collect();
    Linear {
        omega,
        shapes,
        damping,
    }
}

fn dot(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| x * y).sum()
}

fn norm(a: &[f64]) -> f64 {
    dot(a, a).sqrt()
}

fn sub(a: &[f64], b: &[f64]) -> Vec<f64> {
    a.iter().zip(b).map(|(x, y)| x - y).collect()
}

fn unit(n: usize, j: usize) -> Vec<f64> {
    (0..n).map(|i| f64::from(u8::from(i == j))).collect()
}

/// The oracle's system at force `force` (N) and penalty stiffness `kc` (N/m).
fn oracle(spec: &Spec, lin: &Linear, force: f64, kc: f64) -> Pwl {
    let n = spec.mass.len();
    Pwl {
        n,
        m: Dense::from_fn(n, |i, j| spec.mass[i][j]),
        c: Dense::from_fn(n, |i, j| lin.damping[i][j]),
        k: Dense::from_fn(n, |i, j| spec.stiffness[i][j]),
        a: unit(n, spec.contact),
        gap: GAP,
        kc,
        fc: unit(n, spec.master).iter().map(|v| v * force).collect(),
        fs: vec![0.0; n],
    }
}

/// First-harmonic amplitude (m) of coordinate `j` of the linear response to `sys`'s force at
/// W: (K - W^2 M + i W C) X = fc, as a real 2n system.
fn linear_amplitude(sys: &Pwl, omega: f64, j: usize) -> f64 {
    let n = sys.n;
    let big = Dense::from_fn(2 * n, |p, q| {
        let (i, jj) = (p % n, q % n);
        let d = sys.k.at(i, jj) - omega * omega * sys.m.at(i, jj);
        let e = omega * sys.c.at(i, jj);
        match (p < n, q < n) {
            (true, true) | (false, false) => d,
            (true, false) => -e,
            (false, true) => e,
        }
    });
    let mut rhs = sys.fc.clone();
    rhs.extend(vec![0.0; n]);
    let x = big.solve(&rhs);
    x[j].hypot(x[n + j])
}

/// The largest linear response of the contact coordinate per newton around the first mode (m/N):
/// a scan of [0.9, 1.1] w1 refined by golden sections.
fn resonant_compliance(spec: &Spec, lin: &Linear) -> f64 {
    let unit_force = oracle(spec, lin, 1.0, 0.0);
    let f = |w: f64| linear_amplitude(&unit_force, w, spec.contact);
    let w1 = lin.omega[0];
    let grid: Vec<f64> = (0..=2000).map(|i| w1 * (0.9 + 0.2 * i as f64 / 2000.0)).collect();
    let best = (1..grid.len() - 1)
        .max_by(|&a, &b| f(grid[a]).total_cmp(&f(grid[b])))
        .unwrap();
    let (mut lo, mut hi) = (grid[best - 1], grid[best + 1]);
    let r = (5f64.sqrt() - 1.0) / 2.0;
    for _ in 0..80 {
        let (x1, x2) = (hi - r * (hi - lo), lo + r * (hi - lo));
        if f(x1) > f(x2) {
            hi = x2;
        } else {
            lo = x1;
        }
    }
    f(0.5 * (lo + hi))
}

/// The static contact stiffness 1 / (K^-1)_cc (N/m).
fn static_contact_stiffness(spec: &Spec) -> f64 {
    let n = spec.mass.len();
    let k = Dense::from_fn(n, |i, j| spec.stiffness[i][j]);
    1.0 / k.solve(&unit(n, spec.contact))[spec.contact]
}

/// What `nlmodes forced` reported.
struct Reported {
    /// Exit status, stdout and stderr.
    code: Option<i32>,
    stdout: String,
    stderr: String,
    /// Per point: W (rad/s), the master's first harmonic (m, frf.csv's q1_over_g0 x g0), the
    /// orbit's (x, v)(0) of the system's coordinates (from frf.json's coefficients), its N and
    /// frf.csv's `fold` and `piece`.
    omega: Vec<f64>,
    q1: Vec<f64>,
    states: Vec<Vec<f64>>,
    harmonics: Vec<usize>,
    csv_fold: Vec<String>,
    piece: Vec<usize>,
    /// frf.json's folds: (point, W (rad/s) refined, kind).
    folds: Vec<(usize, f64, String)>,
    termination: String,
    kc: f64,
    /// frf_boundary.csv: (W (rad/s), master first harmonic (m), fold).
    boundary: Vec<(f64, f64, bool)>,
    /// Where the run's files are.
    out: PathBuf,
    seconds: f64,
}

/// Writes the model and settings of `spec` under the test binary's temporary directory and runs
/// `nlmodes forced` on them at the force `force` (N).
fn run_forced(spec: &Spec, lin: &Linear, force: f64) -> Reported {
    let root = Path::new(env!("CARGO_TARGET_TMPDIR"))
        .join("forced_oracle")
        .join(spec.name);
    let _ = std::fs::remove_dir_all(&root);
    let (model, out) = (root.join("model"), root.join("out"));
    padded_contact_model(
        &model,
        &spec.mass,
        &spec.stiffness,
        (spec.contact, spec.master),
        &lin.omega,
    );
    let settings = root.join("forced.toml");
    std::fs::write(
        &settings,
        format!(
            "[forced]\nrange = [{:?}, {:?}]\nload = \"master\"\nlevels = [{force:?}]\n\
             level_unit = \"N\"\ncontact = \"penalty\"\npenalty_factor = {:?}\n\
             damping_ratio = {:?}\n",
            spec.range.0, spec.range.1, spec.penalty_factor, spec.zeta
        ),
    )
    .unwrap();
    let started = std::time::Instant::now();
    let run = nlmodes(&[
        "forced",
        model.to_str().unwrap(),
        "--settings",
        settings.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
    ]);
    let seconds = started.elapsed().as_secs_f64();
    let (stdout, stderr) = (
        String::from_utf8_lossy(&run.stdout).into_owned(),
        String::from_utf8_lossy(&run.stderr).into_owned(),
    );
    assert!(
        out.join("frf.json").is_file(),
        "{}: no frf.json ({:?}):\n{stdout}{stderr}",
        spec.name,
        run.status
    );
    let mut reported = read_outputs(&out, spec.mass.len());
    reported.code = run.status.code();
    (reported.stdout, reported.stderr, reported.seconds) = (stdout, stderr, seconds);
    reported
}

/// (x, v)(0) of the first `n` coordinates of an orbit from its coefficients [u0, a1, b1, ...].
fn state_at_zero(coefficients: &serde_json::Value, n: usize, omega: f64) -> Vec<f64> {
    let rows: Vec<Vec<f64>> = (0..n)
        .map(|d| {
            coefficients[d]
                .as_array()
                .expect("coefficients per coordinate")
                .iter()
                .map(|v| v.as_f64().expect("a number"))
                .collect()
        })
        .collect();
    let x = rows.iter().map(|c| c[0] + c[1..].iter().step_by(2).sum::<f64>());
    let v = rows.iter().map(|c| {
        c[2..]
            .iter()
            .step_by(2)
            .enumerate()
            .map(|(h, b)| (h + 1) as f64 * omega * b)
            .sum::<f64>()
    });
    x.chain(v).collect()
}

fn num(s: &str) -> f64 {
    s.parse()
        .unwrap_or_else(|_| panic!("{s:?} is not a number"))
}

/// frf.csv, frf.json and frf_boundary.csv of one level; `n` the system's coordinates.
fn read_outputs(out: &Path, n: usize) -> Reported {
    let read = |f: &str| std::fs::read_to_string(out.join(f)).unwrap();
    let json: serde_json::Value = serde_json::from_str(&read("frf.json")).unwrap();
    let g = json["gap_reference_m"].as_f64().unwrap();
    let curve = &json["curves"][0];
    let orbits = curve["orbits"].as_array().unwrap();
    let rows = csv_columns(
        &read("frf.csv"),
        &["omega_rad_s", "q1_over_g0", "fold", "piece", "harmonics"],
    );
    assert_eq!(rows.len(), orbits.len(), "frf.csv and frf.json disagree");
    let states = orbits
        .iter()
        .map(|o| state_at_zero(&o["coefficients"], n, o["omega"].as_f64().unwrap()))
        .collect();
    let folds = curve["folds"]
        .as_array()
        .unwrap()
        .iter()
        .map(|f| {
            let point = f[0].as_u64().unwrap() as usize;
            (point, f[1].as_f64().unwrap(), f[2].as_str().unwrap().into())
        })
        .collect();
    let boundary = std::fs::read_to_string(out.join("frf_boundary.csv"))
        .map(|text| {
            csv_columns(&text, &["omega_rad_s", "q1_over_g0", "fold"])
                .iter()
                .map(|r| (num(&r[0]), num(&r[1]) * g, r[2] == "1"))
                .collect()
        })
        .unwrap_or_default();
    Reported {
        code: None,
        stdout: String::new(),
        stderr: String::new(),
        omega: rows.iter().map(|r| num(&r[0])).collect(),
        q1: rows.iter().map(|r| num(&r[1]) * g).collect(),
        states,
        harmonics: rows.iter().map(|r| r[4].parse().unwrap()).collect(),
        csv_fold: rows.iter().map(|r| r[2].clone()).collect(),
        piece: rows.iter().map(|r| r[3].parse().unwrap()).collect(),
        folds,
        termination: curve["termination"].as_str().unwrap_or("").into(),
        kc: json["penalty_stiffness_n_per_m"].as_f64().unwrap_or(f64::NAN),
        boundary,
        out: out.to_path_buf(),
        seconds: 0.0,
    }
}

/// The oracle's view of one system: its periodic orbits through the points, its folds and peak.
struct Exact<'s> {
    sys: &'s Pwl,
    master: usize,
    /// (g, w1): the scaled variables are (x, v)(0) / g and W / w1.
    scales: (f64, f64),
}

impl Exact<'_> {
    /// The master's first-harmonic amplitude (m) of an exact orbit.
    fn q1(&self, orbit: &Orbit) -> f64 {
        let integ = Integrator::new(self.sys, orbit.omega, pwl::STEPS);
        let c = integ.fourier(&orbit.flow, &unit(self.sys.n, self.master), 1);
        c[1].hypot(c[2])
    }

    /// The scaled point (z / g, W / w1).
    fn scaled(&self, z: &[f64], omega: f64) -> Vec<f64> {
        let mut v: Vec<f64> = z.iter().map(|x| x / self.scales.0).collect();
        v.push(omega / self.scales.1);
        v
    }

    /// One pseudo-arc-length step of the exact curve: from `orbit` along the unit scaled
    /// tangent `t` by `h`, the orbit on the hyperplane normal to `t` and its tangent.
    fn step(&self, orbit: &Orbit, t: &[f64], h: f64) -> Option<(Orbit, Vec<f64>)> {
        let n2 = orbit.z0.len();
        let z: Vec<f64> = (0..n2)
            .map(|i| orbit.z0[i] + h * t[i] * self.scales.0)
            .collect();
        let w = orbit.omega + h * t[n2] * self.scales.1;
        let next = pwl::periodic_on_plane(self.sys, &z, w, t, self.scales, ORBIT_TOL)?;
        let tangent = pwl::exact_tangent(self.sys, &next, t, self.scales);
        Some((next, tangent))
    }
}

/// The unit secant of the reported curve at point i (from its neighbours in the same piece) in
/// the scaled variables: the orientation of the exact tangent there.
fn secant(exact: &Exact, r: &Reported, i: usize) -> Vec<f64> {
    let last = r.omega.len() - 1;
    let lo = if i > 0 && r.piece[i - 1] == r.piece[i] {
        i - 1
    } else {
        i
    };
    let hi = if i < last && r.piece[i + 1] == r.piece[i] {
        i + 1
    } else {
        i
    };
    let d = sub(
        &exact.scaled(&r.states[hi], r.omega[hi]),
        &exact.scaled(&r.states[lo], r.omega[lo]),
    );
    let length = norm(&d);
    d.iter().map(|v| v / length).collect()
}

/// How a point compares with the exact curve.
#[derive(Clone, Copy, Debug, PartialEq)]
enum How {
    /// An exact orbit at the point's W within `POINT_AMPLITUDE` in the first harmonic.
    AtItsOmega,
    /// Within `NEAR_FOLD_OMEGA` of an exact fold, no such orbit at its W; the exact orbit
    /// nearest to it within `POINT_AMPLITUDE` in q1 and `NEAR_FOLD_OMEGA` in W.
    NearFold,
    /// Neither.
    Missed,
}

/// One reported point against the exact curve.
struct PointCheck {
    /// The exact orbit it is compared with (at its W, or the nearest) and its q1 (m).
    orbit: Orbit,
    q1: f64,
    /// |q1 / q1_reported - 1| and |W_exact / W - 1|.
    error: f64,
    omega_error: f64,
    /// The exact tangent's W component there (oriented along the reported curve).
    slope: f64,
    /// Whether an orbit at the point's own W matched.
    at_omega: bool,
    how: How,
}

/// The exact orbit for point i: at its own W from its own (x, v)(0), else from the previous
/// point's exact orbit (the other branch near a fold); else the exact orbit nearest to it.
fn check_point(exact: &Exact, r: &Reported, i: usize, previous: Option<&Orbit>) -> PointCheck {
    let (w, q) = (r.omega[i], r.q1[i]);
    let mut best: Option<(Orbit, f64)> = None;
    let starts = std::iter::once(&r.states[i]).chain(previous.map(|o| &o.z0));
    for start in starts {
        if let Some(orbit) = pwl::periodic_at(exact.sys, w, start, ORBIT_TOL) {
            let q_exact = exact.q1(&orbit);
            if best.as_ref().is_none_or(|b| (b.1 / q - 1.0).abs() > (q_exact / q - 1.0).abs()) {
                best = Some((orbit, q_exact));
            }
        }
        if best.as_ref().is_some_and(|b| (b.1 / q - 1.0).abs() <= POINT_AMPLITUDE) {
            break;
        }
    }
    let like = secant(exact, r, i);
    let (orbit, q_exact, at_omega) = match best {
        Some((o, qe)) if (qe / q - 1.0).abs() <= POINT_AMPLITUDE => (o, qe, true),
        _ => {
            let (o, _) = pwl::nearest_on_curve(exact.sys, &r.states[i], w, &like, exact.scales, ORBIT_TOL)
                .unwrap_or_else(|| panic!("no exact orbit near point {i} (W = {w})"));
            let qe = exact.q1(&o);
            (o, qe, false)
        }
    };
    let tangent = pwl::exact_tangent(exact.sys, &orbit, &like, exact.scales);
    PointCheck {
        error: (q_exact / q - 1.0).abs(),
        omega_error: (orbit.omega / w - 1.0).abs(),
        slope: tangent[tangent.len() - 1],
        q1: q_exact,
        orbit,
        at_omega,
        how: if at_omega { How::AtItsOmega } else { How::Missed },
    }
}

/// A fold of the exact curve.
#[derive(Clone, Debug)]
struct ExactFold {
    omega: f64,
    q1: f64,
    /// "TurnsBack" (W rose, then falls) or "TurnsForward".
    kind: &'static str,
}

/// The folds of the exact curve: where the W component of the exact tangent changes sign
/// between consecutive points of a piece, solved for by `pwl::fold_near` from the exact orbit
/// with the smaller component; a fold found twice kept once.
fn exact_folds(exact: &Exact, r: &Reported, checks: &[PointCheck]) -> Vec<ExactFold> {
    let mut folds: Vec<ExactFold> = Vec::new();
    for i in 1..checks.len() {
        let (a, b) = (&checks[i - 1], &checks[i]);
        if r.piece[i - 1] != r.piece[i] || a.slope * b.slope >= 0.0 {
            continue;
        }
        let (first, second) = if a.slope.abs() <= b.slope.abs() {
            (a, b)
        } else {
            (b, a)
        };
        let fold = [first, second]
            .iter()
            .find_map(|c| pwl::fold_near(exact.sys, &c.orbit.z0, c.orbit.omega, ORBIT_TOL))
            .unwrap_or_else(|| {
                panic!(
                    "no exact fold near points {} and {i} (W = {} .. {} rad/s)",
                    i - 1,
                    r.omega[i - 1],
                    r.omega[i]
                )
            });
        let kind = if a.slope > 0.0 {
            "TurnsBack"
        } else {
            "TurnsForward"
        };
        let known = folds
            .iter()
            .any(|f| f.kind == kind && (f.omega / fold.omega - 1.0).abs() < 1e-8);
        if !known {
            folds.push(ExactFold {
                omega: fold.omega,
                q1: exact.q1(&fold),
                kind,
            });
        }
    }
    folds
}

/// The peak of the exact curve, (W, q1): from the exact orbit with the largest first harmonic
/// among the points', the curve walked both ways in scaled steps of 1e-3 until q1 has fallen on
/// three steps; the vertex of the parabola q1(s) through the largest sample and its neighbours,
/// W there by the parabola through the same three.
fn exact_peak(exact: &Exact, r: &Reported, checks: &[PointCheck]) -> (f64, f64) {
    let top = (0..checks.len())
        .max_by(|&a, &b| checks[a].q1.total_cmp(&checks[b].q1))
        .unwrap();
    let t0 = pwl::exact_tangent(exact.sys, &checks[top].orbit, &secant(exact, r, top), exact.scales);
    let h = 1e-3;
    let mut samples = vec![(0.0, checks[top].orbit.omega, checks[top].q1)];
    for sign in [1.0, -1.0] {
        let mut t: Vec<f64> = t0.iter().map(|v| sign * v).collect();
        let mut orbit = checks[top].orbit.clone();
        let (mut s, mut last, mut falls) = (0.0, checks[top].q1, 0);
        while falls < 3 {
            let (next, tangent) = exact
                .step(&orbit, &t, h)
                .unwrap_or_else(|| panic!("the exact curve lost near its peak"));
            s += sign * h;
            let q = exact.q1(&next);
            falls = if q < last { falls + 1 } else { 0 };
            samples.push((s, next.omega, q));
            (orbit, t, last) = (next, tangent, q);
        }
    }
    samples.sort_by(|a, b| a.0.total_cmp(&b.0));
    let k = (1..samples.len() - 1)
        .max_by(|&a, &b| samples[a].2.total_cmp(&samples[b].2))
        .unwrap();
    let [p0, p1, p2] = [samples[k - 1], samples[k], samples[k + 1]];
    let lagrange = |x: f64, f: fn(&(f64, f64, f64)) -> f64| {
        f(&p0) * (x - p1.0) * (x - p2.0) / ((p0.0 - p1.0) * (p0.0 - p2.0))
            + f(&p1) * (x - p0.0) * (x - p2.0) / ((p1.0 - p0.0) * (p1.0 - p2.0))
            + f(&p2) * (x - p0.0) * (x - p1.0) / ((p2.0 - p0.0) * (p2.0 - p1.0))
    };
    // Vertex of q(s): q'(s) = 0 for the parabola through the three samples.
    let (d01, d12) = ((p1.2 - p0.2) / (p1.0 - p0.0), (p2.2 - p1.2) / (p2.0 - p1.0));
    let second = (d12 - d01) / (p2.0 - p0.0);
    let s_star = 0.5 * (p0.0 + p1.0) - d01 / (2.0 * second);
    (lagrange(s_star, |p| p.1), lagrange(s_star, |p| p.2))
}

/// Everything one system's checks need.
struct Analysis {
    name: &'static str,
    w1: f64,
    master: usize,
    force: f64,
    kc: f64,
    /// The linear resonant response of the contact coordinate at the force, / g.
    linear_peak_over_gap: f64,
    reported: Reported,
    sys: Pwl,
    checks: Vec<PointCheck>,
    folds: Vec<ExactFold>,
    /// Exact peak (W rad/s, q1 m).
    peak: (f64, f64),
    oracle_seconds: f64,
}

impl Analysis {
    fn exact(&self) -> Exact<'_> {
        Exact {
            sys: &self.sys,
            master: self.master,
            scales: (GAP, self.w1),
        }
    }
}

static ANALYSES: Memo<Analysis> = Memo::new();

/// The run of `spec` and its exact reference (once per test binary).
fn analysis(spec: fn() -> Spec) -> Arc<Analysis> {
    let spec = spec();
    ANALYSES.get(spec.name.into(), || analyse(&spec))
}

fn analyse(spec: &Spec) -> Analysis {
    let lin = linear(spec);
    let compliance = resonant_compliance(spec, &lin);
    let force = match spec.level {
        Level::Newtons(f) => f,
        Level::TimesGrazing(k) => k * GAP / compliance,
    };
    let kc = spec.penalty_factor * static_contact_stiffness(spec);
    let reported = run_forced(spec, &lin, force);
    let started = std::time::Instant::now();
    let sys = oracle(spec, &lin, force, kc);
    let exact = Exact {
        sys: &sys,
        master: spec.master,
        scales: (GAP, lin.omega[0]),
    };
    let mut checks: Vec<PointCheck> = Vec::with_capacity(reported.omega.len());
    for i in 0..reported.omega.len() {
        let previous = checks
            .last()
            .filter(|_| i > 0 && reported.piece[i - 1] == reported.piece[i])
            .map(|c| &c.orbit);
        let c = check_point(&exact, &reported, i, previous);
        checks.push(c);
    }
    let folds = exact_folds(&exact, &reported, &checks);
    for (w, c) in reported.omega.iter().zip(&mut checks) {
        let near = folds
            .iter()
            .any(|f| (w / f.omega - 1.0).abs() <= NEAR_FOLD_OMEGA);
        if !c.at_omega && near && c.error <= POINT_AMPLITUDE && c.omega_error <= NEAR_FOLD_OMEGA {
            c.how = How::NearFold;
        }
    }
    let peak = exact_peak(&exact, &reported, &checks);
    Analysis {
        name: spec.name,
        w1: lin.omega[0],
        master: spec.master,
        force,
        kc,
        linear_peak_over_gap: force * compliance / GAP,
        reported,
        checks,
        folds,
        peak,
        oracle_seconds: started.elapsed().as_secs_f64(),
        sys,
    }
}

/// The reported peak: (W rad/s, q1 m) of the point with the largest first harmonic.
fn reported_peak(r: &Reported) -> (f64, f64) {
    let i = (0..r.q1.len())
        .max_by(|&a, &b| r.q1[a].total_cmp(&r.q1[b]))
        .unwrap();
    (r.omega[i], r.q1[i])
}

/// The exact fold of `kind` nearest to W (rad/s), and the relative distance in W.
fn nearest_fold<'f>(folds: &'f [ExactFold], kind: &str, w: f64) -> Option<(&'f ExactFold, f64)> {
    folds
        .iter()
        .filter(|f| f.kind == kind)
        .map(|f| (f, (w / f.omega - 1.0).abs()))
        .min_by(|a, b| a.1.total_cmp(&b.1))
}

/// Prints what was compared (shown with `--nocapture`).
fn report(a: &Analysis) {
    let (r, w1) = (&a.reported, a.w1);
    let mut ns: Vec<usize> = r.harmonics.clone();
    ns.sort_unstable();
    ns.dedup();
    println!(
        "{}: F = {:.6e} N (linear resonance of the contact coordinate {:.3} g), kc = {} N/m; \
         nlmodes exit {:?} in {:.1} s ({}), {} points at N = {ns:?}; oracle {:.1} s; files in {}",
        a.name,
        a.force,
        a.linear_peak_over_gap,
        a.kc,
        r.code,
        r.seconds,
        r.termination,
        r.omega.len(),
        a.oracle_seconds,
        r.out.display()
    );
    let (wp, qp) = reported_peak(r);
    println!(
        "  peak: reported q1/g {:.5} at W/w1 {:.5}; exact {:.5} at {:.5} ({:.2e}, {:.2e})",
        qp / GAP,
        wp / w1,
        a.peak.1 / GAP,
        a.peak.0 / w1,
        (qp / a.peak.1 - 1.0).abs(),
        (wp / a.peak.0 - 1.0).abs()
    );
    for f in &a.folds {
        println!(
            "  exact fold {}: W/w1 {:.6}, q1/g {:.5}",
            f.kind,
            f.omega / w1,
            f.q1 / GAP
        );
    }
    for (point, w, kind) in &r.folds {
        let d = nearest_fold(&a.folds, kind, *w).map_or(f64::NAN, |x| x.1);
        let d_point = nearest_fold(&a.folds, kind, r.omega[*point]).map_or(f64::NAN, |x| x.1);
        println!(
            "  reported fold {kind}: W/w1 {:.6} ({d:.2e} from the exact fold), at point {point} \
             W/w1 {:.6} ({d_point:.2e})",
            w / w1,
            r.omega[*point] / w1
        );
    }
    let count = |how: How| a.checks.iter().filter(|c| c.how == how).count();
    let at: Vec<f64> = a.checks.iter().filter(|c| c.at_omega).map(|c| c.error).collect();
    let mut sorted = at.clone();
    sorted.sort_by(f64::total_cmp);
    println!(
        "  points: {} at their W (largest error {:.2e}, median {:.2e}), {} near a fold by the \
         nearest exact orbit, {} missed",
        count(How::AtItsOmega),
        sorted.last().copied().unwrap_or(0.0),
        sorted.get(sorted.len() / 2).copied().unwrap_or(0.0),
        count(How::NearFold),
        count(How::Missed)
    );
    for (i, c) in a.checks.iter().enumerate().filter(|(_, c)| c.how != How::AtItsOmega) {
        println!(
            "    point {i} ({:?}): W/w1 {:.6}, N = {}, q1/g {:.5}, exact {:.5} at W/w1 {:.6}: \
             {:.2e} in q1, {:.2e} in W",
            c.how,
            r.omega[i] / w1,
            r.harmonics[i],
            r.q1[i] / GAP,
            c.q1 / GAP,
            c.orbit.omega / w1,
            c.error,
            c.omega_error
        );
    }
}

/// Issue 37's checks on one system (module docs).
fn assert_acceptance(a: &Analysis) {
    let r = &a.reported;
    assert_eq!(
        r.code,
        Some(0),
        "{}: nlmodes forced did not succeed:\n{}{}",
        a.name,
        r.stdout,
        r.stderr
    );
    assert!(
        (r.kc / a.kc - 1.0).abs() < 1e-12,
        "{}: penalty stiffness {} N/m, expected {}",
        a.name,
        r.kc,
        a.kc
    );
    // Past grazing: the linear resonance would reach beyond the gap, and the exact orbit at
    // the largest first harmonic is in contact.
    let top = (0..a.checks.len())
        .max_by(|&x, &y| a.checks[x].q1.total_cmp(&a.checks[y].q1))
        .unwrap();
    assert!(a.linear_peak_over_gap > 1.0 && !a.checks[top].orbit.flow.events.is_empty());
    let (wp, qp) = reported_peak(r);
    let (dq, dw) = ((qp / a.peak.1 - 1.0).abs(), (wp / a.peak.0 - 1.0).abs());
    assert!(
        dq <= PEAK_AMPLITUDE && dw <= PEAK_OMEGA,
        "{}: peak q1 {qp} at W {wp} rad/s, exact {} at {}: {dq:.2e}, {dw:.2e}",
        a.name,
        a.peak.1,
        a.peak.0
    );
    assert_folds(a);
    let passed = a.checks.iter().filter(|c| c.how != How::Missed).count();
    let share = passed as f64 / a.checks.len() as f64;
    assert!(
        share >= POINT_SHARE,
        "{}: {passed} of {} points within {POINT_AMPLITUDE} of the exact curve ({share:.4})",
        a.name,
        a.checks.len()
    );
}

/// The reported folds (frf.json's, refined, and the points frf.csv marks) against the exact
/// ones: as many, each reported within `FOLD_OMEGA` of an exact fold of its kind, and each
/// exact fold so reported.
fn assert_folds(a: &Analysis) {
    let r = &a.reported;
    let kinds = |folds: Vec<&str>| {
        let mut k: Vec<String> = folds.into_iter().map(String::from).collect();
        k.sort();
        k
    };
    assert_eq!(
        kinds(r.folds.iter().map(|f| f.2.as_str()).collect()),
        kinds(a.folds.iter().map(|f| f.kind).collect()),
        "{}: reported folds {:?}, exact {:?}",
        a.name,
        r.folds,
        a.folds
    );
    let marked: Vec<usize> = (0..r.csv_fold.len())
        .filter(|&i| !r.csv_fold[i].is_empty())
        .collect();
    assert_eq!(marked.len(), r.folds.len(), "{}: frf.csv's fold column", a.name);
    for &i in &marked {
        assert!(r.folds.iter().any(|f| f.0 == i && f.2 == r.csv_fold[i]));
    }
    for (point, w, kind) in &r.folds {
        for at in [*w, r.omega[*point]] {
            let (_, d) = nearest_fold(&a.folds, kind, at).expect("an exact fold of the kind");
            assert!(d <= FOLD_OMEGA, "{}: reported fold {kind} at W = {at}: {d:.2e}", a.name);
        }
    }
    for f in &a.folds {
        let reported = r
            .folds
            .iter()
            .any(|(_, w, kind)| kind == f.kind && (w / f.omega - 1.0).abs() <= FOLD_OMEGA);
        assert!(reported, "{}: exact fold {f:?} not reported", a.name);
    }
}

#[test]
fn the_issues_one_dof_oscillator_at_one_percent_meets_its_exact_orbits() {
    let a = analysis(one_dof);
    report(&a);
    assert_acceptance(&a);
}

#[test]
fn the_chain_at_half_a_percent_five_times_past_grazing_meets_its_exact_orbits() {
    let a = analysis(chain);
    report(&a);
    assert_acceptance(&a);
}

/// For every point (W_b, q_b) of frf_boundary.csv, the oracle's orbits at W_b shot from the
/// exact orbits of the five reported points nearest to it in (W, q1), the one closest in q1:
/// the largest relative difference in q1 over the points.
fn boundary_agreement(a: &Analysis) -> f64 {
    let (r, exact) = (&a.reported, a.exact());
    let mut worst = 0.0_f64;
    for &(wb, qb, _) in &r.boundary {
        let d = |i: usize| (r.omega[i] / wb - 1.0).abs() + (r.q1[i] / qb - 1.0).abs();
        let j = (0..r.omega.len()).min_by(|&x, &y| d(x).total_cmp(&d(y))).unwrap();
        let (lo, hi) = (j.saturating_sub(2), (j + 2).min(r.omega.len() - 1));
        let best = (lo..=hi)
            .filter_map(|i| pwl::periodic_at(&a.sys, wb, &a.checks[i].orbit.z0, ORBIT_TOL))
            .map(|o| (exact.q1(&o) / qb - 1.0).abs())
            .fold(f64::INFINITY, f64::min);
        worst = worst.max(best);
    }
    worst
}

/// The program's exact curve (frf_boundary.csv: shooting on the massless contact boundary,
/// which for a penalty law on a model whose modes are all resolved is the penalty equation
/// itself) against the oracle: every point on the oracle's curve, and at each fold: as many
/// folds, each marked point (the first after W turned, not refined) within BOUNDARY_FOLD of the
/// oracle's fold, and no point of the program's curve near it beyond the oracle's fold in W
/// (the fold is W's extremum on the exact curve).
fn assert_boundary_agrees(a: &Analysis) {
    let r = &a.reported;
    assert!(!r.boundary.is_empty(), "{}: no frf_boundary.csv", a.name);
    let worst = boundary_agreement(a);
    let marked: Vec<usize> = (0..r.boundary.len()).filter(|&i| r.boundary[i].2).collect();
    println!(
        "{}: {} points of frf_boundary.csv, largest difference in q1 from the oracle's orbits \
         {worst:.2e}; folds marked at W/w1 {:?}",
        a.name,
        r.boundary.len(),
        marked
            .iter()
            .map(|&i| r.boundary[i].0 / a.w1)
            .collect::<Vec<_>>()
    );
    assert!(worst <= BOUNDARY_POINT, "{}: {worst:.2e}", a.name);
    assert_eq!(marked.len(), a.folds.len(), "{}: folds of frf_boundary.csv", a.name);
    for f in &a.folds {
        let (i, d) = marked
            .iter()
            .map(|&i| (i, (r.boundary[i].0 / f.omega - 1.0).abs()))
            .min_by(|x, y| x.1.total_cmp(&y.1))
            .unwrap();
        let sign = if f.kind == "TurnsBack" { 1.0 } else { -1.0 };
        let (lo, hi) = (i.saturating_sub(3), (i + 3).min(r.boundary.len() - 1));
        let beyond = (lo..=hi)
            .map(|k| sign * (r.boundary[k].0 / f.omega - 1.0))
            .fold(f64::NEG_INFINITY, f64::max);
        println!(
            "  oracle fold {} at W/w1 {:.7}: marked point {:.7} ({d:.2e}), farthest neighbour \
             {beyond:.2e} beyond it",
            f.kind,
            f.omega / a.w1,
            r.boundary[i].0 / a.w1
        );
        assert!(d <= BOUNDARY_FOLD && beyond <= 1e-9, "{}: {f:?}", a.name);
    }
}

/// Bounds of the cross-check of the oracle with the program's exact curve: a point's first
/// harmonic (relative), a marked fold's W (relative).
const BOUNDARY_POINT: f64 = 1e-6;
const BOUNDARY_FOLD: f64 = 1e-4;

#[test]
fn the_oracle_and_the_programs_exact_curve_agree_through_the_folds() {
    for spec in [one_dof as fn() -> Spec, chain] {
        assert_boundary_agrees(&analysis(spec));
    }
}
