//! The node runtime: everything a solver binary needs besides the solver.
//!
//! A node binary's `main` is one call, e.g. `runtime::fluid_main(&["muller", "wcsph"], build)`.

use crate::solver::{FluidSolver, SetupContext, SolidSolver, SolverError};
use std::process::ExitCode;

/// Builds a fluid solver by name.
pub type FluidFactory = fn(&str, &SetupContext) -> Result<Box<dyn FluidSolver>, SolverError>;
/// Builds a solid solver by name.
pub type SolidFactory = fn(&str, &SetupContext) -> Result<Box<dyn SolidSolver>, SolverError>;

/// Runs a fluid node: parses the command line, handshakes, then serves steps until told to stop.
pub fn fluid_main(_solvers: &[&str], _build: FluidFactory) -> ExitCode {
    todo!("runtime")
}

/// Runs a solid node.
pub fn solid_main(_solvers: &[&str], _build: SolidFactory) -> ExitCode {
    todo!("runtime")
}
