//! The master's displacement on the massless contact boundary (docs/STABILITY.md Sec. 9), one
//! row for the free model (the exact backbone, the orbit at q) and the driven one (the exact
//! response curve):
//!
//! ```text
//! u_m(t) = sum_{k < r} phi_mk q_k(t) + sum_{k >= r} phi_mk (p_k(t) - b_k . lambda(t)) / w_k^2
//! ```
//!
//! the kept modes, and the discarded modes' static response to the load p_k = phi_k . f(t)
//! (driven model only) and to the contact forces lambda (N), b_k = A phi_k. u_m in m for SI
//! models.
//!
//! The free and the driven callers hold w_k^2 differently: the free model squares its w_k
//! (`ModalData::omega`, as its residual flexibility does), the driven one reads the system's
//! eigenvalues. The two differ in the last bits (sqrt(lambda)^2 is not lambda), so the row
//! takes w_k^2 as each caller has it: each curve keeps the bits it had before the two rows
//! were one (`tests::w2_as_each_caller_holds_it_differs_by_round_off_only`).

use faer::MatRef;

use crate::driven_model::DrivenInputs;
use crate::model::ModalData;

/// Instants per period at which the master's displacement is sampled (its first harmonic by
/// the trapezoid rule, exact for a smooth periodic function up to aliasing from harmonics 127
/// and 129).
pub(crate) const MASTER_SAMPLES: usize = 128;

/// The master's row (module docs).
#[derive(Clone, Debug)]
pub struct MasterRow {
    /// phi_mk of the kept modes (r).
    kept: Vec<f64>,
    /// sum_{k >= r} phi_mk b_jk / w_k^2 of each contact row j (m/N).
    contact: Vec<f64>,
    /// Per load harmonic h: (h, cos part, sin part) of the discarded modes' static response to
    /// the load (m); empty for the free model.
    drive: Vec<(usize, f64, f64)>,
}

/// The static response at the master of the modes r.. to modal loads.
struct Discarded<'a> {
    /// phi_mk of every mode (n).
    master: &'a [f64],
    /// w_k^2 of every mode (n, rad^2/s^2).
    eigenvalues: &'a [f64],
    r: usize,
}

impl Discarded<'_> {
    /// sum_{k >= r} phi_mk value(k) / w_k^2.
    fn static_response(&self, value: impl Fn(usize) -> f64) -> f64 {
        (self.r..self.eigenvalues.len())
            .map(|k| self.master[k] * value(k) / self.eigenvalues[k])
            .sum()
    }
}

impl MasterRow {
    /// The row of a model keeping the first `r` modes, from the master's row of Phi (n), A Phi
    /// (c x n) and w_k^2 (n, as the caller holds them: module docs). Without drive.
    fn of_modes(
        master: &[f64],
        contact_modal: MatRef<'_, f64>,
        eigenvalues: &[f64],
        r: usize,
    ) -> Self {
        let discarded = Discarded {
            master,
            eigenvalues,
            r,
        };
        Self {
            kept: master[..r].to_vec(),
            contact: (0..contact_modal.nrows())
                .map(|j| discarded.static_response(|k| contact_modal[(j, k)]))
                .collect(),
            drive: Vec::new(),
        }
    }

    /// The master's row of the free model keeping the first `r` modes of `modal` (w_k^2 =
    /// w_k w_k, as `ModalData::model`'s residual flexibility).
    pub fn new(modal: &ModalData<'_>, r: usize) -> Self {
        let eigenvalues: Vec<f64> = modal.omega.iter().map(|w| w * w).collect();
        Self::of_modes(modal.master, modal.contact_modal, &eigenvalues, r)
    }

    /// The master's row of the driven model of `inputs` keeping the first `r` modes, with the
    /// discarded modes' static response to each load harmonic (w_k^2 the system's
    /// eigenvalues, as `driven_model`'s).
    pub(crate) fn driven(inputs: &DrivenInputs<'_>, r: usize) -> Self {
        let system = inputs.system;
        let (phi, lambda) = (system.modes(), system.eigenvalues());
        let (n, m) = (lambda.len(), system.master());
        let b = system.contact_rows() * phi;
        let master: Vec<f64> = (0..n).map(|k| phi[(m, k)]).collect();
        let mut row = Self::of_modes(&master, b.as_ref(), lambda, r);
        let discarded = Discarded {
            master: &master,
            eigenvalues: lambda,
            r,
        };
        let modal = |f: &[f64], k: usize| (0..n).map(|i| phi[(i, k)] * f[i]).sum::<f64>();
        row.drive = (inputs.load.iter())
            .map(|h| {
                (
                    h.harmonic,
                    discarded.static_response(|k| modal(h.cos, k)),
                    discarded.static_response(|k| modal(h.sin, k)),
                )
            })
            .collect();
        row
    }

    /// A row given by its coefficients (test models).
    #[cfg(test)]
    pub(crate) fn from_coefficients(kept: Vec<f64>, contact: Vec<f64>) -> Self {
        Self {
            kept,
            contact,
            drive: Vec::new(),
        }
    }

    /// u_m (m) of the free model at kept coordinates q and contact forces lambda (N).
    pub fn at(&self, q: &[f64], lambda: &[f64]) -> f64 {
        dot(&self.kept, q) - dot(&self.contact, lambda)
    }

    /// u_m (m) of the driven model at time t (s) of excitation frequency W = `omega` (rad/s).
    pub(crate) fn at_time(&self, q: &[f64], lambda: &[f64], omega: f64, t: f64) -> f64 {
        let drive: f64 = (self.drive.iter())
            .map(|&(h, c, s)| {
                let (sn, cs) = (h as f64 * omega * t).sin_cos();
                c * cs + s * sn
            })
            .sum();
        dot(&self.kept, q) + drive - dot(&self.contact, lambda)
    }
}

fn dot(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| x * y).sum::<f64>()
}

#[cfg(test)]
mod tests {
    use super::*;
    use faer::Mat;

    /// The row with w_k^2 as the driven model holds them (eigenvalues) and as the free model
    /// does (squares of w_k = sqrt(eigenvalue)) on 12 modes spread over four decades and 3
    /// contact rows (5 of the 12 w_k^2 change in their last bits): the contact coefficients
    /// differ by round-off only (measured 2.6e-16 relative, asserted below 1e-14: a few ulps
    /// per term of a sum of 9). One row that squared the driven model's w_k would move the
    /// last printed digits of frf_boundary.csv by about this much.
    #[test]
    fn w2_as_each_caller_holds_it_differs_by_round_off_only() {
        let n = 12;
        let eigenvalues: Vec<f64> = (0..n).map(|k| 3.7 * 2.3_f64.powi(k as i32)).collect();
        let omega: Vec<f64> = eigenvalues.iter().map(|l| l.sqrt()).collect();
        let squared: Vec<f64> = omega.iter().map(|w| w * w).collect();
        let changed = eigenvalues
            .iter()
            .zip(&squared)
            .filter(|(a, b)| a != b)
            .count();
        let master: Vec<f64> = (0..n).map(|k| ((k + 1) as f64 * 0.7).sin()).collect();
        let b = Mat::from_fn(3, n, |j, k| ((j * n + k) as f64 * 0.37).cos());
        let driven = MasterRow::of_modes(&master, b.as_ref(), &eigenvalues, 3);
        let free = MasterRow::of_modes(&master, b.as_ref(), &squared, 3);
        let worst = (driven.contact.iter().zip(&free.contact))
            .map(|(a, b)| (a - b).abs() / a.abs())
            .fold(0.0, f64::max);
        println!(
            "{changed} of {n} w_k^2 change in the last bits; contact coefficients {worst:.1e}"
        );
        assert!(
            changed > 0,
            "the test must have eigenvalues whose square root squares back differently"
        );
        assert!(worst < 1e-14, "{worst:e}");
        assert_eq!(driven.kept, free.kept);
    }

    /// Without a drive, `at_time` is `at`; with one, it adds its harmonics' static response.
    #[test]
    fn the_drive_adds_its_static_response() {
        let mut row = MasterRow::from_coefficients(vec![1.0, 0.5], vec![0.25]);
        let (q, lambda) = ([0.2, -0.4], [2.0]);
        assert_eq!(row.at(&q, &lambda), row.at_time(&q, &lambda, 3.0, 0.7));
        row.drive = vec![(2, 0.1, -0.3)];
        let (w, t) = (3.0_f64, 0.7_f64);
        let expected = row.at(&q, &lambda) + 0.1 * (2.0 * w * t).cos() - 0.3 * (2.0 * w * t).sin();
        assert!((row.at_time(&q, &lambda, w, t) - expected).abs() < 1e-15);
    }
}
