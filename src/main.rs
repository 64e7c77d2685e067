//! `nlmodes`: nonlinear normal modes of elastic structures with frictionless unilateral contact,
//! after Laxalde, Legrand & Pierre (2009). Units: SI throughout (m, kg, s, Pa, Hz).

mod backbone;
mod campbell;
mod case;
mod child;
mod exit;
mod forced;
mod layout;
mod mesh;
mod post;
mod problems;
mod reduce;
mod rotation;
mod run;
mod speed_sweep;
mod stage;
mod stage_hash;
mod study;
mod ui;
mod validate;

use anyhow::Result;
use clap::{Args, Parser, Subcommand};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use case::{MaterialSection, ModelSection, NnmSection};
use exit::bad_input;

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
        #[command(flatten)]
        material: MaterialArgs,
        /// Number of modes.
        #[arg(long, default_value_t = ModelSection::default().linear_modes)]
        modes: usize,
        /// Shift sigma, rad^2/s^2 (negative for a structure with rigid-body modes).
        #[arg(long, default_value_t = 0.0, allow_hyphen_values = true)]
        sigma: f64,
        /// Output directory.
        #[arg(long, short)]
        out: PathBuf,
    },
    /// Craig-Bampton reduction onto the contact nodes: writes the reduced-model directory.
    Reduce(ReduceArgs),
    /// Backbone of the first nonlinear mode of a reduced model: writes backbone.csv, backbone.json.
    Backbone(BackboneArgs),
    /// Forced response of the damped reduced model around a mode, one curve per force level:
    /// writes frf.csv, frf.json, frf.svg/.png, frf_max.svg/.png.
    Forced(ForcedArgs),
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
    /// Run a parameter study as a Snakemake workflow: the study file names the case keys to
    /// vary and their values (every combination is a run); the runs share the stages whose
    /// inputs are the same; the runs are gathered into study.csv, figures and report.md in
    /// <results_dir>/<study>/ (docs/STUDIES.md).
    Study {
        /// The study file: a `[study]` table (`case`, `name`, `post`, `[study.parameters]`)
        /// and case tables over the base case.
        study: PathBuf,
        /// Cores for the local run (Snakemake's --cores) [default: all].
        #[arg(long)]
        cores: Option<usize>,
        /// Write the workflow (Snakefile, plan.json, cases/, profiles/) without running it:
        /// run it with snakemake there, e.g. on a SLURM cluster.
        #[arg(long)]
        write_only: bool,
        /// More arguments for snakemake, after `--` (e.g. `-- --dry-run`).
        #[arg(last = true)]
        snakemake: Vec<String>,
    },
    /// One job of a study's workflow, as its Snakefile runs it: JOB (`<stage>-<key>` or
    /// `run-<run>`) of plan.json in DIR.
    StudyJob {
        /// The study's folder.
        dir: PathBuf,
        /// The job's id.
        job: String,
    },
    /// Gather a study's runs into study.csv, figures/ and report.md (the workflow's last job;
    /// by hand, it gathers the runs done so far).
    StudyGather {
        /// The study's folder.
        dir: PathBuf,
    },
}

/// The arguments of `nlmodes reduce`.
#[derive(Args)]
struct ReduceArgs {
    /// The MSH 4.1 mesh.
    mesh: PathBuf,
    /// Dirichlet condition GROUP[:COMPONENTS], repeatable.
    #[arg(long = "fix", default_value = "root")]
    fix: Vec<String>,
    /// The contact node group.
    #[arg(long, default_value_t = ModelSection::default().contact_group)]
    contact: String,
    #[command(flatten)]
    material: MaterialArgs,
    /// Number of fixed-interface modes.
    #[arg(long, default_value_t = ModelSection::default().fixed_interface_modes)]
    modes: usize,
    /// Uniform initial radial gap g0, m.
    #[arg(long, default_value_t = ModelSection::default().gap, allow_hyphen_values = true)]
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
    /// The full-model comparison: `auto` runs it up to 200000 free DOFs, `on` always, `off`
    /// never. It reuses the reduction's factorization of K_ii.
    #[arg(long, value_enum, default_value_t = reduce::FullCheck::Auto)]
    full_check: reduce::FullCheck,
    /// Output directory (the reduced model).
    #[arg(long, short)]
    out: PathBuf,
}

/// The arguments of `nlmodes backbone`.
#[derive(Args)]
struct BackboneArgs {
    /// The reduced-model directory (K.mtx, M.mtx, model.json).
    model: PathBuf,
    /// Largest amplitude, in gaps (q / g0) [default: the settings file's, else the case
    /// default 35].
    #[arg(long, allow_hyphen_values = true)]
    q_max: Option<f64>,
    /// First amplitude, in gaps; below grazing [default: the settings file's, else 0.5].
    #[arg(long, allow_hyphen_values = true)]
    q_start: Option<f64>,
    /// Highest harmonic N (default: the study's, cases/blade.toml).
    #[arg(long, default_value_t = NnmSection::default().harmonics)]
    harmonics: usize,
    /// Time samples per period m (>= 2N + 1).
    #[arg(long, default_value_t = NnmSection::default().samples)]
    samples: usize,
    /// Converged orbits of the main-branch points in contact: the largest N whose modes are kept
    /// dynamic (docs/STABILITY.md Sec. 9.4) [default: 4 x harmonics].
    #[arg(long)]
    max_harmonics: Option<usize>,
    /// Master coordinate (reduced DOF index); default: the model's.
    #[arg(long)]
    master: Option<usize>,
    /// Algorithm 1 parameters and continuation settings as a TOML file with [algorithm] and
    /// [continuation] tables (see cases/blade.toml); --q-max and --q-start override it. A key
    /// it does not set takes the default of a case file (epsilon = 1e-4 g0, q_max = 35).
    #[arg(long)]
    settings: Option<PathBuf>,
    /// Output directory.
    #[arg(long, short)]
    out: PathBuf,
}

/// The arguments of `nlmodes forced`.
#[derive(Args)]
struct ForcedArgs {
    /// The reduced-model directory (K.mtx, M.mtx, model.json).
    model: PathBuf,
    /// A TOML file with a `[forced]` table (a case file will do; other tables are ignored):
    /// damping, load, levels, range, harmonics, contact law (keys: README, cases/blade.toml).
    /// Without it, the defaults of `[forced]`.
    #[arg(long)]
    settings: Option<PathBuf>,
    /// backbone.json of the same model (from `nlmodes backbone`): drawn over the curves, and
    /// the single-nonlinear-mode synthesis computed from it.
    #[arg(long)]
    backbone: Option<PathBuf>,
    /// The forced study at this speed (rpm) on a parametric reduced model (the model
    /// directory is `results/<case>/parametric/`): K_r and the running gaps interpolated there.
    #[arg(long, conflicts_with = "speed_sweep")]
    speed: Option<f64>,
    /// The speed sweeps of the settings file's `[speed_sweep]` table on a parametric reduced
    /// model (W = EO x speed through the Campbell crossings) instead of the frequency sweeps;
    /// `[rotation] engine_orders` of the file (default 1..8) when `speed_sweep.engine_orders`
    /// is empty.
    #[arg(long, conflicts_with = "backbone")]
    speed_sweep: bool,
    /// Output directory.
    #[arg(long, short)]
    out: PathBuf,
}

/// The material of the `modes` and `reduce` subcommands; defaults from [`MaterialSection`],
/// the one place the case defaults live.
#[derive(Args, Clone, Copy)]
struct MaterialArgs {
    /// Young's modulus E, Pa.
    #[arg(long, default_value_t = MaterialSection::default().young, allow_hyphen_values = true)]
    young: f64,
    /// Poisson's ratio.
    #[arg(long, default_value_t = MaterialSection::default().poisson, allow_hyphen_values = true)]
    poisson: f64,
    /// Density, kg/m^3.
    #[arg(long, default_value_t = MaterialSection::default().density, allow_hyphen_values = true)]
    density: f64,
}

impl MaterialArgs {
    /// The material; each flag out of its range is named (bad input).
    fn material(self) -> Result<nlmodes_fem::Isotropic> {
        let positive = |v: f64| v.is_finite() && v > 0.0;
        let mut p = validate::Problems::new(|flag| flag.to_string());
        p.check(
            positive(self.young),
            "--young",
            self.young,
            "a finite value > 0 (Pa)",
        );
        p.check(
            self.poisson > -1.0 && self.poisson < 0.5,
            "--poisson",
            self.poisson,
            "-1 < poisson < 0.5",
        );
        p.check(
            positive(self.density),
            "--density",
            self.density,
            "a finite value > 0 (kg/m^3)",
        );
        p.finish()?;
        Ok(nlmodes_fem::Isotropic::new(
            self.young,
            self.poisson,
            self.density,
        )?)
    }
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
    // Under mpirun: MPI and PETSc for the finite-element stages; ranks other than 0 are quiet.
    // Finalizes PETSc and MPI when main returns.
    let _mpi = match nlmodes_distributed::start() {
        Ok(session) => session,
        Err(e) => {
            eprintln!("error: {e}");
            return std::process::ExitCode::from(exit::FAILURE);
        }
    };
    let rank = nlmodes_distributed::world().map(|w| w.rank);
    ui::init(cli.quiet || rank.is_some_and(|r| r > 0));
    // A panic on any rank ends every rank (unwinding would wait in MPI_Finalize for the others).
    nlmodes_distributed::crew::abort_on_panic();
    // Under mpirun rank 0 runs the command and the other ranks serve its distributed tasks.
    let result = match rank {
        Some(r) if r > 0 => reduce::reduce_mpi::serve(),
        Some(_) => {
            nlmodes_distributed::crew::lead();
            run(cli.command)
        }
        None => run(cli.command),
    };
    // Rank 0 lets the other ranks end (unless an error left them inside a task).
    nlmodes_distributed::crew::release();
    match result {
        Ok(()) => std::process::ExitCode::from(exit::COMPLETE),
        Err(e) => {
            let code = exit::code_of(&e);
            match rank {
                Some(r) => eprintln!("error (MPI rank {r}): {e:#}"),
                None => eprintln!("error: {e:#}"),
            }
            // Every other rank ends too if it could be waiting for this one in a collective.
            nlmodes_distributed::abort_if_parallel(code.into());
            std::process::ExitCode::from(code)
        }
    }
}

fn run(command: Command) -> Result<()> {
    if reduce::reduce_mpi::distributed()
        && !matches!(
            command,
            Command::Modes { .. } | Command::Reduce(_) | Command::Run { .. }
        )
    {
        return Err(bad_input(
            "under mpirun only `nlmodes modes`, `nlmodes reduce` and `nlmodes run` run (their \
             finite-element stages over MPI); run the other commands without mpirun",
        ));
    }
    match command {
        Command::Mesh {
            geo,
            out,
            order,
            set,
        } => {
            validate::check_output_file(&out, "--out")?;
            let params: BTreeMap<String, f64> = set.into_iter().collect();
            let stage = ui::Stage::start("mesh");
            mesh::gmsh::mesh(&geo, &params, order, &out)?;
            stage.done(&format!("wrote {}", out.display()));
            Ok(())
        }
        Command::Modes {
            mesh,
            fix,
            material,
            modes,
            sigma,
            out,
        } => {
            check_count(modes, "--modes")?;
            if !sigma.is_finite() {
                return Err(bad_input(format!(
                    "--sigma {sigma}: expected a finite shift"
                )));
            }
            validate::check_output_dir(&out, "--out")?;
            if reduce::reduce_mpi::distributed() {
                let source = reduce::reduce_mpi::FeSource::new(&mesh, &fix, &material.material()?);
                return reduce::reduce_mpi::write_full_modes(source, modes, sigma, &out);
            }
            let fe = mesh::fe_model::FeModel::build(&mesh, &material.material()?, &fix)?;
            let m = fe.modes(modes, sigma)?;
            mesh::fe_model::write_modes(&fe, &m, &out)?;
            ui::say(&mesh::fe_model::frequency_table(&m));
            Ok(())
        }
        Command::Reduce(args) => reduce_command(args),
        Command::Backbone(args) => backbone_command(args),
        Command::Forced(args) => forced_command(args),
        Command::Run { case, only, force } => run::run(&case, only, force),
        Command::Study {
            study,
            cores,
            write_only,
            snakemake,
        } => {
            let all = std::thread::available_parallelism().map_or(1, |n| n.get());
            let opts = study::Options {
                cores: cores.unwrap_or(all),
                write_only,
                snakemake_args: snakemake,
            };
            study::study(&study, &opts)
        }
        Command::StudyJob { dir, job } => study::study_job::run(&dir, &job),
        Command::StudyGather { dir } => study::study_report::write_gathered(&dir).map(drop),
    }
}

/// A count flag must be at least 1.
fn check_count(n: usize, flag: &str) -> Result<()> {
    if n == 0 {
        return Err(bad_input(format!("{flag} 0: expected at least 1")));
    }
    Ok(())
}

/// `nlmodes reduce`: the arguments and the output path are checked before the mesh is read.
fn reduce_command(a: ReduceArgs) -> Result<()> {
    check_count(a.modes, "--modes")?;
    if !(a.gap.is_finite() && a.gap > 0.0) {
        return Err(bad_input(format!(
            "--gap {}: expected a finite gap > 0 (m)",
            a.gap
        )));
    }
    let axis = nlmodes_modal::RotorAxis::new(a.axis_point, a.axis_direction)
        .map_err(|e| bad_input(format!("--axis-point/--axis-direction: {e}")))?;
    validate::check_output_dir(&a.out, "--out")?;
    let material = a.material.material()?;
    let (mut model, full) = if reduce::reduce_mpi::distributed() {
        let (mesh, dofs) = mesh::fe_model::read_mesh(&a.mesh, &a.fix)?;
        let settings = reduce_settings(&a, axis, dofs.n_free());
        let side = reduce::MeshSide {
            mesh: &mesh,
            dofs: &dofs,
            clamp: &a.fix,
        };
        let source = reduce::reduce_mpi::FeSource::new(&a.mesh, &a.fix, &material);
        reduce::reduce_distributed(
            &side,
            source,
            &settings,
            reduce::reduce_mpi::RootData::default(),
        )?
    } else {
        let fe = mesh::fe_model::FeModel::build(&a.mesh, &material, &a.fix)?;
        reduce::reduce(&fe, &reduce_settings(&a, axis, fe.dofs.n_free()))?
    };
    reduce::write_model(&mut model, &a.out, &a.mesh)?;
    if let Some(full) = full {
        ui::say(&reduce::comparison_table(
            &full,
            &model.linear_frequencies_hz,
        ));
    }
    Ok(())
}

/// The settings of `nlmodes reduce` for a model of `dofs` free DOFs.
fn reduce_settings(
    a: &ReduceArgs,
    axis: nlmodes_modal::RotorAxis,
    dofs: usize,
) -> reduce::ReduceSettings<'_> {
    let check = a.full_check.wanted(dofs);
    if a.compare > 0 && !check {
        tracing::info!(
            "full-model check skipped: {dofs} free DOFs > {} (--full-check on to run it)",
            reduce::FULL_CHECK_AUTO_MAX_DOFS
        );
    }
    reduce::ReduceSettings {
        contact_group: &a.contact,
        axis,
        gap: a.gap,
        modes: a.modes,
        master: a.master,
        check_modes: if check { a.compare.min(dofs) } else { 0 },
        running: None,
        loads: Vec::new(),
    }
}

/// `nlmodes backbone`: every setting and the output path are checked before the model is read,
/// the model before anything is computed.
fn backbone_command(a: BackboneArgs) -> Result<()> {
    let study = match &a.settings {
        Some(p) => case::StudySettings::load(p)?,
        None => case::StudySettings::default(),
    };
    let (params, mut cont, stab) = (study.algorithm, study.continuation, study.stability);
    cont.q_max = a.q_max.unwrap_or(cont.q_max);
    cont.q_start = a.q_start.unwrap_or(cont.q_start);
    let source = a
        .settings
        .as_deref()
        .map_or_else(|| "defaults".to_string(), |p| p.display().to_string());
    let label = source.clone();
    let mut problems = validate::Problems::new(move |key| match key {
        "nnm.harmonics" => "--harmonics".to_string(),
        "nnm.samples" => "--samples".to_string(),
        "nnm.max_harmonics" => "--max-harmonics".to_string(),
        other => format!("{label} (with --q-max/--q-start): {other}"),
    });
    validate::check_nnm(a.harmonics, a.samples, &mut problems);
    let convergence = nlmodes_nnm::ConvergenceSettings {
        max_harmonics: a.max_harmonics.unwrap_or(4 * a.harmonics),
        ..NnmSection::default().convergence()
    };
    validate::check_convergence(&convergence, a.harmonics, &mut problems);
    validate::check_settings(&params, &cont, &mut problems);
    if !(cont.modes.is_empty() || cont.modes == [cont.mode]) {
        problems.check(
            false,
            "continuation.modes",
            &cont.modes,
            "no list here: `nlmodes backbone` traces one mode (`mode = k`); \
             `nlmodes run` traces several",
        );
    }
    if let Err(e) = stab.hill.validate() {
        problems.note("stability.hill", &e.to_string());
    }
    problems.finish()?;
    validate::check_output_dir(&a.out, "--out")?;
    let reduced = load_model(&a.model)?;
    let order = reduced.n();
    if cont.mode >= order {
        return Err(bad_input(format!(
            "{source}: continuation.mode = {}: expected a linear mode index (0-based) below \
             {order}, the order of the reduced model {}",
            cont.mode,
            a.model.display()
        )));
    }
    if let Some(m) = a.master.filter(|&m| m >= order) {
        return Err(bad_input(format!(
            "--master {m}: expected a reduced coordinate index < {order} (the model's order)"
        )));
    }
    let system = backbone::system_of(&reduced, a.master)?;
    backbone::check_reaches_contact(&system, &cont)?;
    let hs = nlmodes_nnm::HarmonicSettings::new(a.harmonics, a.samples)?;
    let mut b = backbone::trace(&system, hs, &params, &cont)?;
    backbone::stability(&system, &mut b, &stab)?;
    backbone::converged::converge(&system, &mut b, &stab, &convergence)?;
    let exact = backbone::backbone_exact::exact_outputs(&system, &b, &[], &stab, cont.q_max)?;
    backbone::write(&b, &a.out)?;
    backbone::backbone_exact::write(&exact, &b, &a.out)?;
    ui::say(&backbone::summary(&b, &params));
    backbone::stopped_early(&b, &a.out)
}

/// `nlmodes forced`: settings, backbone and output path checked before the model is read, then
/// every input against the model (`forced_inputs`) before anything is computed.
fn forced_command(a: ForcedArgs) -> Result<()> {
    let (section, source) = forced_section(a.settings.as_deref())?;
    if a.speed_sweep {
        return speed_sweep::forced_speed_command::sweep(
            &a.model,
            a.settings.as_deref(),
            section,
            &a.out,
        );
    }
    let backbone = match &a.backbone {
        Some(p) => Some(
            post::results::read_json::<post::results::BackboneFile>(p)
                .map_err(|e| e.context(exit::BadInput(format!("--backbone {}", p.display()))))?,
        ),
        None => None,
    };
    validate::check_output_dir(&a.out, "--out")?;
    let reduced = match a.speed {
        Some(rpm) => speed_sweep::forced_speed::model_at_speed(
            &speed_sweep::forced_speed::read_parametric(&a.model)?,
            &a.model,
            rpm,
            "--speed",
        )?,
        None => load_model(&a.model)?,
    };
    // System::new refuses only the model's own matrices and contact data (a K that is not
    // positive definite: a rigid-body mode the loader only warned of).
    let system = backbone::system_of(&reduced, None).map_err(|e| {
        e.context(exit::BadInput(format!(
            "the reduced model {}",
            a.model.display()
        )))
    })?;
    let model = forced::forced_inputs::ForcedModel {
        dir: &a.model,
        reduced: &reduced,
        system: &system,
    };
    let given = a.backbone.as_deref().zip(backbone.as_ref());
    let inputs = forced::forced_inputs::check(&model, &section, &source, given)?;
    let (c, f) = (inputs.damping_matrix, inputs.file_load);
    let study = forced::run(&system, &section, c, f.as_ref(), backbone.as_ref())?;
    forced::forced_output::write(&study, backbone.as_ref(), &a.out)?;
    forced::level_sweep::write(&study, &a.out)?;
    let orbits = forced::forced_paraview::write_chosen_orbits(&study, &reduced, &a.out)?;
    tracing::info!(
        "{orbits} orbits written for ParaView in {}",
        a.out.join("orbits").display()
    );
    ui::say(&(forced::forced_output::summary(&study) + &forced::level_sweep::summary(&study)));
    forced::stopped_early(&study, &a.out)
}

/// The `[forced]` table of `--settings` (the defaults without it), checked, and its source's
/// name for messages.
fn forced_section(
    settings: Option<&Path>,
) -> Result<(forced::forced_settings::ForcedSection, String)> {
    let (section, source) = match settings {
        Some(p) => (forced::forced_settings::load(p)?, p.display().to_string()),
        None => (
            forced::forced_settings::ForcedSection::default(),
            "defaults".to_string(),
        ),
    };
    let label = source.clone();
    let mut problems = validate::Problems::new(move |key| format!("{label}: {key}"));
    section.check(&mut problems);
    problems.finish()?;
    Ok((section, source))
}

/// Reads a reduced model; any failure is bad input naming the directory.
pub fn load_model(dir: &Path) -> Result<nlmodes_modal::ReducedModel> {
    nlmodes_modal::ReducedModel::read(dir).map_err(|e| {
        anyhow::Error::new(e).context(exit::BadInput(format!(
            "reading the reduced model {}",
            dir.display()
        )))
    })
}
