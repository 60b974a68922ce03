//! A solid node with toy physics (see `tests::toy`): ballistic blocks.
fn main() -> std::process::ExitCode {
    shared::runtime::solid_main(tests::toy::SOLID_TOYS, tests::toy::build_solid)
}
