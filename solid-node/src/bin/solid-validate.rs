//! `cargo run --release -p solid-node --bin solid-validate`: runs the solid verification cases
//! (see `solid_node::verification`) and prints a markdown table. Exits non-zero if one fails.
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
    let failed = rows.iter().filter(|r| !r.pass).count();
    println!(
        "{} case(s), {failed} failed, {:.1} s",
        rows.len(),
        start.elapsed().as_secs_f64()
    );
    if failed == 0 {
        std::process::ExitCode::SUCCESS
    } else {
        std::process::ExitCode::FAILURE
    }
}
