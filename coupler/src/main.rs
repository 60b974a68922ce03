//! `coupler`: runs rockwave scenes.

use clap::{Parser, Subcommand};
use std::process::ExitCode;

#[derive(Debug, Parser)]
#[command(
    version,
    about = "rockwave: coupled SPH (water) and 3D-DDA (rock blocks), after Geraili Mikola & Sitar (2014)"
)]
struct Cli {
    #[command(subcommand)]
    command: Cmd,
}

#[derive(Debug, Subcommand)]
enum Cmd {
    /// Run a scene: starts the fluid and solid nodes and steps them to the end time.
    Run(Box<coupler::cli::RunArgs>),
    /// Check a scene file and print what would run.
    Check {
        /// Scene file; default: the embedded default scene.
        scene: Option<std::path::PathBuf>,
    },
    /// Remove shared memory left behind by runs whose processes were all killed.
    Clean,
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    match cli.command {
        Cmd::Run(args) => ExitCode::from(coupler::cli::run(*args)),
        Cmd::Check { scene } => {
            let loaded = match &scene {
                Some(p) => shared::scene::Scene::load(p),
                None => Ok(shared::scene::Scene::default_scene()),
            };
            match loaded {
                Ok(s) => {
                    println!(
                        "scene '{}' is valid: {} blocks ({} moving), water: {}, gauges: {}",
                        s.name,
                        s.blocks.len(),
                        s.moving_blocks().len(),
                        if s.has_fluid() { "yes" } else { "no" },
                        s.gauges.len()
                    );
                    ExitCode::SUCCESS
                }
                Err(e) => {
                    eprintln!("coupler: error: {e}");
                    ExitCode::from(1)
                }
            }
        }
        Cmd::Clean => {
            let cleaned = shared::transport::remove_stale_runs(std::time::Duration::ZERO);
            println!("removed the files of {} dead run(s)", cleaned.len());
            ExitCode::SUCCESS
        }
    }
}
