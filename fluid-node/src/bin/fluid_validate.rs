//! `fluid-validate [--quick] [--out FILE]`: runs the fluid validation cases (still water, Martin &
//! Moyce dam break n² = 2 and 1 with self-convergence, for every solver; the impact pressures of
//! Lobovský et al. 2014, for the default WCSPH) in-process and prints a
//! markdown table; `--out` also writes it to a file. Exits 0 when every row is as documented: every
//! ordinary row passes and every known limitation (`validation::known_limitation`) fails.

use fluid_node::REGISTRY;
use fluid_node::validation::{
    Plan, markdown, validate_impact, validate_solver, validate_terrain_basin,
};
use shared::scene::Walls;
use std::process::ExitCode;

fn main() -> ExitCode {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let quick = args.iter().any(|a| a == "--quick");
    let out = args
        .iter()
        .position(|a| a == "--out")
        .and_then(|i| args.get(i + 1))
        .cloned();
    if let Some(bad) = args
        .iter()
        .find(|a| a.starts_with("--") && *a != "--quick" && *a != "--out")
    {
        eprintln!(
            "fluid-validate: unknown option {bad}; usage: fluid-validate [--quick] [--out FILE]"
        );
        return ExitCode::from(2);
    }
    let plan = if quick { Plan::QUICK } else { Plan::FULL };
    eprintln!(
        "fluid-validate: {} plan {plan:?}",
        if quick { "quick" } else { "full" }
    );
    let start = std::time::Instant::now();
    let mut rows = Vec::new();
    // Every solver, and the paper's also with its own walls (Eq. 22 only), to show what
    // boundary particles buy.
    let runs = REGISTRY.names().into_iter().map(|s| (s, None));
    for (solver, walls) in runs.chain([("muller", Some(Walls::Penalty))]) {
        rows.extend(validate_solver(solver, &plan, walls, |l| {
            eprintln!("  {l}")
        }));
    }
    // Still water over a terrain read from a file (a DEM trough): the default solver.
    rows.extend(validate_terrain_basin("wcsph", &plan, |l| {
        eprintln!("  {l}")
    }));
    // The impact pressures of Lobovský et al. (2014): the default solver.
    rows.extend(validate_impact("wcsph", &plan, |l| eprintln!("  {l}")));
    let table = markdown(&rows);
    println!("{table}");
    eprintln!("fluid-validate: {:.0} s", start.elapsed().as_secs_f64());
    if let Some(path) = out
        && let Err(e) = std::fs::write(&path, &table)
    {
        eprintln!("fluid-validate: cannot write {path}: {e}");
        return ExitCode::FAILURE;
    }
    eprintln!("fluid-validate: {}", shared::report::outcome(&rows));
    if shared::report::all_as_expected(&rows) {
        ExitCode::SUCCESS
    } else {
        ExitCode::FAILURE
    }
}
