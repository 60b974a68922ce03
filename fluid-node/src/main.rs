//! `fluid-node --solver NAME`: the SPH side of a rockwave run, with any solver of
//! [`fluid_node::REGISTRY`]. Started by the coupler, or by hand with the run's `--prefix` (see
//! the README).

use shared::solver::{FluidSolver, SetupContext, SolverError};

fn build(name: &str, ctx: &SetupContext) -> Result<Box<dyn FluidSolver>, SolverError> {
    Ok(fluid_node::REGISTRY.build(name, ctx)?)
}

fn main() -> std::process::ExitCode {
    // The node runs on one of rayon's workers, not on the main thread: every parallel pass of a
    // step then starts on a thread of the pool, which keeps the first half of the particles and
    // hands the second to the other worker, pass after pass. From the main thread each pass
    // was injected into the pool and the main thread slept until it was done: a wake-up per
    // pass, and the halves changed threads (and caches) between passes (docs/PERFORMANCE.md).
    rayon::scope(|_| shared::runtime::fluid_main(&fluid_node::REGISTRY.names(), build))
}
