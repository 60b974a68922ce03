//! `solid-node --solver explicit|implicit`: the 3D-DDA side of a rockwave run. Started by the
//! coupler, or by hand with the run's `--prefix` (see the README).

fn main() -> std::process::ExitCode {
    shared::runtime::solid_main(solid_node::SOLVERS, solid_node::build)
}
