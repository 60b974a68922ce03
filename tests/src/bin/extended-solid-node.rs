//! `extended-solid-node --solver NAME`: the solid node with one more time integrator, `euler`
//! ([`tests::extension::euler`]), added from outside the `solid-node` crate.

use shared::registry::Registry;
use shared::solver::{SetupContext, SolidSolver, SolverError};
use solid_node::dda::DdaSolver;
use solid_node::integrators::{explicit::CentralDifference, implicit::Implicit};
use tests::extension::euler::Euler;

static REGISTRY: Registry<DdaSolver> = Registry {
    role: "solid",
    entries: &[
        solid_node::entry::<CentralDifference>(),
        solid_node::entry::<Implicit>(),
        solid_node::entry::<Euler>(),
    ],
};

fn build(name: &str, ctx: &SetupContext) -> Result<Box<dyn SolidSolver>, SolverError> {
    Ok(REGISTRY.build(name, ctx)?)
}

fn main() -> std::process::ExitCode {
    shared::runtime::solid_main(&REGISTRY.names(), build)
}
