//! `nlmodes`: nonlinear normal modes of elastic structures with frictionless unilateral contact,
//! after Laxalde, Legrand & Pierre (2009). Units: SI throughout (m, kg, s, Pa, Hz).

mod case;
mod gmsh;
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
    }
}
