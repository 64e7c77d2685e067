//! `nlmodes`: nonlinear normal modes of elastic structures with frictionless unilateral contact,
//! after Laxalde, Legrand & Pierre (2009). Units: SI throughout (m, kg, s, Pa, Hz).

mod backbone;
mod case;
mod fe_model;
mod figures;
mod gmsh;
mod layout;
mod output;
mod post;
mod reduce;
mod render;
mod report;
mod results;
mod run;
mod ui;

use anyhow::Result;
use clap::{Parser, Subcommand};
use std::collections::BTreeMap;
use std::path::PathBuf;

#[derive(Parser)]
#[command(
    name = "nlmodes",
    version,
    about = "Nonlinear normal modes of elastic structures with frictionless contact (SI units: m, kg, s, Pa, Hz)"
)]
struct Cli {
    /// No progress bars, no log lines below warnings.
    #[arg(long, short, global = true)]
    quiet: bool,
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Mesh a parametric .geo with gmsh into MSH 4.1.
    Mesh {
        /// The .geo file.
        geo: PathBuf,
        /// Output .msh file.
        #[arg(long, short)]
        out: PathBuf,
        /// Element order: 1 (TET4) or 2 (TET10).
        #[arg(long, default_value_t = 2)]
        order: u32,
        /// A .geo parameter, NAME=VALUE (repeatable), passed as `-setnumber`.
        #[arg(long = "set", value_parser = parse_key_value)]
        set: Vec<(String, f64)>,
    },
    /// Linear modes of a mesh: writes DIR/frequencies.csv and DIR/modes.vtu.
    Modes {
        /// The MSH 4.1 mesh (TET4 or TET10).
        mesh: PathBuf,
        /// Dirichlet condition GROUP[:COMPONENTS] (e.g. `root`, `bottom:z`), repeatable.
        #[arg(long = "fix")]
        fix: Vec<String>,
        /// Young's modulus E, Pa.
        #[arg(long, default_value_t = 113.8e9)]
        young: f64,
        /// Poisson's ratio.
        #[arg(long, default_value_t = 0.342)]
        poisson: f64,
        /// Density, kg/m^3.
        #[arg(long, default_value_t = 4430.0)]
        density: f64,
        /// Number of modes.
        #[arg(long, default_value_t = 10)]
        modes: usize,
        /// Shift sigma, rad^2/s^2 (negative for a structure with rigid-body modes).
        #[arg(long, default_value_t = 0.0, allow_hyphen_values = true)]
        sigma: f64,
        /// Output directory.
        #[arg(long, short)]
        out: PathBuf,
    },
    /// Craig-Bampton reduction onto the contact nodes: writes the reduced-model directory.
    Reduce {
        /// The MSH 4.1 mesh.
        mesh: PathBuf,
        /// Dirichlet condition GROUP[:COMPONENTS], repeatable.
        #[arg(long = "fix", default_value = "root")]
        fix: Vec<String>,
        /// The contact node group.
        #[arg(long, default_value = "tip_edge")]
        contact: String,
        /// Young's modulus E, Pa.
        #[arg(long, default_value_t = 113.8e9)]
        young: f64,
        /// Poisson's ratio.
        #[arg(long, default_value_t = 0.342)]
        poisson: f64,
        /// Density, kg/m^3.
        #[arg(long, default_value_t = 4430.0)]
        density: f64,
        /// Number of fixed-interface modes.
        #[arg(long, default_value_t = 40)]
        modes: usize,
        /// Uniform initial radial gap g0, m.
        #[arg(long, default_value_t = 2.0e-4)]
        gap: f64,
        /// Rotor axis point x,y,z (m).
        #[arg(long, value_parser = parse_vec3, default_value = "0,0,0", allow_hyphen_values = true)]
        axis_point: [f64; 3],
        /// Rotor axis direction x,y,z.
        #[arg(long, value_parser = parse_vec3, default_value = "1,0,0", allow_hyphen_values = true)]
        axis_direction: [f64; 3],
        /// Master coordinate (reduced DOF index); default: the contact DOF with the largest
        /// first-mode amplitude.
        #[arg(long)]
        master: Option<usize>,
        /// Number of full-model modes computed to compare with the reduced model (0 to skip).
        #[arg(long, default_value_t = 10)]
        compare: usize,
        /// Output directory (the reduced model).
        #[arg(long, short)]
        out: PathBuf,
    },
    /// Backbone of the first nonlinear mode of a reduced model: writes backbone.csv, backbone.json.
    Backbone {
        /// The reduced-model directory (K.mtx, M.mtx, model.json).
        model: PathBuf,
        /// Largest amplitude, in gaps (q / g0) [default: the settings file's, else 35].
        #[arg(long)]
        q_max: Option<f64>,
        /// First amplitude, in gaps; below grazing [default: the settings file's, else 0.5].
        #[arg(long)]
        q_start: Option<f64>,
        /// Highest harmonic N (default: the study's, cases/blade.toml).
        #[arg(long, default_value_t = 10)]
        harmonics: usize,
        /// Time samples per period m (>= 2N + 1).
        #[arg(long, default_value_t = 128)]
        samples: usize,
        /// Master coordinate (reduced DOF index); default: the model's.
        #[arg(long)]
        master: Option<usize>,
        /// Algorithm 1 parameters and continuation settings as a TOML file with [algorithm] and
        /// [continuation] tables (see cases/blade.toml); flags above override it. Without it, the
        /// defaults of a case file (epsilon = 1e-3 g0 among them).
        #[arg(long)]
        settings: Option<PathBuf>,
        /// Output directory.
        #[arg(long, short)]
        out: PathBuf,
    },
    /// Run a study case (default cases/blade.toml): mesh, modes, reduce, backbone, post.
    /// Each stage reruns only when its inputs changed.
    Run {
        /// The case file.
        #[arg(default_value = "cases/blade.toml")]
        case: PathBuf,
        /// Run only this stage (and the out-of-date stages it needs).
        #[arg(long, value_enum)]
        only: Option<run::Only>,
        /// Rerun even when up to date: the `--only` stage, or every stage without `--only`
        /// (the stages an `--only` stage needs still rerun only when out of date).
        #[arg(long)]
        force: bool,
    },
}

fn parse_vec3(s: &str) -> Result<[f64; 3], String> {
    let v: Vec<f64> = s
        .split(',')
        .map(|x| x.trim().parse::<f64>())
        .collect::<Result<_, _>>()
        .map_err(|_| format!("expected three comma-separated numbers, got `{s}`"))?;
    v.try_into()
        .map_err(|_| format!("expected three comma-separated numbers, got `{s}`"))
}

fn parse_key_value(s: &str) -> Result<(String, f64), String> {
    let (k, v) = s
        .split_once('=')
        .ok_or_else(|| format!("expected NAME=VALUE, got `{s}`"))?;
    let v: f64 = v
        .trim()
        .parse()
        .map_err(|_| format!("value of `{k}` is not a number: `{v}`"))?;
    Ok((k.trim().to_string(), v))
}

fn main() -> std::process::ExitCode {
    let cli = Cli::parse();
    ui::init(cli.quiet);
    match run(cli.command) {
        Ok(()) => std::process::ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e:#}");
            std::process::ExitCode::FAILURE
        }
    }
}

fn run(command: Command) -> Result<()> {
    match command {
        Command::Mesh {
            geo,
            out,
            order,
            set,
        } => {
            let params: BTreeMap<String, f64> = set.into_iter().collect();
            let stage = ui::Stage::start("mesh");
            gmsh::mesh(&geo, &params, order, &out)?;
            stage.done(&format!("wrote {}", out.display()));
            Ok(())
        }
        Command::Modes {
            mesh,
            fix,
            young,
            poisson,
            density,
            modes,
            sigma,
            out,
        } => {
            let material = nlmodes_fem::Isotropic::new(young, poisson, density)?;
            let fe = fe_model::FeModel::build(&mesh, &material, &fix)?;
            let m = fe.modes(modes, sigma)?;
            fe_model::write_modes(&fe, &m, &out)?;
            ui::say(&fe_model::frequency_table(&m));
            Ok(())
        }
        Command::Reduce {
            mesh,
            fix,
            contact,
            young,
            poisson,
            density,
            modes,
            gap,
            axis_point,
            axis_direction,
            master,
            compare,
            out,
        } => {
            let material = nlmodes_fem::Isotropic::new(young, poisson, density)?;
            let fe = fe_model::FeModel::build(&mesh, &material, &fix)?;
            let settings = reduce::ReduceSettings {
                contact_group: &contact,
                axis: nlmodes_modal::RotorAxis::new(axis_point, axis_direction)?,
                gap,
                modes,
                master,
            };
            let (mut model, _) = reduce::reduce(&fe, &settings)?;
            reduce::write_model(&mut model, &out, &mesh)?;
            if compare > 0 {
                let full = fe.modes(compare, 0.0)?;
                ui::say(&reduce::comparison_table(
                    &full.frequencies_hz(),
                    &model.linear_frequencies_hz,
                ));
            }
            Ok(())
        }
        Command::Backbone {
            model,
            q_max,
            q_start,
            harmonics,
            samples,
            master,
            settings,
            out,
        } => {
            let (params, mut cont) = match settings {
                Some(p) => backbone::load_settings(&p)?,
                None => {
                    let study = case::Case::default();
                    (study.algorithm, study.continuation)
                }
            };
            // A flag given on the command line wins over the settings file.
            cont.q_max = q_max.unwrap_or(cont.q_max);
            cont.q_start = q_start.unwrap_or(cont.q_start);
            let reduced = backbone::load_model(&model)?;
            let system = backbone::system_of(&reduced, master)?;
            backbone::check_reaches_contact(&system, &cont)?;
            let hs = nlmodes_nnm::HarmonicSettings::new(harmonics, samples)?;
            let b = backbone::trace(&system, hs, &params, &cont)?;
            backbone::write(&b, &out)?;
            ui::say(&backbone::summary(&b));
            Ok(())
        }
        Command::Run { case, only, force } => run::run(&case, only, force),
    }
}
