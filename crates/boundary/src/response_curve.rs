//! The exact response curve on the massless contact boundary (docs/STABILITY.md Sec. 9.2;
//! DESIGN §10.6): the model of `driven_model` (the modes up to (N + 1) W at the start of the range
//! dynamic, the others static on the contact rows, a penalty law's spring in series; under a
//! penalty law a model whose modes are all resolved is the penalty equation itself) continued
//! over the range by shooting (`driven_curve`). No harmonic is truncated, every
//! orbit is exact to the shooting tolerance and its multipliers are those of its own exact
//! monodromy: the second method beside the harmonic-balance curve, which shows where N
//! harmonics of the massive model hold and gives a verdict where the harmonic balance cannot.
//!
//! The master's displacement on the boundary is u_m(t) = sum_{k < r} phi_mk q_k(t) +
//! sum_{k >= r} phi_mk (p_k(t) - b_k . lambda(t)) / w_k^2 (p = Phi^T f, b_k the contact rows of
//! mode k): the kept modes, and the discarded modes' static response to the load and the
//! contact forces (`master_row`). Its first harmonic and its largest value come from
//! `MASTER_SAMPLES` instants of the exact flow.

use faer::Mat;

use crate::arc_length::{CurveEnd, CurveSettings};
use crate::driven_curve::trace_driven_curve;
use crate::driven_flow::sample_orbit;
use crate::driven_model::{driven_model, modal_start, DrivenBoundary, DrivenInputs};
use crate::master_row::{MasterRow, MASTER_SAMPLES};
use nlmodes_hb::floquet::{multipliers_of, Verdict};
use nlmodes_hb::HbError;

/// One exact orbit of the boundary's curve.
#[derive(Clone, Debug)]
pub struct BoundaryCurvePoint {
    /// Excitation frequency W (rad/s).
    pub omega: f64,
    /// First-harmonic amplitude of the master (m).
    pub master_amplitude: f64,
    /// Largest |u_master| over the period (m).
    pub master_max: f64,
    /// Largest contact force over the period (N).
    pub max_contact_force: f64,
    /// Largest multiplier modulus of the exact monodromy.
    pub largest_multiplier: f64,
    /// Stable or unstable (the margin plus the Liouville error decide; undetermined inside it).
    pub verdict: Verdict,
    /// W turned between the previous point and this one.
    pub fold: bool,
}

/// The exact response curve of one load level on the boundary.
#[derive(Clone, Debug)]
pub struct BoundaryCurve {
    pub points: Vec<BoundaryCurvePoint>,
    /// Modes kept dynamic.
    pub modes: usize,
    /// Why it ended.
    pub end: CurveEnd,
}

/// The exact curve of the level of `inputs` from the first of the harmonic-balance orbits
/// `orbits` ((coefficients n x (2N + 1), W in rad/s); the first the linear orbit at the start of
/// the range) to W = `end` (rad/s), its modal coordinates scaled by the largest of those orbits';
/// `margin` that of `SampledMonodromy::verdict` (the forced study's `stability_margin`). `None`
/// where the boundary model does not apply (exact contact on a model with every mode resolved)
/// or its first orbit does not converge.
pub fn boundary_curve(
    inputs: &DrivenInputs<'_>,
    orbits: &[(&Mat<f64>, f64)],
    end: f64,
    margin: f64,
) -> Result<Option<BoundaryCurve>, HbError> {
    let Some(&(coefficients, omega)) = orbits.first() else {
        return Ok(None);
    };
    let Some(model) = driven_model(inputs, omega)? else {
        return Ok(None);
    };
    let r = model.omega2.len();
    let norm = |&(c, w): &(&Mat<f64>, f64)| {
        let x = modal_start(inputs.system, c, w, r);
        x[..r].iter().map(|v| v * v).sum::<f64>().sqrt()
    };
    // The modal coordinates' size near the resonance: the largest harmonic-balance orbit's.
    let q_scale = orbits.iter().map(norm).fold(0.0, f64::max);
    if q_scale.is_nan() || q_scale <= 0.0 {
        return Ok(None);
    }
    let start = modal_start(inputs.system, coefficients, omega, r);
    let settings = CurveSettings::new(omega, end);
    let Some(curve) = trace_driven_curve(&model, &start, q_scale, &settings)? else {
        return Ok(None);
    };
    let row = MasterRow::driven(inputs, r);
    let trace: f64 = (0..r).map(|i| model.damping[(i, i)]).sum();
    let points = curve
        .points
        .iter()
        .map(|p| {
            let mut at = model.clone();
            at.omega = p.omega;
            let period = 2.0 * std::f64::consts::PI / p.omega;
            let mono = multipliers_of(p.monodromy.clone(), trace, period)?;
            let (master_amplitude, master_max, max_contact_force) =
                master_measures(&at, &row, &p.start)?;
            Ok(BoundaryCurvePoint {
                omega: p.omega,
                master_amplitude,
                master_max,
                max_contact_force,
                largest_multiplier: mono.largest(),
                verdict: mono.verdict(margin),
                fold: p.fold,
            })
        })
        .collect::<Result<Vec<_>, HbError>>()?;
    Ok(Some(BoundaryCurve {
        points,
        modes: r,
        end: curve.end,
    }))
}

/// (first-harmonic amplitude of the master, its largest |value|, the largest contact force)
/// over the orbit from `start` (module docs).
fn master_measures(
    model: &DrivenBoundary,
    row: &MasterRow,
    start: &[f64],
) -> Result<(f64, f64, f64), HbError> {
    let samples = sample_orbit(model, start, MASTER_SAMPLES)?;
    let (mut a, mut b, mut largest, mut force) = (0.0, 0.0, 0.0_f64, 0.0_f64);
    for s in &samples {
        let u = row.at_time(&s.q, &s.lambda, model.omega, s.time);
        let (sn, cs) = (model.omega * s.time).sin_cos();
        a += u * cs;
        b += u * sn;
        largest = largest.max(u.abs());
        force = s.lambda.iter().fold(force, |f, &l| f.max(l));
    }
    let scale = 2.0 / MASTER_SAMPLES as f64;
    Ok(((a * scale).hypot(b * scale), largest, force))
}

/// The master's amplitude (m) at harmonic `harmonic` of W over the shot orbit `b` of the model
/// `inputs` builds (its `b.modes` kept), from `MASTER_SAMPLES` instants of the exact flow (the
/// kept modes plus the discarded modes' static response, as [`BoundaryCurvePoint`]'s): what
/// `converged_cutoff` compares with the harmonic-balance orbit's.
pub(crate) fn master_amplitude_at(
    inputs: &DrivenInputs<'_>,
    b: &crate::driven_stability::BoundaryMonodromy,
    harmonic: usize,
) -> Result<f64, HbError> {
    let row = MasterRow::driven(inputs, b.modes);
    let samples = sample_orbit(&b.model, &b.start, MASTER_SAMPLES)?;
    let (mut a, mut s) = (0.0, 0.0);
    for x in &samples {
        let u = row.at_time(&x.q, &x.lambda, b.model.omega, x.time);
        let (sn, cs) = (harmonic as f64 * b.model.omega * x.time).sin_cos();
        a += u * cs;
        s += u * sn;
    }
    let scale = 2.0 / MASTER_SAMPLES as f64;
    Ok((a * scale).hypot(s * scale))
}
