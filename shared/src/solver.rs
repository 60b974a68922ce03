//! The coupling interface a solver implements, in the manner of a preCICE adapter or an FMI
//! model: a solver reads and writes coupling data and advances by the dt it is given. It never
//! knows who is on the other side, nor how the data travels; [`crate::runtime`] does that.
//!
//! Per step, the runtime calls, depending on the role:
//! - fluid: [`FluidSolver::read_geometry`] (if a solid node runs), [`FluidSolver::prepare_step`],
//!   [`FluidSolver::write_loads`] (if a solid node runs), then [`Solver::advance`]; with
//!   [`FluidSolver::loads_follow_step`] in the parallel scheme, [`FluidSolver::write_loads`]
//!   after [`Solver::advance`] instead of before;
//! - solid: [`SolidSolver::read_loads`] (if a fluid node runs), [`Solver::advance`], then
//!   [`SolidSolver::write_geometry`].
//!
//! then [`Solver::write_frame`] when the step ends on an output time, and [`Solver::dt_proposal`].

use crate::math::Real;
use crate::protocol::{BlockLoad, BlockState};
use crate::scene::{CouplingScheme, Scene};
use std::path::Path;

/// What a solver is built from.
pub struct SetupContext<'a> {
    pub scene: &'a Scene,
    /// Directory for this node's output files (already created).
    pub run_dir: &'a Path,
    pub scheme: CouplingScheme,
    /// Whether the other side runs at all.
    pub peer_present: bool,
}

/// Why a step failed. The runtime adds the node, step and time before reporting it.
#[derive(Debug, thiserror::Error)]
pub enum SolverError {
    /// The method went unstable: the message names the limit exceeded and the measured value,
    /// e.g. "density ratio 1.42 exceeds bound 1.3 at particle 812".
    #[error("unstable: {0}")]
    Unstable(String),
    /// Anything else: bad input, an unknown option, an I/O error.
    #[error("{0}")]
    Failed(String),
}

impl From<std::io::Error> for SolverError {
    fn from(e: std::io::Error) -> Self {
        SolverError::Failed(format!("I/O error: {e}"))
    }
}

/// The outcome of a successful step.
#[derive(Debug, Default)]
pub struct StepReport {
    /// A non-fatal problem worth telling the user (e.g. compression beyond 1 % in Müller SPH).
    pub warning: Option<String>,
}

/// What every solver does.
pub trait Solver {
    /// Solver name as selected with `--solver` (e.g. "wcsph", "explicit").
    fn name(&self) -> &str;
    /// Largest stable step for the next advance [s], from the method's own limits.
    fn dt_proposal(&self) -> Real;
    /// Advances the solver's state by exactly `dt`.
    fn advance(&mut self, dt: Real) -> Result<StepReport, SolverError>;
    /// Writes output frame `frame` (state at `time`) into the run directory.
    fn write_frame(&mut self, frame: u32, time: Real) -> Result<(), SolverError>;
    /// Flushes time series at the end of the run (normal or not).
    fn finish(&mut self) -> Result<(), SolverError> {
        Ok(())
    }
    /// Checkpoint: flushes the output files, then encodes everything that affects future steps
    /// (state, scheme history, the previous step, the output writers' position), but no cache
    /// that is rebuilt from it (neighbour lists, contact candidates). Restoring it into a solver
    /// built from the same scene must give a run identical to the byte.
    fn save_state(&mut self) -> Result<Vec<u8>, SolverError> {
        Err(SolverError::Failed(format!(
            "solver '{}' cannot write checkpoints. Fix: run without checkpoints (no \
             output.checkpoint_interval, checkpoint_wall_minutes, --checkpoint-*, --retries)",
            self.name()
        )))
    }
    /// Restores what [`Solver::save_state`] wrote into a solver just built from the same scene
    /// (whose output files went elsewhere), and continues the output files in `run_dir`, which
    /// the coupler cut back to their lengths at the checkpoint.
    fn restore_state(&mut self, state: &[u8], run_dir: &Path) -> Result<(), SolverError> {
        let _ = (state, run_dir);
        Err(SolverError::Failed(format!(
            "solver '{}' cannot resume from checkpoints",
            self.name()
        )))
    }
}

/// The water side: reads block geometry, writes loads on blocks.
pub trait FluidSolver: Solver {
    /// Takes the moving blocks' geometry: one state per block in `Scene::moving_blocks` order,
    /// with world-frame corners in `vertices`.
    fn read_geometry(&mut self, blocks: &[BlockState], vertices: &[[f64; 3]]);
    /// Computes the coupling forces (paper Eq. 22) on the particles for the coming advance,
    /// from the current particles and geometry, and their reaction on the moving blocks. Once
    /// per step, after [`FluidSolver::read_geometry`] and before [`FluidSolver::write_loads`]
    /// and [`Solver::advance`]. The default does nothing (a solver that computes its loads in
    /// `write_loads`).
    fn prepare_step(&mut self) {}
    /// Writes the loads of the coming advance ([`FluidSolver::prepare_step`]): the opposite of
    /// the coupling force and its torque about the centroid, summed per moving block, into
    /// `loads` (same order as the geometry).
    fn write_loads(&mut self, loads: &mut [BlockLoad]);
    /// Whether this solver's loads are those of the step it has just taken rather than of the
    /// state it starts from: a solver that moves the blocks within its step (their inertia in
    /// its pressure solve) hands the solid the forces it moved them with, so that the solid
    /// moves them as the fluid predicted. Then, in the parallel scheme, the runtime calls
    /// [`FluidSolver::write_loads`] after [`Solver::advance`] instead of before (the solid
    /// waits for the fluid's step: fluid first, then solid). Asked after each
    /// [`FluidSolver::read_geometry`].
    fn loads_follow_step(&self) -> bool {
        false
    }
}

/// The rock side: reads loads from the water, writes block geometry.
pub trait SolidSolver: Solver {
    /// Takes the water's loads on the moving blocks for the coming advance.
    fn read_loads(&mut self, loads: &[BlockLoad]);
    /// Total number of corners of the moving blocks (the size of the vertex message).
    fn vertex_count(&self) -> usize;
    /// Writes the current pose and velocity of each moving block and its world-frame corners.
    fn write_geometry(&self, blocks: &mut [BlockState], vertices: &mut [[f64; 3]]);
    /// What [`Self::write_geometry`] sends as each free block's response over the coming
    /// coupling step ([`BlockState::free_acceleration`]): with `Some((dt, substeps))`, measured
    /// by trial steps over `dt` in `substeps` steps with the water's loads held, which leave
    /// the state as it was; with `None`, the block on its own (its last forces, its mass).
    /// The default sends the latter always.
    fn look_ahead(&mut self, _step: Option<(f64, u32)>) -> Result<(), SolverError> {
        Ok(())
    }
}
