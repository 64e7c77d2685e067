//! The stiffness of the rotating blade along the speeds of a range (issue 23, item 5; issue 39;
//! docs/ROTATION.md, "Campbell diagram"): [`SpeedFamily`].
//!
//! With the nonlinear prestress (the default) each speed has its own total-Lagrangian static
//! state, marched from rest through the speeds in ascending order (each Newton solve starts
//! from the quadratic extrapolation of the three previous states), and its stiffness at speed
//! K(Omega) = K_T(u0(Omega)) - Omega^2 M_spin is the tangent of the last Newton iteration. On
//! the twisted blade the linear prestress (u = Omega^2 u_1, K = K_e + K_sigma(u) - Omega^2
//! M_spin, one static solve) is 1-2 % off on the second and third modes at 8000 rpm: the
//! linear static state overestimates the lateral bending under the centrifugal load (the
//! stiffening that limits it appears only in the nonlinear solve); for the same reason K_T is
//! not a low-order polynomial in Omega^2 (a quadratic through three speeds was 0.6 % off
//! between them).
//!
//! The rotating model's physics along the speeds (the linear family, the secant start) is
//! `nlmodes_fem::rotation::speed_march`'s; this module marches and hands each speed's
//! K(Omega), with the sparse Cholesky that solved its Newton systems (ordering and symbolic
//! analysis reusable), to a visitor: what needs K(Omega) at a speed (the eigen-solves of the
//! Ritz basis, the reduction of the parametric model) is done there and then, without
//! assembling K(Omega) again. [`SpeedFamily::at`] assembles it again for the passes after the
//! march (bit for bit the same matrix).

use anyhow::{Context, Result};
use nlmodes_fem::rotation::speed_march::LinearStiffnessFamily;
use nlmodes_fem::rotation::{RotatingModel, RotorAxis, StaticSolution};
use nlmodes_fem::Isotropic;
use sprs::CsMat;

use crate::mesh::fe_model::FeModel;
use crate::rotation::rotation_mpi::FullSolver;

/// How the stiffness at speed is known.
enum Stiffness {
    /// Linear prestress: K(x) = K_e + (x / x_top) (K_top - K_e), x = Omega^2, exact, through
    /// the highest speed.
    Linear(LinearStiffnessFamily),
    /// Nonlinear prestress: the total-Lagrangian static states at the speeds of the family,
    /// K(Omega) = K_T(u0(Omega)) - Omega^2 M_spin assembled from them on demand.
    Nonlinear(Vec<StaticSolution>),
}

/// K(Omega) on the free DOFs (N/m) along the speeds of a range, M (kg), and the solver of its
/// static solves: the sparse Cholesky whose analysis (of the mesh's pattern) the
/// factorizations of K(Omega) reuse, or MUMPS over the ranks under mpirun ([`FullSolver`]).
pub struct SpeedFamily<'m> {
    model: RotatingModel<'m>,
    stiffness: Stiffness,
    pub m: CsMat<f64>,
    solver: FullSolver,
    /// The march's K(Omega), kept when they fit in memory.
    kept: Option<KeptStiffness>,
}

/// The values of K(Omega) at the speeds of a march (one pattern, the mesh's), so that
/// [`SpeedFamily::at`] need not assemble them again: kept when all of them take at most a
/// quarter of the memory available (730 MB for the default blade's 14 speeds).
struct KeptStiffness {
    indptr: Vec<usize>,
    indices: Vec<usize>,
    values: Vec<(f64, Vec<f64>)>,
}

impl KeptStiffness {
    /// Room for `count` matrices like `k`, or `None`.
    fn with_room(k: &CsMat<f64>, count: usize) -> Option<Self> {
        let bytes = count * k.nnz() * std::mem::size_of::<f64>();
        let available = nlmodes_modal::memory::available_bytes()?;
        (bytes <= available / 4).then(|| Self {
            indptr: k.indptr().raw_storage().to_vec(),
            indices: k.indices().to_vec(),
            values: Vec::with_capacity(count),
        })
    }

    /// Keeps `k` (N/m) at `omega` (rad/s) if it has the pattern.
    fn keep(&mut self, omega: f64, k: &CsMat<f64>) {
        if k.is_csc() && k.indptr().raw_storage() == self.indptr && k.indices() == self.indices {
            self.values.push((omega, k.data().to_vec()));
        }
    }

    fn at(&self, omega: f64) -> Option<Result<CsMat<f64>>> {
        let (_, values) = self.values.iter().find(|v| v.0 == omega)?;
        let n = self.indptr.len() - 1;
        let shape = (n, n);
        let (indptr, indices) = (self.indptr.clone(), self.indices.clone());
        Some(
            CsMat::try_new_csc(shape, indptr, indices, values.clone())
                .map_err(|(_, _, _, e)| anyhow::anyhow!("a kept K(Omega): {e}")),
        )
    }
}

/// What the march hands to its visitor at each speed.
pub struct SpeedPoint<'a> {
    /// Speed, rad/s.
    pub omega: f64,
    /// K(Omega) on the free DOFs, N/m (exactly symmetric).
    pub stiffness: &'a CsMat<f64>,
    /// The static displacement on all 3n DOFs, m (with the linear prestress, (Omega /
    /// Omega_top)^2 times the state at the highest speed).
    pub displacement: &'a [f64],
    /// The solver of the static solves: its factorization of K(Omega) reuses their analysis
    /// (over the ranks under mpirun).
    pub solver: &'a mut FullSolver,
}

impl<'m> SpeedFamily<'m> {
    /// The family of the clamped model `fe` turning about `axis` at `speeds` and `side` (rad/s,
    /// any order); `visit` is called at each speed, in ascending order, with K(Omega) (module
    /// docs). With the nonlinear prestress the static states at `speeds` are marched from rest,
    /// and those at `side` solved on the side of the march (from the marched states below
    /// them, without entering its sequence: the marched states are bit for bit those of a
    /// march without side speeds); with the linear one a single static solve at the highest
    /// speed serves every speed. `solver` solves the static states and serves the visitors'
    /// solves (`FullSolver::default()` on this process).
    pub fn of(
        mut solver: FullSolver,
        fe: &'m FeModel,
        material: &Isotropic,
        axis: &RotorAxis,
        nonlinear: bool,
        (speeds, side): (&[f64], &[f64]),
        visit: &mut dyn FnMut(SpeedPoint<'_>) -> Result<()>,
    ) -> Result<Self> {
        let model = RotatingModel::new(&fe.mesh, *material, *axis, fe.dofs.clone())
            .context("the rotating model")?;
        let sorted = |v: &[f64]| {
            let mut v = v.to_vec();
            v.sort_by(f64::total_cmp);
            v.dedup();
            v
        };
        let (marched, side) = (sorted(speeds), sorted(side));
        let mut kept: Option<Option<KeptStiffness>> = None;
        let stiffness = if nonlinear {
            let count = marched.len() + side.len();
            let mut keeping = |p: SpeedPoint<'_>| {
                let kept = kept.get_or_insert_with(|| KeptStiffness::with_room(p.stiffness, count));
                if let Some(k) = kept {
                    k.keep(p.omega, p.stiffness);
                }
                visit(p)
            };
            Stiffness::Nonlinear(march(&model, (&marched, &side), &mut solver, &mut keeping)?)
        } else {
            let sorted = sorted(&[marched, side].concat());
            let top = sorted.last().copied().unwrap_or(0.0);
            let top = if top > 0.0 { top } else { 1.0 };
            let state = model
                .solve_linearized(top, false, &mut solver)
                .context("the linear centrifugal static solve")?;
            let stiffness = Stiffness::Linear(LinearStiffnessFamily::new(
                model.linear_operator(0.0)?,
                model.stiffness_at_speed(&state)?,
                top,
            ));
            for &omega in &sorted {
                let k = linear_at(&stiffness, omega).expect("a linear family");
                let scale = (omega / top).powi(2);
                let displacement: Vec<f64> = state.displacement.iter().map(|u| scale * u).collect();
                visit(SpeedPoint {
                    omega,
                    stiffness: &k,
                    displacement: &displacement,
                    solver: &mut solver,
                })?;
            }
            stiffness
        };
        Ok(Self {
            model,
            stiffness,
            m: fe.m.clone(),
            solver,
            kept: kept.flatten(),
        })
    }

    /// K(Omega), N/m; with the nonlinear prestress `omega` must be one of the family's speeds
    /// (assembled again from its static state unless kept from the march: the same bits).
    pub fn at(&self, omega: f64) -> Result<CsMat<f64>> {
        if let Some(k) = linear_at(&self.stiffness, omega) {
            return Ok(k);
        }
        if let Some(k) = self.kept.as_ref().and_then(|kept| kept.at(omega)) {
            return k;
        }
        let Stiffness::Nonlinear(states) = &self.stiffness else {
            unreachable!("a linear family answered above");
        };
        let state = states
            .iter()
            .find(|s| s.omega == omega)
            .with_context(|| format!("no static state at {omega} rad/s"))?;
        Ok(self.model.stiffness_at_speed(state)?)
    }

    /// The total-Lagrangian static states of the family (marched and side speeds, ascending
    /// within each); none with the linear prestress.
    pub fn static_states(&self) -> &[StaticSolution] {
        match &self.stiffness {
            Stiffness::Nonlinear(states) => states,
            Stiffness::Linear(_) => &[],
        }
    }

    /// The rotating model (mesh, material, axis, DOF map).
    pub fn model(&self) -> &RotatingModel<'m> {
        &self.model
    }

    /// M and the solver of the family's static solves (its analysis reusable for K(Omega)).
    pub fn mass_and_solver(&mut self) -> (&CsMat<f64>, &mut FullSolver) {
        (&self.m, &mut self.solver)
    }
}

/// K(Omega) of a linear family, `None` for a nonlinear one.
fn linear_at(stiffness: &Stiffness, omega: f64) -> Option<CsMat<f64>> {
    let Stiffness::Linear(family) = stiffness else {
        return None;
    };
    Some(family.at(omega))
}

/// The nonlinear static states at `marched` (rad/s, ascending, distinct), each from the
/// previous ones, and at `side` (ascending), each from the marched states below it; `visit`
/// gets each speed's K(Omega), in ascending order of speed. The states are returned in that
/// order.
fn march(
    model: &RotatingModel<'_>,
    (marched, side): (&[f64], &[f64]),
    solver: &mut FullSolver,
    visit: &mut dyn FnMut(SpeedPoint<'_>) -> Result<()>,
) -> Result<Vec<StaticSolution>> {
    let bar = crate::ui::bar((marched.len() + side.len()) as u64, "prestress");
    let mut states: Vec<StaticSolution> = Vec::with_capacity(marched.len());
    let mut all: Vec<StaticSolution> = Vec::with_capacity(marched.len() + side.len());
    let mut side = side.iter().copied().peekable();
    for &omega in marched {
        while let Some(w) = side.next_if(|&w| w < omega) {
            all.push(solve_at(model, &states, w, solver, visit)?);
            bar.inc(1);
        }
        let state = solve_at(model, &states, omega, solver, visit)?;
        states.push(state.clone());
        all.push(state);
        bar.inc(1);
    }
    for w in side {
        all.push(solve_at(model, &states, w, solver, visit)?);
        bar.inc(1);
    }
    bar.finish_and_clear();
    Ok(all)
}

/// The static state at `omega` from the marched `states` below it (Newton from their
/// predictor), handed to `visit` with its K(Omega).
fn solve_at(
    model: &RotatingModel<'_>,
    states: &[StaticSolution],
    omega: f64,
    solver: &mut FullSolver,
    visit: &mut dyn FnMut(SpeedPoint<'_>) -> Result<()>,
) -> Result<StaticSolution> {
    let options = nlmodes_fem::rotation::NewtonOptions {
        load_steps: 1,
        ..Default::default()
    };
    // The extrapolation in Omega^2 of the last states with the smallest residual: on the
    // default blade one Newton step and two or three chord steps per speed (docs/ROTATION.md,
    // "Campbell diagram").
    let start = model.march_start(states, omega)?;
    let (state, stiffness) = model
        .solve_nonlinear_with_stiffness(start.as_ref(), omega, &options, solver)
        .map_err(|e| {
            crate::rotation::prestress::not_converged("rotation.campbell_range", omega, e)
        })?;
    tracing::info!(
        "prestress at {:.1} rpm: {}",
        omega * 30.0 / std::f64::consts::PI,
        crate::rotation::prestress::newton_history(&state.steps).join("; ")
    );
    visit(SpeedPoint {
        omega,
        stiffness: &stiffness,
        displacement: &state.displacement,
        solver,
    })?;
    Ok(state)
}

/// Test fixtures of the rotating studies.
#[cfg(test)]
pub(crate) mod fixtures {
    use crate::mesh::fe_model::FeModel;
    use nlmodes_fem::{assemble, fixed_dofs, DofMap, Isotropic, TetKind};

    /// Steel: E = 200 GPa, nu = 0.3, rho = 7800 kg/m^3.
    pub fn steel() -> Isotropic {
        Isotropic::new(200e9, 0.3, 7800.0).expect("material")
    }

    /// A TET10 beam 1 m x 4 cm x 4 cm of steel on `cells` hexahedra (6 tetrahedra each),
    /// clamped on its face x = 0 (group `xmin`; the tip face is `xmax`).
    pub fn beam(cells: [usize; 3]) -> FeModel {
        let mesh = nlmodes_fem::generate::box_mesh([1.0, 0.04, 0.04], cells, TetKind::Tet10)
            .expect("mesh");
        let clamp = vec!["xmin".to_string()];
        let fixed = fixed_dofs(&mesh, &clamp).expect("fixed");
        let dofs = DofMap::new(mesh.n_nodes(), &fixed).expect("dofs");
        let (k, m) = assemble(&mesh, &steel()).expect("assembly");
        let (k, m) = (
            dofs.try_restrict(&k).unwrap(),
            dofs.try_restrict(&m).unwrap(),
        );
        FeModel {
            mesh,
            dofs,
            k,
            m,
            clamp,
        }
    }
}
