//! `coupler run`'s settings: the scene with the command line's overrides and its checks, the
//! estimate printed before the run, and the flags checked before anything of the run exists.

use crate::cli::RunArgs;
use crate::run::launcher::Launcher;
use crate::run::resume::Resumed;
use shared::math::readable;
use shared::scene::Scene;
use shared::transport::{Endpoints, Kind};

/// `--dx`: the scene's particle spacing overridden, once checked.
pub fn set_dx(scene: &mut Scene, dx: f64) -> Result<(), String> {
    if !(dx.is_finite() && dx > 0.0) {
        return Err(format!(
            "--dx {}: must be a positive length in metres",
            readable(dx)
        ));
    }
    scene.set_dx(dx);
    Ok(())
}

/// The scene to run (the resumed run's, the file's or the embedded default) with the command
/// line's overrides, checked again; and where it came from, for the messages.
pub fn scene(args: &RunArgs, resume: Option<&Resumed>) -> Result<(Scene, String), String> {
    let mut scene = match resume {
        Some(r) => r.scene.clone(),
        None => crate::run::scenes::load(args.scene.as_deref()).map_err(|e| e.to_string())?,
    };
    let origin = match (&args.resume, &args.scene) {
        (Some(dir), _) => dir.join("scene.toml").display().to_string(),
        (None, Some(path)) => path.display().to_string(),
        (None, None) => shared::scene::DEFAULT_SCENE_ORIGIN.to_string(),
    };
    if let Some(dx) = args.dx {
        set_dx(&mut scene, dx)?;
    }
    if let Some(target) = args.target_error {
        let fits = crate::run::resolution::parse_csv(crate::run::resolution::EMBEDDED_FIT)?;
        let solver = args
            .fluid_solver
            .clone()
            .or_else(|| scene.fluid.as_ref().map(|f| f.solver.clone()))
            .ok_or("--target-error: the scene has no water, so there is no spacing to choose")?;
        let choice = crate::run::resolution::choose_dx(&fits, &solver, &scene, target)?;
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
    // Overrides must leave a valid scene too, and one that does not crawl (a resumed run was
    // let through when it started).
    let mut problems = crate::run::scenes::problems(&scene);
    if problems.is_empty() && !args.allow_long && resume.is_none() {
        problems = crate::run::sizes::crawl(&scene, args.fluid_solver.as_deref());
    }
    if !problems.is_empty() {
        let list: Vec<String> = problems.iter().map(|e| format!("  {e}")).collect();
        return Err(format!(
            "scene '{origin}' after command-line overrides:\n{}",
            list.join("\n")
        ));
    }
    Ok((scene, origin))
}

/// Prints the slides' blocks and the estimate of the run's size.
pub fn describe(scene: &Scene, args: &RunArgs, resume: Option<&Resumed>) {
    for line in crate::run::slides::describe(scene) {
        eprintln!("coupler: {line}");
    }
    // Stepped as the run's fluid solver steps: a resumed run keeps the one it was started with.
    let stepped_by = resume
        .and_then(|r| r.checkpoint.fluid_solver.as_deref())
        .or(args.fluid_solver.as_deref());
    if let Some(e) = crate::run::sizes::estimate(scene, stepped_by) {
        eprintln!("coupler: estimate: {}", e.describe());
    }
}

/// The flags' settings once checked.
pub struct Checked {
    /// Where the coupler listens and connects (zenoh), and what the nodes it starts connect to.
    pub endpoints: Endpoints,
    pub node_connect: Vec<String>,
    /// Checkpoint every this many simulated seconds and wall-clock minutes.
    pub checkpoint_interval: Option<f64>,
    pub checkpoint_wall_minutes: Option<f64>,
    /// MPI ranks of the fluid node (`--fluid-ranks`, else `[fluid] ranks`), and the launcher
    /// that starts them when there is more than one (`--mpirun`).
    pub fluid_ranks: u32,
    pub launcher: Launcher,
}

/// Checks the timeouts, the transport's endpoints, retries, checkpoints, the dt factor and the
/// fluid's ranks (saying what each would hold).
pub fn check_flags(
    args: &RunArgs,
    scene: &Scene,
    resume: Option<&Resumed>,
) -> Result<Checked, String> {
    check_values(args, scene, resume)?;
    let (endpoints, node_connect) = zenoh_endpoints(args)?;
    if args.attach && args.retries > 0 {
        return Err(format!(
            "--retries {} with --attach: the coupler can only restart nodes it started itself. Fix: drop --attach, or --retries (and resume by hand with --resume)",
            args.retries
        ));
    }
    let fluid_ranks = crate::run::per_rank::ranks(args.fluid_ranks, scene)?;
    refuse_on_ranks(args, scene, resume, fluid_ranks)?;
    let (checkpoint_interval, checkpoint_wall_minutes) = if args.no_checkpoints {
        eprintln!(
            "coupler: no checkpoints (--no-checkpoints): a run killed starts again from t = 0"
        );
        (None, None)
    } else {
        let interval = args
            .checkpoint_interval
            .or(scene.output.checkpoint_interval);
        let wall = args
            .checkpoint_wall_minutes
            .or(scene.output.checkpoint_wall_minutes);
        let asked = interval.is_some() || wall.is_some();
        let wall = wall
            .or((args.retries > 0 && interval.is_none()).then_some(10.0))
            .or_else(|| {
                (!asked)
                    .then(|| default_checkpoints(args, scene, resume))
                    .flatten()
            });
        (interval, wall)
    };
    let launcher = Launcher::parse(args.mpirun.as_deref())?;
    if fluid_ranks > 1
        && let Some(p) = crate::run::per_rank::PerRank::estimate(scene, fluid_ranks)
    {
        eprintln!("coupler: {}", p.describe());
    }
    Ok(Checked {
        endpoints,
        node_connect,
        checkpoint_interval,
        checkpoint_wall_minutes,
        fluid_ranks,
        launcher,
    })
}

/// The flags' values that need no network, launcher or ranks: the timeouts, the checkpoints,
/// the solver names and the dt factor. `coupler spread` checks its members' run arguments with
/// it before the first run starts.
pub fn check_values(args: &RunArgs, scene: &Scene, resume: Option<&Resumed>) -> Result<(), String> {
    timeouts(args)?;
    checkpoints(args, scene)?;
    known_solvers(args)?;
    dt_factor(args, scene, resume)
}

/// Shortest timeout [s]: a shorter one risks declaring a healthy node hung when the machine is
/// busy, and `--step-timeout 1e-300` did ("no answer within 0.0 s"), after the run directory
/// was made.
const MIN_TIMEOUT_SECONDS: f64 = 1.0;

/// Longest timeout [s], about 30 years: `Duration` panics past its range.
const MAX_TIMEOUT_SECONDS: f64 = 1e9;

fn timeouts(args: &RunArgs) -> Result<(), String> {
    for (flag, v) in [
        ("--connect-timeout", args.connect_timeout),
        ("--step-timeout", args.step_timeout),
        ("--setup-timeout", args.setup_timeout),
    ] {
        if !(v.is_finite() && (MIN_TIMEOUT_SECONDS..MAX_TIMEOUT_SECONDS).contains(&v)) {
            return Err(format!(
                "{flag} {}: must be a number of seconds from {MIN_TIMEOUT_SECONDS} (a shorter one risks declaring a healthy node hung) to below 1e9 (about 30 years). Fix: e.g. {flag} 60",
                readable(v)
            ));
        }
    }
    Ok(())
}

/// Longest wall interval between checkpoints [minutes]: as the timeouts, below 1e9 s. Past
/// `Duration`'s range, `--checkpoint-wall-minutes 1e300` panicked once the run directory was
/// made.
const MAX_CHECKPOINT_WALL_MINUTES: f64 = MAX_TIMEOUT_SECONDS / 60.0;

/// The checkpoint intervals as the run takes them (the flag's, else the scene's), each named
/// by where it came from. A simulated interval shorter than `time.dt_min` (the shortest step)
/// is refused: `--checkpoint-interval 1e-300` hung the coupler stepping through its grid.
fn checkpoints(args: &RunArgs, scene: &Scene) -> Result<(), String> {
    if args.no_checkpoints {
        return Ok(()); // not even the scene's are taken (the flags conflict with it)
    }
    // (the name, its value, a good setting of it with `example`)
    let named = |flag: Option<f64>, field: &str, scene_value: Option<f64>, example: &str| {
        let option = format!("--{}", field.replace('_', "-"));
        match flag {
            Some(v) => Some((option.clone(), v, format!("{option} {example}"))),
            None => scene_value.map(|v| {
                let key = format!("output.{field}");
                (key, v, format!("{field} = {example} in [output]"))
            }),
        }
    };
    let dt_min = scene.time.dt_min;
    if let Some((name, v, good)) = named(
        args.checkpoint_interval,
        "checkpoint_interval",
        scene.output.checkpoint_interval,
        "0.5",
    ) && !(v.is_finite() && v >= dt_min)
    {
        return Err(format!(
            "{name} {}: must be a number of simulated seconds of at least time.dt_min = {} (the shortest step; one checkpoint a step at most). Fix: e.g. {good}, or --checkpoint-wall-minutes for checkpoints by the clock",
            readable(v),
            readable(dt_min)
        ));
    }
    if let Some((name, v, good)) = named(
        args.checkpoint_wall_minutes,
        "checkpoint_wall_minutes",
        scene.output.checkpoint_wall_minutes,
        "30",
    ) && !(v.is_finite() && v > 0.0 && v < MAX_CHECKPOINT_WALL_MINUTES)
    {
        return Err(format!(
            "{name} {}: must be a positive number of minutes below {MAX_CHECKPOINT_WALL_MINUTES:.3e} (about 30 years). Fix: e.g. {good}, or --no-checkpoints",
            readable(v)
        ));
    }
    Ok(())
}

/// `--fluid-solver` and `--solid-solver` name a solver of the nodes beside the coupler: an
/// unknown name was found by the node, after the run directory was made ("fluid node
/// (wcsphx) failed at step 0"). A node of one's own (`--fluid-cmd`, `--solid-cmd`, or nodes
/// started by hand with `--attach`) may offer other solvers, and answers for itself.
fn known_solvers(args: &RunArgs) -> Result<(), String> {
    if args.attach {
        return Ok(());
    }
    for (flag, name, own_node, names) in [
        (
            "--fluid-solver",
            &args.fluid_solver,
            &args.fluid_cmd,
            fluid_node::REGISTRY.names(),
        ),
        (
            "--solid-solver",
            &args.solid_solver,
            &args.solid_cmd,
            solid_node::REGISTRY.names(),
        ),
    ] {
        if let (Some(name), None) = (name, own_node)
            && !names.contains(&name.as_str())
        {
            return Err(format!(
                "{flag} '{name}': no such solver. Fix: one of {} (`coupler check` describes them)",
                names.join(", ")
            ));
        }
    }
    Ok(())
}

/// `--dt-factor`: positive, and not so small that the run crawls. Every step is multiplied by
/// it, so a factor of 1e-6 makes a million times the steps: `--dt-factor 1e-300` ran on without
/// end. Refused past the limits [`crate::run::sizes::crawl`] sets for a scene, unless
/// `--allow-long` (a resumed run was let through when it started).
fn dt_factor(args: &RunArgs, scene: &Scene, resume: Option<&Resumed>) -> Result<(), String> {
    use crate::run::sizes::{MAX_STEPS, MAX_WALL_SECONDS, duration, steps_dt_wall};
    let f = args.dt_factor;
    if !(f.is_finite() && f > 0.0) {
        return Err(format!(
            "--dt-factor {}: must be a positive number. Fix: e.g. --dt-factor 0.5 halves every step",
            readable(f)
        ));
    }
    if args.allow_long || resume.is_some() || f >= 1.0 {
        return Ok(());
    }
    let (steps, _, wall, _) = steps_dt_wall(scene, args.fluid_solver.as_deref());
    let (steps, wall) = (steps / f, wall / f);
    if steps <= MAX_STEPS && wall <= MAX_WALL_SECONDS {
        return Ok(());
    }
    Err(format!(
        "--dt-factor {}: makes the run crawl: about {steps:.3e} steps, {} of wall time or more; past the limit of {MAX_STEPS:e} steps or {:.0} h. Fix: a factor nearer 1 (0.5 halves every step), or pass --allow-long to run it anyway",
        readable(f),
        duration(wall),
        MAX_WALL_SECONDS / 3600.0
    ))
}

/// What a fluid on `ranks` ranks cannot do yet ([`crate::run::not_on_ranks`]): the run's fluid
/// solver (a resumed run's is its checkpoint's) must split over ranks.
fn refuse_on_ranks(
    args: &RunArgs,
    scene: &Scene,
    resume: Option<&Resumed>,
    ranks: u32,
) -> Result<(), String> {
    let solver = resume
        .and_then(|r| r.checkpoint.fluid_solver.as_deref())
        .or(args.fluid_solver.as_deref());
    crate::run::not_on_ranks::solver(scene, solver, ranks)
}

/// Wall-clock minutes between the checkpoints of a run estimated to take longer than that when
/// none is asked for: a run killed by the machine loses at most this much, and a run shorter
/// than it writes none.
pub const DEFAULT_CHECKPOINT_MINUTES: f64 = 15.0;

/// The run's estimated wall time [s] from `from_time` to its end, stepped as `solver` (`None`:
/// the scene's) steps it ([`crate::run::sizes::Estimate::wall_likely`]). `None` without water
/// (no estimate).
pub fn estimated_wall_seconds(scene: &Scene, solver: Option<&str>, from_time: f64) -> Option<f64> {
    let e = crate::run::sizes::estimate(scene, solver)?;
    let left = ((scene.time.end - from_time) / scene.time.end).clamp(0.0, 1.0);
    Some(e.wall_likely * left)
}

/// The wall interval of the checkpoints a run writes when none is asked for:
/// [`DEFAULT_CHECKPOINT_MINUTES`] when the rest of the run is estimated longer than that, or
/// cannot be estimated (no water); announced.
fn default_checkpoints(args: &RunArgs, scene: &Scene, resume: Option<&Resumed>) -> Option<f64> {
    let solver = resume
        .and_then(|r| r.checkpoint.fluid_solver.as_deref())
        .or(args.fluid_solver.as_deref());
    let from = resume.map_or(0.0, |r| r.checkpoint.time);
    let minutes = DEFAULT_CHECKPOINT_MINUTES;
    let why = match estimated_wall_seconds(scene, solver, from).filter(|s| s.is_finite()) {
        Some(s) if s <= minutes * 60.0 => return None,
        Some(s) => format!("the run is estimated at about {:.0} minutes", s / 60.0),
        None => "a run without water is not estimated; a shorter one writes none".to_string(),
    };
    eprintln!(
        "coupler: a checkpoint every {minutes} wall minutes ({why}). --no-checkpoints turns them off, --checkpoint-wall-minutes sets the interval"
    );
    Some(minutes)
}

/// What is wrong with a zenoh endpoint `PROTOCOL/HOST:PORT` that can be told without the
/// network (a port past 65 535, a dotted address with a part past 255 would otherwise cost
/// the whole connect timeout), or `None`.
fn endpoint_problem(endpoint: &str) -> Option<String> {
    let Some((proto, addr)) = endpoint.split_once('/').filter(|(p, _)| !p.is_empty()) else {
        return Some("no PROTOCOL/ before the address".into());
    };
    let Some((host, port)) = addr.rsplit_once(':') else {
        return Some("no :PORT after the host".into());
    };
    if !matches!(proto, "tcp" | "udp" | "tls" | "quic") {
        return None; // other links (unixsock-stream, …) have addresses of their own
    }
    if port.parse::<u16>().is_err() {
        return Some(format!("port '{port}' is not a number from 0 to 65535"));
    }
    let dotted: Vec<&str> = host.split('.').collect();
    let numeric = dotted.len() == 4 && dotted.iter().all(|p| p.chars().all(|c| c.is_ascii_digit()));
    if numeric && host.parse::<std::net::Ipv4Addr>().is_err() {
        return Some(format!(
            "'{host}' is not an IPv4 address (each part 0 to 255)"
        ));
    }
    None
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
        endpoint_problem(e).map_or(Ok(()), |problem| {
            Err(format!(
                "'{e}' is not a zenoh endpoint: {problem}. Fix: write PROTOCOL/HOST:PORT, e.g. tcp/0.0.0.0:7447"
            ))
        })?;
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

#[cfg(test)]
mod tests {
    use super::*;
    use clap::Parser;

    fn run_args(words: &[&str]) -> RunArgs {
        let cli = crate::cli::Cli::try_parse_from(["coupler", "run"].iter().chain(words))
            .map_err(|e| e.to_string())
            .unwrap();
        match cli.command {
            crate::cli::Cmd::Run(args) => *args,
            _ => unreachable!(),
        }
    }

    #[test]
    fn an_endpoint_that_cannot_exist_is_named_before_any_connect() {
        assert_eq!(endpoint_problem("tcp/0.0.0.0:7447"), None);
        assert_eq!(endpoint_problem("tcp/[::1]:7447"), None);
        assert_eq!(endpoint_problem("tcp/coupler.example.org:7447"), None);
        for (bad, says) in [
            ("garbage", "PROTOCOL"),
            ("tcp/10.0.0.1", "PORT"),
            ("tcp/10.0.0.1:99999", "65535"),
            ("tcp/999.1.1.1:7447", "IPv4"),
            ("tcp/10.0.0.1:-1", "65535"),
        ] {
            let p = endpoint_problem(bad).unwrap_or_default();
            assert!(p.contains(says), "{bad}: {p}");
        }
    }

    /// A node of one's own, or started by hand, may offer solvers the built-in nodes do not.
    #[test]
    fn solver_names_are_checked_only_for_the_built_in_nodes() {
        assert!(known_solvers(&run_args(&["--fluid-solver", "lite"])).is_err());
        assert!(known_solvers(&run_args(&["--solid-solver", "euler"])).is_err());
        for words in [
            &["--fluid-solver", "lite", "--fluid-cmd", "my-node"][..],
            &["--solid-solver", "euler", "--solid-cmd", "my-node"][..],
            &["--fluid-solver", "lite", "--attach"][..],
        ] {
            assert!(known_solvers(&run_args(words)).is_ok(), "{words:?}");
        }
        assert!(known_solvers(&run_args(&["--fluid-solver", "dfsph"])).is_ok());
    }

    fn wall_minutes(words: &[&str], scene: &Scene) -> Option<f64> {
        check_flags(&run_args(words), scene, None)
            .unwrap()
            .checkpoint_wall_minutes
    }

    /// A run estimated past 15 minutes checkpoints every 15 wall minutes unless told otherwise;
    /// a short one, or one that asks for its own checkpoints, does not get them.
    #[test]
    fn long_runs_checkpoint_by_default() {
        let mut short = Scene::default_scene();
        short.set_dx(0.08);
        short.time.end = 0.1;
        assert!(estimated_wall_seconds(&short, None, 0.0).unwrap() < 60.0);
        assert_eq!(wall_minutes(&[], &short), None);
        let mut long = Scene::default_scene();
        long.set_dx(0.01);
        let s = estimated_wall_seconds(&long, None, 0.0).unwrap();
        assert!(s > DEFAULT_CHECKPOINT_MINUTES * 60.0, "{s}");
        assert!(
            estimated_wall_seconds(&long, None, long.time.end * 0.5).unwrap() < 0.51 * s,
            "a resumed run is estimated over what is left"
        );
        assert_eq!(wall_minutes(&[], &long), Some(DEFAULT_CHECKPOINT_MINUTES));
        assert_eq!(wall_minutes(&["--no-checkpoints"], &long), None);
        assert_eq!(
            wall_minutes(&["--checkpoint-interval", "0.5"], &long),
            None,
            "checkpoints asked for"
        );
        assert_eq!(
            wall_minutes(&["--checkpoint-wall-minutes", "3"], &long),
            Some(3.0)
        );
        let both = crate::cli::Cli::try_parse_from([
            "coupler",
            "run",
            "--no-checkpoints",
            "--checkpoint-interval",
            "1",
        ]);
        assert!(both.is_err(), "--no-checkpoints with a checkpoint flag");
        let mut scene_asks = long.clone();
        scene_asks.output.checkpoint_interval = Some(1.0);
        let checked = check_flags(&run_args(&["--no-checkpoints"]), &scene_asks, None).unwrap();
        assert_eq!(checked.checkpoint_interval, None, "not even the scene's");
    }

    /// On several fluid ranks a long run gets its default checkpoints as on one (rank 0 writes
    /// the one-rank file), the checkpoint flags are taken, and every built-in fluid solver is
    /// let through.
    #[test]
    fn runs_on_ranks_checkpoint_as_on_one() {
        let mut long = Scene::default_scene();
        long.blocks
            .retain(|b| b.kind == shared::scene::BlockKind::Fixed);
        long.fluid.as_mut().unwrap().solver = "wcsph".into();
        long.set_dx(0.01);
        assert_eq!(wall_minutes(&["--fluid-ranks", "2"], &long), Some(15.0));
        for words in [
            &["--checkpoint-interval", "0.5"][..],
            &["--retries", "1"][..],
        ] {
            let args = run_args(&[words, &["--fluid-ranks", "2"]].concat());
            assert!(check_flags(&args, &long, None).is_ok(), "{words:?}");
        }
        for solver in fluid_node::REGISTRY.names() {
            let args = run_args(&["--fluid-ranks", "2", "--fluid-solver", solver]);
            assert!(check_flags(&args, &long, None).is_ok(), "{solver}");
        }
    }
}
