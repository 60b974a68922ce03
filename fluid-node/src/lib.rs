//! SPH solvers for rockwave (being written).
use shared::solver::{FluidSolver, SetupContext, SolverError};

/// Solver names accepted by `--solver`.
pub const SOLVERS: &[&str] = &["muller", "wcsph"];

/// Builds the named solver for a scene.
pub fn build(name: &str, _ctx: &SetupContext) -> Result<Box<dyn FluidSolver>, SolverError> {
    Err(SolverError::Failed(format!("fluid solver '{name}' is not implemented yet")))
}
