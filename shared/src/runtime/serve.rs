//! What every node does once joined: build its solver from the setup, then serve the
//! coupler's commands (exchange, advance, write a frame, report a status) until told to stop,
//! and report a solver's failure to the coupler, which names it.
//!
//! The role-specific exchange of each step is a [`Side`]; the order of the calls it makes is
//! the step contract of [`crate::solver`].

use super::args::NodeArgs;
use super::control::{Control, Fatal, SLICE};
use super::exit;
use crate::checkpoint::{self, NodeCheckpoint, NodeHeader};
use crate::protocol::{Command, CommandKind, Resume, Role, Setup, StatusCode};
use crate::scene::Scene;
use crate::solver::{FluidSolver, SetupContext, SolidSolver, Solver, SolverError, StepReport};
use crate::transport::TransportError;
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

/// One side of the coupling, as the command loop drives it.
pub(super) trait Side {
    fn solver(&mut self) -> &mut dyn Solver;
    /// The step this node can take per exchange, reported to the coupler, which grants the
    /// coupling step from these: the solver's own stable step, unless the node sub-cycles.
    fn coupling_proposal(&mut self) -> f64 {
        self.solver().dt_proposal()
    }
    /// The set-up exchange, before the first status; `resume` is where a resumed run
    /// continues from.
    fn initial_exchange(&mut self, control: &Control, resume: Option<&Resume>)
    -> Result<(), Fatal>;
    /// The runtime's own part of a checkpoint: what this side sent that the peer has not
    /// consumed yet, and its watches.
    fn save_runtime(&self) -> Result<Vec<u8>, String>;
    /// Restores [`Side::save_runtime`].
    fn restore_runtime(&mut self, bytes: &[u8]) -> Result<(), String>;
    /// One step's exchange with the other node and the solver's advance (not the output
    /// frame). Returns the solver's report and the time spent computing (not waiting).
    fn advance(
        &mut self,
        control: &Control,
        cmd: &Command,
    ) -> Result<(StepReport, Duration), StepFailure>;
}

/// Why a step ended early: the solver failed (reported to the coupler), or the node must stop.
pub(super) enum StepFailure {
    Solver(SolverError),
    Fatal(Fatal),
}

impl From<SolverError> for StepFailure {
    fn from(e: SolverError) -> Self {
        StepFailure::Solver(e)
    }
}

impl From<Fatal> for StepFailure {
    fn from(e: Fatal) -> Self {
        StepFailure::Fatal(e)
    }
}

/// Builds a fluid solver by name.
pub type FluidFactory = fn(&str, &SetupContext) -> Result<Box<dyn FluidSolver>, SolverError>;
/// Builds a solid solver by name.
pub type SolidFactory = fn(&str, &SetupContext) -> Result<Box<dyn SolidSolver>, SolverError>;

/// A transport failure during the set-up exchange, reported as the solver's failure.
pub(super) fn fatal_to_solver(f: Fatal) -> SolverError {
    match f {
        Fatal::Transport(e) => SolverError::Failed(format!("transport: {e}")),
        Fatal::CouplerGone => SolverError::Failed("the coupler is gone".into()),
        Fatal::Signal => SolverError::Failed("interrupted".into()),
    }
}

/// A solver built from the setup, with the scene it was built for.
pub(super) struct Built<S: ?Sized> {
    pub solver: Box<S>,
    pub scene: Scene,
}

/// Builds the solver the setup (or this node's own `--solver`, which wins) names. A failure is
/// reported to the coupler and gives `None`.
pub(super) fn build<S: ?Sized>(
    control: &Control,
    setup: &Setup,
    solvers: &[&str],
    args: &NodeArgs,
    factory: fn(&str, &SetupContext) -> Result<Box<S>, SolverError>,
) -> Result<Option<Built<S>>, Fatal> {
    let role = control.role();
    let name = args.solver.clone().unwrap_or_else(|| match role {
        Role::Fluid => setup.fluid_solver.clone(),
        Role::Solid => setup.solid_solver.clone(),
    });
    let scene = match setup.scene() {
        Ok(scene) => scene,
        Err(e) => {
            control.report(StatusCode::Failed, 0, 0.0, 0.0, 0.0, &e)?;
            return Ok(None);
        }
    };
    // A resumed solver is built into a scratch directory: its constructor starts output files
    // afresh, while the run's own ones must keep what was written before the checkpoint.
    // `restore_state` then continues those (the coupler cut them back to the checkpoint).
    let run_dir = match &setup.resume {
        Some(_) => {
            let scratch = scratch_dir(&setup.run_dir, role);
            std::fs::create_dir_all(&scratch).map_err(|e| {
                Fatal::Transport(TransportError::Protocol(format!(
                    "cannot create '{}': {e}",
                    scratch.display()
                )))
            })?;
            scratch
        }
        None => setup.run_dir.clone(),
    };
    let ctx = SetupContext {
        scene: &scene,
        run_dir: &run_dir,
        scheme: setup.scheme,
        peer_present: match role {
            Role::Fluid => setup.solid_present,
            Role::Solid => setup.fluid_present,
        },
    };
    let built = if !solvers.contains(&name.as_str()) {
        Err(SolverError::Failed(format!(
            "unknown {} solver '{name}': this binary offers {}",
            role.name(),
            solvers.join(", ")
        )))
    } else {
        factory(&name, &ctx)
    };
    match built {
        Ok(solver) => Ok(Some(Built { solver, scene })),
        Err(e) => {
            control.report(StatusCode::Failed, 0, 0.0, 0.0, 0.0, &format!("{e}"))?;
            Ok(None)
        }
    }
}

/// Where a resumed node builds its solver (removed once the state is restored).
fn scratch_dir(run_dir: &Path, role: Role) -> PathBuf {
    checkpoint::dir(run_dir).join(format!("scratch-{}", role.name()))
}

/// How the loop runs, from the setup, the scene and the command line.
pub(super) struct Options {
    /// Write frame 0 at set-up (frames after it are asked for by the coupler).
    pub write_vtk: bool,
    /// Test hook: stop answering from this step on.
    pub hang_after: Option<u64>,
    /// Test hook: SIGKILL this node when told to take this step (every time it is started).
    pub die_at: Option<u64>,
    pub role: Role,
    pub run_dir: PathBuf,
    /// [`checkpoint::scene_hash`] of the scene as run.
    pub scene_hash: u64,
    /// Continue from this checkpoint.
    pub resume: Option<Resume>,
}

impl Options {
    pub fn new(scene: &Scene, args: &NodeArgs, setup: &Setup, role: Role) -> Options {
        Options {
            write_vtk: scene.output.vtk,
            hang_after: args.hang_after_steps,
            die_at: args.die_at_step,
            role,
            run_dir: setup.run_dir.clone(),
            scene_hash: checkpoint::run_hash(scene, &setup.scene_toml),
            resume: setup.resume.clone(),
        }
    }

    fn header(&self, solver: &str, step: u64, time: f64) -> NodeHeader {
        NodeHeader {
            role: self.role.name().into(),
            solver: solver.into(),
            scene_hash: self.scene_hash,
            step,
            time,
        }
    }
}

/// Writes this node's checkpoint after `step` steps (the state at `time`).
fn save(side: &mut dyn Side, opts: &Options, step: u64, time: f64) -> Result<(), SolverError> {
    let runtime = side.save_runtime().map_err(SolverError::Failed)?;
    let solver = side.solver().save_state()?;
    let file = NodeCheckpoint {
        header: opts.header(side.solver().name(), step, time),
        runtime,
        solver,
    };
    let dir = checkpoint::dir(&opts.run_dir);
    std::fs::create_dir_all(&dir).map_err(|e| {
        SolverError::Failed(format!(
            "cannot create the checkpoint directory '{}': {e}",
            dir.display()
        ))
    })?;
    let path = checkpoint::node_file(&opts.run_dir, opts.role.name(), step);
    checkpoint::write_file(&path, opts.role.name(), step, &file).map_err(SolverError::Failed)
}

/// Restores this node from its checkpoint `resume`, after checking that it is this node's,
/// for this scene and solver, at the step the coupler resumes.
fn restore(side: &mut dyn Side, opts: &Options, resume: &Resume) -> Result<(), SolverError> {
    let path = checkpoint::node_file(&opts.run_dir, opts.role.name(), resume.step);
    let file: NodeCheckpoint = checkpoint::read_file(&path, opts.role.name(), resume.step)
        .map_err(|e| SolverError::Failed(e.to_string()))?;
    let expected = opts.header(side.solver().name(), resume.step, resume.time);
    file.header
        .check(&expected, &path)
        .map_err(SolverError::Failed)?;
    side.restore_runtime(&file.runtime)
        .map_err(SolverError::Failed)?;
    side.solver().restore_state(&file.solver, &opts.run_dir)?;
    // The scratch directory only held the files the constructor started.
    let _ = std::fs::remove_dir_all(scratch_dir(&opts.run_dir, opts.role));
    Ok(())
}

/// Reports a failure of the set-up (before the loop) and flushes what the solver wrote.
pub(super) fn refuse(
    control: &Control,
    solver: &mut dyn Solver,
    e: SolverError,
) -> Result<u8, Fatal> {
    let result = fail(control, solver, e, 0, 0.0);
    let _ = solver.finish();
    result
}

/// Serves the coupler's commands until told to stop, whatever the outcome leaving the
/// solver's outputs flushed. Returns the exit code.
pub(super) fn serve(control: &Control, side: &mut dyn Side, opts: &Options) -> Result<u8, Fatal> {
    let result = serve_inner(control, side, opts);
    // Outputs written so far stay readable whatever happened.
    let _ = side.solver().finish();
    result
}

fn serve_inner(control: &Control, side: &mut dyn Side, opts: &Options) -> Result<u8, Fatal> {
    let t0 = Instant::now();
    let (step0, time0) = opts.resume.as_ref().map_or((0, 0.0), |r| (r.step, r.time));
    if let Some(resume) = &opts.resume
        && let Err(e) = restore(side, opts, resume)
    {
        return fail(control, side.solver(), e, step0, time0);
    }
    if let Err(f) = side.initial_exchange(control, opts.resume.as_ref()) {
        return fail(control, side.solver(), fatal_to_solver(f), step0, time0);
    }
    // A resumed run has its frame 0 already.
    if opts.write_vtk
        && opts.resume.is_none()
        && let Err(e) = side.solver().write_frame(0, 0.0)
    {
        return fail(control, side.solver(), e, 0, 0.0);
    }
    let dt = side.coupling_proposal();
    control.report(
        StatusCode::Ok,
        step0,
        time0,
        dt,
        t0.elapsed().as_secs_f64(),
        "ready",
    )?;

    loop {
        let cmd = control.next_command()?;
        match cmd.kind {
            k if k == CommandKind::Stop as u32 => {
                if let Err(e) = side.solver().finish() {
                    return fail(control, side.solver(), e, cmd.step, cmd.time);
                }
                control.report(StatusCode::Stopped, cmd.step, cmd.time, 0.0, 0.0, "stopped")?;
                return Ok(0);
            }
            k if k == CommandKind::Checkpoint as u32 => {
                let t = Instant::now();
                if let Err(e) = save(side, opts, cmd.step, cmd.time) {
                    return fail(control, side.solver(), e, cmd.step, cmd.time);
                }
                let dt = side.coupling_proposal();
                let secs = t.elapsed().as_secs_f64();
                control.report(
                    StatusCode::Checkpointed,
                    cmd.step,
                    cmd.time,
                    dt,
                    secs,
                    "checkpoint written",
                )?;
            }
            k if k == CommandKind::Advance as u32 => {
                if opts.die_at == Some(cmd.step) {
                    // Test hook: crash as a SIGKILL would, with nothing flushed or said.
                    // SAFETY: raise(2) on this process.
                    unsafe {
                        libc::raise(libc::SIGKILL);
                    }
                }
                if opts.hang_after.is_some_and(|n| cmd.step >= n) {
                    // Test hook: behave like a node stuck in an endless computation.
                    loop {
                        std::thread::sleep(SLICE);
                        if control.run().termination_requested() {
                            return Err(Fatal::Signal);
                        }
                    }
                }
                match step(control, side, &cmd) {
                    Ok((report, compute)) => {
                        let (code, msg) = match &report.warning {
                            Some(w) => (StatusCode::Warning, w.as_str()),
                            None => (StatusCode::Ok, ""),
                        };
                        let dt = side.coupling_proposal();
                        control.report(code, cmd.step, cmd.time + cmd.dt, dt, compute, msg)?;
                    }
                    Err(StepFailure::Solver(e)) => {
                        return fail(control, side.solver(), e, cmd.step, cmd.time);
                    }
                    Err(StepFailure::Fatal(f)) => return Err(f),
                }
            }
            other => {
                return Err(Fatal::Transport(TransportError::Protocol(format!(
                    "unknown command kind {other}"
                ))));
            }
        }
    }
}

/// One step: the side's exchange and advance, then the output frame when asked for. Returns
/// the solver's report and the seconds spent computing.
fn step(
    control: &Control,
    side: &mut dyn Side,
    cmd: &Command,
) -> Result<(StepReport, f64), StepFailure> {
    let (report, mut compute) = side.advance(control, cmd)?;
    if cmd.output_frame >= 0 {
        let t = Instant::now();
        side.solver()
            .write_frame(cmd.output_frame as u32, cmd.time + cmd.dt)?;
        compute += t.elapsed();
    }
    Ok((report, compute.as_secs_f64()))
}

/// Reports the solver's failure, naming the solver; the node then exits with
/// [`exit::SOLVER`].
fn fail(
    control: &Control,
    solver: &mut dyn Solver,
    e: SolverError,
    step: u64,
    time: f64,
) -> Result<u8, Fatal> {
    let code = match e {
        SolverError::Unstable(_) => StatusCode::Unstable,
        SolverError::Failed(_) => StatusCode::Failed,
    };
    let name = solver.name().to_string();
    control.report(code, step, time, 0.0, 0.0, &format!("[{name}] {e}"))?;
    Ok(exit::SOLVER)
}
