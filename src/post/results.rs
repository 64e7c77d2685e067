//! What the post stage, the report and the figures read back from the backbone stage's files
//! (`backbone/backbone.json`, `backbone/kept.json`): a subset of `nlmodes_nnm::BackbonePoint`;
//! the speed sweeps' summaries in [`speed_sweep`].
//!
//! New columns of the backbone (e.g. a branch index or a stability flag) are added here as
//! `#[serde(default)]` fields, so that older files still read.

use anyhow::{Context, Result};
use serde::Deserialize;
use std::path::Path;

pub mod speed_sweep;

/// What post-processing reads of a backbone point: the orbit u(t) = sum_n u_n cos(n w t)
/// (Eq. 10, cosine basis) and its contact samples.
#[derive(Debug, Clone, Deserialize)]
pub struct Orbit {
    /// First-harmonic amplitude of the master coordinate (m).
    pub q: f64,
    /// Circular frequency w (rad/s).
    pub omega: f64,
    /// w / w1.
    pub omega_ratio: f64,
    /// w / (2 pi) (Hz).
    pub frequency_hz: f64,
    /// Share of the period each contact row is in contact.
    pub contact_fraction: Vec<f64>,
    /// Powell's measure G at convergence (Eq. 21, units of g0).
    pub powell_measure: f64,
    pub newton_iterations: usize,
    pub fold: bool,
    pub jump: bool,
    pub truncation_warning: bool,
    /// Energy at the turning point t = 0 (J).
    #[serde(default)]
    pub energy: f64,
    /// Index of the branch in `BackboneFile::branches` (0 in files written before branches).
    #[serde(default)]
    pub branch: usize,
    /// Between grazing and the first fold of q (the branch leaves grazing toward smaller q).
    #[serde(default)]
    pub pre_fold: bool,
    /// Floquet stability (absent when not computed).
    #[serde(default)]
    pub stability: Option<StabilityRecord>,
    /// A change of stability since the previous point of the branch (snake_case kind).
    #[serde(default)]
    pub bifurcation: Option<String>,
    /// The harmonic-truncation estimate (2N re-solve), where it was made.
    #[serde(default)]
    pub truncation: Option<TruncationRecord>,
    /// The converged orbit at this q (main-branch points in contact; docs/STABILITY.md Sec. 9.4).
    #[serde(default)]
    pub converged: Option<nlmodes_nnm::ConvergedOrbit>,
    /// u_n, n = 0..N (reduced coordinates, m).
    pub coefficients: Vec<Vec<f64>>,
    /// lambda_{j,k} (N) at t_k = k T / m, one vector of m samples per contact row.
    pub contact_force: Vec<Vec<f64>>,
}

/// What the report reads of a point's harmonic-truncation estimate (docs/DESIGN.md §8.5).
#[derive(Debug, Clone, Deserialize)]
pub struct TruncationRecord {
    /// Harmonics of the reference solve (2N).
    pub harmonics: usize,
    /// |w(2N) - w(N)| / w(N).
    pub omega_change: f64,
    /// Largest change of a contact row's share of the period in contact.
    pub contact_share_change: f64,
    /// The 2N solve found the same orbit (else the changes are no estimate).
    pub same_orbit: bool,
}

/// What the figures and the report read of a point's Floquet stability.
#[derive(Debug, Clone, Deserialize)]
pub struct StabilityRecord {
    /// Every non-trivial multiplier within the unit circle (to the analysis tolerance).
    pub stable: bool,
    /// Largest |mu| over the non-trivial multipliers.
    pub max_multiplier_abs: f64,
    /// max |mu - 1| over the trivial pair (the confidence of the flag).
    pub trivial_pair_error: f64,
    /// How the multipliers were computed.
    pub method: nlmodes_nnm::StabilityMethod,
    /// Every multiplier (re, im), the trivial pair included, and the trivial pair's indices.
    pub multipliers: Vec<[f64; 2]>,
    pub trivial: [usize; 2],
    /// |w_shot - w| / w of the shooting method (absent in files of other methods: 0).
    #[serde(default)]
    pub orbit_shift: f64,
    /// The RK4 check of a shooting verdict, where one was made.
    #[serde(default)]
    pub check: Option<nlmodes_nnm::ShootingCheck>,
    /// The shot orbit's per-row contact shares (shooting method only).
    #[serde(default)]
    pub contact_shares: Vec<f64>,
    /// The event-based monodromy's modes above the orbit's harmonics (absent: none).
    #[serde(default)]
    pub unresolved: Vec<nlmodes_nnm::UnresolvedPair>,
    /// Their share of an impact's normal acceleration (absent: 0).
    #[serde(default)]
    pub unresolved_acceleration: f64,
}

impl Orbit {
    /// `stable`, `unstable` or `undetermined` (`nlmodes_nnm::verdict_word`); `None` where the
    /// stability was not computed.
    pub fn verdict(&self) -> Option<&'static str> {
        self.stability.as_ref().map(|s| {
            nlmodes_nnm::verdict_word(&nlmodes_nnm::VerdictInputs {
                method: s.method,
                stable: s.stable,
                max_multiplier_abs: s.max_multiplier_abs,
                trivial_pair_error: s.trivial_pair_error,
                multipliers: &s.multipliers,
                trivial: s.trivial,
                orbit_shift: s.orbit_shift,
                check_failed: s.check.as_ref().is_some_and(|c| !c.agrees()),
                unresolved: &s.unresolved,
                unresolved_acceleration: s.unresolved_acceleration,
            })
        })
    }

    /// Whether the point is known to be unstable (a determined verdict).
    pub fn unstable(&self) -> bool {
        self.verdict() == Some("unstable")
    }

    /// Period T = 2 pi / w (s).
    pub fn period(&self) -> f64 {
        2.0 * std::f64::consts::PI / self.omega
    }

    /// u(t) at phase theta = w t (rad), by `nlmodes_nnm::reconstruct`.
    pub fn at_phase(&self, theta: f64) -> Vec<f64> {
        // reconstruct evaluates cos(n w t); with w = 1 and t = theta the phase is theta exactly.
        nlmodes_nnm::reconstruct(&self.coefficients, 1.0, theta)
    }

    /// u at frame `f` of `frames` over one period (t = f T / frames), with the phases reduced
    /// exactly: cos(n w t) = cos(2 pi k / frames) with k = n f mod frames folded onto
    /// [0, frames / 2], so frames f and frames - f come out bitwise equal, as the cosine series
    /// is even in time (Eq. 10). Agrees with [`Orbit::at_phase`] to rounding.
    pub fn at_frame(&self, f: usize, frames: usize) -> Vec<f64> {
        let n = self.coefficients.first().map_or(0, Vec::len);
        let mut u = vec![0.0; n];
        for (h, c) in self.coefficients.iter().enumerate() {
            let k = (h * f) % frames;
            let k = k.min(frames - k);
            let factor = (2.0 * std::f64::consts::PI * k as f64 / frames as f64).cos();
            u.iter_mut().zip(c).for_each(|(ui, ci)| *ui += factor * ci);
        }
        u
    }

    /// The contact-force sample nearest frame `f` of `frames` (t = f T / frames), mirrored for
    /// the second half of the period (sample m - k for frame frames - f), so that even-in-time
    /// frames use mirrored samples.
    pub fn force_sample_at_frame(&self, f: usize, frames: usize) -> usize {
        let m = self.force_samples().max(1);
        let mirrored = f.min(frames - f);
        let k = self.force_sample_at(mirrored as f64 / frames as f64);
        if mirrored == f {
            k
        } else {
            (m - k) % m
        }
    }

    /// du/dt (m/s) at phase theta = w t (rad), by `nlmodes_nnm::velocity`.
    pub fn rate_at_phase(&self, theta: f64) -> Vec<f64> {
        nlmodes_nnm::velocity(&self.coefficients, self.omega, theta / self.omega)
    }

    /// Number of contact rows touching at some time of the period.
    pub fn touching(&self) -> usize {
        self.contact_fraction.iter().filter(|&&f| f > 0.0).count()
    }

    /// Number of contact-force samples per period (m).
    pub fn force_samples(&self) -> usize {
        self.contact_force.first().map_or(0, Vec::len)
    }

    /// The contact-force sample k (0..m) nearest the fraction `t_over_t` of the period.
    pub fn force_sample_at(&self, t_over_t: f64) -> usize {
        let m = self.force_samples().max(1);
        ((t_over_t * m as f64).round() as usize) % m
    }

    /// The sample k with the largest total contact force, if any force is positive.
    pub fn largest_force_sample(&self) -> Option<usize> {
        let total = |k: usize| self.contact_force.iter().map(|v| v[k]).sum::<f64>();
        (0..self.force_samples())
            .max_by(|&a, &b| total(a).total_cmp(&total(b)))
            .filter(|&k| total(k) > 0.0)
    }
}

/// The backbone file as post-processing reads it.
#[derive(Debug, Clone, Deserialize)]
pub struct BackboneFile {
    pub points: Vec<Orbit>,
    pub termination: serde_json::Value,
    /// w1 (rad/s).
    pub omega_linear: f64,
    /// g0 (m).
    pub gap_reference: f64,
    /// q of first contact (m), if reached.
    pub grazing_amplitude: Option<f64>,
    /// Internal-resonance tongues met by the continuation.
    #[serde(default)]
    pub internal_resonances: Vec<nlmodes_nnm::InternalResonance>,
    /// The branches of the family (linear segment, main branch, tongues).
    #[serde(default)]
    pub branches: Vec<nlmodes_nnm::Branch>,
}

impl BackboneFile {
    /// Whether the continuation reached q_max (`termination` of kind `reached_max_amplitude`;
    /// any other ends the backbone stage early, exit code 3).
    pub fn reached_q_max(&self) -> bool {
        self.termination["kind"] == "reached_max_amplitude"
    }

    /// The termination in words: its kind, then its fields ("step too small (q = ..., ...)").
    pub fn termination_text(&self) -> String {
        let t = &self.termination;
        let kind = t["kind"].as_str().unwrap_or("unknown").replace('_', " ");
        let fields: Vec<String> = (t.as_object().into_iter().flatten())
            .filter(|(k, _)| k.as_str() != "kind")
            .map(|(k, v)| format!("{k} = {v}"))
            .collect();
        if fields.is_empty() {
            kind
        } else {
            format!("{kind} ({})", fields.join(", "))
        }
    }

    /// Whether point `p` lies on a tongue branch.
    pub fn on_tongue(&self, p: &Orbit) -> bool {
        matches!(
            self.branches.get(p.branch).map(|b| &b.kind),
            Some(nlmodes_nnm::BranchKind::Tongue { .. })
        )
    }
}

/// One trace's N and its largest contact force at N and at 2N (frf.json `retraces`, the speed
/// sweeps' speed_sweep.json `retraces`).
#[derive(Clone, Debug, Deserialize)]
pub struct RetraceHead {
    pub harmonics: usize,
    #[serde(default, alias = "largest_contact_force_n")]
    pub largest_contact_force: Option<f64>,
    #[serde(default, alias = "largest_contact_force_finer_n")]
    pub largest_contact_force_finer: Option<f64>,
    /// On the exact orbit (massless boundary, no truncation in N).
    #[serde(default, alias = "largest_contact_force_exact_n")]
    pub largest_contact_force_exact: Option<f64>,
    /// Where, on a speed sweep (rpm).
    #[serde(default)]
    pub largest_contact_force_exact_rpm: Option<f64>,
}

/// Reads a JSON file written by an earlier stage.
pub fn read_json<T: for<'de> Deserialize<'de>>(path: &Path) -> Result<T> {
    let bytes = std::fs::read(path).with_context(|| format!("cannot read {}", path.display()))?;
    serde_json::from_slice(&bytes).with_context(|| format!("invalid JSON in {}", path.display()))
}

/// The exact backbone of the massless contact boundary in `dir` (`backbone_boundary.json`), or
/// `None` where the backbone stage wrote none.
pub fn read_boundary_backbone(dir: &Path) -> Result<Option<nlmodes_nnm::BoundaryBackbone>> {
    let path = dir.join("backbone_boundary.json");
    if !path.exists() {
        return Ok(None);
    }
    read_json(&path).map(Some)
}

/// The kept points' exact orbits on the massless contact boundary (`kept_boundary.json`, one
/// entry per kept point, `None` where there is none), or `kept` `None`s where the backbone
/// stage wrote none or wrote them for another set of kept points.
pub fn read_kept_boundary(
    dir: &Path,
    kept: usize,
) -> Result<Vec<Option<nlmodes_nnm::BoundaryHistory>>> {
    let path = dir.join("kept_boundary.json");
    if !path.exists() {
        return Ok(vec![None; kept]);
    }
    let histories: Vec<Option<nlmodes_nnm::BoundaryHistory>> = read_json(&path)?;
    Ok(if histories.len() == kept {
        histories
    } else {
        vec![None; kept]
    })
}
