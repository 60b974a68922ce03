//! The command line: the arguments of every `coupler` command. `main.rs` dispatches them to
//! [`crate::run`] (run, check, clean, povray) and [`crate::studies`] (the rest).

use clap::{Args, Parser, Subcommand};
use shared::scene::CouplingScheme;
use shared::transport::Kind;
use std::path::PathBuf;

#[derive(Debug, Parser)]
#[command(
    version,
    about = "rockwave: coupled SPH (water) and 3D-DDA (rock blocks), after Geraili Mikola & Sitar (2014)"
)]
pub struct Cli {
    #[command(subcommand)]
    pub command: Cmd,
}

#[derive(Debug, Subcommand)]
pub enum Cmd {
    /// Run a scene: starts the fluid and solid nodes and steps them to the end time.
    Run(Box<RunArgs>),
    /// Check a scene file and print what would run.
    Check {
        /// Scene file; default: the embedded default scene.
        scene: Option<std::path::PathBuf>,
        /// Write the blocks cut from the scene's `[[slide]]`s to this VTK file (.vtp) to
        /// inspect them before the run.
        #[arg(long, value_name = "FILE")]
        slides_vtk: Option<std::path::PathBuf>,
        /// Pass a scene whose run is estimated to take more than 48 h of wall time or 10⁸
        /// steps (otherwise an error naming the field that makes it crawl).
        #[arg(long)]
        allow_long: bool,
        /// Say what each of N fluid ranks would hold (overrides the scene's `[fluid] ranks`),
        /// and refuse more ranks than the water can fill, or a fluid node built without MPI.
        #[arg(long, value_name = "N")]
        fluid_ranks: Option<u32>,
        /// Particle spacing [m] (overrides the scene's fluid.dx): what the scene would cost at
        /// another resolution.
        #[arg(long, allow_hyphen_values = true)]
        dx: Option<f64>,
    },
    /// Remove shared memory left behind by runs whose processes were all killed: every dead
    /// run with a generated id (rw…), and the runs named here (ids given with --run-id).
    Clean {
        /// Run ids to clean besides the generated ones, e.g. `mytest`.
        run_ids: Vec<String>,
    },
    /// Speed against accuracy: run the validation cases over solvers, resolutions, dt factors
    /// and coupling schemes; write CSV, SVG and PNG charts with the Pareto front.
    Chart(crate::studies::speed_accuracy::ChartArgs),
    /// Push each method past its limits (dt factor, contact stiffness, density ratio) and draw
    /// stability maps naming how each failure was detected.
    Stability(crate::studies::stability::StabilityArgs),
    /// How far a scene's gauge crests move when knobs that are not physics turn: the scene as
    /// written and once per value of each --vary, with each gauge's median and range.
    Spread(crate::studies::spread::SpreadArgs),
    /// Write the synthetic reservoir of scenes/fjord.toml as an ESRI ASCII grid (.asc).
    MakeSite(crate::studies::site::SiteArgs),
    /// Time a terrain of many triangles against a box floor, per node (in-process).
    TerrainBench(crate::studies::terrain_bench::TerrainBenchArgs),
    /// Write POV-Ray scene files for every frame of a run directory (and render them).
    Povray {
        /// A run directory written by `coupler run`.
        run_dir: std::path::PathBuf,
        /// Render each frame to PNG with `povray` (must be installed).
        #[arg(long)]
        render: bool,
        #[arg(long, allow_hyphen_values = true, default_value_t = 960)]
        width: u32,
        #[arg(long, allow_hyphen_values = true, default_value_t = 540)]
        height: u32,
    },
}

#[derive(Debug, Args)]
pub struct RunArgs {
    /// Scene file (TOML). Without one, the embedded default scene runs: the paper's sliding
    /// wedge (scenes/sliding_wedge.toml).
    pub scene: Option<PathBuf>,
    /// Fluid solver (overrides the scene): a name from the fluid registry (wcsph, muller, …;
    /// `coupler check` lists them).
    #[arg(long)]
    pub fluid_solver: Option<String>,
    /// Solid solver (overrides the scene): a name from the solid registry (explicit, implicit, …;
    /// `coupler check` lists them).
    #[arg(long)]
    pub solid_solver: Option<String>,
    /// Coupling scheme (overrides the scene).
    #[arg(long)]
    pub scheme: Option<CouplingScheme>,
    /// Multi-rate coupling: the solid takes up to N steps of its own per coupling step, with
    /// the water's loads held (overrides the scene's `[coupling] solid_substeps`; 1 is
    /// single-rate).
    #[arg(long, allow_hyphen_values = true, value_name = "N")]
    pub solid_substeps: Option<u32>,
    /// Added-mass stabilisation: under-relax the water's loads on each block as if it carried
    /// C × ρ_water × its volume of artificial added mass (overrides the scene's `[coupling]
    /// added_mass`; 0 is off).
    #[arg(long, allow_hyphen_values = true, value_name = "C")]
    pub added_mass: Option<f64>,
    /// Particle spacing [m] (overrides the scene's fluid.dx), for quick coarse runs.
    #[arg(long, allow_hyphen_values = true)]
    pub dx: Option<f64>,
    /// Pick the particle spacing for this relative error of the dam-break surge front, from
    /// the convergence curve `coupler chart` measured (docs/charts/fluid_convergence.csv,
    /// compiled in); prints the spacing chosen and why. Exclusive with --dx.
    #[arg(long, allow_hyphen_values = true, conflicts_with = "dx")]
    pub target_error: Option<f64>,
    /// Simulated end time [s] (overrides the scene's time.end).
    #[arg(long, allow_hyphen_values = true)]
    pub end: Option<f64>,
    /// Largest coupling step [s] (overrides the scene's time.dt_max): lets an incompressible
    /// fluid (dfsph) take its own longer step, e.g. `--fluid-solver dfsph --solid-substeps 8
    /// --dt-max 0.002`.
    #[arg(long, allow_hyphen_values = true)]
    pub dt_max: Option<f64>,
    /// Run directory (default: runs/<scene>-<run id>). Must not exist or be empty.
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Executable to run as the fluid node instead of the fluid-node beside the coupler; it
    /// must speak the rockwave protocol. Extra words are passed as arguments.
    #[arg(long)]
    pub fluid_cmd: Option<String>,
    /// Executable to run as the solid node instead of the solid-node beside the coupler.
    #[arg(long)]
    pub solid_cmd: Option<String>,
    /// Run the fluid node as N MPI ranks (overrides the scene's `[fluid] ranks`): the
    /// coupler starts `mpirun -n N fluid-node …` (see --mpirun); rank 0 is the node it talks
    /// to. Needs MPI and a fluid node built with `--features fluid-node/mpi`.
    #[arg(long, value_name = "N")]
    pub fluid_ranks: Option<u32>,
    /// The MPI launcher that starts the fluid ranks, with its own arguments, split into words
    /// as a shell splits them, e.g. "srun --mpi=pmix" or "mpirun --hostfile hosts --mca btl
    /// tcp,self"; `-n N` and the fluid node's command are appended. Default: mpirun (with
    /// --oversubscribe when it is Open MPI's).
    #[arg(long, value_name = "COMMAND", env = "ROCKWAVE_MPIRUN")]
    pub mpirun: Option<String>,
    /// Do not start the nodes: wait (up to --connect-timeout) for nodes started by hand with
    /// `--prefix <run id>` (and, over zenoh, `--transport zenoh --connect <endpoint>`, possibly
    /// on other hosts). The coupler prints the commands.
    #[arg(long)]
    pub attach: bool,
    /// Run id (the iceoryx2 service prefix, the zenoh key prefix); default: a fresh unique one.
    #[arg(long)]
    pub run_id: Option<String>,
    /// How the processes talk: iceoryx2 shared memory (one host, zero copy), or zenoh over TCP
    /// (nodes may run on other hosts: see --listen and --attach).
    #[arg(long, value_enum, default_value_t = Kind::Iceoryx2)]
    pub transport: Kind,
    /// zenoh endpoint the coupler listens on for its nodes, e.g. `tcp/0.0.0.0:7447` (all
    /// interfaces) or `tcp/192.0.2.10:7447`. Repeatable. Default (nodes started here): a free
    /// port on 127.0.0.1.
    #[arg(long, value_name = "ENDPOINT")]
    pub listen: Vec<String>,
    /// zenoh endpoint the coupler connects to as well (another zenoh router). Repeatable.
    #[arg(long, value_name = "ENDPOINT")]
    pub connect: Vec<String>,
    /// Seconds to wait for the nodes to start and say hello.
    #[arg(long, allow_hyphen_values = true, default_value_t = 30.0)]
    pub connect_timeout: f64,
    /// Seconds a node may stay silent within one step before it is declared hung.
    #[arg(long, allow_hyphen_values = true, default_value_t = 60.0)]
    pub step_timeout: f64,
    /// Seconds the nodes may take to set up (build the solvers, fill the water) before a node
    /// that has not reported ready is declared hung.
    #[arg(long, allow_hyphen_values = true, default_value_t = 600.0)]
    pub setup_timeout: f64,
    /// Multiply every granted step by this factor (stability experiments).
    #[arg(long, allow_hyphen_values = true, default_value_t = 1.0)]
    pub dt_factor: f64,
    /// No progress bar.
    #[arg(long)]
    pub quiet: bool,
    /// Checkpoint every this many simulated seconds (overrides the scene's
    /// `output.checkpoint_interval`). Checkpoints never change the steps taken.
    #[arg(long, allow_hyphen_values = true, value_name = "SECONDS")]
    pub checkpoint_interval: Option<f64>,
    /// Checkpoint every this many wall-clock minutes (overrides the scene's
    /// `output.checkpoint_wall_minutes`). When no checkpoint is asked for: 10 with --retries,
    /// else 15 when the run is estimated to take longer than that (see --no-checkpoints).
    #[arg(long, allow_hyphen_values = true, value_name = "MINUTES")]
    pub checkpoint_wall_minutes: Option<f64>,
    /// No checkpoints at all: not the scene's, not those a long run (or --retries) writes by
    /// default. A run killed then starts again from t = 0.
    #[arg(long, conflicts_with_all = ["checkpoint_interval", "checkpoint_wall_minutes"])]
    pub no_checkpoints: bool,
    /// Continue the run in RUN_DIR from its last complete checkpoint, with the scene, solvers
    /// and scheme it was started with; its CSV files are cut back and its later frames removed
    /// first, so the finished run is identical to an uninterrupted one. A damaged, cut, renamed
    /// or foreign checkpoint file is refused by name first; a directory another coupler is
    /// running in is refused with its pid.
    #[arg(long, value_name = "RUN_DIR", conflicts_with_all = ["scene", "out", "dx", "target_error", "end", "dt_max", "solid_substeps", "added_mass"])]
    pub resume: Option<PathBuf>,
    /// Restart a node that dies or hangs up to N times: every node goes back to the last
    /// checkpoint (t = 0 without one) and the run continues; a node that fails again at the
    /// same step stops the run.
    #[arg(
        long,
        allow_hyphen_values = true,
        value_name = "N",
        default_value_t = 0
    )]
    pub retries: u32,
    /// Start a run estimated to take more than 48 h of wall time or 10⁸ steps (`coupler
    /// check` prints the estimate); without it such a run is refused, naming the field that
    /// makes it crawl (time.dt_max, fluid.kinematic_viscosity, fluid.dx).
    #[arg(long)]
    pub allow_long: bool,
}

#[cfg(test)]
mod tests {
    use super::*;
    use clap::Parser;

    fn run_args(extra: &[&str]) -> RunArgs {
        let argv = ["coupler", "run"].iter().chain(extra);
        match Cli::try_parse_from(argv).unwrap().command {
            Cmd::Run(args) => *args,
            other => panic!("{other:?}"),
        }
    }

    /// Every numeric flag takes a negative number (also in exponent form), so that our own
    /// checks name the field and the fix (clap alone said "unexpected argument '-1'").
    #[test]
    fn negative_numbers_after_flags_reach_our_checks() {
        for flag in [
            "--added-mass",
            "--dx",
            "--target-error",
            "--end",
            "--dt-max",
            "--connect-timeout",
            "--step-timeout",
            "--setup-timeout",
            "--dt-factor",
            "--checkpoint-interval",
            "--checkpoint-wall-minutes",
        ] {
            run_args(&[flag, "-1"]);
            run_args(&[flag, "-1e-3"]);
        }
        // An unsigned flag's negative value is named by clap with the flag.
        let err = Cli::try_parse_from(["coupler", "run", "--retries", "-1"]).unwrap_err();
        assert!(err.to_string().contains("--retries"), "{err}");
        let msg = crate::run::settings::scene(&run_args(&["--end", "-1"]), None).unwrap_err();
        assert!(
            msg.contains("time.end = -1.0") && msg.contains("fix:"),
            "{msg}"
        );
        let msg = crate::run::settings::scene(&run_args(&["--dx", "-0.5"]), None).unwrap_err();
        assert!(msg.contains("--dx -0.5"), "{msg}");
    }
}
