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
        /// Write the blocks cut from the scene's `[[slide]]`s to this VTK file (.vtp) to
        /// inspect them before the run.
        #[arg(long, value_name = "FILE")]
        slides_vtk: Option<std::path::PathBuf>,
    },
    /// Remove shared memory left behind by runs whose processes were all killed: every dead
    /// run with a generated id (rw…), and the runs named here (ids given with --run-id).
    Clean {
        /// Run ids to clean besides the generated ones, e.g. `mytest`.
        run_ids: Vec<String>,
    },
    /// Speed against accuracy: run the validation cases over solvers, resolutions, dt factors
    /// and coupling schemes; write CSV, SVG and PNG charts with the Pareto front.
    Chart(coupler::studies::speed_accuracy::ChartArgs),
    /// Push each method past its limits (dt factor, contact stiffness, density ratio) and draw
    /// stability maps naming how each failure was detected.
    Stability(coupler::studies::stability::StabilityArgs),
    /// How far a scene's gauge crests move when knobs that are not physics turn: the scene as
    /// written and once per value of each --vary, with each gauge's median and range.
    Spread(coupler::studies::spread::SpreadArgs),
    /// Write the synthetic reservoir of scenes/fjord.toml as an ESRI ASCII grid (.asc).
    MakeSite(coupler::studies::site::SiteArgs),
    /// Time a terrain of many triangles against a box floor, per node (in-process).
    TerrainBench(coupler::studies::terrain_bench::TerrainBenchArgs),
    /// Write POV-Ray scene files for every frame of a run directory (and render them).
    Povray {
        /// A run directory written by `coupler run`.
        run_dir: std::path::PathBuf,
        /// Render each frame to PNG with `povray` (must be installed).
        #[arg(long)]
        render: bool,
        #[arg(long, default_value_t = 960)]
        width: u32,
        #[arg(long, default_value_t = 540)]
        height: u32,
    },
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    match cli.command {
        Cmd::Run(args) => ExitCode::from(coupler::cli::run(*args)),
        Cmd::Chart(args) => ExitCode::from(coupler::studies::speed_accuracy::run(args)),
        Cmd::Stability(args) => ExitCode::from(coupler::studies::stability::run(args)),
        Cmd::Spread(args) => ExitCode::from(coupler::studies::spread::run(args)),
        Cmd::MakeSite(args) => ExitCode::from(coupler::studies::site::run(args)),
        Cmd::TerrainBench(args) => ExitCode::from(coupler::studies::terrain_bench::run(args)),
        Cmd::Check { scene, slides_vtk } => {
            let loaded = coupler::run::scenes::load_as_written(scene.as_deref());
            match loaded {
                Ok(s) => {
                    println!(
                        "scene '{}' is valid: {} blocks ({} moving), {} terrain(s), water: {}, gauges: {}, domain top: {}",
                        s.name,
                        s.blocks.len(),
                        s.moving_blocks().len(),
                        s.terrain.len(),
                        if s.has_fluid() { "yes" } else { "no" },
                        s.gauges.len(),
                        if s.domain.open_top {
                            "open (spray may fly above it)"
                        } else {
                            "closed"
                        }
                    );
                    match shared::terrain::Terrain::load_all(&s) {
                        Ok(terrain) => terrain.iter().for_each(|t| println!("{}", t.summary())),
                        Err(e) => {
                            eprintln!("coupler: error: {e}");
                            return ExitCode::from(1);
                        }
                    }
                    for line in coupler::run::slides::describe(&s) {
                        println!("{line}");
                    }
                    if let Some(path) = &slides_vtk {
                        match coupler::run::slides::write_vtk(&s, path) {
                            Ok(n) => println!("wrote {n} slide block(s) to {}", path.display()),
                            Err(e) => {
                                eprintln!("coupler: error: {e}");
                                return ExitCode::from(1);
                            }
                        }
                    }
                    if let Some(e) = coupler::run::sizes::estimate(&s, None) {
                        println!("estimate: {}", e.describe());
                    }
                    println!("solvers:\n{}", coupler::run::scenes::solver_list());
                    ExitCode::SUCCESS
                }
                Err(e) => {
                    eprintln!("coupler: error: {e}");
                    ExitCode::from(1)
                }
            }
        }
        Cmd::Povray {
            run_dir,
            render,
            width,
            height,
        } => match coupler::run::povray::export(&run_dir, render, width, height) {
            Ok(files) => {
                println!(
                    "wrote {} POV-Ray frame(s) in {}",
                    files.len(),
                    run_dir.join("povray").display()
                );
                ExitCode::SUCCESS
            }
            Err(e) => {
                eprintln!("coupler: error: {e}");
                ExitCode::from(1)
            }
        },
        Cmd::Clean { run_ids } => {
            let mut cleaned = shared::transport::remove_stale_runs(std::time::Duration::ZERO).len();
            for id in &run_ids {
                let id = match shared::transport::RunId::parse(id) {
                    Ok(id) => id,
                    Err(e) => {
                        eprintln!("coupler: error: {e}");
                        return ExitCode::from(1);
                    }
                };
                if shared::transport::run_has_live_nodes(&id) {
                    eprintln!("coupler: run {id} still has live processes; left alone");
                } else if shared::transport::remove_run_files(&id) > 0 {
                    cleaned += 1;
                }
            }
            let locks = coupler::run::lock::remove_stale_locks();
            println!("removed the files of {cleaned} dead run(s) and {locks} stale run lock(s)");
            ExitCode::SUCCESS
        }
    }
}
