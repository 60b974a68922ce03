//! `coupler`: runs rockwave scenes.

use clap::Parser;
use coupler::cli::{Cli, Cmd};
use coupler::{run, studies};
use std::process::ExitCode;

fn main() -> ExitCode {
    run::slides::show_cutting_progress();
    let code = match Cli::parse().command {
        Cmd::Run(args) => run::command::run(*args),
        Cmd::Check {
            scene,
            slides_vtk,
            allow_long,
            fluid_ranks,
            dx,
        } => run::check::run(
            scene.as_deref(),
            slides_vtk.as_deref(),
            allow_long,
            fluid_ranks,
            dx,
        ),
        Cmd::Clean { run_ids } => run::clean::run(&run_ids),
        Cmd::Povray {
            run_dir,
            render,
            width,
            height,
        } => run::povray::run(&run_dir, render, width, height),
        Cmd::Chart(args) => studies::speed_accuracy::run(args),
        Cmd::Stability(args) => studies::stability::run(args),
        Cmd::Spread(args) => studies::spread::run(args),
        Cmd::MakeSite(args) => studies::site::run(args),
        Cmd::TerrainBench(args) => studies::terrain_bench::run(args),
    };
    ExitCode::from(code)
}
