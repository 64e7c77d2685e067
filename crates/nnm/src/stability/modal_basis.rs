//! The linear modes the stability methods work on (docs/STABILITY.md, Sec. 10).
//!
//! A mode k whose share of every contact row's inverse mass, b_jk^2 / c_j (b = A Phi, Phi
//! mass-normalized, c_j = sum_k b_jk^2 = a_j M^-1 a_j^T), is zero to round-off (at most
//! [`DECOUPLED_SHARE`]) couples to nothing: the contact force does not reach it (nor, through it,
//! the master: its static response to the contact forces, phi_mk b_k^T lambda / w_k^2, is zero),
//! and the free mode is a harmonic oscillator whose Floquet pair exp(+-i w_k T) sits on the unit
//! circle whatever the orbit. The monodromy is block-diagonal: that pair is its own block, and it
//! changes no other multiplier. Such modes (the stiff completing coordinates of a contact node,
//! an external model's modes that never move the contact) are left out of every method, which
//! then neither mistakes their pair for the trivial one nor reads a collision into it at +-1.
//! An orbit that carries such a mode (a backbone traced in one) keeps every mode.

use faer::{Mat, MatRef};

use crate::point::BackbonePoint;
use crate::NnmError;
use nlmodes_hb::dense::generalized_eigen;
use nlmodes_hb::system::System;

/// Largest share b_jk^2 / c_j of a contact row's inverse mass at which a mode counts as decoupled
/// from that row: round-off (for an exactly decoupled mode the eigensolver leaves b_jk ~ 1e-16
/// sqrt(c_j), a share ~ 1e-32).
pub const DECOUPLED_SHARE: f64 = f64::EPSILON;

/// Largest share of the orbit's modal displacement, sum over the harmonics of eta_k,n^2 against
/// that of every mode, at which an orbit is taken to carry no decoupled mode.
const CARRIED_SHARE: f64 = 1e-12;

/// Linear modes and their couplings (mass-normalized, ascending w_k).
#[derive(Clone)]
pub(crate) struct ModalBasis {
    /// w_k (rad/s), ascending.
    pub omega: Vec<f64>,
    /// B = A Phi (c x n).
    pub contact_modal: Mat<f64>,
    /// Phi^T M (n x dofs): modal coordinates of a displacement.
    pub projection: Mat<f64>,
    /// The master's row of Phi (n).
    pub master: Vec<f64>,
}

impl ModalBasis {
    /// Every mode of `system`.
    pub fn of_system(system: &System) -> Result<Self, NnmError> {
        let eig = generalized_eigen(system.stiffness(), system.mass(), "M")?;
        let n = eig.vectors.ncols();
        Ok(Self {
            omega: eig.values.iter().map(|v| v.max(0.0).sqrt()).collect(),
            contact_modal: system.contact_rows() * &eig.vectors,
            projection: eig.vectors.transpose() * system.mass(),
            master: (0..n).map(|k| eig.vectors[(system.master(), k)]).collect(),
        })
    }

    /// The share of row j's inverse mass c_j = sum_k b_jk^2 carried by mode k, b_jk^2 / c_j
    /// (c x n; a row no mode reaches has shares 0).
    pub fn inverse_mass_shares(&self) -> Mat<f64> {
        inverse_mass_shares(self.contact_modal.as_ref())
    }

    /// Splits off the modes decoupled from every contact row (module docs): (the coupled modes,
    /// the decoupled ones).
    pub fn split_decoupled(self) -> (Self, DecoupledModes) {
        let shares = self.inverse_mass_shares();
        let coupled: Vec<usize> = (0..self.omega.len())
            .filter(|&k| (0..shares.nrows()).any(|j| shares[(j, k)] > DECOUPLED_SHARE))
            .collect();
        let decoupled: Vec<usize> = (0..self.omega.len())
            .filter(|k| !coupled.contains(k))
            .collect();
        let rows = |keep: &[usize]| {
            Mat::from_fn(keep.len(), self.projection.ncols(), |i, d| {
                self.projection[(keep[i], d)]
            })
        };
        let left_out = DecoupledModes {
            omega: decoupled.iter().map(|&k| self.omega[k]).collect(),
            projection: rows(&decoupled),
            full_projection: self.projection.clone(),
        };
        let kept = Self {
            omega: coupled.iter().map(|&k| self.omega[k]).collect(),
            contact_modal: Mat::from_fn(self.contact_modal.nrows(), coupled.len(), |j, i| {
                self.contact_modal[(j, coupled[i])]
            }),
            projection: rows(&coupled),
            master: coupled.iter().map(|&k| self.master[k]).collect(),
        };
        (kept, left_out)
    }
}

/// b_jk^2 / c_j for `contact_modal` = B (c x n).
pub(crate) fn inverse_mass_shares(contact_modal: MatRef<'_, f64>) -> Mat<f64> {
    let (c, n) = (contact_modal.nrows(), contact_modal.ncols());
    let inverse_mass: Vec<f64> = (0..c)
        .map(|j| (0..n).map(|k| contact_modal[(j, k)].powi(2)).sum())
        .collect();
    Mat::from_fn(c, n, |j, k| {
        if inverse_mass[j] > 0.0 {
            contact_modal[(j, k)].powi(2) / inverse_mass[j]
        } else {
            0.0
        }
    })
}

/// The modes left out as decoupled from every contact row.
pub(crate) struct DecoupledModes {
    /// Their w_k (rad/s), ascending.
    pub omega: Vec<f64>,
    /// Their rows of Phi^T M.
    projection: Mat<f64>,
    /// Phi^T M of every mode (for the orbit's total modal content).
    full_projection: Mat<f64>,
}

impl DecoupledModes {
    /// None left out.
    pub fn none() -> Self {
        Self {
            omega: Vec::new(),
            projection: Mat::zeros(0, 0),
            full_projection: Mat::zeros(0, 0),
        }
    }

    /// Whether the orbit of `point` moves a decoupled mode by more than round-off (its share of
    /// the modal displacement summed over the harmonics above [`CARRIED_SHARE`]).
    pub fn carried_by(&self, point: &BackbonePoint) -> bool {
        if self.omega.is_empty() {
            return false;
        }
        let content = |p: &Mat<f64>| -> f64 {
            point
                .coefficients
                .iter()
                .map(|u| {
                    (0..p.nrows())
                        .map(|k| (0..u.len()).map(|d| p[(k, d)] * u[d]).sum::<f64>().powi(2))
                        .sum::<f64>()
                })
                .sum()
        };
        let total = content(&self.full_projection);
        content(&self.projection) > CARRIED_SHARE * total
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn shares_sum_to_one_per_row_and_split_keeps_the_coupled_modes() {
        // Row 0 reaches modes 0 and 2; row 1 mode 2 only; mode 1 reaches nothing (round-off).
        let b = Mat::from_fn(2, 3, |j, k| match (j, k) {
            (0, 0) => 0.6,
            (0, 2) => 0.8,
            (1, 2) => 2.0,
            (_, 1) => 1e-17,
            _ => 0.0,
        });
        let s = inverse_mass_shares(b.as_ref());
        assert!((s[(0, 0)] - 0.36).abs() < 1e-15 && (s[(0, 2)] - 0.64).abs() < 1e-15);
        assert!((s[(1, 2)] - 1.0).abs() < 1e-15);
        let basis = ModalBasis {
            omega: vec![1.0, 2.0, 3.0],
            contact_modal: b,
            projection: Mat::identity(3, 3),
            master: vec![0.1, 0.2, 0.3],
        };
        let (kept, left_out) = basis.split_decoupled();
        assert_eq!(kept.omega, vec![1.0, 3.0]);
        assert_eq!(kept.master, vec![0.1, 0.3]);
        assert_eq!(kept.contact_modal[(1, 1)], 2.0);
        assert_eq!(left_out.omega, vec![2.0]);
    }
}
