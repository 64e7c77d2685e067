//! Centrifugal load, spin softening and Coriolis matrices of one element (DESIGN §9):
//!
//! - load, following the deformation: f_a = Omega^2 int rho N_a P (x - p) dV (N), x = X + u
//!   the deformed position, integrated over the reference volume (rho is the reference
//!   density, so rho dV is the conserved mass element);
//! - spin softening: M_spin^ab = int rho N_a N_b dV P (kg); the stiffness at speed gets
//!   -Omega^2 M_spin, the derivative of the load: for isoparametric elements
//!   x = sum_b N_b x_b, so f = Omega^2 M_spin (x_nodes - p) exactly (DESIGN §9: CalculiX's
//!   `e_c3d.f` codes these terms; FEBio's centrifugal body force is the same following load
//!   with the derivative -Omega^2 P);
//! - Coriolis: G^ab = 2 Omega int rho N_a N_b dV [a]x (kg/s), skew-symmetric, from the
//!   rotating-frame inertia rho (u'' + 2 Omega a x u' + ...).
//!
//! The element load is integrated by quadrature ([`crate::rotation::points::load_rule`], exact),
//! the matrices from the exact consistent mass, so that the identity f(u) = Omega^2 M_spin
//! (X + u - p) checks one against the other. The static solves use the identity
//! (`RotatingModel::centrifugal_load`: one product with the nodal mass per residual) and keep
//! the quadrature as its check (`RotatingModel::centrifugal_load_by_quadrature`).

use crate::element::ElementRules;
use crate::error::FemError;
use crate::rotation::axis::{mat_vec, RotorAxis};
use crate::rotation::element_ref::ElementRef;
use crate::rotation::points::{for_each_point, load_rule};

/// Centrifugal load f_a = Omega^2 int rho N_a P (x - p) dV (N) at nodal displacements
/// `displacement` (m, element DOF order; zeros give the reference load), into `out`
/// (length 3 npe, overwritten). `density` in kg/m^3, `omega` in rad/s.
pub fn centrifugal_load_element(
    element: &ElementRef<'_>,
    displacement: &[f64],
    density: f64,
    axis: &RotorAxis,
    omega: f64,
    out: &mut [f64],
) -> Result<(), FemError> {
    element.check_vector(displacement, "element displacements")?;
    element.check_vector(out, "element load")?;
    let npe = element.npe();
    let tab = load_rule(element.kind);
    let scale = omega * omega * density;
    out.fill(0.0);
    // x - p is formed from node positions relative to p, so that an element far from the
    // axis point keeps its digits.
    let p = axis.point();
    let proj = axis.projector();
    for_each_point(element.coords, tab, element.tag, |pt| {
        let mut x = [0.0; 3];
        for b in 0..npe {
            for d in 0..3 {
                x[d] += pt.values[b] * (element.coords[b][d] - p[d] + displacement[3 * b + d]);
            }
        }
        let arm = mat_vec(&proj, &x);
        for a in 0..npe {
            let c = scale * pt.weight * pt.values[a];
            for d in 0..3 {
                out[3 * a + d] += c * arm[d];
            }
        }
    })
}

/// The scalar consistent-mass entries m_ab = int rho N_a N_b dV (kg), row-major npe x npe.
pub(crate) fn scalar_mass(element: &ElementRef<'_>, density: f64) -> [f64; 100] {
    let npe = element.npe();
    let n = 3 * npe;
    let mut full = [0.0; 900];
    ElementRules::for_kind(element.kind)
        .mass
        .element_mass(element.coords, density, &mut full);
    let mut m = [0.0; 100];
    for a in 0..npe {
        for b in 0..npe {
            m[a * npe + b] = full[3 * a * n + 3 * b];
        }
    }
    m
}

/// Writes the blocks m_ab B (B a 3x3 matrix) into the row-major (3 npe)^2 matrix `out`.
fn mass_times_block(
    element: &ElementRef<'_>,
    m: &[f64; 100],
    block: &[[f64; 3]; 3],
    out: &mut [f64],
) {
    let npe = element.npe();
    let n = 3 * npe;
    for a in 0..npe {
        for b in 0..npe {
            let mab = m[a * npe + b];
            for i in 0..3 {
                for j in 0..3 {
                    out[(3 * a + i) * n + 3 * b + j] = mab * block[i][j];
                }
            }
        }
    }
}

/// Spin-softening matrix M_spin^ab = int rho N_a N_b dV P (kg) into `out` (row-major
/// (3 npe)^2, overwritten), exactly symmetric. `density` in kg/m^3.
pub fn spin_softening_element(
    element: &ElementRef<'_>,
    density: f64,
    axis: &RotorAxis,
    out: &mut [f64],
) -> Result<(), FemError> {
    element.check_matrix(out, "element spin-softening matrix")?;
    let m = scalar_mass(element, density);
    mass_times_block(element, &m, &axis.projector(), out);
    Ok(())
}

/// Coriolis matrix G^ab = 2 Omega int rho N_a N_b dV [a]x (kg/s) into `out` (row-major
/// (3 npe)^2, overwritten), exactly skew-symmetric. `omega` in rad/s.
pub fn coriolis_element(
    element: &ElementRef<'_>,
    density: f64,
    axis: &RotorAxis,
    omega: f64,
    out: &mut [f64],
) -> Result<(), FemError> {
    element.check_matrix(out, "element Coriolis matrix")?;
    let m = scalar_mass(element, density);
    let block = axis.cross_matrix().map(|row| row.map(|v| 2.0 * omega * v));
    mass_times_block(element, &m, &block, out);
    Ok(())
}

/// Omega^2 M_spin (x_nodes - p), the load of an isoparametric element written with its
/// spin-softening matrix (N): the identity the quadrature of [`centrifugal_load_element`] is
/// checked against. `displacement` in m (element DOF order).
pub fn centrifugal_load_from_spin_matrix(
    element: &ElementRef<'_>,
    displacement: &[f64],
    density: f64,
    axis: &RotorAxis,
    omega: f64,
) -> Result<Vec<f64>, FemError> {
    element.check_vector(displacement, "element displacements")?;
    let m = scalar_mass(element, density);
    let npe = element.npe();
    let proj = axis.projector();
    let p = axis.point();
    let mut out = vec![0.0; 3 * npe];
    for a in 0..npe {
        for b in 0..npe {
            let r = std::array::from_fn(|d| element.coords[b][d] - p[d] + displacement[3 * b + d]);
            let pr = mat_vec(&proj, &r);
            for d in 0..3 {
                out[3 * a + d] += omega * omega * m[a * npe + b] * pr[d];
            }
        }
    }
    Ok(out)
}
