//! One coupled run: handshake, the shared timestep, and an orderly end whatever happens.
//!
//! Each step: dt = min(node proposals, dt_max) (times `dt_factor` in stability experiments),
//! cut to land exactly on the next output time and the end time ([`shared::coupling::step::grant`]); the
//! command goes to both nodes at once; the nodes exchange geometry and loads directly with each
//! other (see `shared::runtime`) and each answers with a status and its next proposal.
//!
//! The run talks through `shared::transport`'s seam: iceoryx2 shared memory by default, zenoh
//! over TCP with `--transport zenoh` (nodes on other hosts). The session is the same for both.
//!
//! Here: the run's options, the session and the services it opens. `retries.rs` runs the whole
//! thing with its restarts; `start.rs` starts the nodes and hands them the setup; `steps.rs`
//! is the step loop with its checkpoints and the stop; `statuses.rs` collects the nodes'
//! answers and turns deaths, hangs and failures into errors.

mod retries;
mod start;
mod statuses;
mod steps;

use crate::run::checkpoint::CouplerCheckpoint;
use crate::run::error::RunError;
use crate::run::launch::{NodeCommand, NodeProcess};
use crate::run::launcher::Launcher;
use crate::run::stats::RunStats;
use shared::protocol::*;
use shared::scene::{CouplingScheme, Scene};
use shared::transport::{
    self, Bell, Endpoints, Inbox, Kind, Outbox, Party, RunId, Transport, Waiter,
};
use std::time::{Duration, Instant};

/// One slice of blocking wait between liveness checks.
const SLICE: Duration = Duration::from_millis(50);

/// Everything a run needs besides the scene.
#[derive(Debug, Clone)]
pub struct RunOptions {
    pub scene: Scene,
    /// Overrides of the scene's solver choices and scheme.
    pub fluid_solver: Option<String>,
    pub solid_solver: Option<String>,
    pub scheme: Option<CouplingScheme>,
    pub fluid_cmd: NodeCommand,
    pub solid_cmd: NodeCommand,
    /// Nodes are started by hand (or by another tool) with `--prefix <run id>`.
    pub attach: bool,
    pub run_id: RunId,
    /// How the processes talk, and (zenoh) where: the coupler listens on `endpoints.listen`;
    /// the nodes it starts connect to `node_connect`.
    pub transport: Kind,
    pub endpoints: Endpoints,
    pub node_connect: Vec<String>,
    /// How long to wait for the nodes' hello.
    pub connect_timeout: Duration,
    /// How long one step may take before a silent node is declared hung.
    pub step_timeout: Duration,
    /// How long the nodes may take to build their solvers (filling a million particles takes a
    /// while) before one that has not reported ready is declared hung.
    pub setup_timeout: Duration,
    /// Multiplies the granted step (stability experiments; 1 in normal runs).
    pub dt_factor: f64,
    /// Draw a progress bar on stderr.
    pub progress: bool,
    /// Checkpoint every this many simulated seconds and/or wall-clock time (none: never).
    pub checkpoint_interval: Option<f64>,
    pub checkpoint_wall: Option<Duration>,
    /// Continue from this checkpoint of the run directory (`--resume`, or a restart).
    pub resume: Option<CouplerCheckpoint>,
    /// How often a node that dies or hangs is restarted, every node rolling back to the last
    /// checkpoint (or to t = 0 without one).
    pub retries: u32,
    /// MPI ranks of the fluid node. `fluid_cmd` already starts them through `launcher`; with
    /// `attach` the coupler prints the launcher's command line for the user to run.
    pub fluid_ranks: u32,
    pub launcher: Launcher,
}

/// One node as the coupler sees it.
struct Peer {
    role: Role,
    solver: String,
    pid: u32,
    process: Option<NodeProcess>,
    proposal: f64,
    answered: bool,
}

impl Peer {
    fn label(&self) -> String {
        format!(
            "{} node ({}, pid {})",
            self.role.name(),
            self.solver,
            self.pid
        )
    }
}

/// The coupler's side of a run.
pub struct Session {
    opts: RunOptions,
    run: Box<dyn Transport>,
    hello_in: Box<dyn Inbox<Hello>>,
    status_in: Box<dyn Inbox<Status>>,
    setup_out: Box<dyn Outbox<SetupHeader, u8>>,
    command_out: Box<dyn Outbox<Command>>,
    listener: Box<dyn Waiter>,
    fluid_bell: Box<dyn Bell>,
    solid_bell: Box<dyn Bell>,
    peers: Vec<Peer>,
    stats: RunStats,
    step: u64,
    time: f64,
    /// The next frame's number and the next output time.
    frame: u32,
    next_output: f64,
    /// The next simulated time a checkpoint is due, and when the last one was written.
    next_checkpoint: Option<f64>,
    last_checkpoint: Instant,
    /// The kinds of warning printed so far (the message without its numbers, per node): the
    /// first of each kind is printed, whatever the count (not checkpointed: after a resume a
    /// kind may be printed once more).
    warned: std::collections::HashSet<String>,
}

impl Session {
    /// Opens the run's services. Nodes are started by [`Session::start`].
    pub fn open(opts: RunOptions) -> Result<Session, RunError> {
        let run = transport::join(
            opts.transport,
            &opts.run_id,
            Party::Coupler,
            "coupler",
            &opts.endpoints,
            opts.connect_timeout,
        )?;
        let hello_in = run.hello_in()?;
        let status_in = run.status_in()?;
        let setup_out = run.setup_out(1 << 16)?;
        let command_out = run.command_out()?;
        let listener = run.waiter(Party::Coupler)?;
        let fluid_bell = run.bell(Party::Fluid)?;
        let solid_bell = run.bell(Party::Solid)?;
        Ok(Session {
            opts,
            run,
            hello_in,
            status_in,
            setup_out,
            command_out,
            listener,
            fluid_bell,
            solid_bell,
            peers: Vec::new(),
            stats: RunStats::default(),
            step: 0,
            time: 0.0,
            frame: 1,
            next_output: 0.0,
            next_checkpoint: None,
            last_checkpoint: Instant::now(),
            warned: std::collections::HashSet::new(),
        })
    }

    fn scheme(&self) -> CouplingScheme {
        self.opts.scheme.unwrap_or(self.opts.scene.coupling.scheme)
    }

    fn fluid_solver(&self) -> String {
        self.opts
            .fluid_solver
            .clone()
            .or_else(|| self.opts.scene.fluid.as_ref().map(|f| f.solver.clone()))
            .unwrap_or_default()
    }

    fn solid_solver(&self) -> String {
        self.opts
            .solid_solver
            .clone()
            .unwrap_or_else(|| self.opts.scene.solid.solver.clone())
    }

    /// The roles this scene needs: no water, no fluid node; nothing moving, no solid node.
    pub fn roles(scene: &Scene) -> Vec<Role> {
        let mut roles = Vec::new();
        if scene.has_fluid() {
            roles.push(Role::Fluid);
        }
        if scene.has_moving_blocks() {
            roles.push(Role::Solid);
        }
        roles
    }

    fn ring(&self) {
        let _ = self.fluid_bell.ring();
        let _ = self.solid_bell.ring();
    }
}

/// The scene as run, as the TOML text the nodes get, `scene.toml` holds and the checkpoints'
/// scene hash is taken of.
pub fn scene_text(scene: &Scene) -> Result<String, RunError> {
    toml::to_string(scene).map_err(|e| RunError::Input(format!("cannot serialise the scene: {e}")))
}
