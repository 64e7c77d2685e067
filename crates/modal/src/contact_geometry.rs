//! Rotor axis and radial directions of contact nodes (the casing is a
//! surface of revolution about the rotor axis, so the contact normal of a
//! blade-tip node is its radial unit vector; paper Eq. 17).

use serde::{Deserialize, Serialize};

use crate::error::ModalError;

/// The rotor axis: a point on it and its direction (unit vector once normalized).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct RotorAxis {
    /// A point of the axis, m.
    pub point: [f64; 3],
    /// Direction of the axis (stored as a unit vector), dimensionless.
    pub direction: [f64; 3],
}

impl RotorAxis {
    /// An axis through `point` along `direction` (normalized here).
    ///
    /// Errors when a coordinate is not finite or the direction is zero.
    pub fn new(point: [f64; 3], direction: [f64; 3]) -> Result<Self, ModalError> {
        if point.iter().chain(&direction).any(|v| !v.is_finite()) {
            return Err(ModalError::InvalidArgument(format!(
                "rotor axis point {point:?} and direction {direction:?} must be finite"
            )));
        }
        let length = norm(direction);
        if length == 0.0 {
            return Err(ModalError::InvalidArgument(
                "the rotor axis direction is the zero vector".to_string(),
            ));
        }
        Ok(Self {
            point,
            direction: direction.map(|v| v / length),
        })
    }

    /// Radial unit vector of `x` about this axis:
    /// r = (x - p0) - ((x - p0) . a) a, normalized (a = unit direction).
    ///
    /// Errors when `x` is on the axis: its distance to the axis is at most
    /// 1e-12 times max(|x - p0|, 1 m) (round-off of the projection), so no
    /// radial direction exists.
    pub fn radial_unit_vector(&self, x: [f64; 3]) -> Result<[f64; 3], ModalError> {
        let a = self.direction.map(|v| v / norm(self.direction));
        let d = [
            x[0] - self.point[0],
            x[1] - self.point[1],
            x[2] - self.point[2],
        ];
        let along = d[0] * a[0] + d[1] * a[1] + d[2] * a[2];
        let r = [
            d[0] - along * a[0],
            d[1] - along * a[1],
            d[2] - along * a[2],
        ];
        let distance = norm(r);
        if distance.is_nan() || distance <= 1e-12 * norm(d).max(1.0) {
            return Err(ModalError::PointOnAxis {
                x: x[0],
                y: x[1],
                z: x[2],
                distance,
            });
        }
        Ok(r.map(|v| v / distance))
    }
}

/// Radial unit vector of `x` about the axis through `axis_point` along
/// `axis_direction` (any non-zero length): see [`RotorAxis::radial_unit_vector`].
pub fn radial_unit_vector(
    x: [f64; 3],
    axis_point: [f64; 3],
    axis_direction: [f64; 3],
) -> Result<[f64; 3], ModalError> {
    RotorAxis::new(axis_point, axis_direction)?.radial_unit_vector(x)
}

/// Euclidean norm of a 3-vector.
pub(crate) fn norm(v: [f64; 3]) -> f64 {
    (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Axis along z through (1, 2, 0): the point (4, 6, 7) is at radius 5 in
    /// the direction (3, 4, 0) / 5, exactly representable: tolerance 1e-15.
    #[test]
    fn radial_vector_of_a_point() {
        let axis = RotorAxis::new([1.0, 2.0, 0.0], [0.0, 0.0, 2.0]).unwrap();
        assert_eq!(axis.direction, [0.0, 0.0, 1.0]);
        let r = axis.radial_unit_vector([4.0, 6.0, 7.0]).unwrap();
        for (a, b) in r.iter().zip([0.6, 0.8, 0.0]) {
            assert!((a - b).abs() < 1e-15, "{r:?}");
        }
    }

    /// Oblique axis: r is orthogonal to the axis and of unit length (1e-15).
    #[test]
    fn radial_vector_is_orthogonal_to_an_oblique_axis() {
        let axis = RotorAxis::new([0.0; 3], [1.0, 1.0, 1.0]).unwrap();
        let r = axis.radial_unit_vector([0.3, -0.2, 0.9]).unwrap();
        let a = axis.direction;
        assert!((r[0] * a[0] + r[1] * a[1] + r[2] * a[2]).abs() < 1e-15);
        assert!((norm(r) - 1.0).abs() < 1e-15);
    }

    #[test]
    fn point_on_axis_is_an_error() {
        let axis = RotorAxis::new([0.0; 3], [0.0, 0.0, 1.0]).unwrap();
        let err = axis.radial_unit_vector([0.0, 0.0, 0.5]).unwrap_err();
        assert!(err.to_string().contains("lies on the rotor axis"), "{err}");
        assert!(RotorAxis::new([0.0; 3], [0.0; 3]).is_err());
        assert!(RotorAxis::new([f64::NAN, 0.0, 0.0], [0.0, 0.0, 1.0]).is_err());
    }
}
