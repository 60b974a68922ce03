//! A fluid node with toy physics (see `tests::toy`): `--solver hover` or `--solver drop`.
fn main() -> std::process::ExitCode {
    shared::runtime::fluid_main(tests::toy::FLUID_TOYS, tests::toy::build_fluid)
}
