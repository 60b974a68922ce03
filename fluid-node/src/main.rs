//! `fluid-node --solver NAME`: the SPH side of a rockwave run, with any solver of
//! [`fluid_node::REGISTRY`]. Started by the coupler, or by hand with the run's `--prefix` (see
//! the README).

use shared::solver::{FluidSolver, SetupContext, SolverError};

fn build(name: &str, ctx: &SetupContext) -> Result<Box<dyn FluidSolver>, SolverError> {
    Ok(fluid_node::REGISTRY.build(name, ctx)?)
}

fn main() -> std::process::ExitCode {
    // On one of rayon's workers, not on the main thread (`on_pool`: a wake-up per parallel pass
    // otherwise).
    fluid_node::on_pool(|| shared::runtime::fluid_main(&fluid_node::REGISTRY.names(), build))
}
