//! A 1:3 internal-resonance tongue is followed as its own branch, and its frequency locks to a
//! third of the second mode's frequency (issue 12, "Tongues"; docs/DESIGN.md §8.3).
//!
//! System: two unit masses, a spring k1 = 1 from the wall to mass 1 and k2 = 1.7 between the
//! masses (K = [[2.7, -1.7], [-1.7, 1.7]], M = I), one penalty contact row (gap g = 1) on one
//! mass, which is also the master. Linear frequencies w1 = 0.654214, w2 = 1.992989:
//! w2 / w1 = 3.0464. Mass-normalized modes phi1 = (0.599, 0.801), phi2 = (0.801, -0.599). Mode 1
//! grazes and then stiffens (3 w / w2 from 0.985 to 1.063 at q = 10 g with kc = 0.3 on mass 2),
//! so 3 w crosses w2 at w = 1.0155 w1: a 1:3 internal resonance, where the contact force's third
//! harmonic drives mode 2. Three tests:
//! * kc = 0.3 on mass 2; with the contact closed for good (K + kc A^T A) mode 2 would be at
//!   w2c = w2 (1 + 1.42e-2);
//! * kc = 3 on mass 2 (w2c = w2 (1 + 0.195));
//! * kc = 0.3 on mass 1 (w2c = w2 (1 + 2.46e-2)), where mode 2 moves the contact row more
//!   (|a2| = 0.801 against 0.599 on mass 2): mode 2 grazes at a smaller modal amplitude
//!   (eta = 1.249 against 1.669) and the tongue takes it well into its own contact regime.
//!
//! Which w_k the tongue locks to. Along the tongue the energy flows into mode 2 at harmonic 3,
//! and the tongue ends (q -> 0) on mode 2's own branch, seen as a period-3 orbit. The contact
//! changes mode 2 too, so w_k is neither the linear w2 nor a linearization with the contact
//! closed, but the frequency Omega2(eta) of mode 2's own nonlinear mode at the tongue's
//! amplitude of that mode: eta = |phi2^T M u_3|, the modal amplitude of (mass-normalized) mode 2
//! at harmonic 3, and Omega2 is solved independently (the solver on mode 2 alone, N = 60, with a
//! secant on its master amplitude until its own first-harmonic modal amplitude is eta). The claim
//! is 3 w = Omega2(eta) up to the coupling of the mode-1 motion still in the tongue orbit.
//!
//! Tolerance (derived, not fitted). Project the harmonic balance on mass-normalized mode 2
//! (a2 = A phi2; the contact force on the structure is -A^T lambda, lambda = kc (g)_+):
//! (9 w^2 - w2^2) eta = a2 lambda_3 for the tongue, (Omega2^2 - w2^2) eta = a2 Lambda_1 for
//! mode 2's own orbit (in the time 3 w t). Where the two orbits' mode-2 motions agree, their gaps
//! differ by the tongue's mode-1 motion a1 y1(t) (a1 = A phi1), so the forces differ by at most
//! kc |a1| max|y1|, and only while one of them is in contact (time fractions f_t and f_2); a
//! cosine coefficient of the difference is at most twice its mean. Hence
//! |3 w / Omega2 - 1| <= D = kc |a1 a2| max|y1| (f_t + f_2) / (Omega2^2 eta).
//! Neglected: the difference of the mode-2 motions themselves (the tongue's mode 2 is not
//! exactly mode 2's own orbit while mode 1 still acts on it), and the truncation (Omega2 with
//! N = 12, the resolution of mode 2 in the N = 36 tongue, differs from N = 60 by at most 1.2e-6
//! on these tongues, 12 times below the smallest D). D is large where the tongue leaves the main
//! branch (mode 1 still holds about half the energy and dominates the contact motion) and small
//! where the tongue ends on mode 2's branch. The continuation's last tongue point is at
//! q = 0.03-0.06 g; the tongue is followed further toward q = 0 by fixed-q solves (halving q,
//! down to q <= 0.005 g), where D is smaller still.
//!
//! Measured (N = 36, m = 384; the three tests take 0.8-1.3 s in release on 2 shared cores):
//! * kc = 0.3, mass 2: tongue detected at q = 1.518 (mode 2 at harmonic 3 holds 0.59 of the
//!   energy, 3 w / w2 - 1 = +1.6e-3), followed for 24 points down to q = 0.034 (mode-1 share
//!   1e-4), where it leaves the amplitude range. 3 w / Omega2 - 1 from +2.4e-3 (q = 1.47) to
//!   +1.0e-5 (last), D from 3.4e-2 to 1.4e-4, at most 0.28 D. Omega2 / w2 - 1 <= 1.5e-4: the
//!   tongue ends at eta = 1.729, just past mode 2's own grazing. At q = 0.0042: 2.2e-7
//!   (D = 1.6e-5), Omega2 / w2 - 1 = 2.8e-5.
//! * kc = 3, mass 2: detected at q = 1.218 (share 0.50, +2.6e-3), 21 points down to q = 0.036;
//!   3 w / Omega2 - 1 from +3.2e-3 to +6.7e-5, at most 0.21 D; the tongue ends at eta = 1.659,
//!   below mode 2's grazing, so Omega2 = w2 along it. At q = 0.0044: 7.2e-6 (D = 3.2e-5).
//! * kc = 0.3, mass 1: detected at q = 2.161 (share 0.50, +7.0e-3), 35 points down to q = 0.059;
//!   3 w / Omega2 - 1 from +7.2e-3 to +2.6e-5, at most 0.14 D; Omega2 / w2 - 1 up to 2.1e-3
//!   along the tongue. At q = 0.0037 (eta = 1.355): 3 w / Omega2 - 1 = -2.1e-7 (D = 5.8e-5)
//!   while 3 w / w2 - 1 = +3.1e-4: there the tongue locks to mode 2's nonlinear frequency, and the
//!   linear w2 is rejected (the test asserts |3 w / w2 - 1| > D there).
//!
//! On the mass-2 systems the honest w_k is within 1.5e-4 of the linear w2 along the continuation's
//! points, and the bound cannot tell them apart there; at the tongue's end with kc = 0.3 the
//! linear w2 falls outside D too (2.8e-5 > 1.6e-5, a replaced w_k fails the test), but with a
//! margin of 1.7 only, so the separation is asserted on mass 1 alone.
//!
//! Every tongue orbit is also checked by time integration (`check_periodicity`, RK4, 40 000 steps
//! per period): tolerances 2e-4 (displacement, relative to max |u(0)|) and 2e-3 (velocity,
//! relative to w max |u(0)|), as in tests/fold.rs. Measured maxima over the tongues: du 1.7e-6,
//! 4.1e-5, 5.6e-7 and dv 2.7e-5, 1.7e-4, 3.3e-5 (the stiff contact has the largest truncation
//! error; with N = 18 it reached du = 2.05e-4, hence N = 36). With w off by 1e-4 (measured on
//! these orbits) the velocity after one period misses by 3-4e-3: the integration also checks the
//! tongue's frequency independently, to about 1e-4.
//!
//! What it catches: a wrong harmonic (2 w or 4 w against Omega2: 33 % off) or mode, the
//! contact-closed linearization as w_k (rejected from q = 1.28, 1.20 and 1.02 on), the linear w2
//! where mode 2's own stiffening matters (the tongue's end, kc = 0.3), a tongue that drifts with
//! amplitude instead of locking (as the main branch does), a tongue not on the output as its
//! own branch with the main branch as parent, a tongue that does not return to mode 2's branch,
//! a main branch that stops at the tongue or hops past it, and tongue orbits that are not
//! periodic solutions.
//!
//! * kc = 3 on mass 1: the tongue is entered by a fold of q while mode 1 still holds most of the
//!   energy; it is followed while q falls and mode 1's share shrinks (before that rule the
//!   continuation left it after 2 points, "left the resonance", and this test failed there).
//!   Measured: largest |3 w / Omega2 - 1| / D = 0.26, RK4 du = 2.2e-5, dv = 2.1e-4.
//!
//! Not covered: the rigid stop (augmented Lagrangian, Algorithm 1) on the same chain does not
//! give a tongue that can be checked: see `rigid_stop_tongue_study` (ignored) and its doc.

use faer::Mat;
use nlmodes_nnm::{
    backbone, check_periodicity, AlgorithmParams, Backbone, BackbonePoint, BranchKind,
    ContactMethod, ContinuationSettings, HarmonicSettings, Passage, Solver, Start, System,
    Termination,
};

/// Coupling spring between the two masses (the wall spring is 1).
const K2: f64 = 1.7;
/// The second linear mode (0-based) and the harmonic of the tongue.
const MODE_2: usize = 1;
const HARMONIC: usize = 3;

/// The 2-DOF chain with the contact row on mass `contact` (0-based, gap 1), master `master`, and
/// extra stiffness `closed` on the contact row's DOF (0: the system; kc: the contact closed for
/// good).
fn chain_with_contact(contact: usize, master: usize, closed: f64) -> System {
    let m = Mat::from_fn(2, 2, |i, j| if i == j { 1.0 } else { 0.0 });
    let mut k = [[1.0 + K2, -K2], [-K2, K2]];
    k[contact][contact] += closed;
    let kk = Mat::from_fn(2, 2, |i, j| k[i][j]);
    let a = Mat::from_fn(1, 2, |_, c| if c == contact { 1.0 } else { 0.0 });
    System::new(m, kk, a, vec![1.0], master).expect("valid 2-DOF chain")
}

fn penalty(kc: f64) -> AlgorithmParams {
    AlgorithmParams {
        method: ContactMethod::Penalty { stiffness: kc },
        ..AlgorithmParams::default()
    }
}

/// Modal amplitude phi_k^T M u of mass-normalized linear mode `mode` in coefficient vector `u`.
fn modal_amplitude(sys: &System, mode: usize, u: &[f64]) -> f64 {
    let phi = sys.linear_mode(mode).expect("mode");
    let m = sys.mass();
    let n = u.len();
    (0..n)
        .map(|i| phi[i] * (0..n).map(|j| m[(i, j)] * u[j]).sum::<f64>())
        .sum()
}

/// max over the period of |y_k(t)|, y_k the modal coordinate of mode `mode` (4096 samples).
fn modal_peak(sys: &System, mode: usize, p: &BackbonePoint) -> f64 {
    let coef: Vec<f64> = p
        .coefficients
        .iter()
        .map(|u| modal_amplitude(sys, mode, u))
        .collect();
    let n = 4096;
    (0..n)
        .map(|i| {
            let phase = 2.0 * std::f64::consts::PI * i as f64 / n as f64;
            nlmodes_nnm::cosine_series(&coef, phase).abs()
        })
        .fold(0.0, f64::max)
}

/// Mode 2's own nonlinear mode at first-harmonic modal amplitude `eta` (secant on its master
/// amplitude to 1e-12 relative, warm-started from `warm` or from the linear mode).
fn mode2_at(
    solver: &mut Solver<'_>,
    sys: &System,
    eta: f64,
    warm: Option<&BackbonePoint>,
) -> BackbonePoint {
    let q0 = eta * sys.linear_mode(MODE_2).expect("mode 2")[sys.master()];
    let start = warm.map_or(Start::LinearMode(MODE_2), Start::Point);
    let amplitude = |p: &BackbonePoint| modal_amplitude(sys, MODE_2, &p.coefficients[1]);
    let mut p0 = solver.solve_point(q0, start).expect("mode 2 start");
    let mut e0 = amplitude(&p0);
    let mut p1 = solver
        .solve_point(p0.q * eta / e0, Start::Point(&p0))
        .expect("mode 2 second point");
    let mut e1 = amplitude(&p1);
    for _ in 0..40 {
        if (e1 - eta).abs() <= 1e-12 * eta || e1 == e0 {
            break;
        }
        let q = p1.q + (eta - e1) * (p1.q - p0.q) / (e1 - e0);
        let next = solver.solve_point(q, Start::Point(&p1)).expect("secant");
        (p0, e0) = (p1, e1);
        e1 = amplitude(&next);
        p1 = next;
    }
    assert!((e1 - eta).abs() <= 1e-10 * eta, "secant: {e1} vs {eta}");
    // Mode 2's own orbit, not another branch: (mode 2, harmonic 1) holds nearly all the energy.
    assert!(
        p1.mode == MODE_2 && p1.primary_share > 0.99,
        "{}",
        p1.primary_share
    );
    p1
}

#[test]
fn one_to_three_tongue_locks_to_a_third_of_mode_2_soft_penalty() {
    tongue_locks(0.3, 1, false);
}

#[test]
fn one_to_three_tongue_locks_to_a_third_of_mode_2_stiff_penalty() {
    tongue_locks(3.0, 1, false);
}

#[test]
fn one_to_three_tongue_locks_to_mode_2_nonlinear_frequency() {
    tongue_locks(0.3, 0, true);
}

/// kc = 3 on mass 1: the tongue is entered by a fold of q while mode 1 still holds most of the
/// energy (the shares show the resonance only later), and is followed while q falls and mode 1's
/// share shrinks (docs/DESIGN.md §8.3); before, it was left after 2 points.
#[test]
fn one_to_three_tongue_entered_by_a_fold_is_followed_and_locks() {
    tongue_locks(3.0, 0, false);
}

/// The whole check with penalty stiffness `kc` on mass `contact` (0-based, also the master; see
/// the module doc); `separates_w2`: the tongue's end must also be told apart from the linear w2 / 3.
fn tongue_locks(kc: f64, contact: usize, separates_w2: bool) {
    let sys = chain_with_contact(contact, contact, 0.0);
    let w = sys.linear_frequencies();
    let w2_closed = chain_with_contact(contact, contact, kc).linear_frequencies()[MODE_2];
    // N = 36 harmonics of w resolve mode 2 at 3 w with 12; m = 384 = 3 x 128 samples.
    let settings = HarmonicSettings::new(36, 384).expect("settings");
    let cont = ContinuationSettings {
        q_start: 0.5,
        q_max: 10.0,
        step: 0.05,
        max_step: 0.1,
        max_points: 400,
        tongue_points: 60,
        ..ContinuationSettings::default()
    };
    let b = backbone(&sys, settings, penalty(kc), &cont, |_| {}).expect("backbone");
    println!(
        "kc = {kc}: w2/w1 = {:.5}, w2c/w2 - 1 = {:.3e}; termination {:?}; {} points",
        w[1] / w[0],
        w2_closed / w[1] - 1.0,
        b.termination,
        b.points.len()
    );
    println!("{:?}\n{:?}", b.internal_resonances, b.branches);
    let pts = tongue_branch(&b, cont.q_max);
    check_locking(&sys, kc, &pts, w[1], w2_closed);
    check_tongue_end(&sys, kc, settings, pts[pts.len() - 1], separates_w2);

    // Every tongue orbit is a periodic solution of the penalty system (RK4 over one period,
    // independent of harmonic balance); see the module doc for the tolerances.
    let (mut du, mut dv) = (0.0_f64, 0.0_f64);
    for p in &pts {
        let chk = check_periodicity(&sys, &[kc], p, 40_000).expect("integration");
        du = du.max(chk.displacement_error);
        dv = dv.max(chk.velocity_error);
    }
    println!("largest periodicity errors over the tongue: du = {du:.2e}, dv = {dv:.2e}");
    assert!(du <= 2e-4 && dv <= 2e-3, "du = {du:.2e}, dv = {dv:.2e}");
}

/// The 3:1 tongue with mode 2 is detected, followed as its own branch off the main branch, and
/// the main branch is continued past it by a predictor (no fixed-q hop) up to `q_max`. Returns
/// the tongue's points.
fn tongue_branch(b: &Backbone, q_max: f64) -> Vec<&BackbonePoint> {
    let res = b
        .internal_resonances
        .iter()
        .find(|r| (r.mode, r.harmonic) == (MODE_2, HARMONIC))
        .expect("the 1:3 resonance with mode 2 is detected");
    assert!(res.detuning.abs() < 0.02, "{res:?}");
    assert_eq!(res.passed, Some(Passage::Predictor), "{res:?}");
    let id = res.branch.expect("the tongue is followed");
    let tongue = &b.branches[id];
    assert_eq!(
        tongue.kind,
        BranchKind::Tongue {
            mode: MODE_2,
            harmonic: HARMONIC
        }
    );
    let main = tongue.parent.expect("the tongue has a parent");
    assert_eq!(b.branches[main].kind, BranchKind::Main);
    let pts: Vec<&BackbonePoint> = b.points.iter().filter(|p| p.branch == id).collect();
    assert!(pts.len() >= 10, "{} tongue points", pts.len());
    let q_tongue = pts.iter().map(|p| p.q).fold(0.0, f64::max);
    assert_eq!(b.termination, Termination::ReachedMaxAmplitude);
    let last_main = b
        .points
        .iter()
        .rev()
        .find(|p| p.branch == main)
        .expect("main points");
    assert!(last_main.q >= q_max * (1.0 - 1e-9) && last_main.q > q_tongue);
    let first_tongue = b
        .points
        .iter()
        .position(|p| p.branch == id)
        .expect("tongue");
    assert!(
        b.points[first_tongue..]
            .iter()
            .any(|p| p.branch == main && p.q > q_tongue && !p.jump),
        "the main branch goes on past the tongue"
    );
    pts
}

/// The independent reference of the locking: mode 2's own nonlinear mode (N = 60), and the
/// coupling bound D of the module doc.
struct ModeTwoReference<'s> {
    sys: &'s System,
    kc: f64,
    solver: Solver<'s>,
    /// |a1 a2|, a_k = A phi_k the contact displacement of mass-normalized mode k.
    a1a2: f64,
    /// The last reference orbit (warm start of the next).
    warm: Option<BackbonePoint>,
}

/// A tongue point against mode 2's own orbit at the same modal amplitude.
struct Locking {
    /// Modal amplitude of mode 2 at harmonic 3 in the tongue orbit.
    eta: f64,
    /// Omega2(eta) (rad/s).
    omega2: f64,
    /// 3 w / Omega2 - 1.
    detuning: f64,
    /// D.
    bound: f64,
}

impl<'s> ModeTwoReference<'s> {
    fn new(sys: &'s System, kc: f64) -> Self {
        let fine = HarmonicSettings::with_default_samples(60).expect("settings");
        let a = |mode: usize| {
            let phi = sys.linear_mode(mode).expect("mode");
            (0..sys.n_dofs())
                .map(|i| sys.contact_rows()[(0, i)] * phi[i])
                .sum::<f64>()
        };
        Self {
            sys,
            kc,
            solver: Solver::new(sys, fine, penalty(kc)).expect("solver"),
            a1a2: (a(0) * a(MODE_2)).abs(),
            warm: None,
        }
    }

    fn at(&mut self, p: &BackbonePoint) -> Locking {
        let eta = modal_amplitude(self.sys, MODE_2, &p.coefficients[HARMONIC]).abs();
        let own = mode2_at(&mut self.solver, self.sys, eta, self.warm.as_ref());
        // The two contact forces differ only where one of the orbits is in contact.
        let in_contact = p.contact_fraction[0] + own.contact_fraction[0];
        let bound = self.kc * self.a1a2 * modal_peak(self.sys, 0, p) * in_contact
            / (own.omega.powi(2) * eta);
        let locking = Locking {
            eta,
            omega2: own.omega,
            detuning: HARMONIC as f64 * p.omega / own.omega - 1.0,
            bound,
        };
        self.warm = Some(own);
        locking
    }
}

/// Along the tongue, |3 w / Omega2(eta) - 1| <= D (see the module doc) at every point; the
/// tongue returns to q -> 0 on mode 2's own branch, where the mode-1 content vanishes.
fn check_locking(sys: &System, kc: f64, pts: &[&BackbonePoint], w2: f64, w2_closed: f64) {
    let mut reference = ModeTwoReference::new(sys, kc);
    let mut worst: f64 = 0.0;
    for p in pts {
        let l = reference.at(p);
        println!(
            "q {:.4} mode-1 share {:.4} eta {:.4}: 3w/w2 - 1 = {:+.3e}, Omega2/w2 - 1 = {:+.3e}, \
             3w/Omega2 - 1 = {:+.3e} (bound D = {:.3e}), 3w/w2c - 1 = {:+.3e}",
            p.q,
            p.primary_share,
            l.eta,
            HARMONIC as f64 * p.omega / w2 - 1.0,
            l.omega2 / w2 - 1.0,
            l.detuning,
            l.bound,
            HARMONIC as f64 * p.omega / w2_closed - 1.0
        );
        assert!(l.detuning.abs() <= l.bound, "not locked at q = {}", p.q);
        worst = worst.max(l.detuning.abs() / l.bound);
    }
    println!("largest |3w/Omega2 - 1| / D = {worst:.3}");
    // The tongue ends on mode 2's own branch (q -> 0, mode 1's share -> 0).
    let last = pts[pts.len() - 1];
    assert!(last.q < 0.1 && last.primary_share < 1e-3, "{:?}", last.q);
}

/// The tongue's end, closer to q = 0 than the continuation's last point: fixed-q solves from it,
/// halving q down to q <= 0.005 g. There D is small, and the tongue must lock to Omega2(eta)
/// there too; with `separates_w2` (mode 2 well into its own contact regime) the linear w2 must be
/// outside the band: |3 w / w2 - 1| > D.
fn check_tongue_end(
    sys: &System,
    kc: f64,
    settings: HarmonicSettings,
    last: &BackbonePoint,
    separates_w2: bool,
) {
    let mut solver = Solver::new(sys, settings, penalty(kc)).expect("solver");
    let mut p = last.clone();
    while p.q > 0.005 {
        p = solver
            .solve_point(0.5 * p.q, Start::Point(&p))
            .expect("tongue toward q = 0");
        assert!(
            (p.secondary_mode, p.secondary_harmonic) == (MODE_2, HARMONIC)
                && p.secondary_share > 0.99,
            "left the tongue at q = {}",
            p.q
        );
    }
    let l = ModeTwoReference::new(sys, kc).at(&p);
    let w2 = sys.linear_frequencies()[MODE_2];
    let linear = HARMONIC as f64 * p.omega / w2 - 1.0;
    println!(
        "tongue end q = {:.5}, mode-1 share {:.2e}, eta {:.4}: 3w/Omega2 - 1 = {:+.3e} (D = {:.3e}), \
         Omega2/w2 - 1 = {:+.3e}, 3w/w2 - 1 = {:+.3e}",
        p.q,
        p.primary_share,
        l.eta,
        l.detuning,
        l.bound,
        l.omega2 / w2 - 1.0,
        linear
    );
    assert!(
        l.detuning.abs() <= l.bound,
        "not locked at the tongue's end"
    );
    if separates_w2 {
        assert!(linear.abs() > l.bound, "w2 not separated from Omega2");
    }
}

/// Study of the rigid stop (augmented Lagrangian, Algorithm 1) on the same chain (not a check:
/// run with `-- --ignored --nocapture`). Same continuation settings, N = 18, m = 192. Seen
/// (2026-11-24, this branch):
/// * stop on mass 2 (the system above), epsilon = 1e-3 g0: the main branch leaves grazing at
///   w = 1.01 w1 with mode 2 at harmonic 3 already at 17 % of the energy and ends with
///   `StepTooSmall` at q = 1.1676 (w = 1.01095 w1, 3 w / w2 = 0.9956): Newton stagnates
///   (relative residual 2e-3). The same with N = 40, m = 512, epsilon = 1e-6, and with
///   step = 0.01, max_step = 0.02.
/// * the same with epsilon = 1e-4 g0: the tongue is entered by a fold of q at q = 1.1673 (w =
///   1.01678 w1, 3 w / w2 - 1 = +1.3e-3, mode 2's share 0.36 < mode 1's), followed for 2 points
///   before tongues entered by a fold were followed while q falls (37 points in all now, 26
///   before), and no predictor gets past it: `Termination::InternalResonance`.
/// * stop on mass 1, master mass 1: reaches q_max; the (mode 2, harmonic 3) tongue is entered by a
///   fold at q = 1.164 (w = 1.01712 w1, 3 w / w2 - 1 = +1.6e-3), 2 points with mode 2's share
///   0.12-0.15, and the main branch resumes at q = 1.393, w = 1.197 w1 (nothing in between).
/// * stop on mass 1, master mass 2: the same tongue at q = 1.574 (2 points, share 0.13-0.14), the
///   main branch resumes at q = 2.825, w = 1.230 w1; then two more "tongues" were recorded as
///   (mode 0, harmonic 0), detuning -1, at q = 4.68 and 5.26: steps accepted at the smallest step
///   as jumps (w from 1.2990 to 1.3543 w1 at q 4.708 -> 4.681) that lower q, read as folds into a
///   tongue whose largest secondary share is the mean (harmonic 0) of mode 1 itself. Since such
///   steps are corners (docs/DESIGN.md §8.3) the run passes two corners (q = 4.95 and 7.01) and
///   reaches q_max with no false tongue.
///
/// With stiffer coupling (k2 = 2.0 to 2.8, w2 / w1 = 3.23 to 3.67, stop on mass 1) the tongue is
/// entered 2.8-6.5 % away from 3 w = w2 and followed for 2-4 points, some flagged as jumps; with
/// the stop on mass 2, k2 = 2.0 ends with `StepTooSmall` at q = 1.26 and k2 = 2.3 enters the
/// tongue at 3 w / w2 = 0.976 and is not passed. None gives a tongue along which a locking could
/// be checked, hence no assertion here.
#[test]
#[ignore = "study of the rigid-stop tongue, printed (a few seconds)"]
fn rigid_stop_tongue_study() {
    let settings = HarmonicSettings::new(18, 192).expect("settings");
    let cont = ContinuationSettings {
        q_start: 0.5,
        q_max: 10.0,
        step: 0.05,
        max_step: 0.1,
        max_points: 600,
        tongue_points: 60,
        ..ContinuationSettings::default()
    };
    for (contact, master, epsilon) in [(1, 1, 1e-3), (1, 1, 1e-4), (0, 0, 1e-3), (0, 1, 1e-3)] {
        let sys = chain_with_contact(contact, master, 0.0);
        let w2 = sys.linear_frequencies()[MODE_2];
        let params = AlgorithmParams {
            epsilon,
            ..AlgorithmParams::default()
        };
        let b = backbone(&sys, settings, params, &cont, |_| {}).expect("backbone");
        println!(
            "stop on mass {}, master {}, epsilon {epsilon:e}: {:?}, {} points",
            contact + 1,
            master + 1,
            b.termination,
            b.points.len()
        );
        for r in &b.internal_resonances {
            println!("  {r:?}");
        }
        for (i, p) in b.points.iter().enumerate() {
            let near_tongue = p.branch > 1 || b.points.get(i + 1).is_some_and(|n| n.branch > 1);
            if near_tongue || (p.branch == 1 && i % 10 == 0) {
                println!(
                    "  {i:4} branch {} q {:.5} w/w1 {:.6} 3w/w2 {:.6} shares {:.3} / ({}, {}) {:.3} fold {} jump {}",
                    p.branch,
                    p.q,
                    p.omega_ratio,
                    HARMONIC as f64 * p.omega / w2,
                    p.primary_share,
                    p.secondary_mode,
                    p.secondary_harmonic,
                    p.secondary_share,
                    p.fold,
                    p.jump
                );
            }
        }
    }
}
