//! The rotating model along the speeds of a range (docs/ROTATION.md, "Campbell diagram"): the
//! stiffness at speed of the linear prestress, exact in Omega^2 from two matrices
//! ([`LinearStiffnessFamily`]), and the start of the nonlinear static solve at the next speed
//! of a march from the states before it ([`RotatingModel::march_start`]: extrapolations in
//! Omega^2 checked by their residual). Units: SI (rad/s,
//! m, N/m).

use sprs::CsMat;

use crate::rotation::{RotatingModel, RotationError, StaticSolution};

/// K(Omega) on the free DOFs (N/m) under the linear prestress: the static state is Omega^2
/// times one state, so K(x) = K_e + (x / x_top) (K_top - K_e), x = Omega^2, exactly, with K_e
/// = K(0) and K_top = K(Omega_top). Taken through the highest speed of the range, not 1
/// rad/s, where K - K_e is 1e-6 of K and the extrapolation would lose its digits.
pub struct LinearStiffnessFamily {
    k_e: CsMat<f64>,
    k_top: CsMat<f64>,
    x_top: f64,
}

impl LinearStiffnessFamily {
    /// The family through K_e (N/m, at rest) and K_top (N/m) at `omega_top` (rad/s, > 0).
    pub fn new(k_e: CsMat<f64>, k_top: CsMat<f64>, omega_top: f64) -> Self {
        Self {
            k_e,
            k_top,
            x_top: omega_top * omega_top,
        }
    }

    /// K(Omega) (N/m) at `omega` (rad/s): (1 - t) K_e + t K_top, t = Omega^2 / Omega_top^2.
    pub fn at(&self, omega: f64) -> CsMat<f64> {
        let t = omega * omega / self.x_top;
        &self.k_e.map(|v| (1.0 - t) * v) + &self.k_top.map(|v| t * v)
    }
}

/// A higher-order start of [`RotatingModel::march_start`] is kept unless its residual exceeds
/// this many times that of the lower-order one (an overshoot: both extrapolations on the test
/// cantilever near its in-plane softening are 800 times the load, the last state 0.31; on the
/// blade the residual norms of the candidates differ by factors of 2-20 either way).
pub const OVERSHOOT: f64 = 10.0;

impl RotatingModel<'_> {
    /// The first Newton iterate at `omega` (rad/s) of a march over ascending speeds, from its
    /// converged `states`: the highest-order extrapolation in Omega^2 that does not overshoot,
    /// of the last state itself, the secant through the last two and the quadratic through the
    /// last three, each taken in that order unless its residual at `omega` exceeds
    /// [`OVERSHOOT`] times that of the one before (a residual without tangent each: 0.13 s CPU
    /// on the default blade). On the blade the plain previous state overshoots (residual 0.75
    /// of the load at 2000 rpm from 1000, 1.1 after the first Newton step: the lateral bending
    /// is stiffened by the very stress the step adds) although its residual is below the
    /// secant's (1.4, 1.4e-4 after the first Newton step): the residual norm weighs the stiff
    /// components, which Newton corrects at once, so it only guards against overshoot; the
    /// quadratic start is at 0.04-0.12 of the load instead of the secant's 1-2.7
    /// (docs/BENCHMARKS.md, "Issue 39, session 21"). Where the state is far from quadratic in
    /// Omega^2 (near a speed where the structure softens) the quadratic extrapolation can
    /// overshoot by orders of magnitude (`crates/fem/tests/rotation_chord_newton.rs`). `None`
    /// without states.
    pub fn march_start(
        &self,
        states: &[StaticSolution],
        omega: f64,
    ) -> Result<Option<StaticSolution>, RotationError> {
        let Some(last) = states.last() else {
            return Ok(None);
        };
        let mut chosen = (self.residual_norm(omega, &last.displacement_free)?, None);
        for count in [2, 3] {
            if let Some(start) = self.extrapolated_start(states, omega, count)? {
                let norm = self.residual_norm(omega, &start.displacement_free)?;
                if norm <= OVERSHOOT * chosen.0 {
                    chosen = (norm, Some(start));
                }
            }
        }
        Ok(Some(chosen.1.unwrap_or_else(|| last.clone())))
    }

    /// ||r|| (N) at `omega` (rad/s) and the free displacement `u` (m).
    fn residual_norm(&self, omega: f64, u: &[f64]) -> Result<f64, RotationError> {
        let (r, _) = self.residual(omega, u)?;
        let norm = r.iter().map(|x| x * x).sum::<f64>().sqrt();
        Ok(if norm.is_nan() { f64::INFINITY } else { norm })
    }

    /// The Lagrange extrapolation in Omega^2 to `omega` (rad/s) of the displacements of the
    /// last `count` of `states` (ascending speeds; 2: the secant, 3: quadratic), as a start
    /// state at the last state's speed (the Newton iterations of `solve_nonlinear_from` begin
    /// at a start's displacement). `None` with fewer states or two at one speed.
    pub fn extrapolated_start(
        &self,
        states: &[StaticSolution],
        omega: f64,
        count: usize,
    ) -> Result<Option<StaticSolution>, RotationError> {
        if count < 2 || states.len() < count {
            return Ok(None);
        }
        let used = &states[states.len() - count..];
        let nodes: Vec<f64> = used.iter().map(|s| s.omega * s.omega).collect();
        if nodes.windows(2).any(|w| w[0] >= w[1]) {
            return Ok(None);
        }
        let x = omega * omega;
        let last = &used[count - 1];
        let mut free = vec![0.0; last.displacement_free.len()];
        for (i, state) in used.iter().enumerate() {
            let weight: f64 = (0..count)
                .filter(|&j| j != i)
                .map(|j| (x - nodes[j]) / (nodes[i] - nodes[j]))
                .product();
            for (f, u) in free.iter_mut().zip(&state.displacement_free) {
                *f += weight * u;
            }
        }
        Ok(Some(StaticSolution {
            displacement: self.dofs().try_expand(&free)?,
            displacement_free: free,
            steps: Vec::new(),
            ..last.clone()
        }))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::generate::box_mesh;
    use crate::rotation::{Kinematics, RotorAxis};
    use crate::{fixed_dofs, DofMap, Isotropic, TetKind};
    use sprs::TriMat;

    /// K_e at rest and K_top at the top speed exactly; in between linear in Omega^2 (to 1e-15 of
    /// the entries).
    #[test]
    fn the_linear_family_interpolates_in_omega_squared() {
        let matrix = |scale: f64| {
            let mut t = TriMat::new((3, 3));
            for (i, j, v) in [
                (0, 0, 4.0),
                (1, 1, 5.0),
                (2, 2, 6.0),
                (0, 2, -1.0),
                (2, 0, -1.0),
            ] {
                t.add_triplet(i, j, scale * v + if i == j { 1.0 } else { 0.0 });
            }
            t.to_csc()
        };
        let (k_e, k_top) = (matrix(1.0), matrix(1.3));
        let family = LinearStiffnessFamily::new(k_e.clone(), k_top.clone(), 800.0);
        assert_eq!(family.at(0.0), k_e);
        assert_eq!(family.at(800.0), k_top);
        let t = (300.0_f64 / 800.0).powi(2);
        let mid = family.at(300.0);
        for ((&a, &e), &top) in mid.data().iter().zip(k_e.data()).zip(k_top.data()) {
            assert!((a - (e + t * (top - e))).abs() < 1e-15 * top.abs());
        }
    }

    /// States proportional to Omega^2 (the linear prestress) are extrapolated exactly: the start
    /// at 90 rad/s from states at 30 and 60 is (90 / 60)^2 times the last, zero on the clamped
    /// DOFs; fewer than two states give none. States quadratic in Omega^2 are extrapolated
    /// exactly from three.
    #[test]
    fn the_start_is_exact_for_states_linear_and_quadratic_in_omega_squared() {
        let mesh = box_mesh([0.3, 0.05, 0.04], [2, 1, 1], TetKind::Tet4).expect("mesh");
        let dofs = DofMap::new(
            mesh.n_nodes(),
            &fixed_dofs(&mesh, &["xmin"]).expect("fixed"),
        )
        .expect("dofs");
        let material = Isotropic::new(200e9, 0.3, 7800.0).expect("material");
        let axis = RotorAxis::new([0.0, 0.0, 0.0], [0.0, 0.0, 1.0]).expect("axis");
        let model = RotatingModel::new(&mesh, material, axis, dofs.clone()).expect("model");
        let unit: Vec<f64> = (0..dofs.n_free())
            .map(|i| 1e-9 * (i as f64 + 1.0).sin())
            .collect();
        let state = |omega: f64| {
            let free: Vec<f64> = unit.iter().map(|u| omega * omega * u).collect();
            StaticSolution {
                omega,
                kinematics: Kinematics::Linear,
                spin_softening_in_operator: false,
                displacement: dofs.try_expand(&free).expect("expand"),
                displacement_free: free,
                steps: Vec::new(),
            }
        };
        let states = [state(30.0), state(60.0)];
        assert!(model
            .extrapolated_start(&states[..1], 90.0, 2)
            .unwrap()
            .is_none());
        let start = model
            .extrapolated_start(&states, 90.0, 2)
            .unwrap()
            .expect("a start");
        let exact = state(90.0);
        for (a, b) in start.displacement.iter().zip(&exact.displacement) {
            assert!((a - b).abs() <= 1e-14 * b.abs().max(1e-30), "{a} vs {b}");
        }
        assert_eq!(start.omega, 60.0, "a start at the last state's speed");
        // Quadratic in Omega^2 (u = x u1 + x^2 u2, x = Omega^2): exact from three states (to
        // round-off: the weights are O(1), the terms up to 4x the result), off from two.
        let quadratic = |omega: f64| {
            let mut s = state(omega);
            let x = omega * omega;
            for (u, u1) in s.displacement_free.iter_mut().zip(&unit) {
                *u += x * x * 1e-4 * u1.abs();
            }
            s.displacement = dofs.try_expand(&s.displacement_free).expect("expand");
            s
        };
        let exact = quadratic(90.0);
        let error = |states: &[StaticSolution], count: usize| {
            let start = model
                .extrapolated_start(states, 90.0, count)
                .unwrap()
                .expect("a start");
            start
                .displacement
                .iter()
                .zip(&exact.displacement)
                .map(|(a, b)| (a - b).abs() / b.abs().max(1e-30))
                .fold(0.0, f64::max)
        };
        let three = [quadratic(20.0), quadratic(40.0), quadratic(60.0)];
        assert!(error(&three, 3) < 1e-13, "{}", error(&three, 3));
        assert!(error(&three, 2) > 1e-3, "{}", error(&three, 2));
    }
}
