//! Linear isotropic elasticity: sigma_ij = lambda delta_ij eps_kk + 2 mu eps_ij (paper
//! Sec. 2.2), with the Lamé constants from Young's modulus and Poisson's ratio.
//!
//! Voigt order (xx, yy, zz, yz, xz, xy) with engineering shear strains
//! gamma_ij = 2 eps_ij, so that stress = D strain and the strain energy is strain^T D strain / 2.

use crate::error::FemError;

/// Linear isotropic elastic material.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Isotropic {
    /// Young's modulus E (Pa).
    pub young: f64,
    /// Poisson's ratio nu (dimensionless).
    pub poisson: f64,
    /// Mass density rho (kg/m^3).
    pub density: f64,
}

/// Lamé constants lambda and mu (Pa).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Lame {
    /// First Lamé constant lambda = E nu / ((1 + nu)(1 - 2 nu)) (Pa).
    pub lambda: f64,
    /// Shear modulus mu = E / (2 (1 + nu)) (Pa).
    pub mu: f64,
}

impl Isotropic {
    /// Builds a validated material: E > 0 (Pa), -1 < nu < 0.5, rho > 0 (kg/m^3), all finite.
    pub fn new(young: f64, poisson: f64, density: f64) -> Result<Self, FemError> {
        let m = Isotropic {
            young,
            poisson,
            density,
        };
        m.validate()?;
        Ok(m)
    }

    /// Checks E > 0, -1 < nu < 0.5 and rho > 0 (all finite).
    pub fn validate(&self) -> Result<(), FemError> {
        if !(self.young.is_finite() && self.young > 0.0) {
            return Err(FemError::InvalidMaterial {
                parameter: "Young's modulus E (Pa)",
                value: self.young,
                expected: "a finite value > 0",
            });
        }
        if !(self.poisson > -1.0 && self.poisson < 0.5) {
            return Err(FemError::InvalidMaterial {
                parameter: "Poisson's ratio nu",
                value: self.poisson,
                expected: "-1 < nu < 0.5",
            });
        }
        if !(self.density.is_finite() && self.density > 0.0) {
            return Err(FemError::InvalidMaterial {
                parameter: "density rho (kg/m^3)",
                value: self.density,
                expected: "a finite value > 0",
            });
        }
        Ok(())
    }

    /// Lamé constants (Pa).
    pub fn lame(&self) -> Lame {
        let (e, nu) = (self.young, self.poisson);
        Lame {
            lambda: e * nu / ((1.0 + nu) * (1.0 - 2.0 * nu)),
            mu: e / (2.0 * (1.0 + nu)),
        }
    }

    /// 6x6 elasticity matrix D (Pa), Voigt order (xx, yy, zz, yz, xz, xy), engineering shear.
    pub fn elasticity_matrix(&self) -> [[f64; 6]; 6] {
        let Lame { lambda, mu } = self.lame();
        let mut d = [[0.0; 6]; 6];
        for i in 0..3 {
            for j in 0..3 {
                d[i][j] = lambda;
            }
            d[i][i] = lambda + 2.0 * mu;
            d[i + 3][i + 3] = mu;
        }
        d
    }

    /// Stress (Pa) from strain (Voigt, engineering shear): sigma = D eps.
    pub fn stress(&self, strain: &[f64; 6]) -> [f64; 6] {
        let d = self.elasticity_matrix();
        let mut s = [0.0; 6];
        for (si, di) in s.iter_mut().zip(&d) {
            *si = di.iter().zip(strain).map(|(a, b)| a * b).sum();
        }
        s
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rejects_out_of_range_constants_naming_them() {
        let bad = [
            (0.0, 0.3, 1.0, "Young"),
            (-1.0, 0.3, 1.0, "Young"),
            (f64::NAN, 0.3, 1.0, "Young"),
            (1.0, 0.5, 1.0, "Poisson"),
            (1.0, -1.0, 1.0, "Poisson"),
            (1.0, f64::NAN, 1.0, "Poisson"),
            (1.0, 0.3, 0.0, "density"),
            (1.0, 0.3, f64::INFINITY, "density"),
        ];
        for (e, nu, rho, what) in bad {
            let err = Isotropic::new(e, nu, rho).expect_err("must be rejected");
            let msg = err.to_string();
            assert!(msg.contains(what), "{msg}");
        }
        assert!(Isotropic::new(210e9, 0.3, 7800.0).is_ok());
        assert!(Isotropic::new(1.0, -0.99, 1.0).is_ok());
    }

    #[test]
    fn uniaxial_stress_recovers_young_and_poisson() {
        // Independent check of D: apply the uniaxial strain state of a bar under stress s
        // (eps_xx = s/E, eps_yy = eps_zz = -nu s/E) and expect (s, 0, 0, 0, 0, 0);
        // pure shear gamma gives tau = E / (2 (1 + nu)) gamma. Round-off on 1e11-sized
        // terms cancelling to 0: 1e-12 relative to s is ample.
        let m = Isotropic::new(200e9, 0.3, 7800.0).expect("valid");
        let s = 1e6;
        let eps = [
            s / m.young,
            -m.poisson * s / m.young,
            -m.poisson * s / m.young,
            0.0,
            0.0,
            0.0,
        ];
        let sig = m.stress(&eps);
        assert!((sig[0] - s).abs() < 1e-12 * s, "{sig:?}");
        for v in &sig[1..] {
            assert!(v.abs() < 1e-12 * s, "{sig:?}");
        }
        let gamma = 1e-3;
        let sig = m.stress(&[0.0, 0.0, 0.0, 0.0, 0.0, gamma]);
        let tau = m.young / (2.0 * (1.0 + m.poisson)) * gamma;
        assert!((sig[5] - tau).abs() < 1e-12 * tau);
    }
}
