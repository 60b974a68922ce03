//! The fluid node: reads the solid's geometry, writes the loads on the blocks, advances.
//!
//! Per step n (when a solid node runs): wait for geometry message G_n (parallel scheme) or
//! G_{n+1} (serial scheme), hand it to the solver, prepare the step (the coupling forces at
//! that geometry), write the loads straight into shared memory (or, over zenoh, into a reused
//! buffer) and send them tagged for the solid step that consumes them (n, or n + 1), then
//! advance. In the serial scheme the loads for solid step 0 are computed at set-up from G_0.
//! A solver whose loads are those of the step it takes (it moves the blocks within it:
//! `FluidSolver::loads_follow_step`) advances first and sends them after, in the parallel
//! scheme; the solid waits for them, the tags are the same.
//! Without a solid node the step is still prepared (Eq. 22 on fixed walls only), and nothing
//! is sent.

use super::FluidFactory;
use super::args::NodeArgs;
use super::control::{self, Control, Fatal};
use super::serve::{self, Side, StepFailure};
use crate::protocol::{BlockLoad, BlockState, Command, GeometryHeader, LoadsHeader, Resume, Role};
use crate::scene::CouplingScheme;
use crate::solver::{FluidSolver, Solver, StepReport};
use crate::transport::{Bell, Inbox, Outbox, Transport};
use std::time::{Duration, Instant};

/// Joins the run as its fluid node and serves it; returns the exit code.
pub(super) fn run_node(
    run: &dyn Transport,
    solvers: &[&str],
    build: FluidFactory,
    args: &NodeArgs,
) -> Result<u8, Fatal> {
    let joined = control::join(run, Role::Fluid, args, GeometryIn::open)?;
    let (control, setup) = (&joined.control, &joined.setup);
    let Some(built) = serve::build(control, setup, solvers, args, build)? else {
        return Ok(super::exit::SOLVER);
    };
    let n_moving = built.scene.moving_blocks().len();
    let opts = serve::Options::new(&built.scene, args, setup, Role::Fluid);
    let mut solver = built.solver;
    let solid = if setup.solid_present {
        match SolidLink::open(run, joined.inbox, joined.peer_bell, n_moving) {
            Ok(link) => Solid::Coupled(Box::new(link)),
            Err(f) => return serve::refuse(control, solver.as_mut(), serve::fatal_to_solver(f)),
        }
    } else {
        Solid::Absent
    };
    let mut fluid = Fluid {
        solver,
        solid,
        scheme: setup.scheme,
        n_moving,
        sent: SentLoads::default(),
    };
    serve::serve(control, &mut fluid, &opts)
}

/// The geometry inboxes (blocks and their corners), opened before the hello.
pub(super) struct GeometryIn {
    blocks: Box<dyn Inbox<GeometryHeader, BlockState>>,
    vertices: Box<dyn Inbox<GeometryHeader, [f64; 3]>>,
}

impl GeometryIn {
    fn open(run: &dyn Transport) -> Result<GeometryIn, Fatal> {
        Ok(GeometryIn {
            blocks: run.blocks_in()?,
            vertices: run.vertices_in()?,
        })
    }
}

/// Whether a solid node runs: a scene without moving blocks has none.
enum Solid {
    Absent,
    Coupled(Box<SolidLink>),
}

/// The data ports to and from the solid node.
struct SolidLink {
    geometry: GeometryIn,
    loads: Box<dyn Outbox<LoadsHeader, BlockLoad>>,
    bell: Box<dyn Bell>,
}

struct Fluid {
    solver: Box<dyn FluidSolver>,
    solid: Solid,
    scheme: CouplingScheme,
    n_moving: usize,
    /// The last loads sent. In the serial scheme the solid consumes them in the step after the
    /// one that computed them, from a fluid state that is gone by then: a checkpoint between
    /// the two steps must keep them (the runtime's part of the fluid's checkpoint).
    sent: SentLoads,
}

/// A loads message as sent.
#[derive(Debug, Clone, Default, serde::Serialize, serde::Deserialize)]
struct SentLoads {
    header: Option<(u64, f64)>,
    loads: Vec<BlockLoad>,
}

impl SolidLink {
    fn open(
        run: &dyn Transport,
        geometry: GeometryIn,
        bell: Box<dyn Bell>,
        n_moving: usize,
    ) -> Result<SolidLink, Fatal> {
        let loads = run.loads_out(n_moving)?;
        Ok(SolidLink {
            geometry,
            loads,
            bell,
        })
    }

    /// Waits for geometry message `tag` (both parts) and hands it to the solver.
    fn receive_geometry(
        &self,
        control: &Control,
        solver: &mut dyn FluidSolver,
        tag: u64,
    ) -> Result<Duration, Fatal> {
        let mut read = Duration::ZERO;
        let mut inner = Ok(());
        control.receive_tagged(&*self.geometry.blocks, |h| h.step, tag, &mut |_, blocks| {
            inner = control.receive_tagged(
                &*self.geometry.vertices,
                |h| h.step,
                tag,
                &mut |_, vertices| {
                    let t = Instant::now();
                    // Zero copy over iceoryx2: the solver reads straight from shared memory.
                    solver.read_geometry(blocks, vertices);
                    read = t.elapsed();
                },
            );
        })?;
        inner?;
        Ok(read)
    }

    /// Writes the coupling loads (prepared by [`FluidSolver::prepare_step`]) straight into the
    /// outgoing message (loaned shared memory over iceoryx2) and sends them; keeps a copy in
    /// `sent` (a few numbers per moving block).
    fn send_loads(
        &self,
        solver: &mut dyn FluidSolver,
        n_moving: usize,
        tag: u64,
        time: f64,
        followed: bool,
        sent: &mut SentLoads,
    ) -> Result<Duration, Fatal> {
        let t = Instant::now();
        self.loads.publish(n_moving, &mut |header, loads| {
            *header = LoadsHeader {
                step: tag,
                time,
                flags: if followed { LoadsHeader::FOLLOWED } else { 0 },
                _reserved: 0,
            };
            solver.write_loads(loads);
            sent.header = Some((tag, time));
            sent.loads.clear();
            sent.loads.extend_from_slice(loads);
        })?;
        self.bell.ring()?;
        Ok(t.elapsed())
    }

    /// Sends loads saved in a checkpoint again (a resumed serial run).
    fn resend_loads(&self, sent: &SentLoads) -> Result<(), Fatal> {
        let Some((step, time)) = sent.header else {
            return Ok(());
        };
        self.loads.publish(sent.loads.len(), &mut |header, loads| {
            // Only the serial scheme resends, whose loads never follow the step.
            *header = LoadsHeader {
                step,
                time,
                ..LoadsHeader::default()
            };
            loads.copy_from_slice(&sent.loads);
        })?;
        self.bell.ring()?;
        Ok(())
    }
}

impl Side for Fluid {
    fn solver(&mut self) -> &mut dyn Solver {
        self.solver.as_mut()
    }

    fn initial_exchange(
        &mut self,
        control: &Control,
        resume: Option<&Resume>,
    ) -> Result<(), Fatal> {
        if let Solid::Coupled(link) = &self.solid
            && self.scheme == CouplingScheme::Serial
        {
            match resume {
                // The loads of solid step k were computed in fluid step k − 1 (from G_k,
                // which the solid sends again and this node skips as old).
                Some(_) => link.resend_loads(&self.sent)?,
                None => {
                    link.receive_geometry(control, self.solver.as_mut(), 0)?;
                    self.solver.prepare_step();
                    // Serial: the loads never follow the step.
                    link.send_loads(
                        self.solver.as_mut(),
                        self.n_moving,
                        0,
                        0.0,
                        false,
                        &mut self.sent,
                    )?;
                }
            }
        }
        Ok(())
    }

    fn save_runtime(&self) -> Result<Vec<u8>, String> {
        crate::checkpoint::encode(&self.sent)
    }

    fn restore_runtime(&mut self, bytes: &[u8]) -> Result<(), String> {
        self.sent = crate::checkpoint::decode(bytes, "the fluid runtime's loads")?;
        Ok(())
    }

    fn advance(
        &mut self,
        control: &Control,
        cmd: &Command,
    ) -> Result<(StepReport, Duration), StepFailure> {
        let mut compute = Duration::ZERO;
        match &self.solid {
            Solid::Coupled(link) => {
                // The geometry read and the loads' tag: this step (parallel) or the next
                // (serial, which reads the solid's newest geometry).
                let tag = match self.scheme {
                    CouplingScheme::Parallel => cmd.step,
                    CouplingScheme::Serial => cmd.step + 1,
                };
                compute += link.receive_geometry(control, self.solver.as_mut(), tag)?;
                let t = Instant::now();
                self.solver.prepare_step();
                compute += t.elapsed();
                // The loads of the step about to be taken are sent after it (the solid waits
                // for them); the others before.
                let follow =
                    self.scheme == CouplingScheme::Parallel && self.solver.loads_follow_step();
                let report = if follow {
                    let t = Instant::now();
                    let report = self.solver.advance(cmd.dt)?;
                    compute += t.elapsed();
                    Some(report)
                } else {
                    None
                };
                compute += link.send_loads(
                    self.solver.as_mut(),
                    self.n_moving,
                    tag,
                    cmd.time,
                    follow,
                    &mut self.sent,
                )?;
                if let Some(report) = report {
                    return Ok((report, compute));
                }
            }
            Solid::Absent => {
                // Only fixed walls: the step's Eq. 22 forces, no loads to send.
                let t = Instant::now();
                self.solver.prepare_step();
                compute += t.elapsed();
            }
        }
        let t = Instant::now();
        let report = self.solver.advance(cmd.dt)?;
        compute += t.elapsed();
        Ok((report, compute))
    }
}
