//! `solid-node --solver NAME`: the 3D-DDA side of a rockwave run, with any solver of
//! [`solid_node::REGISTRY`]. Started by the coupler, or by hand with the run's `--prefix` (see
//! the README).

use shared::solver::{SetupContext, SolidSolver, SolverError};

fn build(name: &str, ctx: &SetupContext) -> Result<Box<dyn SolidSolver>, SolverError> {
    Ok(solid_node::REGISTRY.build(name, ctx)?)
}

fn main() -> std::process::ExitCode {
    shared::runtime::solid_main(&solid_node::REGISTRY.names(), build)
}
