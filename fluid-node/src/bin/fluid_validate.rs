//! `fluid-validate [--quick] [--out FILE] [--only GROUP]…`: runs the fluid validation cases
//! (still water, Martin & Moyce dam break n² = 2 and 1 with self-convergence, for every solver,
//! and again with Eq. 22 walls for the solvers whose registry entry asks for it; still water
//! over a `[[terrain]]` trough and the impact pressures of Lobovský et al. 2014, for the
//! default solver, the registry's first) in-process and prints a markdown table; `--out` also writes it to a
//! file. `--only impact-study` runs the impact pressures' resolution study instead (every
//! solver at H/dx = 15, 30 and 60; about half an hour on two cores), which the default run leaves out. Exits 0 when every row is as documented: every ordinary row passes and every known
//! limitation (`validation::known_limitation`) fails.

use fluid_node::REGISTRY;
use fluid_node::validation::{
    IMPACT_STUDY_PER_H, Plan, markdown, validate_impact, validate_impact_study, validate_solver,
    validate_terrain_basin,
};
use shared::registry::study;
use shared::scene::Walls;
use std::process::ExitCode;

/// The group of the impact pressures' resolution study (only when named).
const IMPACT_STUDY: &str = "impact-study";

/// The group of one solver's impact-pressure study.
fn study_group(name: &str) -> String {
    format!("{IMPACT_STUDY}-{name}")
}

/// The group of rows that runs solver `name` with its own walls (Eq. 22 only).
fn penalty_group(name: &str) -> String {
    format!("{name}-penalty")
}

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
    /// breaks), `<solver>-penalty` (a solver with Eq. 22 walls), `terrain`, `impact`, or
    /// `impact-study` (every solver's impact pressures at H/dx = 15, 30, 60;
    /// `impact-study-<solver>` one solver's). Default: all but the studies.
    #[arg(long, value_name = "GROUP")]
    only: Vec<String>,
}

fn main() -> ExitCode {
    let args = <Args as clap::Parser>::parse();
    let solvers = REGISTRY.names();
    // The solvers run again with Eq. 22 walls only, to show what boundary particles buy.
    let penalty: Vec<(&str, String)> = REGISTRY
        .entries
        .iter()
        .filter(|e| !(e.advice.study_variants)(study::PENALTY_WALLS).is_empty())
        .map(|e| (e.name, penalty_group(e.name)))
        .collect();
    let studies: Vec<String> = solvers.iter().map(|s| study_group(s)).collect();
    let groups: Vec<&str> = solvers
        .iter()
        .copied()
        .chain(penalty.iter().map(|(_, g)| g.as_str()))
        .chain(["terrain", "impact", IMPACT_STUDY])
        .chain(studies.iter().map(String::as_str))
        .collect();
    if let Some(bad) = args.only.iter().find(|g| !groups.contains(&g.as_str())) {
        eprintln!(
            "fluid-validate: --only {bad}: no such group; the groups are {}",
            groups.join(", ")
        );
        return ExitCode::from(2);
    }
    let named = |g: &str| args.only.iter().any(|o| o == g);
    let wanted = |g: &str| (args.only.is_empty() && g != IMPACT_STUDY) || named(g);
    let plan = if args.quick { Plan::QUICK } else { Plan::FULL };
    eprintln!(
        "fluid-validate: {} plan {plan:?}",
        if args.quick { "quick" } else { "full" }
    );
    let start = std::time::Instant::now();
    let mut rows = Vec::new();
    // Every solver, then those with their own walls (Eq. 22 only).
    let runs = solvers.iter().map(|&s| (s, s, None));
    let penalty = penalty
        .iter()
        .map(|(s, g)| (*s, g.as_str(), Some(Walls::Penalty)));
    for (solver, group, walls) in runs.chain(penalty) {
        if wanted(group) {
            rows.extend(validate_solver(solver, &plan, walls, |l| {
                eprintln!("  {l}")
            }));
        }
    }
    let default = REGISTRY.first().name;
    // Still water over a terrain read from a file (a DEM trough): the default solver.
    if wanted("terrain") {
        rows.extend(validate_terrain_basin(default, &plan, |l| {
            eprintln!("  {l}")
        }));
    }
    // The impact pressures of Lobovský et al. (2014): the default solver.
    if wanted("impact") {
        rows.extend(validate_impact(default, &plan, |l| eprintln!("  {l}")));
    }
    // The resolution study of the impact pressures (Lobovský et al. 2014), when named.
    for solver in &solvers {
        if wanted(IMPACT_STUDY) || named(&study_group(solver)) {
            rows.extend(validate_impact_study(solver, &IMPACT_STUDY_PER_H, |l| {
                eprintln!("  {l}")
            }));
        }
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
