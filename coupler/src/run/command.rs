//! `coupler run`: from the command line to a finished run directory, in the order a run takes:
//! the run to resume, the scene and its overrides, the flags, the run id and its lock, the node
//! commands, the run directory, the session's steps ([`crate::run::session`]), the summary.

use crate::cli::RunArgs;
use crate::run::checkpoint::CouplerCheckpoint;
use crate::run::launch::NodeCommand;
use crate::run::output::RunDir;
use crate::run::resume::Resumed;
use crate::run::session::{RunOptions, Session};
use crate::run::settings::Checked;
use crate::run::summary::Summary;
use crate::run::{error::RunError, lock::RunLock, stats::RunStats};
use shared::protocol::Role;
use shared::scene::{CouplingScheme, Scene};
use shared::transport::RunId;
use std::path::{Path, PathBuf};
use std::time::Duration;

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

fn run_inner(args: RunArgs) -> Result<u8, String> {
    let resume = crate::run::resume::resume(&args)?;
    // The scene's checks and the estimates read the terrains once between them.
    let once = shared::terrain::reuse::Reuse::begin();
    let (scene, origin) = crate::run::settings::scene(&args, resume.as_ref())?;
    crate::run::settings::describe(&scene, &args, resume.as_ref());
    let checked = crate::run::settings::check_flags(&args, &scene, resume.as_ref())?;
    drop(once);
    let (run_id, _lock) = claim_run_id(&args)?;
    let nodes = node_commands(&args, &scene, &checked)?;
    let (out, mut dir, fresh_lock) = run_dir(&args, &scene, &run_id, resume.as_ref())?;
    // Cheap housekeeping: files of runs whose processes were all killed long ago.
    let stale = shared::transport::remove_stale_runs(Duration::from_secs(60));
    if !stale.is_empty() {
        eprintln!(
            "coupler: removed shared memory left by {} dead run(s)",
            stale.len()
        );
    }
    let solvers = Solvers::choose(&args, &scene, resume.as_ref());
    eprintln!(
        "coupler: scene '{}' ({origin}); run {run_id}; fluid: {}; solid: {}; scheme {}; output in {}",
        scene.name,
        solvers.fluid.as_deref().unwrap_or("none (no water)"),
        solvers
            .solid
            .as_deref()
            .unwrap_or("none (no moving blocks)"),
        solvers.scheme,
        out.display()
    );
    warn(&scene, solvers.fluid.as_deref(), solvers.scheme);
    let scheme = solvers.scheme;
    // The run directory's lock (the resumed run's, or the new one's) is held until the end.
    let (checkpoint, mut dir_lock) = match resume {
        Some(r) => (Some(r.checkpoint), Some(r.lock)),
        None => (None, fresh_lock),
    };
    if let Some(lock) = &mut dir_lock {
        if let Some(old) = lock.previous_run() {
            remove_interrupted(&old);
        }
        lock.name_run(&run_id)?;
    }
    let opts = options(&args, &scene, solvers, nodes, &run_id, checked, checkpoint);
    let (stats, outcome) = Session::execute(opts, &mut dir);
    Ok(finish(&dir, &scene, &run_id, &stats, outcome, scheme, &out))
}

/// How long the nodes of a run whose coupler was killed are given to leave before a resume
/// removes what they left.
const INTERRUPTED_GRACE: Duration = Duration::from_secs(5);

/// The run `old` whose coupler died in this run directory (a resume): once its nodes are gone,
/// its shared memory goes too. Its nodes tidy up when they find the coupler dead, but an MPI
/// launcher may kill a rank before it has (its own grace after forwarding SIGTERM is short);
/// the sweep of dead runs at every start only takes files a minute old.
fn remove_interrupted(old: &RunId) {
    let start = std::time::Instant::now();
    while shared::transport::run_has_live_nodes(old) {
        if start.elapsed() > INTERRUPTED_GRACE {
            return; // still alive: they will tidy up themselves
        }
        // Processes leaving have no event to wait on; they take moments.
        std::thread::sleep(Duration::from_millis(50));
    }
    if shared::transport::remove_run_files(old) > 0 {
        eprintln!("coupler: removed shared memory left by the interrupted run {old}");
    }
}

/// Takes the run id (given or fresh) for this coupler, and clears what dead runs left.
fn claim_run_id(args: &RunArgs) -> Result<(RunId, RunLock), String> {
    let run_id = match &args.run_id {
        Some(s) => RunId::parse(s).map_err(|e| format!("--run-id: {e}"))?,
        None => RunId::fresh(),
    };
    // Before anything of the run exists: a second coupler on a live run's id would stop that
    // run and remove its files.
    let lock = RunLock::acquire(&run_id)?;
    // A coupler killed by SIGKILL could not remove its lock file (its nodes remove the run's
    // shared memory, not the lock): the next run sweeps such free locks, so they do not pile up.
    crate::run::lock::remove_stale_locks();
    // The id is ours; files a killed run of the same id left behind would confuse the services.
    if !shared::transport::run_has_live_nodes(&run_id)
        && shared::transport::remove_run_files(&run_id) > 0
    {
        eprintln!("coupler: removed shared memory left by an earlier, dead run {run_id}");
    }
    Ok((run_id, lock))
}

/// The fluid and solid node commands, the fluid's through the MPI launcher on more than one
/// rank ([`crate::run::launcher`]); a missing node binary or launcher, or a node built without
/// MPI for more than one rank, is reported before anything is written.
fn node_commands(
    args: &RunArgs,
    scene: &Scene,
    checked: &Checked,
) -> Result<(NodeCommand, NodeCommand), String> {
    let fluid_cmd = fluid_node(args, scene, checked.fluid_ranks, &checked.launcher)?;
    let solid_cmd = match &args.solid_cmd {
        Some(c) => NodeCommand::given(Role::Solid, c),
        None => NodeCommand::beside_me(Role::Solid)?,
    };
    if !args.attach {
        for role in &Session::roles(scene) {
            let cmd = if *role == Role::Fluid {
                &fluid_cmd
            } else {
                &solid_cmd
            };
            cmd.check()?;
        }
    }
    Ok((fluid_cmd, solid_cmd))
}

/// The fluid node's command (`--fluid-cmd`, else the fluid-node beside the coupler), through
/// `launcher` on more than one of `ranks` when the scene has water: a missing node binary or
/// launcher, or a node built without MPI, is refused ([`crate::run::launcher::fluid_command`]).
/// `coupler spread` asks it of its runs before the first starts.
pub fn fluid_node(
    args: &RunArgs,
    scene: &Scene,
    ranks: u32,
    launcher: &crate::run::launcher::Launcher,
) -> Result<NodeCommand, String> {
    let node = match &args.fluid_cmd {
        Some(c) => NodeCommand::given(Role::Fluid, c),
        None => NodeCommand::beside_me(Role::Fluid)?,
    };
    if !Session::roles(scene).contains(&Role::Fluid) {
        return Ok(node);
    }
    let asked = crate::run::node_ranks::asked(args.fluid_ranks, ranks);
    crate::run::launcher::fluid_command(node, ranks, &asked, launcher, args.attach)
}

/// The run directory: a new one (with its lock), or the resumed run's cut back to its
/// checkpoint (its lock is the resume's).
fn run_dir(
    args: &RunArgs,
    scene: &Scene,
    run_id: &RunId,
    resume: Option<&Resumed>,
) -> Result<(PathBuf, RunDir, Option<RunLock>), String> {
    let out = match (&args.resume, &args.out) {
        (Some(dir), _) => dir.clone(),
        (None, Some(out)) => out.clone(),
        (None, None) => PathBuf::from("runs").join(format!("{}-{}", scene.name, run_id)),
    };
    let (dir, lock) = match resume {
        Some(r) => {
            let mut dir = RunDir::open_existing(&out, scene);
            let ck = &r.checkpoint;
            crate::run::checkpoint::rollback(&out, ck)?;
            dir.restore_series(ck.particles.clone(), ck.blocks.clone())
                .map_err(|e| {
                    format!("cannot rewrite the .pvd series in '{}': {e}", out.display())
                })?;
            (dir, None)
        }
        None => {
            let dir = RunDir::create(&out, scene)?;
            // A `--resume` of this directory while it runs is refused.
            (dir, Some(RunLock::directory(&out)?))
        }
    };
    Ok((out, dir, lock))
}

/// The scheme and solvers the run uses: a resumed run keeps those it was started with.
struct Solvers {
    scheme: CouplingScheme,
    /// The command line's (or the checkpoint's) choices, for the session.
    args_fluid: Option<String>,
    args_solid: Option<String>,
    dt_factor: f64,
    /// The solvers that will run, by name (none: no such node), for the messages.
    fluid: Option<String>,
    solid: Option<String>,
}

impl Solvers {
    fn choose(args: &RunArgs, scene: &Scene, resume: Option<&Resumed>) -> Solvers {
        let roles = Session::roles(scene);
        let saved = resume.map(|r| &r.checkpoint);
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
        Solvers {
            scheme,
            args_fluid: args_fluid_solver,
            args_solid: args_solid_solver,
            dt_factor,
            fluid: fluid_solver,
            solid: solid_solver,
        }
    }
}

/// Warnings about settings that work against each other: the fluid solver's registry entry's,
/// and [`sampling_warning`].
fn warn(scene: &Scene, fluid_solver: Option<&str>, scheme: CouplingScheme) {
    let own = fluid_solver
        .and_then(|n| fluid_node::REGISTRY.get(n).ok())
        .map(|entry| (entry.advice.warnings)(scene, scheme))
        .unwrap_or_default();
    for w in own.into_iter().chain(sampling_warning(scene)) {
        eprintln!("coupler: warning: {w}");
    }
}

/// Fewer instrument rows than this over a run with gauges or probes is warned about.
const FEW_ROWS: f64 = 20.0;

/// Gauges and probes record at most every `output.interval/50`
/// ([`fluid_node::instruments::gauges::ROWS_PER_INTERVAL`]): an interval long against the run
/// leaves a handful of rows, and crests and peaks read from them mean nothing (`interval = 10`
/// over a 0.2 s run wrote one row and a crest of 0, without a word). Not refused: `--end`
/// shortens a run below its interval on purpose (a quick look, the tests).
fn sampling_warning(scene: &Scene) -> Option<String> {
    use fluid_node::instruments::gauges::ROWS_PER_INTERVAL;
    let instruments = scene.gauges.len() + scene.probes.len();
    let every = scene.output.interval / ROWS_PER_INTERVAL;
    let rows = scene.time.end / every;
    (instruments > 0 && scene.has_fluid() && rows < FEW_ROWS).then(|| {
        format!(
            "the scene's {instruments} gauges and probes record at most every output.interval/{ROWS_PER_INTERVAL} = {every:.3e} s, about {} row(s) over time.end = {} s: too few for a crest or a peak; fix: output.interval ≤ {:.3e} s gives {FEW_ROWS} rows or more",
            // The first row at the first step, then one each `every`: ⌈end/every⌉.
            (rows.ceil() as u64).max(1),
            shared::math::readable(scene.time.end),
            scene.time.end * ROWS_PER_INTERVAL / FEW_ROWS
        )
    })
}

/// What the session needs.
fn options(
    args: &RunArgs,
    scene: &Scene,
    solvers: Solvers,
    (fluid_cmd, solid_cmd): (NodeCommand, NodeCommand),
    run_id: &RunId,
    checked: Checked,
    resume: Option<CouplerCheckpoint>,
) -> RunOptions {
    RunOptions {
        scene: scene.clone(),
        fluid_solver: solvers.args_fluid,
        solid_solver: solvers.args_solid,
        scheme: Some(solvers.scheme),
        fluid_cmd,
        solid_cmd,
        attach: args.attach,
        run_id: run_id.clone(),
        transport: args.transport,
        endpoints: checked.endpoints,
        node_connect: checked.node_connect,
        connect_timeout: Duration::from_secs_f64(args.connect_timeout),
        step_timeout: Duration::from_secs_f64(args.step_timeout),
        setup_timeout: Duration::from_secs_f64(args.setup_timeout),
        dt_factor: solvers.dt_factor,
        progress: !args.quiet,
        checkpoint_interval: checked.checkpoint_interval,
        checkpoint_wall: checked
            .checkpoint_wall_minutes
            .map(|m| Duration::from_secs_f64(m * 60.0)),
        resume,
        retries: args.retries,
        fluid_ranks: checked.fluid_ranks,
        launcher: checked.launcher,
    }
}

/// Writes `summary.json` (and the POV-Ray frames the scene asks for), says how the run ended
/// and returns the exit code.
fn finish(
    dir: &RunDir,
    scene: &Scene,
    run_id: &RunId,
    stats: &RunStats,
    outcome: Result<(), RunError>,
    scheme: CouplingScheme,
    out: &Path,
) -> u8 {
    let summary = Summary::gather(
        dir.path(),
        scene,
        run_id.as_str(),
        stats,
        &outcome,
        scheme.to_string(),
    );
    if let Err(e) = summary.write(dir.path()) {
        eprintln!("coupler: cannot write summary.json: {e}");
    }
    if scene.output.povray {
        // The paper rendered with POV-Ray: scene files always, pictures when povray is here.
        let render = std::env::var_os("PATH")
            .is_some_and(|p| std::env::split_paths(&p).any(|d| d.join("povray").is_file()));
        match crate::run::povray::export(out, render, 960, 540) {
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
            0
        }
        Err(e) => {
            eprintln!("coupler: error: {e}");
            eprintln!("coupler: results written so far are in {}", out.display());
            e.exit_code()
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A run shorter than a few sampling intervals is warned about, naming the fix; the
    /// default scene (2.5 s at interval 0.05: 2 500 rows) is not.
    #[test]
    fn too_few_instrument_rows_are_warned_about() {
        let mut scene = Scene::default_scene();
        assert_eq!(sampling_warning(&scene), None);
        scene.output.interval = 10.0;
        scene.time.end = 0.2;
        let w = sampling_warning(&scene).expect("a warning");
        assert!(
            w.contains("about 1 row(s) over time.end = 0.2 s")
                && w.contains("fix: output.interval ≤ 5.000e-1 s"),
            "{w}"
        );
    }
}
