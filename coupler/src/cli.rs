//! `coupler run`: the command a user types.

use crate::checkpoint::CouplerCheckpoint;
use crate::launch::NodeCommand;
use crate::output::{RunDir, Summary};
use crate::session::{RunOptions, Session};
use clap::Args;
use shared::protocol::Role;
use shared::scene::CouplingScheme;
use shared::transport::{Endpoints, Kind, RunId};
use std::path::PathBuf;
use std::time::Duration;

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
    #[arg(long, value_name = "N")]
    pub solid_substeps: Option<u32>,
    /// Added-mass stabilisation: under-relax the water's loads on each block as if it carried
    /// C × ρ_water × its volume of artificial added mass (overrides the scene's `[coupling]
    /// added_mass`; 0 is off).
    #[arg(long, value_name = "C")]
    pub added_mass: Option<f64>,
    /// Particle spacing [m] (overrides the scene's fluid.dx), for quick coarse runs.
    #[arg(long)]
    pub dx: Option<f64>,
    /// Pick the particle spacing for this relative error of the dam-break surge front, from
    /// the convergence curve `coupler chart` measured (docs/charts/fluid_convergence.csv,
    /// compiled in); prints the spacing chosen and why. Exclusive with --dx.
    #[arg(long, conflicts_with = "dx")]
    pub target_error: Option<f64>,
    /// Simulated end time [s] (overrides the scene's time.end).
    #[arg(long)]
    pub end: Option<f64>,
    /// Largest coupling step [s] (overrides the scene's time.dt_max): lets an incompressible
    /// fluid (dfsph) take its own longer step, e.g. `--fluid-solver dfsph --solid-substeps 8
    /// --dt-max 0.002`.
    #[arg(long)]
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
    #[arg(long, default_value_t = 30.0)]
    pub connect_timeout: f64,
    /// Seconds a node may stay silent within one step before it is declared hung.
    #[arg(long, default_value_t = 60.0)]
    pub step_timeout: f64,
    /// Seconds the nodes may take to set up (build the solvers, fill the water) before a node
    /// that has not reported ready is declared hung.
    #[arg(long, default_value_t = 600.0)]
    pub setup_timeout: f64,
    /// Multiply every granted step by this factor (stability experiments).
    #[arg(long, default_value_t = 1.0)]
    pub dt_factor: f64,
    /// No progress bar.
    #[arg(long)]
    pub quiet: bool,
    /// Checkpoint every this many simulated seconds (overrides the scene's
    /// `output.checkpoint_interval`). Checkpoints never change the steps taken.
    #[arg(long, value_name = "SECONDS")]
    pub checkpoint_interval: Option<f64>,
    /// Checkpoint every this many wall-clock minutes (overrides the scene's
    /// `output.checkpoint_wall_minutes`; 10 when --retries is given and no checkpoint is asked
    /// for).
    #[arg(long, value_name = "MINUTES")]
    pub checkpoint_wall_minutes: Option<f64>,
    /// Continue the run in RUN_DIR from its last complete checkpoint, with the scene, solvers
    /// and scheme it was started with; its CSV files are cut back and its later frames removed
    /// first, so the finished run is identical to an uninterrupted one.
    #[arg(long, value_name = "RUN_DIR", conflicts_with_all = ["scene", "out", "dx", "target_error", "end", "dt_max", "solid_substeps", "added_mass"])]
    pub resume: Option<PathBuf>,
    /// Restart a node that dies or hangs up to N times: every node goes back to the last
    /// checkpoint (t = 0 without one) and the run continues; a node that fails again at the
    /// same step stops the run.
    #[arg(long, value_name = "N", default_value_t = 0)]
    pub retries: u32,
}

/// Where the coupler listens and connects (zenoh), and what the nodes it starts connect to.
fn zenoh_endpoints(args: &RunArgs) -> Result<(Endpoints, Vec<String>), String> {
    if args.transport != Kind::Zenoh {
        if !args.listen.is_empty() || !args.connect.is_empty() {
            return Err(
                "--listen and --connect are zenoh endpoints. Fix: add --transport zenoh, or drop them"
                    .into(),
            );
        }
        return Ok((Endpoints::default(), Vec::new()));
    }
    for e in args.listen.iter().chain(&args.connect) {
        let ok = e
            .split_once('/')
            .is_some_and(|(proto, addr)| !proto.is_empty() && addr.contains(':'));
        if !ok {
            return Err(format!(
                "'{e}' is not a zenoh endpoint. Fix: write PROTOCOL/HOST:PORT, e.g. tcp/0.0.0.0:7447"
            ));
        }
    }
    let listen = if !args.listen.is_empty() {
        args.listen.clone()
    } else if args.attach {
        return Err(
            "--attach with --transport zenoh: the nodes on other hosts need an address to connect to. Fix: add --listen tcp/0.0.0.0:7447 (or this host's address and a free port)"
                .into(),
        );
    } else {
        vec![format!("tcp/127.0.0.1:{}", free_port()?)]
    };
    // The nodes this coupler starts run on this host: "all interfaces" is reached locally.
    let node_connect = listen
        .iter()
        .map(|e| {
            e.replace("/0.0.0.0:", "/127.0.0.1:")
                .replace("/[::]:", "/[::1]:")
        })
        .collect();
    Ok((
        Endpoints {
            listen,
            connect: args.connect.clone(),
        },
        node_connect,
    ))
}

/// A TCP port free on 127.0.0.1 right now (the system's choice; the coupler binds it moments
/// later).
fn free_port() -> Result<u16, String> {
    std::net::TcpListener::bind("127.0.0.1:0")
        .and_then(|l| l.local_addr())
        .map(|a| a.port())
        .map_err(|e| format!("cannot find a free TCP port on 127.0.0.1: {e}"))
}

/// Runs `coupler run`; returns the process exit code.
pub fn run(args: RunArgs) -> u8 {
    match run_inner(args) {
        Ok(code) => code,
        Err(msg) => {
            eprintln!("coupler: error: {msg}");
            1
        }
    }
}

/// The scene, last checkpoint and settings of a run to resume (`--resume RUN_DIR`).
struct Resumed {
    scene: shared::scene::Scene,
    checkpoint: CouplerCheckpoint,
}

fn resumed(args: &RunArgs, dir: &std::path::Path) -> Result<Resumed, String> {
    let path = dir.join("scene.toml");
    if !path.is_file() {
        return Err(format!(
            "--resume {}: no scene.toml there: not a run directory of `coupler run`. Fix: name the directory the run wrote (its --out)",
            dir.display()
        ));
    }
    let scene = crate::scenes::load(Some(&path)).map_err(|e| e.to_string())?;
    let Some(ck) = crate::checkpoint::latest(dir)? else {
        return Err(format!(
            "--resume {}: the run wrote no complete checkpoint (checkpoints/coupler-*.ckpt). Fix: start it again with --checkpoint-interval or --checkpoint-wall-minutes",
            dir.display()
        ));
    };
    let hash = shared::checkpoint::run_hash(
        &scene,
        &crate::session::scene_text(&scene).map_err(|e| e.to_string())?,
    );
    if hash != ck.scene_hash {
        let terrain: Vec<String> = scene
            .terrain
            .iter()
            .map(|t| format!("'{}'", t.file.display()))
            .collect();
        let (what, fix) = if terrain.is_empty() {
            (
                "scene.toml is".to_string(),
                "restore the run's own scene.toml",
            )
        } else {
            (
                format!("scene.toml or its terrain file ({}) is", terrain.join(", ")),
                "restore the run's own scene.toml and terrain files (a terrain file changed under the same path is another run)",
            )
        };
        return Err(format!(
            "--resume {}: {what} not what the checkpoint at step {} was written for (hash {hash:016x}, checkpoint {:016x}). Fix: {fix}",
            dir.display(),
            ck.step,
            ck.scene_hash
        ));
    }
    for (flag, given, saved) in [
        ("--fluid-solver", &args.fluid_solver, &ck.fluid_solver),
        ("--solid-solver", &args.solid_solver, &ck.solid_solver),
    ] {
        if let (Some(g), Some(s)) = (given, saved)
            && g != s
        {
            return Err(format!(
                "--resume: {flag} {g}, but the checkpoint was written by solver '{s}'. Fix: drop {flag} (a resumed run keeps its solvers)"
            ));
        }
    }
    if let Some(scheme) = args.scheme
        && scheme != ck.scheme
    {
        return Err(format!(
            "--resume: --scheme {scheme}, but the run was coupled {}. Fix: drop --scheme",
            ck.scheme
        ));
    }
    if args.dt_factor != 1.0 && args.dt_factor != ck.dt_factor {
        return Err(format!(
            "--resume: --dt-factor {}, but the run was started with {}. Fix: drop --dt-factor",
            args.dt_factor, ck.dt_factor
        ));
    }
    Ok(Resumed {
        scene,
        checkpoint: ck,
    })
}

fn run_inner(args: RunArgs) -> Result<u8, String> {
    let resume = match &args.resume {
        Some(dir) => Some(resumed(&args, dir)?),
        None => None,
    };
    if let Some(r) = &resume {
        let ck = &r.checkpoint;
        eprintln!(
            "coupler: resuming {} from its checkpoint at step {} (t = {:.6} s)",
            args.resume.as_ref().expect("resuming").display(),
            ck.step,
            ck.time
        );
    }
    let mut scene = match &resume {
        Some(r) => r.scene.clone(),
        None => crate::scenes::load(args.scene.as_deref()).map_err(|e| e.to_string())?,
    };
    let origin = match (&args.resume, &args.scene) {
        (Some(dir), _) => dir.join("scene.toml").display().to_string(),
        (None, Some(path)) => path.display().to_string(),
        (None, None) => shared::scene::DEFAULT_SCENE_ORIGIN.to_string(),
    };
    if let Some(dx) = args.dx {
        if !(dx.is_finite() && dx > 0.0) {
            return Err(format!("--dx {dx}: must be a positive length in metres"));
        }
        scene.set_dx(dx);
    }
    if let Some(target) = args.target_error {
        let fits = crate::resolution::parse_csv(crate::resolution::EMBEDDED_FIT)?;
        let solver = args
            .fluid_solver
            .clone()
            .or_else(|| scene.fluid.as_ref().map(|f| f.solver.clone()))
            .ok_or("--target-error: the scene has no water, so there is no spacing to choose")?;
        let choice = crate::resolution::choose_dx(&fits, &solver, &scene, target)?;
        eprintln!("coupler: {}", choice.explanation);
        scene.set_dx(choice.dx);
    }
    if let Some(end) = args.end {
        scene.time.end = end;
    }
    if let Some(dt) = args.dt_max {
        scene.time.dt_max = dt;
    }
    if let Some(n) = args.solid_substeps {
        scene.coupling.solid_substeps = n;
    }
    if let Some(c) = args.added_mass {
        scene.coupling.added_mass = c;
    }
    // Overrides must leave a valid scene too.
    let problems = crate::scenes::problems(&scene);
    if !problems.is_empty() {
        let list: Vec<String> = problems.iter().map(|e| format!("  {e}")).collect();
        return Err(format!(
            "scene '{origin}' after command-line overrides:\n{}",
            list.join("\n")
        ));
    }
    for line in crate::slides::describe(&scene) {
        eprintln!("coupler: {line}");
    }
    // Stepped as the run's fluid solver steps: a resumed run keeps the one it was started with.
    let stepped_by = resume
        .as_ref()
        .and_then(|r| r.checkpoint.fluid_solver.as_deref())
        .or(args.fluid_solver.as_deref());
    if let Some(e) = crate::sizes::estimate(&scene, stepped_by) {
        eprintln!("coupler: estimate: {}", e.describe());
    }
    for (flag, v) in [
        ("--connect-timeout", args.connect_timeout),
        ("--step-timeout", args.step_timeout),
        ("--setup-timeout", args.setup_timeout),
    ] {
        if !(v.is_finite() && v > 0.0 && v < 1e9) {
            return Err(format!("{flag} {v}: must be a positive number of seconds"));
        }
    }
    let (endpoints, node_connect) = zenoh_endpoints(&args)?;
    if args.attach && args.retries > 0 {
        return Err(format!(
            "--retries {} with --attach: the coupler can only restart nodes it started itself. Fix: drop --attach, or --retries (and resume by hand with --resume)",
            args.retries
        ));
    }
    for (flag, v) in [
        ("--checkpoint-interval", args.checkpoint_interval),
        ("--checkpoint-wall-minutes", args.checkpoint_wall_minutes),
    ] {
        if let Some(v) = v
            && !(v.is_finite() && v > 0.0)
        {
            return Err(format!(
                "{flag} {v}: must be a positive number. Fix: leave it out for no checkpoints"
            ));
        }
    }
    let checkpoint_interval = args
        .checkpoint_interval
        .or(scene.output.checkpoint_interval);
    let checkpoint_wall_minutes = args
        .checkpoint_wall_minutes
        .or(scene.output.checkpoint_wall_minutes)
        .or((args.retries > 0 && checkpoint_interval.is_none()).then_some(10.0));
    if !(args.dt_factor.is_finite() && args.dt_factor > 0.0) {
        return Err(format!(
            "--dt-factor {}: must be a positive number",
            args.dt_factor
        ));
    }
    let run_id = match &args.run_id {
        Some(s) => RunId::parse(s).map_err(|e| format!("--run-id: {e}"))?,
        None => RunId::fresh(),
    };
    // Before anything of the run exists: a second coupler on a live run's id would stop that
    // run and remove its files.
    let _lock = crate::lock::RunLock::acquire(&run_id)?;
    // A coupler killed by SIGKILL could not remove its lock file (its nodes remove the run's
    // shared memory, not the lock): the next run sweeps such free locks, so they do not pile up.
    crate::lock::remove_stale_locks();
    // The id is ours; files a killed run of the same id left behind would confuse the services.
    if !shared::transport::run_has_live_nodes(&run_id)
        && shared::transport::remove_run_files(&run_id) > 0
    {
        eprintln!("coupler: removed shared memory left by an earlier, dead run {run_id}");
    }
    let fluid_cmd = match &args.fluid_cmd {
        Some(c) => NodeCommand::given(Role::Fluid, c),
        None => NodeCommand::beside_me(Role::Fluid)?,
    };
    let solid_cmd = match &args.solid_cmd {
        Some(c) => NodeCommand::given(Role::Solid, c),
        None => NodeCommand::beside_me(Role::Solid)?,
    };
    // A missing node binary is reported before anything is written.
    let roles = Session::roles(&scene);
    if !args.attach {
        for role in &roles {
            let cmd = if *role == Role::Fluid {
                &fluid_cmd
            } else {
                &solid_cmd
            };
            cmd.check()?;
        }
    }
    let out = match (&args.resume, &args.out) {
        (Some(dir), _) => dir.clone(),
        (None, Some(out)) => out.clone(),
        (None, None) => PathBuf::from("runs").join(format!("{}-{}", scene.name, run_id)),
    };
    let mut dir = match &resume {
        Some(r) => {
            let mut dir = RunDir::open_existing(&out, &scene);
            let ck = &r.checkpoint;
            crate::checkpoint::rollback(&out, ck)?;
            dir.restore_series(ck.particles.clone(), ck.blocks.clone())
                .map_err(|e| {
                    format!("cannot rewrite the .pvd series in '{}': {e}", out.display())
                })?;
            dir
        }
        None => RunDir::create(&out, &scene)?,
    };

    // Cheap housekeeping: files of runs whose processes were all killed long ago.
    let stale = shared::transport::remove_stale_runs(Duration::from_secs(60));
    if !stale.is_empty() {
        eprintln!(
            "coupler: removed shared memory left by {} dead run(s)",
            stale.len()
        );
    }

    let saved = resume.as_ref().map(|r| &r.checkpoint);
    let scheme = saved
        .map(|c| c.scheme)
        .or(args.scheme)
        .unwrap_or(scene.coupling.scheme);
    let args_fluid_solver = saved
        .and_then(|c| c.fluid_solver.clone())
        .or(args.fluid_solver.clone());
    let args_solid_solver = saved
        .and_then(|c| c.solid_solver.clone())
        .or(args.solid_solver.clone());
    let dt_factor = saved.map_or(args.dt_factor, |c| c.dt_factor);
    let fluid_solver = roles.contains(&Role::Fluid).then(|| {
        args_fluid_solver.clone().unwrap_or_else(|| {
            scene
                .fluid
                .as_ref()
                .map(|f| f.solver.clone())
                .unwrap_or_default()
        })
    });
    let solid_solver = roles.contains(&Role::Solid).then(|| {
        args_solid_solver
            .clone()
            .unwrap_or_else(|| scene.solid.solver.clone())
    });
    eprintln!(
        "coupler: scene '{}' ({origin}); run {run_id}; fluid: {}; solid: {}; scheme {scheme}; output in {}",
        scene.name,
        fluid_solver.as_deref().unwrap_or("none (no water)"),
        solid_solver.as_deref().unwrap_or("none (no moving blocks)"),
        out.display()
    );
    if fluid_solver.as_deref()
        == Some(<fluid_node::methods::dfsph::Dfsph as fluid_node::methods::SphMethod>::NAME)
        && scheme == CouplingScheme::Parallel
        && scene.coupling.added_mass > 0.0
        && fluid_node::methods::dfsph::blocks_in_solve(&scene)
    {
        eprintln!(
            "coupler: warning: [coupling] added_mass = {} relaxes the loads of blocks that DFSPH already moves inside its pressure solve (its default in the parallel scheme): the solid then moves them otherwise than the water predicted (docs/REFERENCES.md §4.1b). Fix: drop --added-mass, or set [fluid.dfsph] blocks_in_solve = false to relax lagged loads instead",
            scene.coupling.added_mass
        );
    }
    let opts = RunOptions {
        scene: scene.clone(),
        fluid_solver: args_fluid_solver,
        solid_solver: args_solid_solver,
        scheme: Some(scheme),
        fluid_cmd,
        solid_cmd,
        attach: args.attach,
        run_id: run_id.clone(),
        transport: args.transport,
        endpoints,
        node_connect,
        connect_timeout: Duration::from_secs_f64(args.connect_timeout),
        step_timeout: Duration::from_secs_f64(args.step_timeout),
        setup_timeout: Duration::from_secs_f64(args.setup_timeout),
        dt_factor,
        progress: !args.quiet,
        checkpoint_interval,
        checkpoint_wall: checkpoint_wall_minutes.map(|m| Duration::from_secs_f64(m * 60.0)),
        resume: resume.map(|r| r.checkpoint),
        retries: args.retries,
    };
    let (stats, outcome) = Session::execute(opts, &mut dir);
    let summary = Summary::gather(
        &dir,
        &scene,
        run_id.as_str(),
        &stats,
        &outcome,
        scheme.to_string(),
    );
    if let Err(e) = dir.write_summary(&summary) {
        eprintln!("coupler: cannot write summary.json: {e}");
    }
    if scene.output.povray {
        // The paper rendered with POV-Ray: scene files always, pictures when povray is here.
        let render = std::env::var_os("PATH")
            .is_some_and(|p| std::env::split_paths(&p).any(|d| d.join("povray").is_file()));
        match crate::povray::export(&out, render, 960, 540) {
            Ok(files) => eprintln!(
                "coupler: {} POV-Ray frame(s) in {}{}",
                files.len(),
                out.join("povray").display(),
                if render {
                    ", rendered"
                } else {
                    " (install povray to render them)"
                }
            ),
            Err(e) => eprintln!("coupler: POV-Ray export failed: {e}"),
        }
    }
    match outcome {
        Ok(()) => {
            eprintln!(
                "coupler: done: {} steps to t = {:.4} s in {:.1} s wall; results in {}",
                stats.steps,
                stats.time,
                stats.wall_seconds,
                out.display()
            );
            Ok(0)
        }
        Err(e) => {
            eprintln!("coupler: error: {e}");
            eprintln!("coupler: results written so far are in {}", out.display());
            Ok(e.exit_code())
        }
    }
}
