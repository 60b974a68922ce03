//! `cargo run --release -p solid-node --bin solid-validate`: runs the solid verification cases
//! (see `solid_node::verification`) and prints a markdown table. Exits 0 when every row is as documented (every ordinary row
//! passes, every known limitation fails; `shared::report::all_as_expected`).
//! `--quick` shortens the 10 s stack run to 3 s; `--deformable` runs only the deformable-block
//! cases.

fn main() -> std::process::ExitCode {
    let quick = std::env::args().any(|a| a == "--quick");
    let deformable = std::env::args().any(|a| a == "--deformable");
    let start = std::time::Instant::now();
    let rows = if deformable {
        solid_node::REGISTRY
            .names()
            .into_iter()
            .flat_map(solid_node::verification::deformable::rows)
            .collect()
    } else {
        solid_node::verification::run_all(quick)
    };
    println!("{}", solid_node::verification::markdown(&rows));
    println!(
        "{}, {:.1} s",
        shared::report::outcome(&rows),
        start.elapsed().as_secs_f64()
    );
    if shared::report::all_as_expected(&rows) {
        std::process::ExitCode::SUCCESS
    } else {
        std::process::ExitCode::FAILURE
    }
}
