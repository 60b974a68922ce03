//! 3D-DDA solvers for rockwave (being written).
use shared::solver::{SetupContext, SolidSolver, SolverError};

/// Solver names accepted by `--solver`.
pub const SOLVERS: &[&str] = &["explicit", "implicit"];

/// Builds the named solver for a scene.
pub fn build(name: &str, _ctx: &SetupContext) -> Result<Box<dyn SolidSolver>, SolverError> {
    Err(SolverError::Failed(format!("solid solver '{name}' is not implemented yet")))
}
