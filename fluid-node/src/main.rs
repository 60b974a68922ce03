//! `fluid-node --solver muller|wcsph`: the SPH side of a rockwave run. Started by the coupler,
//! or by hand with the run's `--prefix` (see the README).

fn main() -> std::process::ExitCode {
    shared::runtime::fluid_main(fluid_node::SOLVERS, fluid_node::build)
}
