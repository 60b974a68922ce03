//! The node runtime: everything a solver binary needs besides the solver.
//!
//! A node binary's `main` is one call, e.g. `runtime::fluid_main(&["muller", "wcsph"], build)`.
//! The runtime joins the run named by `--prefix`, says hello until the coupler answers with the
//! setup, builds the solver, and then serves commands: for each step it exchanges coupling data
//! with the other node (see [`crate::solver`] for the order) and reports a [`Status`].
//!
//! Data tags. Geometry message k holds the blocks at t_k (the solid sends G_0 at set-up and
//! G_{n+1} at the end of step n). A loads message is tagged with the solid step that consumes
//! it. In the parallel scheme the fluid at step n reads G_n and its loads feed solid step n; in
//! the serial scheme the fluid reads G_{n+1} and its loads feed solid step n+1 (the first ones
//! are computed at set-up from G_0).

use crate::added_mass::AddedMassMonitor;
use crate::geometry::Polyhedron;
use crate::math::Vector;
use crate::protocol::*;
use crate::scene::{BlockKind, Scene, Scheme};
use crate::solver::{FluidSolver, SetupContext, SolidSolver, Solver, SolverError, StepReport};
use crate::transport::{self, Ipc, Party, Pub, Run, RunId, Sub, TransportError, Wake};
use clap::Parser;
use iceoryx2::port::listener::Listener;
use iceoryx2::port::notifier::Notifier;
use iceoryx2::sample::Sample;
use std::process::ExitCode;
use std::time::{Duration, Instant};

/// Builds a fluid solver by name.
pub type FluidFactory = fn(&str, &SetupContext) -> Result<Box<dyn FluidSolver>, SolverError>;
/// Builds a solid solver by name.
pub type SolidFactory = fn(&str, &SetupContext) -> Result<Box<dyn SolidSolver>, SolverError>;

/// How long a node waits in one slice before checking that the coupler lives and no signal
/// arrived. Waking ten times a second costs nothing measurable; it is not a spin.
const SLICE: Duration = Duration::from_millis(100);
/// How often a node repeats its hello while no coupler answered.
const HELLO_EVERY: Duration = Duration::from_millis(250);

/// Exit codes of a node process.
pub mod exit {
    /// The solver went unstable or failed; its status message says why.
    pub const SOLVER: u8 = 2;
    /// The transport failed or the coupler vanished.
    pub const TRANSPORT: u8 = 3;
    /// SIGINT or SIGTERM.
    pub const SIGNAL: u8 = 130;
}

/// Command line shared by every node binary.
#[derive(Debug, Parser)]
#[command(
    about = "A rockwave solver node. Normally started by `coupler run`; start it by hand with the run id the coupler prints."
)]
struct NodeArgs {
    /// Solver to run (overrides the scene's choice).
    #[arg(long)]
    solver: Option<String>,
    /// Run id (service prefix) of the coupler to join.
    #[arg(long, required_unless_present = "list_solvers")]
    prefix: Option<String>,
    /// Seconds to wait for a coupler to answer the hello.
    #[arg(long, default_value_t = 60.0)]
    connect_timeout: f64,
    /// Print the solvers this binary offers and exit.
    #[arg(long)]
    list_solvers: bool,
    /// Speak this protocol version instead of the real one (tests the coupler's check).
    #[arg(long, hide = true)]
    fake_protocol_version: Option<u32>,
    /// Stop answering after this many steps (tests the coupler's hang detection).
    #[arg(long, hide = true)]
    hang_after_steps: Option<u64>,
}

/// Runs a fluid node: parses the command line, handshakes, then serves steps until told to stop.
pub fn fluid_main(solvers: &[&str], build: FluidFactory) -> ExitCode {
    node_main(Role::Fluid, solvers, Factory::Fluid(build))
}

/// Runs a solid node.
pub fn solid_main(solvers: &[&str], build: SolidFactory) -> ExitCode {
    node_main(Role::Solid, solvers, Factory::Solid(build))
}

enum Factory {
    Fluid(FluidFactory),
    Solid(SolidFactory),
}

fn node_main(role: Role, solvers: &[&str], factory: Factory) -> ExitCode {
    let args = NodeArgs::parse();
    if args.list_solvers {
        println!("{}", solvers.join("\n"));
        return ExitCode::SUCCESS;
    }
    let prefix = args.prefix.as_deref().unwrap_or_default();
    let who = format!("{}-node", role.name());
    let id = match RunId::parse(prefix) {
        Ok(id) => id,
        Err(e) => {
            eprintln!("{who}: --prefix: {e}");
            return ExitCode::from(exit::TRANSPORT);
        }
    };
    match serve(role, solvers, &factory, &args, &id) {
        Ok(code) => ExitCode::from(code),
        Err(Fatal::Transport(e)) => {
            eprintln!("{who}: {e}");
            ExitCode::from(exit::TRANSPORT)
        }
        Err(Fatal::CouplerGone) => {
            eprintln!("{who}: the coupler of run {id} is gone; stopping");
            // Nobody else may be left to tidy up: the last one out removes the run's files.
            if !transport::run_has_live_nodes(&id) {
                transport::remove_run_files(&id);
            }
            ExitCode::from(exit::TRANSPORT)
        }
        Err(Fatal::Signal) => ExitCode::from(exit::SIGNAL),
    }
}

/// Why a node stops early.
enum Fatal {
    Transport(TransportError),
    CouplerGone,
    Signal,
}

impl From<TransportError> for Fatal {
    fn from(e: TransportError) -> Self {
        Fatal::Transport(e)
    }
}

fn iox<E: std::fmt::Debug>(what: &'static str) -> impl FnOnce(E) -> Fatal {
    move |e| Fatal::Transport(TransportError::Iceoryx(format!("{what}: {e:?}")))
}

/// The solver, whichever side it plays.
enum Side {
    Fluid(Box<dyn FluidSolver>),
    Solid(Box<dyn SolidSolver>),
}

impl Side {
    fn solver(&mut self) -> &mut dyn Solver {
        match self {
            Side::Fluid(s) => s.as_mut(),
            Side::Solid(s) => s.as_mut(),
        }
    }
}

/// The ports a node talks through: control ports for all, data ports for its side.
struct Ports {
    command: Sub<Command>,
    status: Pub<Status>,
    coupler_bell: Notifier<Ipc>,
    listener: Listener<Ipc>,
    // Fluid side.
    geometry_blocks_in: Option<Sub<[BlockState], GeometryHeader>>,
    geometry_vertices_in: Option<Sub<[[f64; 3]], GeometryHeader>>,
    loads_out: Option<Pub<[BlockLoad], LoadsHeader>>,
    // Solid side.
    loads_in: Option<Sub<[BlockLoad], LoadsHeader>>,
    geometry_blocks_out: Option<Pub<[BlockState], GeometryHeader>>,
    geometry_vertices_out: Option<Pub<[[f64; 3]], GeometryHeader>>,
    peer_bell: Notifier<Ipc>,
}

/// One node's view of the run once set up.
struct Node<'a> {
    role: Role,
    run: &'a Run,
    ports: Ports,
    setup: Setup,
    side: Side,
    n_moving: usize,
    write_vtk: bool,
    hang_after: Option<u64>,
    /// The solid's watch on the loads for the added-mass instability (when water exists).
    added_mass: Option<AddedMassMonitor>,
}

fn serve(
    role: Role,
    solvers: &[&str],
    factory: &Factory,
    args: &NodeArgs,
    id: &RunId,
) -> Result<u8, Fatal> {
    let who = format!("{}-node", role.name());
    let run = Run::join(id, &who)?;
    let me = if role == Role::Fluid {
        Party::Fluid
    } else {
        Party::Solid
    };
    let peer = if role == Role::Fluid {
        Party::Solid
    } else {
        Party::Fluid
    };

    // Every subscriber exists before the hello goes out, so nothing sent to us is lost.
    let setup_in = run
        .setup()?
        .subscriber_builder()
        .create()
        .map_err(iox("setup subscriber"))?;
    let command = run
        .command()?
        .subscriber_builder()
        .create()
        .map_err(iox("command subscriber"))?;
    let (mut geometry_blocks_in, mut geometry_vertices_in, mut loads_in) = (None, None, None);
    if role == Role::Fluid {
        geometry_blocks_in = Some(
            run.geometry_blocks()?
                .subscriber_builder()
                .create()
                .map_err(iox("geometry subscriber"))?,
        );
        geometry_vertices_in = Some(
            run.geometry_vertices()?
                .subscriber_builder()
                .create()
                .map_err(iox("vertex subscriber"))?,
        );
    } else {
        loads_in = Some(
            run.loads()?
                .subscriber_builder()
                .create()
                .map_err(iox("loads subscriber"))?,
        );
    }
    let listener = run.listener(me)?;
    let coupler_bell = run.notifier(Party::Coupler)?;
    let peer_bell = run.notifier(peer)?;
    let hello_out = run
        .hello()?
        .publisher_builder()
        .create()
        .map_err(iox("hello publisher"))?;
    let status = run
        .status()?
        .publisher_builder()
        .create()
        .map_err(iox("status publisher"))?;

    let hello = Hello {
        protocol_version: args.fake_protocol_version.unwrap_or(PROTOCOL_VERSION),
        role: role as u32,
        pid: std::process::id(),
        solver: Text::new(args.solver.as_deref().unwrap_or("")),
    };

    // Say hello until the setup arrives.
    let started = Instant::now();
    let mut last_hello: Option<Instant> = None;
    let setup = loop {
        if run.termination_requested() {
            return Err(Fatal::Signal);
        }
        if last_hello.is_none_or(|t| t.elapsed() >= HELLO_EVERY) {
            hello_out.send_copy(hello).map_err(iox("send hello"))?;
            coupler_bell.notify().map_err(iox("notify coupler"))?;
            last_hello = Some(Instant::now());
        }
        if let Some(sample) = setup_in.receive().map_err(iox("receive setup"))? {
            if sample.user_header().protocol_version != PROTOCOL_VERSION {
                return Err(Fatal::Transport(TransportError::Iceoryx(format!(
                    "the coupler speaks protocol {}, this node {}",
                    sample.user_header().protocol_version,
                    PROTOCOL_VERSION
                ))));
            }
            match Setup::decode(sample.payload()) {
                Ok(s) => break s,
                Err(e) => return Err(Fatal::Transport(TransportError::Iceoryx(e))),
            }
        }
        if started.elapsed().as_secs_f64() > args.connect_timeout {
            return Err(Fatal::Transport(TransportError::Iceoryx(format!(
                "no coupler answered on run id {id} within {} s (start `coupler run --attach {id}`)",
                args.connect_timeout
            ))));
        }
        transport::wait(&listener, HELLO_EVERY)?;
    };
    drop(hello_out);

    let ports = Ports {
        command,
        status,
        coupler_bell,
        listener,
        geometry_blocks_in,
        geometry_vertices_in,
        loads_out: None,
        loads_in,
        geometry_blocks_out: None,
        geometry_vertices_out: None,
        peer_bell,
    };

    // Build the solver; a failure is reported to the coupler, which names it. A solver named
    // on this node's own command line wins over the coupler's choice.
    let name = args.solver.clone().unwrap_or_else(|| match role {
        Role::Fluid => setup.fluid_solver.clone(),
        Role::Solid => setup.solid_solver.clone(),
    });
    let scene = match setup.scene() {
        Ok(scene) => scene,
        Err(e) => {
            report(&ports, role, StatusCode::Failed, 0, 0.0, 0.0, 0.0, &e)?;
            return Ok(exit::SOLVER);
        }
    };
    let ctx = SetupContext {
        scene: &scene,
        run_dir: &setup.run_dir,
        scheme: setup.scheme,
        peer_present: if role == Role::Fluid {
            setup.solid_present
        } else {
            setup.fluid_present
        },
    };
    let built = if !solvers.contains(&name.as_str()) {
        Err(SolverError::Failed(format!(
            "unknown {} solver '{name}': this binary offers {}",
            role.name(),
            solvers.join(", ")
        )))
    } else {
        match factory {
            Factory::Fluid(f) => f(&name, &ctx).map(Side::Fluid),
            Factory::Solid(f) => f(&name, &ctx).map(Side::Solid),
        }
    };
    let side = match built {
        Ok(side) => side,
        Err(e) => {
            report(
                &ports,
                role,
                StatusCode::Failed,
                0,
                0.0,
                0.0,
                0.0,
                &format!("{e}"),
            )?;
            return Ok(exit::SOLVER);
        }
    };
    let n_moving = scene.moving_blocks().len();
    let write_vtk = scene.output.vtk;
    let added_mass = match (role, &scene.fluid) {
        (Role::Solid, Some(fluid)) => Some(added_mass_monitor(&scene, fluid.density)),
        _ => None,
    };
    let mut node = Node {
        role,
        run: &run,
        ports,
        setup,
        side,
        n_moving,
        write_vtk,
        hang_after: args.hang_after_steps,
        added_mass,
    };
    node.serve()
}

/// The added-mass watch over the scene's moving blocks (kinematic ones cannot be moved by
/// their loads: infinite mass).
fn added_mass_monitor(scene: &Scene, water_density: f64) -> AddedMassMonitor {
    let blocks = scene
        .moving_blocks()
        .into_iter()
        .map(|i| {
            let b = &scene.blocks[i];
            let volume = Polyhedron::from_shape(&b.shape).map_or(f64::NAN, |p| p.volume);
            let mass = match b.kind {
                BlockKind::Free => b.density * volume,
                _ => f64::INFINITY,
            };
            (b.name.clone(), mass, b.density)
        })
        .collect();
    AddedMassMonitor::new(blocks, Vector::from(scene.gravity).norm(), water_density)
}

/// Sends a status to the coupler and rings it.
#[allow(clippy::too_many_arguments)]
fn report(
    ports: &Ports,
    role: Role,
    code: StatusCode,
    step: u64,
    time: f64,
    dt_proposal: f64,
    compute_seconds: f64,
    message: &str,
) -> Result<(), Fatal> {
    let status = Status {
        role: role as u32,
        code: code as u32,
        step,
        time,
        dt_proposal,
        compute_seconds,
        cpu_seconds: process_cpu_seconds(),
        message: Text::new(message),
    };
    ports.status.send_copy(status).map_err(iox("send status"))?;
    ports.coupler_bell.notify().map_err(iox("notify coupler"))?;
    Ok(())
}

/// CPU time (user + system) of this process so far [s].
pub fn process_cpu_seconds() -> f64 {
    // SAFETY: getrusage writes into the zeroed struct we pass and nothing else.
    let usage = unsafe {
        let mut u: libc::rusage = std::mem::zeroed();
        libc::getrusage(libc::RUSAGE_SELF, &mut u);
        u
    };
    let secs = |t: libc::timeval| t.tv_sec as f64 + t.tv_usec as f64 * 1e-6;
    secs(usage.ru_utime) + secs(usage.ru_stime)
}

impl Node<'_> {
    fn peer_present(&self) -> bool {
        match self.role {
            Role::Fluid => self.setup.solid_present,
            Role::Solid => self.setup.fluid_present,
        }
    }

    /// Waits one slice, then checks the coupler and signals.
    fn wait_slice(&self) -> Result<(), Fatal> {
        if transport::wait(&self.ports.listener, SLICE)? == Wake::Quiet
            && !transport::process_alive(self.setup.coupler_pid)
        {
            return Err(Fatal::CouplerGone);
        }
        if self.run.termination_requested() {
            return Err(Fatal::Signal);
        }
        Ok(())
    }

    fn serve(&mut self) -> Result<u8, Fatal> {
        let result = self.serve_inner();
        // Outputs written so far stay readable whatever happened.
        let _ = self.side.solver().finish();
        result
    }

    fn serve_inner(&mut self) -> Result<u8, Fatal> {
        let t0 = Instant::now();
        if let Err(e) = self.initial_exchange() {
            return self.fail(e, 0, 0.0);
        }
        if self.write_vtk
            && let Err(e) = self.side.solver().write_frame(0, 0.0)
        {
            return self.fail(e, 0, 0.0);
        }
        let dt = self.side.solver().dt_proposal();
        report(
            &self.ports,
            self.role,
            StatusCode::Ok,
            0,
            0.0,
            dt,
            t0.elapsed().as_secs_f64(),
            "ready",
        )?;

        loop {
            let cmd = self.next_command()?;
            match cmd.kind {
                k if k == CommandKind::Stop as u32 => {
                    if let Err(e) = self.side.solver().finish() {
                        return self.fail(e, cmd.step, cmd.time);
                    }
                    report(
                        &self.ports,
                        self.role,
                        StatusCode::Stopped,
                        cmd.step,
                        cmd.time,
                        0.0,
                        0.0,
                        "stopped",
                    )?;
                    return Ok(0);
                }
                k if k == CommandKind::Advance as u32 => {
                    if self.hang_after.is_some_and(|n| cmd.step >= n) {
                        // Test hook: behave like a node stuck in an endless computation.
                        loop {
                            std::thread::sleep(SLICE);
                            if self.run.termination_requested() {
                                return Err(Fatal::Signal);
                            }
                        }
                    }
                    match self.step(&cmd) {
                        Ok((report_, compute)) => {
                            let (code, msg) = match &report_.warning {
                                Some(w) => (StatusCode::Warning, w.as_str()),
                                None => (StatusCode::Ok, ""),
                            };
                            let dt = self.side.solver().dt_proposal();
                            report(
                                &self.ports,
                                self.role,
                                code,
                                cmd.step,
                                cmd.time + cmd.dt,
                                dt,
                                compute,
                                msg,
                            )?;
                        }
                        Err(StepFailure::Solver(e)) => return self.fail(e, cmd.step, cmd.time),
                        Err(StepFailure::Fatal(f)) => return Err(f),
                    }
                }
                other => {
                    return Err(Fatal::Transport(TransportError::Iceoryx(format!(
                        "unknown command kind {other}"
                    ))));
                }
            }
        }
    }

    fn fail(&mut self, e: SolverError, step: u64, time: f64) -> Result<u8, Fatal> {
        let code = match e {
            SolverError::Unstable(_) => StatusCode::Unstable,
            SolverError::Failed(_) => StatusCode::Failed,
        };
        let name = self.side.solver().name().to_string();
        report(
            &self.ports,
            self.role,
            code,
            step,
            time,
            0.0,
            0.0,
            &format!("[{name}] {e}"),
        )?;
        Ok(exit::SOLVER)
    }

    fn next_command(&self) -> Result<Command, Fatal> {
        loop {
            if let Some(s) = self
                .ports
                .command
                .receive()
                .map_err(iox("receive command"))?
            {
                return Ok(*s.payload());
            }
            self.wait_slice()?;
        }
    }

    /// Set-up exchange: the solid sends G_0; in the serial scheme the fluid answers with the
    /// loads for solid step 0, computed from G_0.
    fn initial_exchange(&mut self) -> Result<(), SolverError> {
        match self.role {
            Role::Solid => {
                self.create_solid_publishers().map_err(fatal_to_solver)?;
                if self.peer_present() {
                    self.send_geometry(0, 0.0).map_err(fatal_to_solver)?;
                }
            }
            Role::Fluid => {
                self.create_fluid_publisher().map_err(fatal_to_solver)?;
                if self.peer_present() && self.setup.scheme == Scheme::Serial {
                    self.receive_geometry(0).map_err(fatal_to_solver)?;
                    self.send_loads(0, 0.0).map_err(fatal_to_solver)?;
                }
            }
        }
        Ok(())
    }

    fn create_fluid_publisher(&mut self) -> Result<(), Fatal> {
        if self.setup.solid_present {
            let p = self
                .run
                .loads()?
                .publisher_builder()
                .initial_max_slice_len(self.n_moving.max(1))
                .create()
                .map_err(iox("loads publisher"))?;
            self.ports.loads_out = Some(p);
        }
        Ok(())
    }

    fn create_solid_publishers(&mut self) -> Result<(), Fatal> {
        let Side::Solid(solver) = &self.side else {
            unreachable!()
        };
        let nv = solver.vertex_count().max(1);
        if self.setup.fluid_present {
            self.ports.geometry_blocks_out = Some(
                self.run
                    .geometry_blocks()?
                    .publisher_builder()
                    .initial_max_slice_len(self.n_moving.max(1))
                    .create()
                    .map_err(iox("geometry publisher"))?,
            );
            self.ports.geometry_vertices_out = Some(
                self.run
                    .geometry_vertices()?
                    .publisher_builder()
                    .initial_max_slice_len(nv)
                    .create()
                    .map_err(iox("vertex publisher"))?,
            );
        }
        Ok(())
    }

    /// One step. Returns the solver's report and the seconds spent computing (not waiting).
    fn step(&mut self, cmd: &Command) -> Result<(StepReport, f64), StepFailure> {
        let mut compute = Duration::ZERO;
        let end = cmd.time + cmd.dt;
        let report_ = match self.role {
            Role::Fluid => {
                if self.peer_present() {
                    let want = match self.setup.scheme {
                        Scheme::Parallel => cmd.step,
                        Scheme::Serial => cmd.step + 1,
                    };
                    compute += self.receive_geometry(want)?;
                    let tag = match self.setup.scheme {
                        Scheme::Parallel => cmd.step,
                        Scheme::Serial => cmd.step + 1,
                    };
                    compute += self.send_loads(tag, cmd.time)?;
                } else {
                    // No solid node: only fixed walls, still computed through the same path.
                    let t = Instant::now();
                    let Side::Fluid(f) = &mut self.side else {
                        unreachable!()
                    };
                    f.write_loads(&mut []);
                    compute += t.elapsed();
                }
                let t = Instant::now();
                let r = self.side.solver().advance(cmd.dt)?;
                compute += t.elapsed();
                r
            }
            Role::Solid => {
                if self.peer_present() {
                    let (t, added_mass) = self.receive_loads(cmd.step)?;
                    compute += t;
                    if let Some(msg) = added_mass {
                        return Err(StepFailure::Solver(SolverError::Unstable(msg)));
                    }
                }
                let t = Instant::now();
                let r = self.side.solver().advance(cmd.dt)?;
                compute += t.elapsed();
                if self.peer_present() {
                    compute += self.send_geometry(cmd.step + 1, end)?;
                }
                r
            }
        };
        if cmd.output_frame >= 0 {
            let t = Instant::now();
            self.side
                .solver()
                .write_frame(cmd.output_frame as u32, end)?;
            compute += t.elapsed();
        }
        Ok((report_, compute.as_secs_f64()))
    }

    /// Waits for geometry message `tag` (both parts) and hands it to the fluid solver.
    fn receive_geometry(&mut self, tag: u64) -> Result<Duration, Fatal> {
        let blocks_in = self
            .ports
            .geometry_blocks_in
            .as_ref()
            .expect("fluid has geometry ports");
        let vertices_in = self
            .ports
            .geometry_vertices_in
            .as_ref()
            .expect("fluid has geometry ports");
        let blocks = self.receive_tagged(blocks_in, |h| h.step, tag)?;
        let vertices = self.receive_tagged(vertices_in, |h| h.step, tag)?;
        let t = Instant::now();
        let Side::Fluid(f) = &mut self.side else {
            unreachable!()
        };
        // Zero copy: the solver reads straight from shared memory.
        f.read_geometry(blocks.payload(), vertices.payload());
        Ok(t.elapsed())
    }

    /// Computes the coupling loads straight into a loaned shared-memory slice and sends them.
    fn send_loads(&mut self, tag: u64, time: f64) -> Result<Duration, Fatal> {
        let t = Instant::now();
        let out = self
            .ports
            .loads_out
            .as_ref()
            .expect("loads publisher exists when a solid runs");
        let mut sample = out.loan_slice(self.n_moving).map_err(iox("loan loads"))?;
        *sample.user_header_mut() = LoadsHeader { step: tag, time };
        let Side::Fluid(f) = &mut self.side else {
            unreachable!()
        };
        f.write_loads(sample.payload_mut());
        sample.send().map_err(iox("send loads"))?;
        self.ports.peer_bell.notify().map_err(iox("notify solid"))?;
        Ok(t.elapsed())
    }

    /// Waits for loads message `tag` and hands it to the solid solver; also what the
    /// added-mass watch makes of them.
    fn receive_loads(&mut self, tag: u64) -> Result<(Duration, Option<String>), Fatal> {
        let loads_in = self
            .ports
            .loads_in
            .as_ref()
            .expect("solid has a loads port");
        let sample = self.receive_tagged(loads_in, |h| h.step, tag)?;
        let t = Instant::now();
        let Side::Solid(s) = &mut self.side else {
            unreachable!()
        };
        s.read_loads(sample.payload());
        let added_mass = self
            .added_mass
            .as_mut()
            .and_then(|m| m.observe(sample.payload()));
        Ok((t.elapsed(), added_mass))
    }

    /// Writes the solid's geometry straight into loaned shared memory and sends it.
    fn send_geometry(&mut self, tag: u64, time: f64) -> Result<Duration, Fatal> {
        let t = Instant::now();
        let Side::Solid(s) = &self.side else {
            unreachable!()
        };
        let nv = s.vertex_count();
        let header = GeometryHeader {
            step: tag,
            time,
            vertex_count: nv as u32,
            _reserved: 0,
        };
        let blocks_out = self
            .ports
            .geometry_blocks_out
            .as_ref()
            .expect("geometry publisher exists when a fluid runs");
        let vertices_out = self
            .ports
            .geometry_vertices_out
            .as_ref()
            .expect("vertex publisher exists when a fluid runs");
        let mut blocks = blocks_out
            .loan_slice(self.n_moving)
            .map_err(iox("loan geometry"))?;
        let mut vertices = vertices_out.loan_slice(nv).map_err(iox("loan vertices"))?;
        *blocks.user_header_mut() = header;
        *vertices.user_header_mut() = header;
        s.write_geometry(blocks.payload_mut(), vertices.payload_mut());
        vertices.send().map_err(iox("send vertices"))?;
        blocks.send().map_err(iox("send geometry"))?;
        self.ports.peer_bell.notify().map_err(iox("notify fluid"))?;
        Ok(t.elapsed())
    }

    /// Blocks until a sample tagged `want` arrives on `sub`; older ones are dropped. If the
    /// peer died meanwhile, the coupler ends the run and terminates this node with SIGTERM,
    /// which ends the wait within one slice.
    fn receive_tagged<E, H>(
        &self,
        sub: &Sub<[E], H>,
        tag: fn(&H) -> u64,
        want: u64,
    ) -> Result<Sample<Ipc, [E], H>, Fatal>
    where
        E: std::fmt::Debug + iceoryx2::prelude::ZeroCopySend + 'static,
        H: std::fmt::Debug + iceoryx2::prelude::ZeroCopySend + 'static,
    {
        loop {
            while let Some(s) = sub.receive().map_err(iox("receive data"))? {
                let got = tag(s.user_header());
                if got == want {
                    return Ok(s);
                }
                if got > want {
                    return Err(Fatal::Transport(TransportError::Iceoryx(format!(
                        "coupling data out of order: expected message {want}, got {got}"
                    ))));
                }
            }
            self.wait_slice()?;
        }
    }
}

enum StepFailure {
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

fn fatal_to_solver(f: Fatal) -> SolverError {
    match f {
        Fatal::Transport(e) => SolverError::Failed(format!("transport: {e}")),
        Fatal::CouplerGone => SolverError::Failed("the coupler is gone".into()),
        Fatal::Signal => SolverError::Failed("interrupted".into()),
    }
}
