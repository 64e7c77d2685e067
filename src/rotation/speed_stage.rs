//! The `speed` stage of `nlmodes run` (issue 23, items 2-4, 6, 8): the centrifugal prestress at
//! the operating speed of `[rotation]` (and at each of its `map_speeds`), the running gaps, and
//! the Craig-Bampton reduction of K(Omega) onto the prestressed contact nodes. Writes
//! `results/<case>/speed/` (`speeds/<rpm>rpm/` for a map speed):
//! `prestress.vtu` (displacement, m; von Mises stress, Pa), `prestress.json`, `model/` (the
//! reduced model at speed, read by the backbone at speed) and `section.md` (the report's
//! section). Reruns when the FE model, `[model]` or the operating speed and kinematics change.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use anyhow::Result;
use nlmodes_fem::Isotropic;
use serde::Serialize;

use crate::case::Case;
use crate::layout::Layout;
use crate::mesh::fe_model::FeModel;
use crate::rotation::prestress::{self, Prestress};
use crate::rotation::rotation_mpi::FullSolver;
use crate::rotation::rotation_settings::{RotationSection, RPM_TO_RAD_S};
use crate::rotation::static_states;
use crate::stage::{Only, Stage};
use crate::stage_hash::fnv1a;

/// What `prestress.json` holds (SI units, speeds also in rpm).
#[derive(Serialize)]
pub struct PrestressSummary {
    pub speed_rpm: f64,
    pub omega_rad_s: f64,
    pub kinematics: String,
    /// Newton history: per load step, ||r|| / ||f_c|| of each iteration.
    pub newton: Vec<String>,
    /// Largest nodal von Mises stress over the clamped groups, Pa, and its mesh node (1-based).
    pub root_von_mises_pa: Option<f64>,
    pub root_von_mises_node: Option<usize>,
    /// Per contact node (leading to trailing edge): mesh node (1-based), radial growth (m), cold
    /// and running gaps (m).
    pub contact_mesh_nodes: Vec<usize>,
    pub radial_growth_m: Vec<f64>,
    pub cold_gap_m: f64,
    pub running_gap_m: Vec<f64>,
    /// The speed (rpm) at which the first contact node would close its gap statically
    /// (growth ~ Omega^2).
    pub static_closure_rpm: Option<f64>,
    /// The speed (rpm) of the Campbell march's state the Newton solve started from
    /// (`crate::rotation::static_states`); `None`: from rest.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub started_from_rpm: Option<f64>,
}

/// The stage: inputs' hash and outputs.
pub struct SpeedStage<'a> {
    case: &'a Case,
    rotation: &'a RotationSection,
    material: &'a Isotropic,
    /// The speed, rpm.
    speed_rpm: f64,
    layout: Layout,
    mesh: PathBuf,
    hash: String,
    /// Where the Campbell stage keeps its static states, and their key.
    states: (PathBuf, String),
}

impl<'a> SpeedStage<'a> {
    /// The stage at `speed_rpm`: the operating speed's results in `speed/`, another speed's in
    /// `speeds/<rpm>rpm/` (`map_speed_layout`).
    pub fn at(
        case: &'a Case,
        rotation: &'a RotationSection,
        material: &'a Isotropic,
        layout: &Layout,
        fe_hash: &str,
        speed_rpm: f64,
    ) -> Self {
        let inputs =
            serde_json::to_vec(&(&case.model, speed_rpm, &rotation.kinematics)).unwrap_or_default();
        let own = if speed_rpm == rotation.operating_speed {
            speed_layout(layout)
        } else {
            map_speed_layout(layout, speed_rpm)
        };
        Self {
            case,
            rotation,
            material,
            speed_rpm,
            layout: own,
            mesh: layout.mesh(),
            hash: fnv1a(&[fe_hash.as_bytes(), &inputs]),
            states: (
                static_states::states_dir(&layout.shared),
                static_states::states_key(
                    fe_hash,
                    (case.model.rotor_axis_point, case.model.rotor_axis_direction),
                    &rotation.kinematics,
                ),
            ),
        }
    }

    /// The speed, rpm.
    pub fn speed_rpm(&self) -> f64 {
        self.speed_rpm
    }

    /// The case key the speed comes from.
    fn key(&self) -> &'static str {
        if self.speed_rpm == self.rotation.operating_speed {
            "rotation.operating_speed"
        } else {
            "rotation.map_speeds"
        }
    }

    /// The results folder relative to the case's: `speed` or `speeds/<rpm>rpm`.
    fn dir_name(&self) -> String {
        if self.speed_rpm == self.rotation.operating_speed {
            "speed".into()
        } else {
            format!("speeds/{}rpm", self.speed_rpm)
        }
    }

    fn prestress_and_model(&self) -> Result<PrestressSummary> {
        let material = self.material;
        let mut fe = FeModel::build(&self.mesh, material, &self.case.model.clamp)?;
        let m = &self.case.model;
        let axis = prestress::fem_axis(m.rotor_axis_point, m.rotor_axis_direction)?;
        let nodes = crate::reduce::ordered_contact_nodes(&fe, &m.contact_group)?;
        let omega = self.speed_rpm * RPM_TO_RAD_S;
        // Over the ranks under mpirun: the Newton steps and the reduction of K(Omega).
        let mut solver = FullSolver::of(&fe, &self.mesh, material);
        let nonlinear = self.rotation.nonlinear();
        let start = nonlinear
            .then(|| static_states::march_start(&self.states.0, &self.states.1, omega, &fe.dofs))
            .flatten();
        let p = prestress::at_speed(
            &fe,
            material,
            &axis,
            (omega, self.key()),
            (nonlinear, start.as_ref()),
            (&nodes, m.gap),
            &mut solver,
        )?;
        let mut summary = summarize(&p, self.rotation, &nodes, m.gap);
        summary.started_from_rpm = start.map(|s| s.omega / RPM_TO_RAD_S);
        if let Some(rpm) = summary.started_from_rpm {
            tracing::info!("prestress Newton from the Campbell march's state at {rpm:.1} rpm");
        }
        for line in &summary.newton {
            tracing::info!("prestress Newton: {line}");
        }
        crate::ui::say(&short_summary(&summary));
        std::fs::create_dir_all(&self.layout.root)?;
        write_field(&fe, &p, &self.layout.root.join("prestress.vtu"))?;
        nlmodes_output::write_json(&self.layout.root.join("prestress.json"), &summary)?;
        let mut settings = crate::reduce::reduce_stage::reduce_settings(self.case)?;
        settings.running = Some(crate::reduce::RunningContact {
            displacement: &p.solution.displacement,
            gaps: &p.running_gaps,
        });
        fe.k = p.stiffness;
        let (mut model, _) = solver.reduce(&fe, &settings)?;
        crate::reduce::write_model(&mut model, &self.layout.model(), &self.mesh)?;
        Ok(summary)
    }
}

impl Stage for SpeedStage<'_> {
    fn name(&self) -> String {
        "speed".into()
    }
    fn only(&self) -> Only {
        Only::Speed
    }
    fn hash(&self) -> &str {
        &self.hash
    }
    fn layout(&self) -> &Layout {
        &self.layout
    }
    fn outputs(&self) -> Vec<PathBuf> {
        let root = &self.layout.root;
        vec![
            self.layout.model().join("model.json"),
            root.join("prestress.json"),
            root.join("prestress.vtu"),
            root.join("section.md"),
        ]
    }
    fn work(&self) -> Result<()> {
        let root = &self.layout.root;
        let st = crate::ui::Stage::start("speed");
        let summary = self.prestress_and_model()?;
        let operating = self.speed_rpm == self.rotation.operating_speed;
        let text = section(&summary, operating, &self.dir_name());
        crate::post::output::write_atomic(&root.join("section.md"), text.as_bytes())?;
        st.done(&format!(
            "prestress and reduced model at {:.0} rpm in {}",
            summary.speed_rpm,
            root.display()
        ));
        Ok(())
    }
}

/// The results at the operating speed live in `results/<case>/speed/`, laid out as a case of
/// their own (model/, backbone/, amplitude folders, report.md).
pub fn speed_layout(layout: &Layout) -> Layout {
    Layout::new(layout.shared.join("speed"))
}

/// The results at a map speed (`[rotation] map_speeds`): `results/<case>/speeds/<rpm>rpm/`.
pub fn map_speed_layout(layout: &Layout, speed_rpm: f64) -> Layout {
    Layout::new(layout.shared.join("speeds").join(format!("{speed_rpm}rpm")))
}

fn summarize(p: &Prestress, r: &RotationSection, nodes: &[usize], cold: f64) -> PrestressSummary {
    let worst = (0..p.growth.len()).max_by(|&a, &b| p.growth[a].total_cmp(&p.growth[b]));
    PrestressSummary {
        speed_rpm: p.omega / RPM_TO_RAD_S,
        omega_rad_s: p.omega,
        kinematics: r.kinematics.clone(),
        newton: prestress::newton_history(&p.solution.steps),
        root_von_mises_pa: p.root_stress.map(|(_, v)| v),
        root_von_mises_node: p.root_stress.map(|(n, _)| n + 1),
        contact_mesh_nodes: nodes.iter().map(|n| n + 1).collect(),
        radial_growth_m: p.growth.clone(),
        cold_gap_m: cold,
        running_gap_m: p.running_gaps.clone(),
        static_closure_rpm: worst.and_then(|j| prestress::closure_rpm(p.omega, p.growth[j], cold)),
        started_from_rpm: None,
    }
}

fn range(v: &[f64]) -> (f64, f64) {
    v.iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &x| {
            (a.min(x), b.max(x))
        })
}

/// Two lines for the terminal.
fn short_summary(s: &PrestressSummary) -> String {
    let (gmin, gmax) = range(&s.running_gap_m);
    let (umin, umax) = range(&s.radial_growth_m);
    format!(
        "prestress at {:.0} rpm ({}): root von Mises {:.1} MPa, tip radial growth {:.3e} .. {:.3e} \
         m\nrunning gap {:.3e} .. {:.3e} m (cold {:.3e} m); static closure at about {:.0} rpm",
        s.speed_rpm,
        s.kinematics,
        s.root_von_mises_pa.unwrap_or(f64::NAN) * 1e-6,
        umin,
        umax,
        gmin,
        gmax,
        s.cold_gap_m,
        s.static_closure_rpm.unwrap_or(f64::INFINITY)
    )
}

/// `prestress.vtu`: the static displacement (m) and the nodal von Mises stress (Pa).
fn write_field(fe: &FeModel, p: &Prestress, path: &Path) -> Result<()> {
    use nlmodes_output::{Field, Precision, VtuEncoding, VtuWriter};
    let fields = [
        Field::vector("displacement", &p.solution.displacement).f32(),
        Field::scalar("von_mises", &p.von_mises).f32(),
    ];
    let mesh = crate::post::output::vtu_mesh(&fe.mesh);
    let writer = VtuWriter::new(path, &mesh, VtuEncoding::Zlib, Precision::F32)?;
    Ok(writer.write(path, &fields, &[])?)
}

/// The report's section on the prestress.
fn section(s: &PrestressSummary, operating: bool, dir: &str) -> String {
    let mut out = String::from("## The blade at speed\n\n");
    let which = if operating {
        "Operating speed"
    } else {
        "Map speed"
    };
    let (gmin, gmax) = range(&s.running_gap_m);
    let (umin, umax) = range(&s.radial_growth_m);
    let _ = writeln!(
        out,
        "{which} {:.0} rpm ({:.2} rad/s), centrifugal static solve `{}` (the load \
         following the deformation for `nonlinear`). Root von Mises stress (largest nodal value \
         over the clamped groups): {:.1} MPa. Radial growth of the contact nodes {:.3e} .. {:.3e} \
         m; running gap {:.3e} .. {:.3e} m from the cold gap {:.3e} m; the gap would close \
         statically at about {:.0} rpm. Fields: `{dir}/prestress.vtu` (displacement, von \
         Mises); numbers: `{dir}/prestress.json`; the nonlinear mode at speed: \
         `{dir}/report.md`.\n",
        s.speed_rpm,
        s.omega_rad_s,
        s.kinematics,
        s.root_von_mises_pa.unwrap_or(f64::NAN) * 1e-6,
        umin,
        umax,
        gmin,
        gmax,
        s.cold_gap_m,
        s.static_closure_rpm.unwrap_or(f64::INFINITY)
    );
    let from = s.started_from_rpm.map_or("rest".to_string(), |rpm| {
        format!("the Campbell march's converged state at {rpm:.0} rpm")
    });
    let _ = writeln!(
        out,
        "Newton history (||r|| / ||f_c|| per iteration), from {from}:\n"
    );
    for line in &s.newton {
        let _ = writeln!(out, "- {line}");
    }
    out.push('\n');
    out
}
