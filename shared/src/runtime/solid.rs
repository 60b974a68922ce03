//! The solid node: reads the water's loads on the blocks, advances, writes the geometry.
//!
//! At set-up the solid sends geometry message G_0 (the blocks at t = 0). Per step n (when a
//! fluid node runs): wait for the loads tagged n, hand them to the solver and to the
//! added-mass watch, advance, then write G_{n+1} straight into shared memory and send it.
//! A step whose loads the watch finds unstable (the water's added mass dominates a light
//! block: the instability of partitioned coupling, see [`crate::coupling::added_mass`]) fails as
//! unstable before the solver advances.
//!
//! Multi-rate coupling (`[coupling] solid_substeps = N > 1`): the solid may take up to N
//! steps of its own inside one coupling step, so its stability limit (the explicit DDA's
//! 2/ω_max of the contact springs, paper Eq. 8) no longer binds the shared step: it proposes
//! N times its stable step to the coupler, and within a granted step dt takes
//! n = ⌈dt / dt_stable⌉ equal substeps. The water's loads are held over the coupling step
//! (zero-order hold): they are the loads of the fluid state the step starts from, which is all
//! an explicit partitioned scheme has. Interpolating them would need the loads at the step's
//! end, i.e. extrapolation in the parallel scheme, which feeds the added-mass instability
//! rather than damping it. (A fluid that moves the blocks in its own solve sends the mean
//! load of the step itself, `FluidSolver::loads_follow_step`; holding it is then exact.)
//!
//! Looking ahead: a fluid that moves the blocks inside its own step (DFSPH with the blocks in
//! its pressure solve) needs how each block will answer a force over that step, its contacts
//! included, and marks its loads [`LoadsHeader::FOLLOWED`]. After such a step, when it
//! sub-cycles (`solid_substeps` > 1), the solid measures that answer over a step like the one
//! just taken, with trial steps it takes back (`SolidSolver::look_ahead`; the DDA's in
//! `solid-node/src/dda/look_ahead.rs`), and sends it with the geometry
//! ([`BlockState::free_acceleration`], [`BlockState::mobility`]). Otherwise each block is sent
//! on its own (its mass and last forces): single-rate, the solid's step is its own stable
//! step, within which a contact answers little: looking ahead gained nothing there and moved
//! the floating block's draft off its reference (docs/journal/2026-11-performance.md "The
//! solid looks ahead: a resting block's contact inside DFSPH's step").

use super::SolidFactory;
use super::args::NodeArgs;
use super::control::{self, Control, Fatal};
use super::serve::{self, Side, StepFailure};
use crate::coupling::added_mass::{AddedMassMonitor, Verdict};
use crate::coupling::load_relaxation::LoadRelaxation;
use crate::geometry::Polyhedron;
use crate::math::Vector;
use crate::protocol::{BlockLoad, BlockState, Command, GeometryHeader, LoadsHeader, Resume, Role};
use crate::scene::{BlockKind, Scene};
use crate::solver::{SolidSolver, Solver, SolverError, StepReport};
use crate::transport::{Bell, Inbox, Outbox, Transport};
use std::time::{Duration, Instant};

/// Joins the run as its solid node and serves it; returns the exit code.
pub(super) fn run_node(
    run: &dyn Transport,
    solvers: &[&str],
    build: SolidFactory,
    args: &NodeArgs,
) -> Result<u8, Fatal> {
    let joined = control::join(run, Role::Solid, args, open_loads_in)?;
    let (control, setup) = (&joined.control, &joined.setup);
    let Some(built) = serve::build(control, setup, solvers, args, build)? else {
        return Ok(super::exit::SOLVER);
    };
    let scene = &built.scene;
    let n_moving = scene.moving_blocks().len();
    let opts = serve::Options::new(scene, args, setup, Role::Solid);
    let (added_mass, relaxation) = scene
        .fluid
        .as_ref()
        .map(|fluid| load_handling(scene, fluid.density))
        .unzip();
    let mut solver = built.solver;
    let fluid = if setup.fluid_present {
        let link = FluidLink::open(
            run,
            joined.inbox,
            joined.peer_bell,
            n_moving,
            solver.vertex_count(),
            added_mass,
            relaxation.flatten(),
        );
        match link {
            Ok(link) => Fluid::Coupled(Box::new(link)),
            Err(f) => return serve::refuse(control, solver.as_mut(), serve::fatal_to_solver(f)),
        }
    } else {
        Fluid::Absent
    };
    let mut solid = Solid {
        solver,
        fluid,
        n_moving,
        substeps: scene.coupling.solid_substeps,
    };
    serve::serve(control, &mut solid, &opts)
}

type LoadsIn = Box<dyn Inbox<LoadsHeader, BlockLoad>>;

/// The loads inbox, opened before the hello.
fn open_loads_in(run: &dyn Transport) -> Result<LoadsIn, Fatal> {
    Ok(run.loads_in()?)
}

/// (name, mass, volume, density) of each moving block, in loads order (kinematic blocks
/// cannot be moved by their loads: infinite mass).
fn moving_masses(scene: &Scene) -> Vec<(String, f64, f64, f64)> {
    scene
        .moving_blocks()
        .into_iter()
        .map(|i| {
            let b = &scene.blocks[i];
            let volume = Polyhedron::from_shape(&b.shape).map_or(f64::NAN, |p| p.volume);
            let mass = match b.kind {
                BlockKind::Free => b.density * volume,
                _ => f64::INFINITY,
            };
            (b.name.clone(), mass, volume, b.density)
        })
        .collect()
}

/// What the solid node does with the water's loads before its solver sees them: the
/// added-mass watch, and the relaxation when the scene asks for it.
fn load_handling(scene: &Scene, water_density: f64) -> (AddedMassMonitor, Option<LoadRelaxation>) {
    let blocks = moving_masses(scene);
    let masses: Vec<_> = blocks.iter().map(|b| (b.1, b.2)).collect();
    let relax = LoadRelaxation::new(&masses, scene.coupling.added_mass, water_density);
    let watched = blocks.into_iter().map(|(n, m, _, d)| (n, m, d)).collect();
    let watch = AddedMassMonitor::new(watched, Vector::from(scene.gravity).norm(), water_density);
    (watch, relax)
}

/// Whether a fluid node runs: a dry scene has none.
enum Fluid {
    Absent,
    Coupled(Box<FluidLink>),
}

/// The data ports to and from the fluid node, and the watch on what arrives.
struct FluidLink {
    loads: LoadsIn,
    blocks: Box<dyn Outbox<GeometryHeader, BlockState>>,
    vertices: Box<dyn Outbox<GeometryHeader, [f64; 3]>>,
    bell: Box<dyn Bell>,
    /// The watch on the loads for the added-mass instability (when the scene has water).
    added_mass: Option<AddedMassMonitor>,
    /// The loads' under-relaxation (`[coupling] added_mass` > 0).
    relaxation: Option<LoadRelaxation>,
}

struct Solid {
    solver: Box<dyn SolidSolver>,
    fluid: Fluid,
    n_moving: usize,
    /// Most solid steps per coupling step (1: single-rate).
    substeps: u32,
}

/// Advances the solver over `dt` in n = ⌈dt / dt_stable⌉ ≤ `max` equal substeps with the loads
/// it holds (multi-rate); one step of `dt` when `max` is 1. A step the coupler granted beyond
/// `max` stable steps (a dt-factor experiment) is taken anyway: the solver's own checks name
/// the instability.
fn advance_substeps(
    solver: &mut dyn SolidSolver,
    dt: f64,
    max: u32,
) -> Result<StepReport, SolverError> {
    // One step of exactly dt when max is 1 (dt / 1 is dt to the bit).
    let n = substep_count(solver, dt, max);
    let h = dt / n as f64;
    let mut report = StepReport::default();
    for _ in 0..n {
        let r = solver.advance(h)?;
        if r.warning.is_some() {
            report = r;
        }
    }
    Ok(report)
}

/// How many substeps [`advance_substeps`] takes over `dt`.
fn substep_count(solver: &dyn SolidSolver, dt: f64, max: u32) -> u32 {
    if max <= 1 {
        return 1;
    }
    (dt / solver.dt_proposal()).ceil().clamp(1.0, max as f64) as u32
}

impl FluidLink {
    fn open(
        run: &dyn Transport,
        loads: LoadsIn,
        bell: Box<dyn Bell>,
        n_moving: usize,
        vertex_count: usize,
        added_mass: Option<AddedMassMonitor>,
        relaxation: Option<LoadRelaxation>,
    ) -> Result<FluidLink, Fatal> {
        let blocks = run.blocks_out(n_moving)?;
        let vertices = run.vertices_out(vertex_count)?;
        Ok(FluidLink {
            loads,
            blocks,
            vertices,
            bell,
            added_mass,
            relaxation,
        })
    }

    /// Waits for loads message `tag` and hands it (relaxed, if asked) to the solver; also what
    /// the added-mass watch makes of the loads the solver was given (relaxed loads that still
    /// oscillate and grow are still an instability).
    fn receive_loads(
        &mut self,
        control: &Control,
        solver: &mut dyn SolidSolver,
        tag: u64,
    ) -> Result<(Duration, Option<Verdict>, bool), Fatal> {
        let mut read = Duration::ZERO;
        let mut added_mass = None;
        let mut followed = false;
        let watch = &mut self.added_mass;
        let relaxation = &mut self.relaxation;
        control.receive_tagged(&*self.loads, |h| h.step, tag, &mut |h, loads| {
            let t = Instant::now();
            followed = h.followed();
            let loads = match relaxation.as_mut() {
                Some(r) => r.apply(loads),
                None => loads,
            };
            solver.read_loads(loads);
            added_mass = watch.as_mut().and_then(|m| m.observe(loads));
            read = t.elapsed();
        })?;
        Ok((read, added_mass, followed))
    }

    /// Writes the solver's geometry straight into the outgoing messages (loaned shared memory
    /// over iceoryx2) and sends them.
    fn send_geometry(
        &self,
        solver: &dyn SolidSolver,
        n_moving: usize,
        tag: u64,
        time: f64,
    ) -> Result<Duration, Fatal> {
        let t = Instant::now();
        let nv = solver.vertex_count();
        let header = GeometryHeader {
            step: tag,
            time,
            vertex_count: nv as u32,
            _reserved: 0,
        };
        // The solver writes both parts in one call: the blocks' message is filled (and sent)
        // inside the vertices' one, which is sent when the closure returns.
        let mut inner = Ok(());
        self.vertices.publish(nv, &mut |vh, vertices| {
            *vh = header;
            inner = self.blocks.publish(n_moving, &mut |bh, blocks| {
                *bh = header;
                solver.write_geometry(blocks, vertices);
            });
        })?;
        inner?;
        self.bell.ring()?;
        Ok(t.elapsed())
    }
}

impl Side for Solid {
    fn solver(&mut self) -> &mut dyn Solver {
        self.solver.as_mut()
    }

    fn coupling_proposal(&mut self) -> f64 {
        self.substeps as f64 * self.solver.dt_proposal()
    }

    fn initial_exchange(
        &mut self,
        _control: &Control,
        resume: Option<&Resume>,
    ) -> Result<(), Fatal> {
        // G_0, or G_k of a run resumed after k steps (the fluid of the parallel scheme reads
        // it first; the serial one has used it before the checkpoint and skips it).
        let (step, time) = resume.map_or((0, 0.0), |r| (r.step, r.time));
        if let Fluid::Coupled(link) = &self.fluid {
            link.send_geometry(self.solver.as_ref(), self.n_moving, step, time)?;
        }
        Ok(())
    }

    fn save_runtime(&self) -> Result<Vec<u8>, String> {
        let state = match &self.fluid {
            Fluid::Coupled(link) => (link.added_mass.clone(), link.relaxation.clone()),
            Fluid::Absent => (None, None),
        };
        crate::checkpoint::encode(&state)
    }

    fn restore_runtime(&mut self, bytes: &[u8]) -> Result<(), String> {
        let (watch, relaxation): (Option<AddedMassMonitor>, Option<LoadRelaxation>) =
            crate::checkpoint::decode(bytes, "the solid runtime's load watch and relaxation")?;
        if let Fluid::Coupled(link) = &mut self.fluid {
            link.added_mass = watch;
            link.relaxation = relaxation;
        }
        Ok(())
    }

    fn advance(
        &mut self,
        control: &Control,
        cmd: &Command,
    ) -> Result<(StepReport, Duration), StepFailure> {
        let mut compute = Duration::ZERO;
        let mut burst = None;
        let mut followed = false;
        if let Fluid::Coupled(link) = &mut self.fluid {
            let (t, added_mass, f) = link.receive_loads(control, self.solver.as_mut(), cmd.step)?;
            compute += t;
            followed = f;
            match added_mass {
                Some(Verdict::Unstable(msg)) => {
                    return Err(StepFailure::Solver(SolverError::Unstable(msg)));
                }
                Some(Verdict::Burst(msg)) => burst = Some(msg),
                None => {}
            }
        }
        let t = Instant::now();
        let mut report = advance_substeps(self.solver.as_mut(), cmd.dt, self.substeps)?;
        // A fluid that moved the blocks inside its step reads their response over the next
        // one: measured over a step like this one when the solid sub-cycles (module doc,
        // "Looking ahead").
        let ahead = (followed && self.substeps > 1).then(|| {
            let n = substep_count(self.solver.as_ref(), cmd.dt, self.substeps);
            (cmd.dt, n)
        });
        self.solver.look_ahead(ahead)?;
        // The solver's own warning, if any, is the more specific; a burst is otherwise named.
        if report.warning.is_none() {
            report.warning = burst;
        }
        compute += t.elapsed();
        if let Fluid::Coupled(link) = &self.fluid {
            compute += link.send_geometry(
                self.solver.as_ref(),
                self.n_moving,
                cmd.step + 1,
                cmd.time + cmd.dt,
            )?;
        }
        Ok((report, compute))
    }
}
