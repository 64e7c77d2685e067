//! A computed nonlinear-mode point and helpers to evaluate its orbit in time.

use serde::Serialize;

use nlmodes_hb::contact::Multipliers;
use nlmodes_hb::fourier::{cosine_series, cosine_series_rate};
use nlmodes_hb::system::System;

/// One point of the backbone: a periodic orbit u(t) = sum_n u_n cos(n w t) at master amplitude q.
///
/// Lengths are in the unit of the system (u, q, gaps), `omega` in rad/s, `energy` in the work unit
/// of K u . u (J for SI matrices).
#[derive(Clone, Debug, Serialize)]
pub struct BackbonePoint {
    /// Linear mode the branch starts from (0-based).
    pub mode: usize,
    /// First-harmonic amplitude of the master coordinate, e_master . u_1 (Sec. 2.6).
    pub q: f64,
    /// Nonlinear circular frequency w (rad/s).
    pub omega: f64,
    /// w / w_lin, w_lin the linear frequency of `mode`.
    pub omega_ratio: f64,
    /// w / (2 pi) (Hz).
    pub frequency_hz: f64,
    /// Conserved energy at t = 0, a turning point (zero velocity): (1/2) u(0)^T K u(0), plus the
    /// penalty-spring energy (1/2) kc (g(0))_+^2 in penalty mode. In augmented-Lagrangian mode the
    /// constraint force does no work at convergence (g <= epsilon g0), so nothing is added.
    pub energy: f64,
    /// Mean over the period of each contact row's gap g_j (negative = open).
    pub mean_gap: Vec<f64>,
    /// Maximum over the period of each contact row's gap (closest approach; > 0 = penetration).
    pub max_gap: Vec<f64>,
    /// Mean of `mean_gap` over the contact rows.
    pub mean_gap_overall: f64,
    /// Maximum of `max_gap` over the contact rows.
    pub max_gap_overall: f64,
    /// max(0, max_gap_overall).
    pub max_penetration: f64,
    /// Share of the time samples with a positive contact force, per contact row.
    pub contact_fraction: Vec<f64>,
    /// Powell's measure G at convergence (Eq. 21, units of g0).
    pub powell_measure: f64,
    /// Accepted iterations of Algorithm 1.
    pub outer_iterations: usize,
    /// Inner solves (accepted or not).
    pub inner_solves: usize,
    /// Newton iterations summed over the inner solves.
    pub newton_iterations: usize,
    /// Turning point of q along the branch (sign change of dq/ds) at this point.
    pub fold: bool,
    /// Accepted at the smallest step although the corrector landed far from the predictor:
    /// possibly a jump to another branch (see `ContinuationSettings::jump_factor`).
    pub jump: bool,
    /// Index of the branch of [`crate::Backbone::branches`] the point belongs to.
    pub branch: usize,
    /// A main-branch point between grazing and the first fold of q, on the stretch where the
    /// branch leaves grazing toward smaller first-harmonic amplitude.
    pub pre_fold: bool,
    /// Highest harmonic's share of the contact-row motion (see `truncation_warning`).
    pub truncation_share: f64,
    /// `truncation_share` exceeds `AlgorithmParams::truncation_warning`: N is too small here.
    pub truncation_warning: bool,
    /// Modal purity: share of the orbit's energy in the starting linear mode at harmonic 1 (see
    /// [`crate::System::modal_shares`]); 1 below grazing, lower as contact spreads the motion.
    pub primary_share: f64,
    /// The linear mode (0-based) holding the largest other share.
    pub secondary_mode: usize,
    /// The harmonic of that largest other share.
    pub secondary_harmonic: usize,
    /// The largest other share; close to `primary_share` or above it in an internal resonance
    /// (`secondary_harmonic` x w close to the frequency of `secondary_mode`).
    pub secondary_share: f64,
    /// Fourier coefficients u_n, n = 0..N, each a full n-vector (physical coordinates).
    pub coefficients: Vec<Vec<f64>>,
    /// Contact force samples lambda_{j,k} at t_k = k T / m, one vector of m per contact row.
    pub contact_force: Vec<Vec<f64>>,
    /// A-posteriori truncation estimate (the point re-solved with 2N harmonics; None when not
    /// computed, see [`crate::truncation_estimate`]).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub truncation: Option<crate::TruncationEstimate>,
    /// The converged orbit at this q: the exact orbit of the massless contact boundary with its
    /// dynamic modes chosen by accuracy (None when not computed, see
    /// [`crate::FloquetAnalysis::converged_orbit`]; docs/STABILITY.md Sec. 9.4).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub converged: Option<crate::ConvergedOrbit>,
    /// Floquet stability by Hill's method ([`crate::analyze_backbone`]; None when not computed).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub stability: Option<crate::Stability>,
    /// A change of stability since the previous point of the same branch.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub bifurcation: Option<crate::Bifurcation>,
    /// Augmented-Lagrangian variables at convergence (warm start of the next point).
    #[serde(skip)]
    pub multipliers: Multipliers,
}

impl BackbonePoint {
    /// Period T = 2 pi / w (s).
    pub fn period(&self) -> f64 {
        2.0 * std::f64::consts::PI / self.omega
    }

    /// Displacement u(t).
    pub fn displacement_at(&self, t: f64) -> Vec<f64> {
        reconstruct(&self.coefficients, self.omega, t)
    }

    /// Velocity du/dt(t).
    pub fn velocity_at(&self, t: f64) -> Vec<f64> {
        velocity(&self.coefficients, self.omega, t)
    }

    /// Displacements at `count` equally spaced times over one period, t_i = i T / count.
    pub fn displacement_over_period(&self, count: usize) -> Vec<Vec<f64>> {
        let t = self.period();
        (0..count)
            .map(|i| self.displacement_at(t * i as f64 / count as f64))
            .collect()
    }

    /// Gaps g_j(t_i) = A_j u(t_i) - g0_j at `count` equally spaced times over one period,
    /// one vector of `count` values per contact row.
    pub fn gap_samples(&self, system: &System, count: usize) -> Vec<Vec<f64>> {
        let nh = self.coefficients.len();
        let c = system.n_contacts();
        let mut out = Vec::with_capacity(c);
        for j in 0..c {
            let coef: Vec<f64> = (0..nh)
                .map(|n| system.contact_displacement(j, &self.coefficients[n]))
                .collect();
            let g0 = system.gaps()[j];
            out.push(
                (0..count)
                    .map(|i| {
                        let phase = 2.0 * std::f64::consts::PI * i as f64 / count as f64;
                        cosine_series(&coef, phase) - g0
                    })
                    .collect(),
            );
        }
        out
    }
}

/// u(t) = sum_n u_n cos(n w t) from coefficient vectors `coefficients[n]`.
pub fn reconstruct(coefficients: &[Vec<f64>], omega: f64, t: f64) -> Vec<f64> {
    let n = coefficients.first().map_or(0, Vec::len);
    let phase = omega * t;
    let mut u = vec![0.0; n];
    for (h, c) in coefficients.iter().enumerate() {
        let f = (h as f64 * phase).cos();
        u.iter_mut().zip(c).for_each(|(ui, ci)| *ui += f * ci);
    }
    u
}

/// du/dt(t) = -sum_n n w u_n sin(n w t).
pub fn velocity(coefficients: &[Vec<f64>], omega: f64, t: f64) -> Vec<f64> {
    let n = coefficients.first().map_or(0, Vec::len);
    let phase = omega * t;
    (0..n)
        .map(|i| {
            let coef: Vec<f64> = coefficients.iter().map(|c| c[i]).collect();
            cosine_series_rate(&coef, omega, phase)
        })
        .collect()
}
