//! Craig-Bampton reduction of the clamped FE model onto its contact nodes, and the reduced-model
//! directory (format documented in `nlmodes_modal::reduced_model` and in the README).

pub(crate) mod reduce_mpi;
pub(crate) mod reduce_stage;

use anyhow::{Context, Result};
use faer::Mat;
use nlmodes_fem::{DofMap, Mesh};
use nlmodes_modal::{
    craig_bampton_with_loads, reduced_eigen, ContactNode, CraigBampton, MasterCoordinate,
    MeshReference, ReducedModel, RotorAxis,
};
use std::path::Path;

use crate::exit::bad_input;
use crate::mesh::fe_model::FeModel;
use crate::ui;

/// What the reduction needs besides the FE model.
pub struct ReduceSettings<'a> {
    pub contact_group: &'a str,
    pub axis: RotorAxis,
    /// Uniform initial radial gap g0, m.
    pub gap: f64,
    /// Number of fixed-interface modes.
    pub modes: usize,
    /// Master coordinate: `None` = the contact DOF with the largest first-mode amplitude.
    pub master: Option<usize>,
    /// Full-model modes computed to check the reduced frequencies (0: no check).
    pub check_modes: usize,
    /// The blade at speed (issue 23): contact positions and normals of the prestressed state
    /// and each contact node's running gap; `None` at rest (positions of the mesh, gap `gap`).
    pub running: Option<RunningContact<'a>>,
    /// Loads on the free DOFs whose static corrections join the basis (issue 22).
    pub loads: Vec<Vec<f64>>,
}

/// The contact geometry of a prestressed blade.
pub struct RunningContact<'a> {
    /// Global static displacement (3 per mesh node), m.
    pub displacement: &'a [f64],
    /// Running gap of each contact node in the order of [`ordered_contact_nodes`], m.
    pub gaps: &'a [f64],
}

/// Up to this many DOFs the full-model check runs by default (`auto`): at 93k DOFs (the default
/// blade) it costs a few seconds more with the reduction's factorization reused; at 0.9M DOFs its
/// eigen-solve alone took 83 s (docs/BENCHMARKS.md, "Industrial size").
pub const FULL_CHECK_AUTO_MAX_DOFS: usize = 200_000;

/// Whether the full model's modes are computed to check the reduction (`--full-check`,
/// `[model] full_check`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum FullCheck {
    /// Only up to [`FULL_CHECK_AUTO_MAX_DOFS`] DOFs.
    Auto,
    /// Always.
    On,
    /// Never.
    Off,
}

impl FullCheck {
    /// `"auto"`, `"on"` or `"off"` (the case key's values).
    pub fn parse(s: &str) -> Option<Self> {
        match s {
            "auto" => Some(Self::Auto),
            "on" => Some(Self::On),
            "off" => Some(Self::Off),
            _ => None,
        }
    }

    /// Whether the check runs for a model of `dofs` DOFs.
    pub fn wanted(self, dofs: usize) -> bool {
        match self {
            Self::Auto => dofs <= FULL_CHECK_AUTO_MAX_DOFS,
            Self::On => true,
            Self::Off => false,
        }
    }
}

/// Number of nodes of an MSH 4.1 file, from its `$Nodes` header (`numEntityBlocks numNodes
/// minNodeTag maxNodeTag`), without reading the mesh; None if the file has no such header.
pub fn msh_node_count(path: &Path) -> Option<usize> {
    use std::io::BufRead;
    let file = std::fs::File::open(path).ok()?;
    let mut lines = std::io::BufReader::new(file).lines();
    while let Some(Ok(line)) = lines.next() {
        if line.trim() == "$Nodes" {
            let header = lines.next()?.ok()?;
            return header.split_whitespace().nth(1)?.parse().ok();
        }
    }
    None
}

/// Contact nodes of `group` (mesh node indices), ordered from the leading edge to the trailing edge:
/// along the line through the two farthest-apart nodes, from the end with the smaller y.
pub fn ordered_contact_nodes(fe: &FeModel, group: &str) -> Result<Vec<usize>> {
    contact_nodes_of(&fe.mesh, group)
}

/// [`ordered_contact_nodes`] of a mesh.
fn contact_nodes_of(mesh: &Mesh, group: &str) -> Result<Vec<usize>> {
    let g = mesh.group(group)?;
    let mut nodes = g.nodes.clone();
    if nodes.is_empty() {
        return Err(bad_input(format!("contact group `{group}` has no nodes")));
    }
    let x = |n: usize| mesh.nodes[n];
    let dist2 = |a: [f64; 3], b: [f64; 3]| (0..3).map(|i| (a[i] - b[i]).powi(2)).sum::<f64>();
    let (mut a, mut b, mut best) = (nodes[0], nodes[0], -1.0);
    for &p in &nodes {
        for &q in &nodes {
            let d = dist2(x(p), x(q));
            if d > best {
                (a, b, best) = (p, q, d);
            }
        }
    }
    if x(a)[1] > x(b)[1] {
        std::mem::swap(&mut a, &mut b);
    }
    let (xa, xb) = (x(a), x(b));
    let dir = [xb[0] - xa[0], xb[1] - xa[1], xb[2] - xa[2]];
    let proj = |n: usize| (0..3).map(|i| (x(n)[i] - xa[i]) * dir[i]).sum::<f64>();
    nodes.sort_by(|&p, &q| proj(p).total_cmp(&proj(q)));
    Ok(nodes)
}

/// Two contact nodes at the same point (distinct tags, equal coordinates) would make two
/// identical contact rows: bad input naming both nodes.
fn check_distinct_positions(mesh: &Mesh, nodes: &[usize], group: &str) -> Result<()> {
    let mut sorted: Vec<usize> = nodes.to_vec();
    sorted.sort_by(|&a, &b| {
        let (p, q) = (mesh.nodes[a], mesh.nodes[b]);
        p.iter()
            .zip(&q)
            .map(|(x, y)| x.total_cmp(y))
            .find(|o| o.is_ne())
            .unwrap_or(std::cmp::Ordering::Equal)
    });
    if let Some(w) = sorted
        .windows(2)
        .find(|w| mesh.nodes[w[0]] == mesh.nodes[w[1]])
    {
        return Err(bad_input(format!(
            "contact group `{group}`: mesh nodes {} and {} are both at {:?}: duplicated contact \
             node (each contact point must be one mesh node)",
            w[0] + 1,
            w[1] + 1,
            mesh.nodes[w[0]]
        )));
    }
    Ok(())
}

/// Reduce `fe` by Craig-Bampton onto the three DOFs of every contact node; with the frequencies
/// (Hz) of the full model's first `s.check_modes` modes when asked.
pub fn reduce(fe: &FeModel, s: &ReduceSettings) -> Result<(ReducedModel, Option<Vec<f64>>)> {
    let fe_side = MeshSide {
        mesh: &fe.mesh,
        dofs: &fe.dofs,
        clamp: &fe.clamp,
    };
    reduce_with(&fe_side, s, |boundary| {
        let (cb, full) = ui::with_solve_spinner("reduce", |opts| {
            craig_bampton_with_loads(
                &fe.k,
                &fe.m,
                boundary,
                s.modes,
                s.check_modes,
                &s.loads,
                opts,
            )
        })?;
        Ok((cb, full.map(|m| m.frequencies_hz())))
    })
}

/// The mesh side of an FE model: what the reduction needs besides K and M.
pub struct MeshSide<'a> {
    pub mesh: &'a Mesh,
    pub dofs: &'a DofMap,
    /// The Dirichlet specifications applied, for messages.
    pub clamp: &'a [String],
}

/// [`reduce`] over the ranks of an MPI job (`mpirun -n P nlmodes reduce`, the reduce stage of
/// `nlmodes run`), on rank 0: K and M assembled, factorized and reduced by PETSc, MUMPS and
/// SLEPc (`nlmodes_distributed`) with the other ranks, which read the mesh of `source`.
/// K and M are assembled over the ranks, or sent by this process when `root` holds them (the
/// model at speed, K(Omega)).
pub fn reduce_distributed(
    fe_side: &MeshSide,
    source: crate::reduce::reduce_mpi::FeSource,
    s: &ReduceSettings,
    root: crate::reduce::reduce_mpi::RootData,
) -> Result<(ReducedModel, Option<Vec<f64>>)> {
    reduce_with(fe_side, s, |boundary| {
        let task = crate::reduce::reduce_mpi::Task::Reduce {
            fe: source,
            boundary: boundary.to_vec(),
            modes: s.modes,
            check_modes: s.check_modes,
            loads: s.loads.clone(),
            from_root: root.k.is_some(),
        };
        match crate::reduce::reduce_mpi::lead(&task, fe_side.mesh, fe_side.dofs, root)? {
            crate::reduce::reduce_mpi::Delivered::Reduction(r) => Ok((r.cb, r.full_check_hz)),
            _ => anyhow::bail!("a reduction task delivered something else"),
        }
    })
}

/// The reduction with the Craig-Bampton basis of `craig_bampton` (given the boundary DOFs in
/// the free numbering).
fn reduce_with(
    fe: &MeshSide,
    s: &ReduceSettings,
    craig_bampton: impl FnOnce(&[usize]) -> Result<(CraigBampton, Option<Vec<f64>>)>,
) -> Result<(ReducedModel, Option<Vec<f64>>)> {
    if !(s.gap > 0.0 && s.gap.is_finite()) {
        return Err(bad_input(format!(
            "the initial gap must be > 0 m, got {}",
            s.gap
        )));
    }
    let nodes = contact_nodes_of(fe.mesh, s.contact_group)?;
    check_distinct_positions(fe.mesh, &nodes, s.contact_group)?;
    let mut boundary = Vec::with_capacity(3 * nodes.len());
    for &n in &nodes {
        for c in 0..3 {
            let free = fe.dofs.free_index(3 * n + c).ok_or_else(|| {
                let clamped: Vec<String> = fe
                    .clamp
                    .iter()
                    .filter(|spec| {
                        nlmodes_fem::parse_fix_spec(spec).is_ok_and(|(group, _)| {
                            fe.mesh
                                .group(&group)
                                .is_ok_and(|g| g.nodes.binary_search(&n).is_ok())
                        })
                    })
                    .map(|spec| format!("'{spec}'"))
                    .collect();
                bad_input(format!(
                    "contact node {} of group `{}` at {:?} has a fixed DOF: it lies on the \
                     clamped group(s) {}; the contact group must be free",
                    n + 1,
                    s.contact_group,
                    fe.mesh.nodes[n],
                    clamped.join(", ")
                ))
            })?;
            boundary.push(free);
        }
    }
    let stage = ui::Stage::start("reduce");
    let (cb, full) = craig_bampton(&boundary).with_context(|| {
        format!(
            "Craig-Bampton reduction onto {} contact nodes with {} fixed-interface modes",
            nodes.len(),
            s.modes
        )
    })?;
    tracing::info!(
        "reduced model: {} coordinates; asymmetry before symmetrization K_r {:.1e}, M_r {:.1e}",
        cb.n_reduced(),
        cb.asymmetry_k,
        cb.asymmetry_m
    );
    let (eigenvalues, vectors) = reduced_eigen(&cb)?;
    let freqs: Vec<f64> = eigenvalues
        .iter()
        .take(20)
        .map(|l| l.signum() * l.abs().sqrt() / (2.0 * std::f64::consts::PI))
        .collect();
    let contact_nodes = nodes
        .iter()
        .enumerate()
        .map(|(j, &n)| {
            let x = fe.mesh.nodes[n];
            let (position, gap) = match &s.running {
                None => (x, s.gap),
                Some(r) => {
                    let u = &r.displacement[3 * n..3 * n + 3];
                    ([x[0] + u[0], x[1] + u[1], x[2] + u[2]], r.gaps[j])
                }
            };
            Ok(ContactNode {
                mesh_node: Some(n as u64 + 1),
                dofs: [3 * j, 3 * j + 1, 3 * j + 2],
                position,
                radial: s.axis.radial_unit_vector(position)?,
                gap,
            })
        })
        .collect::<Result<Vec<_>>>()?;
    let master = master_coordinate(s.master, &vectors, &contact_nodes, cb.n_reduced())?;
    let fixed: Vec<usize> = (0..fe.dofs.n_global())
        .filter(|&d| fe.dofs.is_fixed(d))
        .collect();
    let model = ReducedModel {
        k: cb.k_r.clone(),
        m: cb.m_r.clone(),
        contact_nodes,
        rotor_axis: s.axis.clone(),
        master,
        linear_frequencies_hz: freqs,
        recovery: Some(cb.recovery_basis()),
        mesh: Some(MeshReference {
            msh_file: String::new(),
            n_full_dofs: fe.dofs.n_global(),
            fixed_dofs: fixed,
        }),
    };
    stage.done(&format!(
        "{} constraint modes + {} fixed-interface modes{}",
        boundary.len(),
        s.modes,
        match cb.phi.ncols() - s.modes {
            0 => String::new(),
            k => format!(" + {k} static correction(s)"),
        }
    ));
    Ok((model, full))
}

/// The master coordinate: given, or the contact DOF with the largest amplitude in the first mode.
fn master_coordinate(
    given: Option<usize>,
    vectors: &Mat<f64>,
    contact: &[ContactNode],
    n: usize,
) -> Result<MasterCoordinate> {
    let describe = |dof: usize| {
        for (j, c) in contact.iter().enumerate() {
            if let Some(k) = c.dofs.iter().position(|&d| d == dof) {
                return format!(
                    "{} displacement of contact node {} of {} (mesh node {}), m",
                    ["x", "y", "z"][k],
                    j + 1,
                    contact.len(),
                    c.mesh_node.unwrap_or(0)
                );
            }
        }
        format!("reduced coordinate {dof}")
    };
    let dof = match given {
        Some(d) if d < n => d,
        Some(d) => {
            return Err(bad_input(format!(
                "master coordinate {d} is out of range: the reduced model has {n} coordinates"
            )))
        }
        None => contact
            .iter()
            .flat_map(|c| c.dofs)
            .max_by(|&a, &b| vectors[(a, 0)].abs().total_cmp(&vectors[(b, 0)].abs()))
            .context("no contact DOF")?,
    };
    Ok(MasterCoordinate {
        dof,
        description: describe(dof),
    })
}

/// Write the model directory, pointing its mesh reference at `msh` (made relative when possible).
pub fn write_model(model: &mut ReducedModel, dir: &Path, msh: &Path) -> Result<()> {
    std::fs::create_dir_all(dir).with_context(|| format!("cannot create {}", dir.display()))?;
    if let Some(m) = model.mesh.as_mut() {
        let abs = std::fs::canonicalize(msh).unwrap_or_else(|_| msh.to_path_buf());
        m.msh_file = abs.to_string_lossy().into_owned();
    }
    // The compact recovery file: R feeds only the Float32 output fields and pictures.
    let predictions = match &model.mesh {
        Some(reference) => crate::post::output::mid_edge_predictions(msh, reference)?,
        None => Vec::new(),
    };
    model
        .write_with(
            dir,
            &nlmodes_modal::RecoveryStorage::Fixed24 { predictions },
        )
        .with_context(|| format!("writing the reduced model to {}", dir.display()))
}

/// The first reduced frequencies beside the full model's, with their relative error.
/// (For `nlmodes reduce` the full ones come from the same factorization, see
/// `nlmodes_modal::craig_bampton_with_check`.)
pub fn comparison_table(full_hz: &[f64], reduced_hz: &[f64]) -> String {
    let mut s = format!(
        "{:>5} {:>14} {:>14} {:>12}\n",
        "mode", "full [Hz]", "reduced [Hz]", "rel. error"
    );
    for (i, (f, r)) in full_hz.iter().zip(reduced_hz).take(10).enumerate() {
        s.push_str(&format!(
            "{:>5} {f:>14.4} {r:>14.4} {:>12.2e}\n",
            i + 1,
            (r - f) / f
        ));
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn full_check_auto_stops_above_the_threshold() {
        assert!(FullCheck::Auto.wanted(93_138));
        assert!(FullCheck::Auto.wanted(FULL_CHECK_AUTO_MAX_DOFS));
        assert!(!FullCheck::Auto.wanted(FULL_CHECK_AUTO_MAX_DOFS + 1));
        assert!(FullCheck::On.wanted(2_000_000));
        assert!(!FullCheck::Off.wanted(10));
        assert_eq!(FullCheck::parse("off"), Some(FullCheck::Off));
        assert_eq!(FullCheck::parse("yes"), None);
    }

    #[test]
    fn node_count_comes_from_the_nodes_header() {
        let dir = std::env::temp_dir().join(format!("nlmodes-msh-count-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("m.msh");
        let text = "$MeshFormat\n4.1 0 8\n$EndMeshFormat\n$Nodes\n3 78840 1 78840\n1 0 0 1\n";
        std::fs::write(&path, text).unwrap();
        assert_eq!(msh_node_count(&path), Some(78840));
        std::fs::write(&path, "$MeshFormat\n4.1 0 8\n").unwrap();
        assert_eq!(msh_node_count(&path), None);
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
