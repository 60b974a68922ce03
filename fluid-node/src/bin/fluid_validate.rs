//! `fluid-validate [--quick] [--out FILE] [--only GROUP]…`: runs the fluid validation cases
//! (still water, Martin & Moyce dam break n² = 2 and 1 with self-convergence, for every solver;
//! still water over a `[[terrain]]` trough and the impact pressures of Lobovský et al. 2014,
//! for the default WCSPH) in-process and prints a markdown table; `--out` also writes it to a
//! file. Exits 0 when every row is as documented: every ordinary row passes and every known
//! limitation (`validation::known_limitation`) fails.

use fluid_node::REGISTRY;
use fluid_node::validation::{
    Plan, markdown, validate_impact, validate_solver, validate_terrain_basin,
};
use shared::scene::Walls;
use std::process::ExitCode;

/// The group of rows that runs the paper's solver with its own walls (Eq. 22 only).
const MULLER_PENALTY: &str = "muller-penalty";

#[derive(clap::Parser)]
#[command(about = "Runs the fluid validation cases and prints their table (docs/VALIDATION.md)")]
struct Args {
    /// The quick plan: coarser and shorter cases (what the tests run).
    #[arg(long)]
    quick: bool,
    /// Also write the table to this file.
    #[arg(long, value_name = "FILE")]
    out: Option<String>,
    /// Run only these groups of rows (repeatable): a solver's name (its still water and dam
    /// breaks), `muller-penalty`, `terrain` or `impact`. Default: all.
    #[arg(long, value_name = "GROUP")]
    only: Vec<String>,
}

fn main() -> ExitCode {
    let args = <Args as clap::Parser>::parse();
    let solvers = REGISTRY.names();
    let groups: Vec<&str> = solvers
        .iter()
        .copied()
        .chain([MULLER_PENALTY, "terrain", "impact"])
        .collect();
    if let Some(bad) = args.only.iter().find(|g| !groups.contains(&g.as_str())) {
        eprintln!(
            "fluid-validate: --only {bad}: no such group; the groups are {}",
            groups.join(", ")
        );
        return ExitCode::from(2);
    }
    let wanted = |g: &str| args.only.is_empty() || args.only.iter().any(|o| o == g);
    let plan = if args.quick { Plan::QUICK } else { Plan::FULL };
    eprintln!(
        "fluid-validate: {} plan {plan:?}",
        if args.quick { "quick" } else { "full" }
    );
    let start = std::time::Instant::now();
    let mut rows = Vec::new();
    // Every solver, and the paper's also with its own walls (Eq. 22 only), to show what
    // boundary particles buy.
    let runs = solvers.iter().map(|&s| (s, s, None));
    let penalty = ("muller", MULLER_PENALTY, Some(Walls::Penalty));
    for (solver, group, walls) in runs.chain([penalty]) {
        if wanted(group) {
            rows.extend(validate_solver(solver, &plan, walls, |l| {
                eprintln!("  {l}")
            }));
        }
    }
    // Still water over a terrain read from a file (a DEM trough): the default solver.
    if wanted("terrain") {
        rows.extend(validate_terrain_basin("wcsph", &plan, |l| {
            eprintln!("  {l}")
        }));
    }
    // The impact pressures of Lobovský et al. (2014): the default solver.
    if wanted("impact") {
        rows.extend(validate_impact("wcsph", &plan, |l| eprintln!("  {l}")));
    }
    let table = markdown(&rows);
    println!("{table}");
    eprintln!("fluid-validate: {:.0} s", start.elapsed().as_secs_f64());
    if let Some(path) = &args.out
        && let Err(e) = std::fs::write(path, &table)
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
