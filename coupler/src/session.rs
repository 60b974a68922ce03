//! One coupled run: handshake, the shared timestep, and an orderly end whatever happens.
//!
//! Each step: dt = min(node proposals, dt_max) (times `dt_factor` in stability experiments),
//! cut to land exactly on the next output time and the end time ([`shared::step::grant`]); the
//! command goes to both nodes at once; the nodes exchange geometry and loads directly with each
//! other (see `shared::runtime`) and each answers with a status and its next proposal.
//!
//! The run talks through `shared::transport`'s seam: iceoryx2 shared memory by default, zenoh
//! over TCP with `--transport zenoh` (nodes on other hosts). The session is the same for both.

use crate::checkpoint::CouplerCheckpoint;
use crate::launch::{NodeCommand, NodeProcess, describe_exit};
use crate::output::RunDir;
use shared::coupling::step::{self, StepRule};
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
}

/// How a run ended, when it did not complete.
#[derive(Debug, thiserror::Error)]
pub enum RunError {
    #[error("{0}")]
    Input(String),
    #[error("{node} went unstable at step {step}, t = {time:.6} s: {cause}")]
    Unstable {
        node: String,
        step: u64,
        time: f64,
        cause: String,
    },
    #[error("{node} failed at step {step}, t = {time:.6} s: {cause}")]
    Failed {
        node: String,
        step: u64,
        time: f64,
        cause: String,
    },
    #[error("{node} died at step {step}, t = {time:.6} s: the process {how}")]
    Died {
        node: String,
        step: u64,
        time: f64,
        how: String,
    },
    #[error("{node} hung at step {step}, t = {time:.6} s: no answer within {waited:.1} s")]
    Hung {
        node: String,
        step: u64,
        time: f64,
        waited: f64,
    },
    #[error("start-up failed: {0}")]
    Handshake(String),
    #[error(
        "step collapsed at step {step}, t = {time:.6} s: {node} proposed dt = {dt:e} s, below dt_min = {dt_min:e} s"
    )]
    Collapsed {
        node: String,
        step: u64,
        time: f64,
        dt: f64,
        dt_min: f64,
    },
    #[error("interrupted at step {step}, t = {time:.6} s")]
    Interrupted { step: u64, time: f64 },
    #[error("transport: {0}")]
    Transport(String),
    #[error("{cause} (again, after a restart from step {from_step}: the run stops)")]
    Again {
        cause: Box<RunError>,
        from_step: u64,
    },
}

impl RunError {
    /// The process exit code for this outcome.
    pub fn exit_code(&self) -> u8 {
        match self {
            RunError::Input(_) => 1,
            RunError::Unstable { .. } | RunError::Failed { .. } | RunError::Collapsed { .. } => 2,
            RunError::Died { .. }
            | RunError::Hung { .. }
            | RunError::Handshake(_)
            | RunError::Transport(_) => 3,
            RunError::Interrupted { .. } => 130,
            RunError::Again { cause, .. } => cause.exit_code(),
        }
    }

    /// The node ("fluid node (...)") and step of a death or hang, which a restart may cure.
    fn restartable(&self) -> Option<(String, u64)> {
        match self {
            RunError::Died { node, step, .. } | RunError::Hung { node, step, .. } => {
                let role = node.split(" node").next().unwrap_or(node).to_string();
                Some((role, *step))
            }
            _ => None,
        }
    }
}

impl From<transport::TransportError> for RunError {
    fn from(e: transport::TransportError) -> Self {
        RunError::Transport(e.to_string())
    }
}

/// What a run did, completed or not.
#[derive(Debug, Clone, Default, serde::Serialize, serde::Deserialize)]
pub struct RunStats {
    pub steps: u64,
    /// Simulated time reached [s].
    pub time: f64,
    pub wall_seconds: f64,
    /// Seconds each node spent computing (solver work plus writing or reading coupling data).
    pub fluid_compute_seconds: f64,
    pub solid_compute_seconds: f64,
    /// Smallest and largest step granted [s].
    pub dt_min: f64,
    pub dt_max: f64,
    pub warnings: u64,
    pub last_warning: Option<String>,
    /// Output frames written (including frame 0).
    pub frames: u32,
    /// CPU seconds each process used over the run; compare with the compute seconds: the
    /// difference is what waiting and talking cost.
    pub fluid_cpu_seconds: f64,
    pub solid_cpu_seconds: f64,
    pub coupler_cpu_seconds: f64,
    /// Peak resident memory of each process [bytes]: the nodes' `VmHWM` read from /proc just
    /// before they are told to stop (None if a node was already gone), the coupler's own from
    /// getrusage at the end.
    pub fluid_peak_rss_bytes: Option<u64>,
    pub solid_peak_rss_bytes: Option<u64>,
    pub coupler_peak_rss_bytes: u64,
    /// Median and 99th percentile of the wall time of one step, command to last status [µs].
    pub step_wall_median_us: f64,
    pub step_wall_p99_us: f64,
    /// Solvers the nodes actually run (a node may be started with its own `--solver`).
    pub fluid_solver: Option<String>,
    pub solid_solver: Option<String>,
    /// Checkpoints written (over the whole run, resumed parts included).
    #[serde(default)]
    pub checkpoints: u64,
    /// Node restarts after a death or hang (`--retries`), in this invocation.
    #[serde(default)]
    pub restarts: u32,
    /// The step this invocation resumed from (`--resume`, or its last restart); null if it ran
    /// from the start.
    #[serde(default)]
    pub resumed_from_step: Option<u64>,
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

    /// Runs the whole thing: start, step to the end, stop. The run directory receives what was
    /// written whatever the outcome; `stats` tells how far it got.
    ///
    /// With `retries`, a node that dies or hangs is restarted: every process of the attempt is
    /// ended, the run directory and the coupler go back to the last complete checkpoint (or to
    /// t = 0 without one), and fresh nodes resume from their checkpoint files. A node that
    /// fails again at the same step stops the run with its cause.
    pub fn execute(mut opts: RunOptions, dir: &mut RunDir) -> (RunStats, Result<(), RunError>) {
        let id = opts.run_id.clone();
        let started = Instant::now();
        let mut failures: Vec<(String, u64)> = Vec::new();
        let mut restarts = 0u32;
        let (mut stats, result) = loop {
            let (stats, result) = match Session::open(opts.clone()) {
                Ok(mut session) => {
                    let result = session.start(dir).and_then(|_| session.advance_to_end(dir));
                    let result = session.stop(result);
                    (session.stats.clone(), result)
                }
                Err(e) => (RunStats::default(), Err(e)),
            };
            // The session is gone, and with it every node of this attempt.
            let Err(e) = &result else {
                break (stats, result);
            };
            let Some(failure) = e.restartable() else {
                break (stats, result);
            };
            let from_step = opts.resume.as_ref().map_or(0, |c| c.step);
            if failures.contains(&failure) {
                let Err(cause) = result else { unreachable!() };
                let again = RunError::Again {
                    cause: Box::new(cause),
                    from_step,
                };
                break (stats, Err(again));
            }
            if restarts >= opts.retries {
                break (stats, result);
            }
            failures.push(failure);
            restarts += 1;
            transport::remove_run_files(&id);
            let back = match crate::checkpoint::latest(dir.path()) {
                Ok(Some(ck)) => crate::checkpoint::rollback(dir.path(), &ck)
                    .and_then(|_| {
                        dir.restore_series(ck.particles.clone(), ck.blocks.clone())
                            .map_err(|e| format!("cannot rewrite the .pvd series: {e}"))
                    })
                    .map(|_| Some(ck)),
                Ok(None) => crate::checkpoint::rollback_to_start(dir.path(), dir.static_blocks())
                    .and_then(|_| {
                        dir.restore_series(Vec::new(), Vec::new())
                            .map_err(|e| format!("cannot rewrite the .pvd series: {e}"))
                    })
                    .map(|_| None),
                Err(e) => Err(e),
            };
            match back {
                Ok(ck) => {
                    eprintln!(
                        "coupler: {e}; restart {restarts} of {}: every node goes back to {}",
                        opts.retries,
                        match &ck {
                            Some(c) =>
                                format!("the checkpoint at step {} (t = {:.6} s)", c.step, c.time),
                            None => "t = 0 (no checkpoint yet)".into(),
                        }
                    );
                    opts.resume = ck;
                }
                Err(msg) => {
                    let Err(cause) = result else { unreachable!() };
                    break (
                        stats,
                        Err(RunError::Input(format!(
                            "{cause}; the restart failed: {msg}"
                        ))),
                    );
                }
            }
        };
        stats.restarts = restarts;
        stats.resumed_from_step = opts.resume.as_ref().map(|c| c.step);
        stats.wall_seconds = started.elapsed().as_secs_f64();
        stats.coupler_cpu_seconds = shared::runtime::process_cpu_seconds();
        stats.coupler_peak_rss_bytes = shared::runtime::process_peak_rss_bytes();
        // Every process of the run is gone now (the session dropped its children): remove
        // whatever iceoryx2 left in /dev/shm and /tmp/iceoryx2, e.g. after a SIGKILL.
        transport::remove_run_files(&id);
        (stats, result)
    }

    /// Starts (or awaits) the nodes, checks their protocol, sends the setup and waits for every
    /// node to report ready.
    pub fn start(&mut self, dir: &mut RunDir) -> Result<(), RunError> {
        let roles = Session::roles(&self.opts.scene);
        if roles.is_empty() {
            return Err(RunError::Input(
                "the scene has neither water nor moving blocks: nothing to simulate".into(),
            ));
        }
        let mut processes = Vec::new();
        if !self.opts.attach {
            for &role in &roles {
                let cmd = if role == Role::Fluid {
                    &self.opts.fluid_cmd
                } else {
                    &self.opts.solid_cmd
                };
                processes.push(
                    NodeProcess::spawn(cmd, &self.opts.run_id, &self.node_transport_args())
                        .map_err(RunError::Input)?,
                );
            }
        } else {
            eprintln!(
                "coupler: waiting up to {:.0} s for the nodes of run {id}; start them with:",
                self.opts.connect_timeout.as_secs_f64(),
                id = self.opts.run_id
            );
            let extra = self.node_transport_args().join(" ");
            for &role in &roles {
                eprintln!(
                    "  {}-node --prefix {}{}{extra}",
                    role.name(),
                    self.opts.run_id,
                    if extra.is_empty() { "" } else { " " }
                );
            }
        }
        self.handshake(&roles, processes)?;

        let setup = Setup {
            scene_toml: scene_text(&self.opts.scene)?,
            run_dir: dir.path().to_path_buf(),
            scheme: self.scheme(),
            fluid_present: roles.contains(&Role::Fluid),
            solid_present: roles.contains(&Role::Solid),
            fluid_solver: self.fluid_solver(),
            solid_solver: self.solid_solver(),
            coupler_pid: std::process::id(),
            resume: self.opts.resume.as_ref().map(|c| Resume {
                step: c.step,
                time: c.time,
            }),
        };
        let bytes = setup.encode();
        self.setup_out
            .publish(bytes.len(), &mut |header, payload| {
                *header = SetupHeader {
                    protocol_version: PROTOCOL_VERSION,
                    payload_len: bytes.len() as u32,
                };
                payload.copy_from_slice(&bytes);
            })?;
        self.ring();
        let interval = self.opts.scene.output.interval;
        self.next_output = interval.min(self.opts.scene.time.end);
        self.next_checkpoint = self.opts.checkpoint_interval;
        if let Some(ck) = self.opts.resume.clone() {
            // The nodes restore theirs; the coupler continues from its own.
            let stats = std::mem::take(&mut self.stats);
            self.stats = RunStats {
                fluid_solver: stats.fluid_solver,
                solid_solver: stats.solid_solver,
                ..ck.stats.clone()
            };
            self.step = ck.step;
            self.time = ck.time;
            self.frame = ck.frame;
            self.next_output = ck.next_output;
            self.next_checkpoint = ck.next_checkpoint;
            self.collect_statuses(ck.step, self.opts.setup_timeout, false)?;
            return Ok(());
        }
        self.collect_statuses(0, self.opts.setup_timeout, false)?;
        if self.opts.scene.output.vtk {
            dir.add_frame(
                0,
                0.0,
                &self.peers.iter().map(|p| p.role).collect::<Vec<_>>(),
            )
            .map_err(|e| RunError::Input(format!("cannot write to the run directory: {e}")))?;
            self.stats.frames = 1;
        }
        Ok(())
    }

    fn ring(&self) {
        let _ = self.fluid_bell.ring();
        let _ = self.solid_bell.ring();
    }

    /// What the nodes need besides the run id to reach this coupler.
    fn node_transport_args(&self) -> Vec<String> {
        match self.opts.transport {
            Kind::Iceoryx2 => Vec::new(),
            Kind::Zenoh => {
                let mut args = vec!["--transport".to_string(), "zenoh".to_string()];
                for e in &self.opts.node_connect {
                    args.push("--connect".into());
                    args.push(e.clone());
                }
                args
            }
        }
    }

    /// Waits for a hello from each role; checks protocol versions.
    fn handshake(
        &mut self,
        roles: &[Role],
        mut processes: Vec<NodeProcess>,
    ) -> Result<(), RunError> {
        let started = Instant::now();
        while self.peers.len() < roles.len() {
            while let Some(hello) = self.hello_in.receive()? {
                let Some(role) = Role::from_u32(hello.role).filter(|r| roles.contains(r)) else {
                    return Err(RunError::Handshake(format!(
                        "a node with unknown role {} said hello",
                        hello.role
                    )));
                };
                if self.peers.iter().any(|p| p.role == role) {
                    continue; // a repeated hello
                }
                let process = processes
                    .iter()
                    .position(|p| p.role == role)
                    .map(|i| processes.swap_remove(i));
                let program = process
                    .as_ref()
                    .map(|p| p.program.display().to_string())
                    .unwrap_or_else(|| format!("pid {}", hello.pid));
                if hello.protocol_version != PROTOCOL_VERSION {
                    return Err(RunError::Handshake(format!(
                        "the {} node '{program}' speaks protocol version {}, this coupler version {PROTOCOL_VERSION}. \
                         Fix: rebuild both from the same source (`cargo build --release`)",
                        role.name(),
                        hello.protocol_version
                    )));
                }
                // A node started with its own --solver runs that one.
                let solver = match hello.solver.as_str() {
                    "" if role == Role::Fluid => self.fluid_solver(),
                    "" => self.solid_solver(),
                    own => own.to_string(),
                };
                match role {
                    Role::Fluid => self.stats.fluid_solver = Some(solver.clone()),
                    Role::Solid => self.stats.solid_solver = Some(solver.clone()),
                }
                self.peers.push(Peer {
                    role,
                    solver,
                    pid: hello.pid,
                    process,
                    proposal: f64::INFINITY,
                    answered: false,
                });
            }
            if self.peers.len() == roles.len() {
                break;
            }
            for p in processes.iter_mut() {
                if let Some(status) = p.exited() {
                    return Err(RunError::Handshake(format!(
                        "the {} node '{}' {} before saying hello",
                        p.role.name(),
                        p.program.display(),
                        describe_exit(status)
                    )));
                }
            }
            if self.run.termination_requested() {
                return Err(RunError::Interrupted { step: 0, time: 0.0 });
            }
            if started.elapsed() > self.opts.connect_timeout {
                let missing: Vec<&str> = roles
                    .iter()
                    .filter(|r| !self.peers.iter().any(|p| p.role == **r))
                    .map(|r| r.name())
                    .collect();
                return Err(RunError::Handshake(format!(
                    "no hello from the {} node(s) within {:.0} s",
                    missing.join(" and "),
                    self.opts.connect_timeout.as_secs_f64()
                )));
            }
            self.listener.wait(SLICE)?;
        }
        Ok(())
    }

    /// Waits until every node answered `step` (the checkpoint command of `step` when
    /// `checkpoint`); records proposals; turns failures into errors.
    fn collect_statuses(
        &mut self,
        step: u64,
        timeout: Duration,
        checkpoint: bool,
    ) -> Result<(), RunError> {
        for p in self.peers.iter_mut() {
            p.answered = false;
        }
        let sent = Instant::now();
        loop {
            while let Some(s) = self.status_in.receive()? {
                let Some(peer) = self.peers.iter_mut().find(|p| p.role as u32 == s.role) else {
                    continue;
                };
                let node = peer.label();
                match StatusCode::from_u32(s.code) {
                    code @ (StatusCode::Ok
                    | StatusCode::Warning
                    | StatusCode::Stopped
                    | StatusCode::Checkpointed) => {
                        if s.step != step || (code == StatusCode::Checkpointed) != checkpoint {
                            continue; // stale answer to an earlier command
                        }
                        peer.answered = true;
                        peer.proposal = s.dt_proposal;
                        match peer.role {
                            Role::Fluid => {
                                self.stats.fluid_compute_seconds += s.compute_seconds;
                                self.stats.fluid_cpu_seconds = s.cpu_seconds;
                            }
                            Role::Solid => {
                                self.stats.solid_compute_seconds += s.compute_seconds;
                                self.stats.solid_cpu_seconds = s.cpu_seconds;
                            }
                        }
                        if StatusCode::from_u32(s.code) == StatusCode::Warning {
                            self.stats.warnings += 1;
                            let msg = format!(
                                "{node}: warning at step {step}, t = {:.6} s: {}",
                                s.time,
                                s.message.as_str()
                            );
                            // Repeats of a kind thin out (#1, 2, 4, 8, …); a new kind, such
                            // as a block's landing burst among a solver's repeated warnings,
                            // is always printed.
                            let kind = warning_kind(&node, s.message.as_str());
                            if self.warned.insert(kind) || self.stats.warnings.is_power_of_two() {
                                eprintln!("coupler: {msg} (warning #{})", self.stats.warnings);
                            }
                            self.stats.last_warning = Some(msg);
                        }
                    }
                    StatusCode::Unstable => {
                        return Err(RunError::Unstable {
                            node,
                            step: s.step,
                            time: s.time,
                            cause: s.message.as_str().into(),
                        });
                    }
                    StatusCode::Failed => {
                        return Err(RunError::Failed {
                            node,
                            step: s.step,
                            time: s.time,
                            cause: s.message.as_str().into(),
                        });
                    }
                }
            }
            if self.peers.iter().all(|p| p.answered) {
                return Ok(());
            }
            self.check_peers(step)?;
            if self.run.termination_requested() {
                return Err(RunError::Interrupted {
                    step,
                    time: self.time,
                });
            }
            if sent.elapsed() > timeout {
                // When neither node answered, one is waiting for the other's data within the
                // step (the step contract): the parallel scheme's solid for the fluid's loads,
                // the serial scheme's fluid for the solid's new geometry. The one waited for
                // is the hung one (a restart must know which node failed).
                let waited_for = match self.scheme() {
                    CouplingScheme::Parallel => Role::Fluid,
                    CouplingScheme::Serial => Role::Solid,
                };
                let silent: Vec<&Peer> = self.peers.iter().filter(|p| !p.answered).collect();
                let p = silent
                    .iter()
                    .find(|p| silent.len() > 1 && !checkpoint && p.role == waited_for)
                    .or(silent.first())
                    .expect("someone has not answered");
                return Err(RunError::Hung {
                    node: p.label(),
                    step,
                    time: self.time,
                    waited: sent.elapsed().as_secs_f64(),
                });
            }
            self.listener.wait(SLICE)?;
        }
    }

    /// A node whose process ended (or, for attached nodes, whose pid vanished; over zenoh,
    /// whose liveliness token was withdrawn) ends the run. Only nodes that have not answered
    /// the current command count: a node that answered a stop exits at once, and must not be
    /// taken for dead while the other one still flushes.
    fn check_peers(&mut self, step: u64) -> Result<(), RunError> {
        let run = &self.run;
        let remote = run.kind() != Kind::Iceoryx2;
        for p in self.peers.iter_mut().filter(|p| !p.answered) {
            let gone = |p: &Peer| {
                (!run.alive(Party::from(p.role), p.pid)).then(|| run.gone_how().to_string())
            };
            let how = match p.process.as_mut() {
                Some(proc_) => match proc_.exited().map(describe_exit) {
                    None if remote => gone(p),
                    how => how,
                },
                None => gone(p),
            };
            if let Some(how) = how {
                return Err(RunError::Died {
                    node: p.label(),
                    step,
                    time: self.time,
                    how,
                });
            }
        }
        Ok(())
    }

    /// Steps until the scene's end time.
    fn advance_to_end(&mut self, dir: &mut RunDir) -> Result<(), RunError> {
        let scene = &self.opts.scene;
        let end = scene.time.end;
        let interval = scene.output.interval;
        let dt_max = scene.time.dt_max;
        let rule = StepRule::new(dt_max, scene.time.dt_min).with_factor(self.opts.dt_factor);
        let roles: Vec<Role> = self.peers.iter().map(|p| p.role).collect();
        let progress = crate::progress::Progress::new(self.opts.progress, end);
        // Step wall times, for the median and tail the benchmark reports.
        let expected_steps = (end / dt_max.max(1e-12)).min(1e7) as usize;
        let mut step_walls: Vec<f32> = Vec::with_capacity(expected_steps);
        if self.opts.resume.is_none() {
            self.stats.dt_min = f64::INFINITY;
        }
        self.last_checkpoint = Instant::now();
        let tol = 1e-12 * end.max(1.0);

        while self.time < end - tol {
            // The shared step: the most restrictive proposal, never past dt_max, landing
            // exactly on the next output time.
            let target = self.next_output.min(end);
            let proposals = self.peers.iter().map(|p| (p.label(), p.proposal));
            let granted = step::grant(proposals, &rule, self.time, target).map_err(|c| {
                RunError::Collapsed {
                    node: c.limiting.to_string(),
                    step: self.step,
                    time: self.time,
                    dt: c.proposal,
                    dt_min: c.dt_min,
                }
            })?;
            let (dt, lands) = (granted.dt, granted.lands);
            let output_frame =
                if lands && self.opts.scene.output.vtk && (self.next_output <= end + tol) {
                    self.frame as i32
                } else {
                    -1
                };
            let cmd = Command {
                kind: CommandKind::Advance as u32,
                output_frame,
                step: self.step,
                time: self.time,
                dt,
            };
            let sent = Instant::now();
            self.command_out.send(cmd)?;
            self.ring();
            self.collect_statuses(self.step, self.opts.step_timeout, false)?;
            step_walls.push(sent.elapsed().as_secs_f32());

            self.stats.dt_min = self.stats.dt_min.min(dt);
            self.stats.dt_max = self.stats.dt_max.max(dt);
            self.step += 1;
            self.time = granted.end_time(self.time, target);
            self.stats.steps = self.step;
            self.stats.time = self.time;
            if lands {
                if output_frame >= 0 {
                    dir.add_frame(self.frame, self.time, &roles).map_err(|e| {
                        RunError::Input(format!("cannot write to the run directory: {e}"))
                    })?;
                    self.stats.frames = self.frame + 1;
                    self.frame += 1;
                }
                self.next_output += interval;
            }
            if self.time < end - tol && self.checkpoint_due() {
                self.checkpoint(dir)?;
            }
            progress.update(self.time, self.step);
        }
        progress.finish();
        if !step_walls.is_empty() {
            step_walls.sort_by(f32::total_cmp);
            let at = |q: f64| {
                step_walls[((step_walls.len() - 1) as f64 * q).round() as usize] as f64 * 1e6
            };
            self.stats.step_wall_median_us = at(0.5);
            self.stats.step_wall_p99_us = at(0.99);
        }
        Ok(())
    }

    /// Whether a checkpoint is due after this step: the simulated interval was crossed, or the
    /// wall interval passed. Checkpoints never cut a step: the grants stay those of a run
    /// without them.
    fn checkpoint_due(&mut self) -> bool {
        let mut due = false;
        if let (Some(next), Some(every)) = (self.next_checkpoint, self.opts.checkpoint_interval)
            && self.time >= next * (1.0 - 1e-12)
        {
            due = true;
            let mut n = next;
            while n <= self.time * (1.0 + 1e-12) {
                n += every;
            }
            self.next_checkpoint = Some(n);
        }
        if self
            .opts
            .checkpoint_wall
            .is_some_and(|w| self.last_checkpoint.elapsed() >= w)
        {
            due = true;
        }
        due
    }

    /// A checkpoint of the state after `self.step` steps: each node writes its own file and
    /// answers, then the coupler records the series' lengths and its state (last, so that a
    /// coupler file means a complete checkpoint).
    fn checkpoint(&mut self, dir: &RunDir) -> Result<(), RunError> {
        let cmd = Command {
            kind: CommandKind::Checkpoint as u32,
            output_frame: -1,
            step: self.step,
            time: self.time,
            dt: 0.0,
        };
        self.command_out.send(cmd)?;
        self.ring();
        self.collect_statuses(self.step, self.opts.step_timeout, true)?;
        let fail = |e: String| RunError::Failed {
            node: "coupler".into(),
            step: self.step,
            time: self.time,
            cause: format!("checkpoint: {e}"),
        };
        let series = crate::checkpoint::series_lengths(dir.path()).map_err(fail)?;
        let (particles, blocks) = dir.series();
        self.stats.checkpoints += 1;
        let ck = CouplerCheckpoint {
            scene_hash: shared::checkpoint::run_hash(
                &self.opts.scene,
                &scene_text(&self.opts.scene)?,
            ),
            fluid_solver: self.stats.fluid_solver.clone(),
            solid_solver: self.stats.solid_solver.clone(),
            scheme: self.scheme(),
            dt_factor: self.opts.dt_factor,
            step: self.step,
            time: self.time,
            frame: self.frame,
            next_output: self.next_output,
            next_checkpoint: self.next_checkpoint,
            stats: self.stats.clone(),
            particles,
            blocks,
            series,
        };
        ck.write(dir.path()).map_err(fail)?;
        self.last_checkpoint = Instant::now();
        Ok(())
    }

    /// Ends the run: asks the nodes to stop (they flush their files), then makes sure every
    /// process is gone. Returns the run's outcome.
    fn stop(&mut self, outcome: Result<(), RunError>) -> Result<(), RunError> {
        // The nodes' peak memory, while they are still alive to be asked (on this host: a
        // node attached over zenoh may run elsewhere, where its pid means nothing here).
        let local = self.run.kind() == Kind::Iceoryx2;
        for p in &self.peers {
            let rss = if local || p.process.is_some() {
                shared::runtime::peak_rss_bytes_of(p.pid)
            } else {
                None
            };
            match p.role {
                Role::Fluid => self.stats.fluid_peak_rss_bytes = rss,
                Role::Solid => self.stats.solid_peak_rss_bytes = rss,
            }
        }
        let cmd = Command {
            kind: CommandKind::Stop as u32,
            output_frame: -1,
            step: self.step,
            time: self.time,
            dt: 0.0,
        };
        let _ = self.command_out.send(cmd);
        self.ring();
        let stopped = if outcome.is_ok() {
            // A clean end: wait for the nodes to confirm they flushed their outputs.
            self.collect_statuses(self.step, Duration::from_secs(30), false)
        } else {
            Ok(())
        };
        for p in self.peers.iter_mut() {
            if let Some(proc_) = p.process.as_mut()
                && proc_.wait_exit(Duration::from_secs(1)).is_none()
            {
                proc_.terminate(Duration::from_secs(1));
            }
        }
        outcome.and(stopped)
    }
}

/// The scene as run, as the TOML text the nodes get, `scene.toml` holds and the checkpoints'
/// scene hash is taken of.
pub fn scene_text(scene: &Scene) -> Result<String, RunError> {
    toml::to_string(scene).map_err(|e| RunError::Input(format!("cannot serialise the scene: {e}")))
}

/// What makes two warnings the same kind: the node and the message without its numbers.
fn warning_kind(node: &str, message: &str) -> String {
    let text: String = message.chars().filter(|c| !c.is_ascii_digit()).collect();
    format!("{node}: {text}")
}

#[cfg(test)]
mod tests {
    use super::warning_kind;

    #[test]
    fn warnings_differing_only_in_their_numbers_are_one_kind() {
        let solid = "solid node (explicit, pid 7)";
        let burst = |w: u32| {
            format!(
                "the water's load on block 'rock' (ρ_b/ρ_w = 2.5000) bursts to {w} weights per step"
            )
        };
        assert_eq!(
            warning_kind(solid, &burst(47)),
            warning_kind(solid, &burst(13))
        );
        let other =
            "the water's load on block 'wedge' (ρ_b/ρ_w = 2.5000) bursts to 47 weights per step";
        assert_ne!(warning_kind(solid, &burst(47)), warning_kind(solid, other));
        let fluid = "fluid node (dfsph, pid 8)";
        let solve = "dfsph: density solve did not converge: mean error 0.07 % after 100 iterations";
        assert_ne!(warning_kind(fluid, solve), warning_kind(solid, &burst(47)));
        assert_ne!(warning_kind(fluid, solve), warning_kind(solid, solve));
    }
}
