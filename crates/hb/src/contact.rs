//! The sampled contact law and Powell's measure (Eqs. 13-16, 21).
//!
//! At each contact row j and time sample k the augmented-Lagrangian force is
//! lambda_{j,k} = kappa_{j,k} max(0, g_j(t_k) + theta_{j,k}) (the integrand of Eq. 15), with
//! theta in length units and kappa in force per length, so that kappa * theta is the Lagrange
//! multiplier estimate (Eq. 13). Its generalized derivative with respect to the gap is kappa on
//! active samples (g + theta > 0) and 0 elsewhere: that is what the semi-smooth Newton uses.

use serde::{Deserialize, Serialize};

/// Augmented-Lagrangian variables, one per contact row j and time sample k (row-major, j * m + k).
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Multipliers {
    /// Samples per period m.
    pub samples: usize,
    /// theta_{j,k}: multiplier estimate divided by the penalty (length units, >= 0).
    pub theta: Vec<f64>,
    /// kappa_{j,k}: penalty parameters (force per length, > 0).
    pub kappa: Vec<f64>,
}

impl Multipliers {
    /// theta = 0 and kappa_{j,k} = `kappa[j]` for every sample.
    pub fn uniform(kappa: &[f64], samples: usize) -> Self {
        let c = kappa.len();
        let mut k = Vec::with_capacity(c * samples);
        for &v in kappa {
            k.extend(std::iter::repeat_n(v, samples));
        }
        Self {
            samples,
            theta: vec![0.0; c * samples],
            kappa: k,
        }
    }

    /// Number of contact rows.
    pub fn rows(&self) -> usize {
        self.theta.len().checked_div(self.samples).unwrap_or(0)
    }
}

/// Contact force samples lambda = kappa (g + theta)_+ and their slopes d lambda / d g.
///
/// With `smoothing` mu > 0 the positive part is replaced by the smooth
/// phi_mu(s) = (s + sqrt(s^2 + 4 mu^2)) / 2 (Chen-Harker-Kanzow-Smale), used only on the way to a
/// solution when the semi-smooth Newton stalls; mu = 0 is the exact law. Slopes below 1e-12 kappa
/// are set to 0 so that far-open samples stay out of the Jacobian.
pub fn apply_contact_law(
    gaps: &[f64],
    multipliers: &Multipliers,
    smoothing: f64,
    lambda: &mut [f64],
    slope: &mut [f64],
) {
    for i in 0..gaps.len() {
        let s = gaps[i] + multipliers.theta[i];
        let k = multipliers.kappa[i];
        if smoothing > 0.0 {
            let r = (s * s + 4.0 * smoothing * smoothing).sqrt();
            lambda[i] = k * 0.5 * (s + r);
            let d = 0.5 * (1.0 + s / r);
            slope[i] = if d > 1e-12 { k * d } else { 0.0 };
        } else if s > 0.0 {
            lambda[i] = k * s;
            slope[i] = k;
        } else {
            lambda[i] = 0.0;
            slope[i] = 0.0;
        }
    }
}

/// Normalized constraint violations v_{j,k} = max(g_{j,k}, -theta_{j,k}) / g0_j (the quantity of
/// Eq. 21 and of the multiplier update Eq. 16, in units of the initial gap).
pub fn violations(gaps: &[f64], theta: &[f64], g0: &[f64], samples: usize, out: &mut [f64]) {
    for (j, &g0j) in g0.iter().enumerate() {
        for k in 0..samples {
            let i = j * samples + k;
            out[i] = gaps[i].max(-theta[i]) / g0j;
        }
    }
}

/// Which reading of Powell's measure, Eq. (21), decides convergence.
///
/// With v_{j,k} = max(g_{j,k}, -theta_{j,k}) / g0_j:
/// * `Entrywise` (default): G = max_{j,k} |v_{j,k}|, Powell's (1978) and Arora et al.'s (1991)
///   measure, the infinity norm of the same entries the set L of Algorithm 1 tests one by one.
///   G <= epsilon implies both g <= epsilon g0 and, wherever lambda > 0, |g| <= epsilon g0
///   (complementarity).
/// * `RowMaximum`: G = max_j |max_k v_{j,k}| (docs/DESIGN.md §3's literal reading of Eq. 21). Caution: any
///   free sample with theta = 0 has v = max(g, 0) = 0, so max_k v >= 0 and negative entries never
///   count: G can be 0 while lambda > 0 on samples where g << 0 (complementarity violated, a wrong
///   orbit). The `powell_measure` test shows such a case on the 1-DOF rigid stop. Kept for
///   comparison only.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize, Default)]
#[serde(rename_all = "snake_case")]
pub enum PowellMeasure {
    /// max over contact rows and samples of |v|.
    #[default]
    Entrywise,
    /// max over contact rows of |max over samples of v|.
    RowMaximum,
}

/// Powell's measure (Eq. 21, units of g0) of normalized violations `violations` (c x m).
pub fn powell_measure_of(violations: &[f64], samples: usize, kind: PowellMeasure) -> f64 {
    if samples == 0 {
        return 0.0;
    }
    if violations.iter().any(|v| v.is_nan()) {
        // f64::max drops NaN: a NaN gap would otherwise measure 0, i.e. "converged".
        return f64::NAN;
    }
    match kind {
        PowellMeasure::Entrywise => violations.iter().fold(0.0, |a: f64, v| a.max(v.abs())),
        PowellMeasure::RowMaximum => violations
            .chunks(samples)
            .map(|row| row.iter().fold(f64::NEG_INFINITY, |a, &v| a.max(v)).abs())
            .fold(0.0, f64::max),
    }
}

/// Powell's measure of gap samples `gaps` (c x m, row-major) for multipliers `theta` and initial
/// gaps `g0`, Eq. (21) in units of g0.
pub fn powell_measure(
    gaps: &[f64],
    theta: &[f64],
    g0: &[f64],
    samples: usize,
    kind: PowellMeasure,
) -> f64 {
    let mut v = vec![0.0; gaps.len()];
    violations(gaps, theta, g0, samples, &mut v);
    powell_measure_of(&v, samples, kind)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn law_and_measure_on_hand_values() {
        let m = Multipliers {
            samples: 3,
            theta: vec![0.0, 0.5, 0.0],
            kappa: vec![10.0; 3],
        };
        let gaps = [0.2, -0.2, -1.0];
        let (mut l, mut s) = ([0.0; 3], [0.0; 3]);
        apply_contact_law(&gaps, &m, 0.0, &mut l, &mut s);
        assert_eq!(l, [2.0, 3.0, 0.0]);
        assert_eq!(s, [10.0, 10.0, 0.0]);
        // v = [0.2, max(-0.2,-0.5) = -0.2, max(-1, 0) = 0] / g0 (= 2) = [0.1, -0.1, 0]
        let g = powell_measure(&gaps, &m.theta, &[2.0], 3, PowellMeasure::RowMaximum);
        assert!((g - 0.1).abs() < 1e-15);
        // Multipliers too large where the gap is open: theta = [0.8, 0.5, 0],
        // v = [max(-0.6, -0.8), max(-0.2, -0.5), max(-1, 0)] / 2 = [-0.3, -0.1, 0]:
        // row maximum 0 (the violation is invisible), entrywise 0.3.
        let gaps = [-0.6, -0.2, -1.0];
        let theta = [0.8, 0.5, 0.0];
        let g = powell_measure(&gaps, &theta, &[2.0], 3, PowellMeasure::RowMaximum);
        assert_eq!(g, 0.0);
        let g = powell_measure(&gaps, &theta, &[2.0], 3, PowellMeasure::Entrywise);
        assert!((g - 0.3).abs() < 1e-15);
    }
}
