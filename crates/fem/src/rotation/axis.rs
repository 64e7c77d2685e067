//! The rotor axis: a point p and a unit direction a (DESIGN §9), with the projector
//! P = I - a a^T onto the plane of rotation.

use crate::rotation::error::RotationError;

/// A 3x3 matrix, row-major (`m[i][j]`).
pub type Mat3 = [[f64; 3]; 3];

/// The rotation axis of the rotor: the line through `point` (m) along the unit vector
/// `direction`. The rotation is about this line, counter-clockwise seen from the tip of
/// `direction`, at speed Omega (rad/s) given separately.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RotorAxis {
    point: [f64; 3],
    direction: [f64; 3],
}

impl RotorAxis {
    /// The axis through `point` (m) along `direction` (any non-zero finite vector; it is
    /// normalized). Errors on a zero or non-finite direction or a non-finite point.
    pub fn new(point: [f64; 3], direction: [f64; 3]) -> Result<Self, RotationError> {
        if !point.iter().chain(&direction).all(|v| v.is_finite()) {
            return Err(RotationError::InvalidAxis(format!(
                "point {point:?} and direction {direction:?} must be finite"
            )));
        }
        let norm = dot(&direction, &direction).sqrt();
        if norm == 0.0 {
            return Err(RotationError::InvalidAxis(
                "the direction is the zero vector".to_string(),
            ));
        }
        Ok(RotorAxis {
            point,
            direction: direction.map(|v| v / norm),
        })
    }

    /// A point of the axis, p (m).
    pub fn point(&self) -> [f64; 3] {
        self.point
    }

    /// The unit direction a.
    pub fn direction(&self) -> [f64; 3] {
        self.direction
    }

    /// P = I - a a^T, the orthogonal projector onto the plane of rotation (exactly symmetric:
    /// P_ij and P_ji are the same floating-point expression).
    pub fn projector(&self) -> Mat3 {
        let a = self.direction;
        let mut p = [[0.0; 3]; 3];
        for i in 0..3 {
            for j in 0..3 {
                let delta = if i == j { 1.0 } else { 0.0 };
                p[i][j] = delta - a[i] * a[j];
            }
        }
        p
    }

    /// The cross-product matrix [a]x, with [a]x v = a x v (skew-symmetric).
    pub fn cross_matrix(&self) -> Mat3 {
        let a = self.direction;
        [[0.0, -a[2], a[1]], [a[2], 0.0, -a[0]], [-a[1], a[0], 0.0]]
    }

    /// The radial vector P (x - p) of a position x (m): the arm of the centrifugal force
    /// rho Omega^2 P (x - p) per unit volume.
    pub fn radial_vector(&self, x: [f64; 3]) -> [f64; 3] {
        let d = [
            x[0] - self.point[0],
            x[1] - self.point[1],
            x[2] - self.point[2],
        ];
        let along = dot(&d, &self.direction);
        [
            d[0] - along * self.direction[0],
            d[1] - along * self.direction[1],
            d[2] - along * self.direction[2],
        ]
    }

    /// The distance |P (x - p)| of a position x (m) from the axis, m.
    pub fn distance(&self, x: [f64; 3]) -> f64 {
        let r = self.radial_vector(x);
        dot(&r, &r).sqrt()
    }

    /// The radial growth (m) of the point at X (m) displaced by u (m): the change of its
    /// distance from the axis, |P (X + u - p)| - |P (X - p)| (a contact node's growth closes
    /// its gap to the casing).
    pub fn radial_growth(&self, x: [f64; 3], u: [f64; 3]) -> f64 {
        self.distance([x[0] + u[0], x[1] + u[1], x[2] + u[2]]) - self.distance(x)
    }
}

/// Dot product of two 3-vectors.
#[inline]
pub fn dot(a: &[f64; 3], b: &[f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

/// m v for a 3x3 matrix m.
#[inline]
pub fn mat_vec(m: &Mat3, v: &[f64; 3]) -> [f64; 3] {
    [dot(&m[0], v), dot(&m[1], v), dot(&m[2], v)]
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn projector_removes_the_axial_component() {
        let axis = RotorAxis::new([1.0, 2.0, 3.0], [0.0, 0.0, 2.0]).expect("valid");
        assert_eq!(axis.direction(), [0.0, 0.0, 1.0]);
        assert_eq!(axis.radial_vector([4.0, 6.0, -7.0]), [3.0, 4.0, 0.0]);
        let p = axis.projector();
        assert_eq!(mat_vec(&p, &[3.0, 4.0, 5.0]), [3.0, 4.0, 0.0]);
        assert_eq!(
            mat_vec(&axis.cross_matrix(), &[1.0, 0.0, 0.0]),
            [0.0, 1.0, 0.0]
        );
        assert!(RotorAxis::new([0.0; 3], [0.0; 3]).is_err());
        assert!(RotorAxis::new([f64::NAN, 0.0, 0.0], [1.0, 0.0, 0.0]).is_err());
    }
}
