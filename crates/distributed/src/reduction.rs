//! The Craig-Bampton reduction over MPI (`nlmodes_modal::craig_bampton_with_loads` is the
//! serial one; same basis T = [[I, 0], [Psi, Phi]], same reduced matrices, docs/DESIGN.md
//! section 4): distributed assembly, the fixed-interface modes by SLEPc, the constraint modes
//! and static corrections in one MUMPS solve with the same factor of K_ii, the projection
//! T^T K T, T^T M T as distributed products, and the basis gathered on rank 0, which returns
//! the [`CraigBampton`] the serial path would have.

use faer::Mat;
use nlmodes_fem::{DofMap, Mesh};
use nlmodes_modal::dense::{relative_asymmetry, symmetrize};
use nlmodes_modal::{tall_gram, CraigBampton};

use crate::collective::{gather_to_root, max_all, sum_all};
use crate::error::{DistributedError, Result};
use crate::layout::Layout;
use crate::operators::Operators;
use crate::pencil::{nearest_modes, Pencil, ShiftInvert};
use crate::petsc::{peak_rss_gb, IndexSet, Matrix};
use crate::restricted::dot_all;
use crate::session::world;
use crate::static_solve::Factor;

/// What the reduction needs: the mesh side of the FE model and the reduction's settings.
pub struct ReductionInput<'a> {
    pub mesh: &'a Mesh,
    /// K and M: assembled over the ranks, or K(Omega) and M sent by rank 0.
    pub operators: Operators<'a>,
    pub dofs: &'a DofMap,
    /// Boundary DOFs (free numbering, the caller's order).
    pub boundary: &'a [usize],
    /// Number of fixed-interface modes.
    pub n_modes: usize,
    /// Full-model modes computed to check the reduction (0: none).
    pub check_modes: usize,
    /// Loads (free numbering, N) whose static corrections join the basis.
    pub loads: &'a [Vec<f64>],
}

/// The reduction on rank 0: the basis and matrices, and the check's full-model frequencies (Hz).
pub struct Reduction {
    pub cb: CraigBampton,
    pub full_check_hz: Option<Vec<f64>>,
}

/// Logs a finished step with its wall time and this rank's peak memory.
fn logged(step: &str, start: std::time::Instant) {
    tracing::info!(
        "MPI rank {}: {step}, {:.2} s, peak RSS {:.2} GB",
        world().map_or(0, |w| w.rank),
        start.elapsed().as_secs_f64(),
        peak_rss_gb()
    );
}

/// The Craig-Bampton reduction over the ranks of the session: `Some` on rank 0, `None` on the
/// others (collective: every rank calls it with the same input).
pub fn craig_bampton(input: &ReductionInput) -> Result<Option<Reduction>> {
    let world = world().ok_or_else(|| DistributedError::Invalid("no MPI session".into()))?;
    let n_free = input.dofs.n_free();
    let position = boundary_positions(input, n_free)?;
    let t = std::time::Instant::now();
    let layout = Layout::new(input.mesh, input.dofs, world)?;
    let (k, m) = input.operators.build(input.mesh, input.dofs, &layout)?;
    logged(
        &format!(
            "partition and assembly of {} of {} elements, rows {:?} of {n_free}",
            layout.elements.len(),
            input.mesh.n_elements(),
            layout.owned()
        ),
        t,
    );
    let interior_rows: Vec<usize> = layout
        .owned()
        .filter(|&r| position[layout.free_of_row[r]].is_none())
        .collect();
    let (psi, phi, eigenvalues) = interior_solves(input, &layout, &k, &m, &interior_rows)?;
    let full_check_hz = full_check(input, &layout, &k, &m)?;
    let t = std::time::Instant::now();
    let basis = Basis {
        layout: &layout,
        position: &position,
        psi: &psi,
        phi: &phi,
    };
    let (k_r, m_r) = basis.project(&k, &m)?;
    drop((k, m));
    logged("projection T^T K T, T^T M T", t);
    let t = std::time::Instant::now();
    let gathered = basis.gather(&interior_rows)?;
    logged("basis gathered on rank 0", t);
    let Some(GatheredBasis { interior, psi, phi }) = gathered else {
        return Ok(None);
    };
    let (mut k_r, mut m_r) = (k_r, m_r);
    let (asymmetry_k, asymmetry_m) = (
        relative_asymmetry(k_r.as_ref()),
        relative_asymmetry(m_r.as_ref()),
    );
    symmetrize(&mut k_r);
    symmetrize(&mut m_r);
    let cb = CraigBampton {
        k_r,
        m_r,
        psi,
        phi,
        interior,
        boundary: input.boundary.to_vec(),
        fixed_interface_eigenvalues: eigenvalues,
        asymmetry_k,
        asymmetry_m,
        n_full: n_free,
    };
    Ok(Some(Reduction { cb, full_check_hz }))
}

/// The position of each free DOF in the boundary list, after checking the input (the serial
/// path's checks, before any expensive work).
fn boundary_positions(input: &ReductionInput, n_free: usize) -> Result<Vec<Option<usize>>> {
    let mut position = vec![None; n_free];
    for (j, &b) in input.boundary.iter().enumerate() {
        match position.get_mut(b) {
            None => {
                return Err(DistributedError::Invalid(format!(
                    "boundary DOF {b} out of range: the model has {n_free} free DOFs"
                )))
            }
            Some(Some(_)) => {
                return Err(DistributedError::Invalid(format!(
                    "boundary DOF {b} listed twice"
                )))
            }
            Some(p) => *p = Some(j),
        }
    }
    let n_i = n_free - input.boundary.len();
    if input.boundary.is_empty() || input.n_modes > n_i {
        return Err(DistributedError::Invalid(format!(
            "{} fixed-interface modes with {} boundary DOFs of {n_free}: at least one boundary \
             DOF and at most as many modes as interior DOFs ({n_i}) are needed",
            input.n_modes,
            input.boundary.len()
        )));
    }
    if let Some(f) = input
        .loads
        .iter()
        .find(|f| f.len() != n_free || f.iter().any(|v| !v.is_finite()))
    {
        return Err(DistributedError::Invalid(format!(
            "a static-correction load of {} values (finite ones expected, the model has \
             {n_free})",
            f.len()
        )));
    }
    Ok(position)
}

/// Local rows of Psi, of Phi (modes, then static corrections) and the diagonal of the modal
/// block of K_r: the eigen-solve on (K_ii, M_ii), then one MUMPS solve with the same factor
/// for the n_b constraint modes and the loads.
fn interior_solves(
    input: &ReductionInput,
    layout: &Layout,
    k: &Matrix,
    m: &Matrix,
    interior_rows: &[usize],
) -> Result<(Mat<f64>, Mat<f64>, Vec<f64>)> {
    let serial_index = interior_serial_index(input, layout, interior_rows);
    let pencil = Pencil::restricted(k, m, interior_rows, serial_index)?;
    let t = std::time::Instant::now();
    let (solver, mut phi, mut eigenvalues) = if input.n_modes > 0 {
        let what = format!(
            "K_ii (the {} interior DOFs)",
            input.dofs.n_free() - input.boundary.len()
        );
        let (solver, modes) = nearest_modes(&pencil, input.n_modes, 0.0, &what)?;
        (solver, modes.vectors, modes.eigenvalues)
    } else {
        let solver = ShiftInvert::Static(pencil.factor_k()?);
        (solver, Mat::zeros(interior_rows.len(), 0), Vec::new())
    };
    logged(&format!("{} fixed-interface modes", input.n_modes), t);
    let t = std::time::Instant::now();
    let n_b = input.boundary.len();
    let mut x = right_hand_sides(input, layout, k, interior_rows)?;
    solve_in_chunks(&solver.factor()?, &mut x)?;
    // The factor of K_ii is freed before the full-model check and the projection.
    drop(solver);
    let psi = Mat::from_fn(x.nrows(), n_b, |r, j| x[(r, j)]);
    for l in 0..input.loads.len() {
        let f_max = max_all((0..x.nrows()).fold(0.0, |a: f64, r| {
            a.max(rhs_load(input, layout, interior_rows, l, r).abs())
        }));
        if f_max == 0.0 {
            continue;
        }
        let col: Vec<f64> = (0..x.nrows()).map(|r| x[(r, n_b + l)]).collect();
        if let Some((c, kcc)) = static_correction(&pencil, &phi, col)? {
            phi = Mat::from_fn(phi.nrows(), phi.ncols() + 1, |r, j| {
                if j < phi.ncols() {
                    phi[(r, j)]
                } else {
                    c[r]
                }
            });
            eigenvalues.push(kcc);
        }
    }
    logged(
        &format!(
            "{n_b} constraint modes and {} static correction(s), one MUMPS solve",
            input.loads.len()
        ),
        t,
    );
    Ok((psi, phi, eigenvalues))
}

/// The serial index of each local row of K_ii: the rank of its free DOF among the interior
/// DOFs (the serial path's K_ii has the interior free DOFs in ascending order).
fn interior_serial_index(
    input: &ReductionInput,
    layout: &Layout,
    interior_rows: &[usize],
) -> Vec<usize> {
    let mut boundary = vec![false; input.dofs.n_free()];
    for &b in input.boundary {
        boundary[b] = true;
    }
    let index_of_free: Vec<usize> = boundary
        .iter()
        .scan(0, |next, &is_boundary| {
            let i = *next;
            *next += usize::from(!is_boundary);
            Some(i)
        })
        .collect();
    interior_rows
        .iter()
        .map(|&r| index_of_free[layout.free_of_row[r]])
        .collect()
}

/// Load `l` at local interior row `r`, N.
fn rhs_load(
    input: &ReductionInput,
    layout: &Layout,
    interior_rows: &[usize],
    l: usize,
    r: usize,
) -> f64 {
    input.loads[l][layout.free_of_row[interior_rows[r]]]
}

/// Right-hand sides solved per MUMPS solve: 72 at once added 1.2 GB per rank at 1M DOFs on
/// 2 ranks (PETSc's dense copies and MUMPS's solve workspace), the peak of the reduction;
/// chunks of 24 cost two more passes over the factor (docs/LARGE_MODELS.md, "Over MPI").
const SOLVE_CHUNK: usize = 24;

/// `x` <- K_ii^-1 `x` (local rows of K_ii, any number of columns), [`SOLVE_CHUNK`] columns per
/// MUMPS solve.
fn solve_in_chunks(factor: &Factor, x: &mut Mat<f64>) -> Result<()> {
    for start in (0..x.ncols()).step_by(SOLVE_CHUNK) {
        let width = SOLVE_CHUNK.min(x.ncols() - start);
        let b = Matrix::dense(x.nrows(), width)?;
        b.set_dense_local(x.get(.., start..start + width))?;
        let solved = factor.solve_many(&b)?.dense_local()?;
        x.get_mut(.., start..start + width).copy_from(&solved);
    }
    Ok(())
}

/// The right-hand sides [-K_ib | f_i], local rows of K_ii (the boundary columns of K_ib in the
/// order of the boundary DOFs, from rank 0's extraction of the sorted columns).
fn right_hand_sides(
    input: &ReductionInput,
    layout: &Layout,
    k: &Matrix,
    interior_rows: &[usize],
) -> Result<Mat<f64>> {
    let n_b = input.boundary.len();
    let mut sorted: Vec<(usize, usize)> = input
        .boundary
        .iter()
        .enumerate()
        .map(|(j, &b)| (layout.row_of_free[b], j))
        .collect();
    sorted.sort_unstable();
    let rows: Vec<usize> = sorted.iter().map(|&(row, _)| row).collect();
    let is_i = IndexSet::new(interior_rows)?;
    let is_b = IndexSet::new(if layout.world.is_root() { &rows } else { &[] })?;
    let k_ib = k.submatrix(&is_i, &is_b)?;
    let mut rhs = Mat::from_fn(interior_rows.len(), n_b + input.loads.len(), |r, j| {
        if j < n_b {
            0.0
        } else {
            rhs_load(input, layout, interior_rows, j - n_b, r)
        }
    });
    k_ib.for_each_local_entry(|r, c, v| rhs[(r, sorted[c].1)] = -v)?;
    Ok(rhs)
}

/// The static correction of one load (serial: `craig_bampton_with_loads`): x = K_ii^-1 f_i,
/// M_ii-orthogonalized twice against Phi, M_ii-normalized; with its K_ii Rayleigh quotient;
/// None when less than 1e-10 of its M_ii-norm is left.
fn static_correction(
    pencil: &Pencil,
    phi: &Mat<f64>,
    mut x: Vec<f64>,
) -> Result<Option<(Vec<f64>, f64)>> {
    let m_norm = |x: &[f64]| -> Result<f64> { Ok(dot_all(x, &pencil.m().apply(x)?).sqrt()) };
    let before = m_norm(&x)?;
    for _ in 0..2 {
        let mx = pencil.m().apply(&x)?;
        for j in 0..phi.ncols() {
            let col: Vec<f64> = (0..phi.nrows()).map(|r| phi[(r, j)]).collect();
            let c = dot_all(&col, &mx);
            for (xr, p) in x.iter_mut().zip(&col) {
                *xr -= c * p;
            }
        }
    }
    let after = m_norm(&x)?;
    if after.is_nan() || after <= 1e-10 * before {
        return Ok(None);
    }
    let x: Vec<f64> = x.iter().map(|v| v / after).collect();
    let kxx = dot_all(&x, &pencil.k().apply(&x)?);
    Ok(Some((x, kxx)))
}

/// The frequencies (Hz) of the full model's first `check_modes` modes (a second MUMPS
/// factorization, of K), when asked.
fn full_check(
    input: &ReductionInput,
    layout: &Layout,
    k: &Matrix,
    m: &Matrix,
) -> Result<Option<Vec<f64>>> {
    if input.check_modes == 0 {
        return Ok(None);
    }
    let t = std::time::Instant::now();
    let what = format!("the full model ({} free DOFs)", input.dofs.n_free());
    let pencil = Pencil::whole(k, m, layout.serial_free_index())?;
    let (_, modes) = nearest_modes(&pencil, input.check_modes, 0.0, &what)?;
    logged(&format!("full-model check, {} modes", input.check_modes), t);
    Ok(Some(
        modes
            .eigenvalues
            .iter()
            .map(|l| l.signum() * l.abs().sqrt() / (2.0 * std::f64::consts::PI))
            .collect(),
    ))
}

/// Psi and Phi on rank 0, rows in the serial order: interior free DOFs ascending.
struct GatheredBasis {
    interior: Vec<usize>,
    psi: Mat<f64>,
    phi: Mat<f64>,
}

/// The local rows of the reduction basis.
struct Basis<'a> {
    layout: &'a Layout,
    position: &'a [Option<usize>],
    psi: &'a Mat<f64>,
    phi: &'a Mat<f64>,
}

impl Basis<'_> {
    /// The local rows of T over the free DOFs (PETSc order).
    fn local_t(&self) -> Mat<f64> {
        let n_b = self.psi.ncols();
        let owned = self.layout.owned();
        let mut t = Mat::<f64>::zeros(owned.len(), n_b + self.phi.ncols());
        let mut interior = 0;
        for (li, row) in owned.enumerate() {
            match self.position[self.layout.free_of_row[row]] {
                Some(j) => t[(li, j)] = 1.0,
                None => {
                    for j in 0..n_b {
                        t[(li, j)] = self.psi[(interior, j)];
                    }
                    for j in 0..self.phi.ncols() {
                        t[(li, n_b + j)] = self.phi[(interior, j)];
                    }
                    interior += 1;
                }
            }
        }
        t
    }

    /// K_r = T^T K T and M_r = T^T M T (before symmetrization), on every rank.
    fn project(&self, k: &Matrix, m: &Matrix) -> Result<(Mat<f64>, Mat<f64>)> {
        let t_local = self.local_t();
        let t = k.dense_like_rows(t_local.ncols())?;
        t.set_dense_local(t_local.as_ref())?;
        let mut out = Vec::with_capacity(2);
        for a in [k, m] {
            let at = a.times_dense(&t)?.dense_local()?;
            let n_r = t_local.ncols();
            // On a rank's rows in row chunks over its threads (rayon), as the serial path.
            let r = tall_gram(t_local.as_ref(), at.as_ref());
            let mut flat: Vec<f64> = (0..n_r * n_r).map(|i| r[(i % n_r, i / n_r)]).collect();
            sum_all(&mut flat);
            out.push(Mat::from_fn(n_r, n_r, |i, j| flat[j * n_r + i]));
        }
        let m_r = out.pop().expect("two products");
        let k_r = out.pop().expect("two products");
        Ok((k_r, m_r))
    }

    /// Psi and Phi on rank 0 with their rows in the serial order (interior free DOFs
    /// ascending), and the interior DOFs; `None` on the other ranks. One column at a time.
    fn gather(&self, interior_rows: &[usize]) -> Result<Option<GatheredBasis>> {
        let frees: Vec<u64> = interior_rows
            .iter()
            .map(|&r| self.layout.free_of_row[r] as u64)
            .collect();
        let all_frees = gather_to_root(&frees)?;
        let root = all_frees.map(|all| {
            let interior: Vec<usize> = (0..self.position.len())
                .filter(|&f| self.position[f].is_none())
                .collect();
            let mut row_of = vec![usize::MAX; self.position.len()];
            for (i, &f) in interior.iter().enumerate() {
                row_of[f] = i;
            }
            let target: Vec<usize> = all.iter().map(|&f| row_of[f as usize]).collect();
            (interior, target)
        });
        let n_i = self.position.iter().filter(|p| p.is_none()).count();
        let mut psi = root
            .as_ref()
            .map(|_| Mat::<f64>::zeros(n_i, self.psi.ncols()));
        let mut phi = root
            .as_ref()
            .map(|_| Mat::<f64>::zeros(n_i, self.phi.ncols()));
        for (local, gathered) in [(self.psi, &mut psi), (self.phi, &mut phi)] {
            for j in 0..local.ncols() {
                let col: Vec<f64> = (0..local.nrows()).map(|r| local[(r, j)]).collect();
                if let (Some(values), Some(out), Some((_, target))) =
                    (gather_to_root(&col)?, gathered.as_mut(), root.as_ref())
                {
                    for (&row, v) in target.iter().zip(values) {
                        out[(row, j)] = v;
                    }
                }
            }
        }
        Ok(match (root, psi, phi) {
            (Some((interior, _)), Some(psi), Some(phi)) => {
                Some(GatheredBasis { interior, psi, phi })
            }
            _ => None,
        })
    }
}
