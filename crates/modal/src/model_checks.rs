//! Physical checks of a reduced model read from files (issue 14): magnitudes, M positive
//! definite (a Cholesky factorization and its conditioning), K positive semi-definite with the
//! rigid modes reported, contact nodes distinct, gaps positive relative to the model's size.
//! The format checks (sizes, symmetry, finiteness, indices) are in
//! [`crate::reduced_model::ReducedModel::validate`], which calls [`check_physics`] after them.
//!
//! Every failure is a [`ModalError::ReducedModel`] naming the file and the entry.

use std::path::Path;

use faer::{Mat, MatRef, Side};

use crate::contact_geometry::RotorAxis;
use crate::error::ModalError;
use crate::modes::dense_generalized_eigen;
use nlmodes_dense::max_abs;

/// One contact node as the checks see it: a label for messages (`contact node 3 (mesh node
/// 812)`), its position (m) and its gap g0 (m).
pub struct ContactPoint {
    /// Names the node in messages.
    pub label: String,
    /// Undeformed position, m.
    pub position: [f64; 3],
    /// Initial gap g0, m.
    pub gap: f64,
}

/// Range of max |K| and max |M| accepted (units of the file: N/m and kg for physical
/// coordinates). A blade's reduced K spans about 1e5 to 1e12 and its M 1e-4 to 1; the solver
/// forms squares of residuals built from K q with q ~ g0 ~ 1e-4 m, so entries within 1e+-30
/// keep every square 1e200 away from the overflow and underflow limits of f64 (1e+-308). A
/// model outside this range is mistyped units or a corrupted file.
pub const MAGNITUDE_RANGE: (f64, f64) = (1e-30, 1e30);

/// Eigenvalues of (K, M) with |lambda| <= this times the largest are rigid-body modes, and an
/// eigenvalue below minus this times the largest makes K indefinite. The dense solver is
/// backward stable: absolute eigenvalue errors are of order eps lambda_max (2.2e-16 lambda_max),
/// so 1e-12 leaves a margin of about 5000 for the Cholesky transformation and for matrices read
/// back from 18-digit text.
pub const RIGID_MODE_TOLERANCE: f64 = 1e-12;

/// Smallest accepted lambda_min(M) / lambda_max(M): above cond(M) = 1e12 the generalized
/// eigenvalues of (K, M) keep fewer than 4 correct digits (their error grows as eps cond(M)), so
/// a mass matrix that passes a floating-point Cholesky with a tiny pivot is still singular for
/// the study (the linear frequency would be wrong without warning).
pub const MASS_CONDITION_LIMIT: f64 = 1e-12;

/// Smallest accepted gap and distance between two contact nodes, relative to the largest distance
/// of a contact node from the rotor axis. Positions are known to eps |x| (~1e-16 relative); a gap
/// of 1e-9 of the radius keeps the solver's tolerance (epsilon g0, epsilon = 1e-4) 1e3 times above
/// that round-off. Physical gaps are about 1e-3 of the radius.
pub const MIN_RELATIVE_GAP: f64 = 1e-9;

/// Runs every physical check; `k_path`, `m_path`, `json` name the files in messages.
/// Returns the rigid-mode eigenvalues of (K, M) (rad^2/s^2), empty for a clamped model.
pub fn check_physics(
    k: &Mat<f64>,
    m: &Mat<f64>,
    contact: &[ContactPoint],
    axis: &RotorAxis,
    paths: [&Path; 3],
) -> Result<Vec<f64>, ModalError> {
    let [k_path, m_path, json] = paths;
    check_magnitude(k.as_ref(), k_path, "K")?;
    check_magnitude(m.as_ref(), m_path, "M")?;
    check_mass_definite(m.as_ref(), m_path)?;
    let rigid = check_stiffness_semidefinite(k.as_ref(), m.as_ref(), k_path)?;
    check_contact_scale(contact, axis, json)?;
    Ok(rigid)
}

fn bad(path: &Path, message: String) -> ModalError {
    ModalError::ReducedModel {
        path: path.to_path_buf(),
        message,
    }
}

/// max |A| within [`MAGNITUDE_RANGE`].
fn check_magnitude(a: MatRef<'_, f64>, path: &Path, name: &str) -> Result<(), ModalError> {
    let largest = max_abs(a);
    let (lo, hi) = MAGNITUDE_RANGE;
    if !(lo..=hi).contains(&largest) {
        return Err(bad(
            path,
            format!(
                "the largest entry of {name} is {largest:e}: expected between {lo:e} and {hi:e} \
                 (SI units: K in N/m, M in kg); check the units or the file"
            ),
        ));
    }
    Ok(())
}

/// M = L L^T must exist (Cholesky, not the diagonal) and be well conditioned.
fn check_mass_definite(m: MatRef<'_, f64>, path: &Path) -> Result<(), ModalError> {
    if let Err(faer::linalg::solvers::LltError::NonPositivePivot { index }) = m.llt(Side::Lower) {
        return Err(bad(
            path,
            format!(
                "M is not positive definite: its Cholesky factorization meets a non-positive \
                 pivot at row/column {index} (0-based; entry ({index}, {index}) = {:e}); a mass \
                 matrix must be positive definite",
                m[(index, index)]
            ),
        ));
    }
    let identity = Mat::<f64>::identity(m.nrows(), m.ncols());
    let (values, vectors) = dense_generalized_eigen(m, identity.as_ref())?;
    let (low, high) = (values[0], values[values.len() - 1]);
    let well_conditioned = low > MASS_CONDITION_LIMIT * high;
    if !well_conditioned {
        let worst = (0..m.nrows())
            .max_by(|&a, &b| vectors[(a, 0)].abs().total_cmp(&vectors[(b, 0)].abs()))
            .unwrap_or(0);
        return Err(bad(
            path,
            format!(
                "M is singular to working precision: its smallest eigenvalue {low:e} is below \
                 {MASS_CONDITION_LIMIT:e} times its largest {high:e} (the null vector is largest \
                 on row {worst}, 0-based); a mass matrix must be positive definite"
            ),
        ));
    }
    Ok(())
}

/// The eigenvalues of (K, M) must be >= -tol lambda_max; those within tol lambda_max of 0 are
/// rigid-body modes, returned (and logged) for the caller to report.
fn check_stiffness_semidefinite(
    k: MatRef<'_, f64>,
    m: MatRef<'_, f64>,
    path: &Path,
) -> Result<Vec<f64>, ModalError> {
    let (values, _) = dense_generalized_eigen(k, m)?;
    let largest = values.iter().fold(0.0_f64, |a, v| a.max(v.abs()));
    let bound = RIGID_MODE_TOLERANCE * largest;
    if let Some(&low) = values.first().filter(|&&v| v < -bound) {
        let negative = values.iter().filter(|&&v| v < -bound).count();
        return Err(bad(
            path,
            format!(
                "K is not positive semi-definite: (K, M) has {negative} negative eigenvalue(s), \
                 the lowest {low:e} rad^2/s^2 (largest |lambda| {largest:e}; tolerance \
                 {RIGID_MODE_TOLERANCE:e} relative)"
            ),
        ));
    }
    let rigid: Vec<f64> = values
        .iter()
        .copied()
        .filter(|v| v.abs() <= bound)
        .collect();
    if !rigid.is_empty() {
        tracing::warn!(
            "{}: K has {} rigid-body mode(s) (eigenvalues {:?} rad^2/s^2, within {:e} of 0): \
             the structure is not clamped",
            path.display(),
            rigid.len(),
            rigid,
            bound
        );
    }
    Ok(rigid)
}

/// Contact nodes at distinct positions, gaps positive relative to the model's size.
fn check_contact_scale(
    contact: &[ContactPoint],
    axis: &RotorAxis,
    json: &Path,
) -> Result<(), ModalError> {
    let radius = |p: [f64; 3]| {
        let d: Vec<f64> = (0..3).map(|c| p[c] - axis.point[c]).collect();
        let along: f64 = (0..3).map(|c| d[c] * axis.direction[c]).sum();
        (0..3)
            .map(|c| (d[c] - along * axis.direction[c]).powi(2))
            .sum::<f64>()
            .sqrt()
    };
    let size = contact
        .iter()
        .map(|c| radius(c.position))
        .fold(0.0_f64, f64::max);
    let label = |j: usize| &contact[j].label;
    for (j, node) in contact.iter().enumerate() {
        if node.gap < MIN_RELATIVE_GAP * size {
            return Err(bad(
                json,
                format!(
                    "{}: gap {:e} m is below {MIN_RELATIVE_GAP:e} times the model's radius \
                     {size:e} m: expected a clearance the solver can resolve (about 1e-3 of the \
                     radius for a blade)",
                    label(j),
                    node.gap
                ),
            ));
        }
        for (i, other) in contact[..j].iter().enumerate() {
            let d2: f64 = (0..3)
                .map(|c| (node.position[c] - other.position[c]).powi(2))
                .sum();
            if d2.sqrt() <= MIN_RELATIVE_GAP * size {
                return Err(bad(
                    json,
                    format!(
                        "{} and {} are at the same position {:?} m: every contact node must be \
                         a distinct point",
                        label(i),
                        label(j),
                        node.position
                    ),
                ));
            }
        }
    }
    Ok(())
}
