//! Casing distortion as an excitation (issue 39, item 3; docs/DESIGN.md §10.11).
//!
//! An ovalized or n-lobed casing makes the clearance the rotating blade sees vary in time: in
//! the contact law of every row j the gap is
//!
//! ```text
//! g_j(theta) = g0_j - delta cos(h theta + phi),   theta = W t,
//! ```
//!
//! delta the casing's intrusion amplitude (m), h the harmonic of the orbit's fundamental W at
//! which the lobes pass (h = 1 when W is the lobe-passing frequency n Omega) and phi its phase
//! (rad). The penetration y_j - g_j = (y_j + delta cos(h theta + phi)) - g0_j is the same
//! trigonometric polynomial shifted at harmonic h, so the solver works on the contact
//! coordinates measured from the distorted casing, y~_j = y_j + c(theta) with the casing's
//! intrusion c(theta) = delta cos(h theta + phi), against the constant gaps g0_j: the exact
//! penalty integral, the sampled law of Algorithm 1, the grazing passages and the switched
//! monodromy see y~ - g0 unchanged. Only the linear part moves: y = y_F - G Lambda becomes
//! R(y~) = y~ - c - s y_F(W) + G(W) Lambda(y~) = 0. Since c sits at a fixed harmonic of W, it
//! does not depend on W (dR/dW is the structure's alone) nor on the unknowns (the Jacobian is
//! unchanged).

use nlmodes_boundary::GapHarmonic;
use nlmodes_hb::FullBasis;

use crate::error::ForcedError;

/// The casing's intrusion into the clearance, delta cos(h theta + phi), the same on every
/// contact row (module docs).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CasingDistortion {
    /// Harmonic h >= 1 of the orbit's fundamental W at which the gap varies.
    pub harmonic: usize,
    /// delta (m, >= 0): the gap's largest reduction (at h theta + phi = 0 mod 2 pi).
    pub amplitude: f64,
    /// phi (rad).
    pub phase: f64,
}

impl CasingDistortion {
    /// Checks 1 <= h <= N (`highest`: the harmonic must be on the basis), a finite delta >= 0
    /// and a finite phase.
    pub fn validate(&self, highest: usize) -> Result<(), ForcedError> {
        let bad = |name, value, expected| {
            Err(ForcedError::Parameter {
                name,
                value,
                expected,
            })
        };
        if self.harmonic == 0 || self.harmonic > highest {
            return bad(
                "distortion harmonic",
                self.harmonic as f64,
                "1 <= h <= N (the highest harmonic kept)",
            );
        }
        if !(self.amplitude.is_finite() && self.amplitude >= 0.0) {
            return bad(
                "distortion amplitude",
                self.amplitude,
                "a finite amplitude >= 0 (m)",
            );
        }
        if !self.phase.is_finite() {
            return bad("distortion phase", self.phase, "a finite phase (rad)");
        }
        Ok(())
    }

    /// The intrusion delta cos(h theta + phi) as a series of the full basis of `terms` = 2N + 1
    /// coefficients: delta cos(phi) on cos h theta, -delta sin(phi) on sin h theta.
    pub fn series(&self, terms: usize) -> Vec<f64> {
        let mut c = vec![0.0; terms];
        let (s, co) = self.phase.sin_cos();
        c[FullBasis::cos_index(self.harmonic)] = self.amplitude * co;
        c[FullBasis::sin_index(self.harmonic)] = -self.amplitude * s;
        c
    }

    /// The intrusion of every one of `rows` contact rows, signal-major as the contact
    /// coordinates (rows x `terms`).
    pub fn offsets(&self, rows: usize, terms: usize) -> Vec<f64> {
        self.series(terms).repeat(rows)
    }

    /// The intrusion on each of `rows` contact rows as a moving gap of the massless boundary
    /// (docs/STABILITY.md Sec. 9.5): delta cos(phi) on cos h W t, -delta sin(phi) on sin h W t.
    pub fn gap_harmonic(&self, rows: usize) -> GapHarmonic {
        let (s, co) = self.phase.sin_cos();
        GapHarmonic {
            harmonic: self.harmonic,
            intrusion: [
                vec![self.amplitude * co; rows],
                vec![-self.amplitude * s; rows],
            ],
        }
    }

    /// The intrusion at phase theta = W t (m).
    pub fn intrusion_at(&self, theta: f64) -> f64 {
        self.amplitude * (self.harmonic as f64 * theta + self.phase).cos()
    }

    /// The same casing seen from a time origin advanced by theta = W tau (rad): its phase
    /// phi + h theta (the gap at t is the old one at t + tau).
    pub fn advanced(&self, theta: f64) -> Self {
        Self {
            phase: self.phase + self.harmonic as f64 * theta,
            ..*self
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_series_is_the_intrusion_at_every_phase() {
        let d = CasingDistortion {
            harmonic: 3,
            amplitude: 2e-4,
            phase: 0.7,
        };
        let s = d.series(2 * 5 + 1);
        for k in 0..50 {
            let th = 0.13 * k as f64;
            let v = FullBasis::value_at(&s, th);
            assert!((v - d.intrusion_at(th)).abs() < 1e-18, "{v}");
        }
        assert_eq!(d.offsets(2, 11).len(), 22);
        // The boundary's moving gap (docs/STABILITY.md Sec. 9.5) is the same intrusion.
        let g = d.gap_harmonic(2);
        assert_eq!((g.harmonic, g.intrusion[0].len()), (3, 2));
        for k in 0..50 {
            let th = 0.13 * k as f64;
            let (sn, co) = (3.0 * th).sin_cos();
            let v = g.intrusion[0][1] * co + g.intrusion[1][1] * sn;
            assert!((v - d.intrusion_at(th)).abs() < 1e-18, "{v}");
        }
    }

    #[test]
    fn bad_values_are_named() {
        let ok = CasingDistortion {
            harmonic: 2,
            amplitude: 1e-4,
            phase: 0.0,
        };
        assert!(ok.validate(2).is_ok());
        let named = |d: CasingDistortion, name: &str| match d.validate(2) {
            Err(ForcedError::Parameter { name: n, .. }) => assert_eq!(n, name),
            other => panic!("{other:?}"),
        };
        named(
            CasingDistortion { harmonic: 3, ..ok },
            "distortion harmonic",
        );
        named(
            CasingDistortion { harmonic: 0, ..ok },
            "distortion harmonic",
        );
        named(
            CasingDistortion {
                amplitude: -1e-6,
                ..ok
            },
            "distortion amplitude",
        );
        named(
            CasingDistortion {
                amplitude: f64::INFINITY,
                ..ok
            },
            "distortion amplitude",
        );
        named(
            CasingDistortion {
                phase: f64::NAN,
                ..ok
            },
            "distortion phase",
        );
    }
}
