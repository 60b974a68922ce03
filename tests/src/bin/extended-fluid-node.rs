//! `extended-fluid-node --solver NAME`: the fluid node with one more SPH method, `lite`
//! ([`tests::extension::lite`]), added from outside the `fluid-node` crate: the built-in
//! methods' entries and one line for the new one.

use fluid_node::methods::{dfsph::Dfsph, muller::Muller, riemann::Riemann, wcsph::Wcsph};
use fluid_node::sph::SphSolver;
use shared::registry::Registry;
use shared::solver::{FluidSolver, SetupContext, SolverError};
use tests::extension::lite::Lite;

static REGISTRY: Registry<dyn SphSolver> = Registry {
    role: "fluid",
    entries: &[
        fluid_node::entry::<Wcsph>(),
        fluid_node::entry::<Muller>(),
        fluid_node::entry::<Dfsph>(),
        fluid_node::entry::<Riemann>(),
        fluid_node::entry::<Lite>(),
    ],
};

fn build(name: &str, ctx: &SetupContext) -> Result<Box<dyn FluidSolver>, SolverError> {
    Ok(REGISTRY.build(name, ctx)?)
}

fn main() -> std::process::ExitCode {
    fluid_node::on_pool(|| shared::runtime::fluid_main(&REGISTRY.names(), build))
}
