//! Rank 0 leads, the others follow: rank 0 is the fluid node the coupler talks to, and before
//! each call of the coupling interface it tells the other ranks to make the same call
//! ([`Leader`]); they wait for it in [`follow`]. Each call's collective steps (halo messages,
//! reductions) then meet on every rank in the same order.

use super::comm::Comm;
use serde::{Deserialize, Serialize};
use shared::math::Real;
use shared::protocol::{BlockLoad, BlockState};
use shared::scene::{CouplingScheme, Scene};
use shared::solver::{FluidSolver, SetupContext, Solver, SolverError, StepReport};
use std::path::{Path, PathBuf};
use std::sync::Arc;

/// What rank 0 tells the others.
#[derive(Debug, Serialize, Deserialize)]
enum Call {
    /// Build the solver: its name and the context rank 0 built its own with.
    Setup {
        solver: String,
        scene_toml: String,
        run_dir: PathBuf,
        scheme: CouplingScheme,
        peer_present: bool,
    },
    /// The solid's new poses: the blocks' states (as their bytes) and corners.
    Geometry(Vec<u8>, Vec<[f64; 3]>),
    Prepare,
    Advance(Real),
    Frame(u32, Real),
    Finish,
    /// Take part in a checkpoint (rank 0 writes the whole state).
    Save,
    /// Restore the whole state rank 0 read, continuing the files in the run directory.
    Restore(Vec<u8>, PathBuf),
    /// The run is over (or rank 0 failed to build): leave.
    Stop,
}

fn tell(comm: &dyn Comm, call: &Call) {
    let mut bytes = bincode::serde::encode_to_vec(call, bincode::config::standard())
        .expect("a call always encodes");
    comm.broadcast(&mut bytes);
}

fn hear(comm: &dyn Comm) -> Result<Call, String> {
    let mut bytes = Vec::new();
    comm.broadcast(&mut bytes);
    bincode::serde::decode_from_slice(&bytes, bincode::config::standard())
        .map(|(c, _)| c)
        .map_err(|e| format!("undecodable call from rank 0: {e}"))
}

/// The type the node builds its solvers with.
pub type Factory = fn(&str, &SetupContext) -> Result<Box<dyn FluidSolver>, SolverError>;

/// Rank 0's solver: tells the other ranks every call, then makes it.
pub struct Leader {
    comm: Arc<dyn Comm>,
    inner: Box<dyn FluidSolver>,
}

impl Leader {
    /// Tells the other ranks to build solver `name` with `ctx`, builds rank 0's, and leads.
    pub fn build(
        comm: Arc<dyn Comm>,
        name: &str,
        ctx: &SetupContext,
        factory: Factory,
    ) -> Result<Box<dyn FluidSolver>, SolverError> {
        let scene_toml = toml::to_string(ctx.scene)
            .map_err(|e| SolverError::Failed(format!("cannot hand the scene to the ranks: {e}")))?;
        tell(
            &*comm,
            &Call::Setup {
                solver: name.to_string(),
                scene_toml,
                run_dir: ctx.run_dir.to_path_buf(),
                scheme: ctx.scheme,
                peer_present: ctx.peer_present,
            },
        );
        match factory(name, ctx) {
            Ok(inner) => Ok(Box::new(Leader { comm, inner })),
            Err(e) => {
                // The others failed alike (the same scene), or wait to be told.
                tell(&*comm, &Call::Stop);
                Err(e)
            }
        }
    }
}

impl Drop for Leader {
    fn drop(&mut self) {
        tell(&*self.comm, &Call::Stop);
    }
}

impl Solver for Leader {
    fn name(&self) -> &str {
        self.inner.name()
    }

    fn dt_proposal(&self) -> Real {
        self.inner.dt_proposal()
    }

    fn advance(&mut self, dt: Real) -> Result<StepReport, SolverError> {
        tell(&*self.comm, &Call::Advance(dt));
        self.inner.advance(dt)
    }

    fn write_frame(&mut self, frame: u32, time: Real) -> Result<(), SolverError> {
        tell(&*self.comm, &Call::Frame(frame, time));
        self.inner.write_frame(frame, time)
    }

    fn finish(&mut self) -> Result<(), SolverError> {
        tell(&*self.comm, &Call::Finish);
        self.inner.finish()
    }

    fn save_state(&mut self) -> Result<Vec<u8>, SolverError> {
        tell(&*self.comm, &Call::Save);
        self.inner.save_state()
    }

    fn restore_state(&mut self, state: &[u8], run_dir: &Path) -> Result<(), SolverError> {
        tell(
            &*self.comm,
            &Call::Restore(state.to_vec(), run_dir.to_path_buf()),
        );
        self.inner.restore_state(state, run_dir)
    }
}

impl FluidSolver for Leader {
    fn read_geometry(&mut self, blocks: &[BlockState], vertices: &[[f64; 3]]) {
        tell(
            &*self.comm,
            &Call::Geometry(bytemuck::cast_slice(blocks).to_vec(), vertices.to_vec()),
        );
        self.inner.read_geometry(blocks, vertices);
    }

    fn loads_follow_step(&self) -> bool {
        self.inner.loads_follow_step()
    }

    fn prepare_step(&mut self) {
        tell(&*self.comm, &Call::Prepare);
        self.inner.prepare_step();
    }

    fn write_loads(&mut self, loads: &mut [BlockLoad]) {
        self.inner.write_loads(loads);
    }
}

/// A rank other than 0: builds the solver rank 0 names and makes the calls it makes, until it
/// says stop. A failed call is rank 0's to report (the ranks agree on failures, so rank 0
/// failed alike); this rank waits for the next.
pub fn follow(comm: Arc<dyn Comm>, factory: Factory) -> Result<(), String> {
    let mut solver = loop {
        match hear(&*comm)? {
            Call::Setup {
                solver,
                scene_toml,
                run_dir,
                scheme,
                peer_present,
            } => {
                let scene =
                    Scene::parse(&scene_toml, "rank 0's scene").map_err(|e| e.to_string())?;
                let ctx = SetupContext {
                    scene: &scene,
                    run_dir: &run_dir,
                    scheme,
                    peer_present,
                };
                match factory(&solver, &ctx) {
                    Ok(s) => break s,
                    // Rank 0 fails too (the ranks agree) and says stop.
                    Err(e) => {
                        eprintln!("fluid-node rank {}: {e}", comm.rank());
                        continue;
                    }
                }
            }
            Call::Stop => return Ok(()),
            other => return Err(format!("rank 0 sent {other:?} before the setup")),
        }
    };
    loop {
        // Failures are rank 0's to report.
        let _ = match hear(&*comm)? {
            Call::Geometry(blocks, vertices) => {
                // Copied out: the bytes need not be aligned as the states are.
                let blocks: Vec<BlockState> = blocks
                    .chunks_exact(std::mem::size_of::<BlockState>())
                    .map(bytemuck::pod_read_unaligned)
                    .collect();
                solver.read_geometry(&blocks, &vertices);
                Ok(())
            }
            Call::Prepare => {
                solver.prepare_step();
                Ok(())
            }
            Call::Advance(dt) => solver.advance(dt).map(|_| ()),
            Call::Frame(frame, time) => solver.write_frame(frame, time),
            Call::Finish => solver.finish(),
            Call::Save => solver.save_state().map(|_| ()),
            Call::Restore(state, run_dir) => solver.restore_state(&state, &run_dir),
            Call::Stop => return Ok(()),
            Call::Setup { .. } => return Err("rank 0 sent a second setup".into()),
        };
    }
}
