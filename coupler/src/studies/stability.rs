//! `coupler stability`: pushes each method past its limits and records, for every trial, stable
//! or unstable and how the instability was detected (the solver's or the run's own message).
//! Three stability maps (`chart::stability_map`), each CSV + SVG + PNG:
//!
//! - `stability_dt_factor`: every step × 0.1 … 10 of what the method proposes: explicit DDA
//!   and Shi's implicit DDA on a block resting on undamped springs, every SPH scheme on the
//!   dam break, and the coupled floating block in the rows each fluid solver's registry entry
//!   asks for (`shared::registry::Advice::study_variants`);
//! - `stability_stiffness`: the contact spring over decades at a fixed dt = 1 ms (explicit DDA
//!   must fail once ω·dt = dt·sqrt(4k/m) passes 2, i.e. k > m/dt²; the implicit scheme must not);
//! - `stability_density`: block-to-water density ratio 0.001 … 3 in the rows each fluid
//!   solver's registry entry asks for: coupling schemes, solid solvers, sub-cycling, relaxed
//!   loads, and its own parameters (e.g. blocks held over the fluid's step or moved in its
//!   solve); the asked range 0.3 … 3, and below it down to where the added-mass instability of
//!   one-step-lagged loads appears (`shared::coupling::added_mass`).
//!
//! It also measures the numerical damping of Shi's scheme (restitution of an undamped bounce
//! against exp(−πΩ/4)), written to `stability_implicit_damping.csv`.

use crate::studies::chart::{self, Trial};
use crate::studies::coupled_sweep::{self, Config};
use crate::studies::fluid_sweep;
use crate::studies::runner::Scratch;
use crate::studies::solid_sweep;
use clap::Args;
use shared::registry::study;
use std::io::Write;
use std::path::{Path, PathBuf};

#[derive(Debug, Args)]
pub struct StabilityArgs {
    /// Fewer trials (a few minutes instead of ~20).
    #[arg(long)]
    pub quick: bool,
    /// Where the CSV, SVG and PNG files go.
    #[arg(long, default_value = "docs/charts")]
    pub out: PathBuf,
    /// Only these maps (dt, stiffness, density, damping); default all.
    // A misspelt name ran nothing and said nothing: clap names the ones there are.
    #[arg(long, value_delimiter = ',', value_parser = ["dt", "stiffness", "density", "damping"])]
    pub only: Vec<String>,
    /// Redraw the maps (with --only, those) from the CSV files already in --out, running
    /// nothing.
    #[arg(long)]
    pub replot: bool,
    /// Rerun only the rows whose label contains this text (e.g. "added mass", "blocks in
    /// solve") of one map; its other rows are kept from its CSV in --out. Needs `--only density`
    /// or `--only dt`.
    #[arg(long, value_name = "TEXT")]
    pub rows: Option<String>,
}

/// File stem, title and x label of each map.
const DT_MAP: (&str, &str, &str) = (
    "stability_dt_factor",
    "Stability against the step: dt = factor × the method's proposal",
    "dt factor",
);
const STIFFNESS_MAP: (&str, &str, &str) = (
    "stability_stiffness",
    "Contact penalty stiffness at dt = 1 ms (explicit limit k = m/dt² = 4.0e7 N/m)",
    "normal contact stiffness k [N/m]",
);
const DENSITY_MAP: (&str, &str, &str) = (
    "stability_density",
    "Block-to-water density ratio under each coupling scheme",
    "ρ_block / ρ_water",
);

/// The map of each `--only` name that has one, in the order they are drawn.
const MAPS: [(&str, (&str, &str, &str)); 3] = [
    ("dt", DT_MAP),
    ("stiffness", STIFFNESS_MAP),
    ("density", DENSITY_MAP),
];

fn draw(out: &Path, map: (&str, &str, &str), trials: &[Trial]) -> Result<(), String> {
    let stem = out.join(map.0);
    chart::stability_map(&stem, map.1, map.2, trials)?;
    println!("  map: {}.{{csv,svg,png}}", stem.display());
    Ok(())
}

struct Plan {
    dt_factors: &'static [f64],
    coupled_dt_factors: &'static [f64],
    stiffness: &'static [f64],
    density: &'static [f64],
    damping_omegas: &'static [f64],
    coupled_end: f64,
    dam_per_a: usize,
}

const FULL: Plan = Plan {
    dt_factors: &[0.1, 0.3, 0.5, 1.0, 1.5, 2.0, 2.5, 3.0, 5.0, 10.0],
    coupled_dt_factors: &[0.5, 1.0, 2.0, 3.0, 5.0, 10.0],
    stiffness: &[1e4, 1e5, 1e6, 3e6, 1e7, 3e7, 1e8, 3e8, 1e9, 1e10],
    density: &[
        0.001, 0.005, 0.01, 0.02, 0.05, 0.1, 0.3, 0.5, 0.8, 1.2, 2.0, 3.0,
    ],
    damping_omegas: &[0.05, 0.1, 0.2, 0.5, 1.0, 2.0, 5.0],
    coupled_end: 0.6,
    dam_per_a: 8,
};

const QUICK: Plan = Plan {
    dt_factors: &[0.1, 0.5, 1.0, 2.0, 3.0, 10.0],
    coupled_dt_factors: &[1.0, 3.0, 10.0],
    stiffness: &[1e5, 1e6, 1e7, 3e7, 1e8, 1e9],
    density: &[0.001, 0.01, 0.05, 0.3, 1.2, 3.0],
    damping_omegas: &[0.1, 0.5, 1.0, 2.0],
    coupled_end: 0.4,
    dam_per_a: 6,
};

/// Fixed step of the stiffness map [s].
pub const STIFFNESS_DT: f64 = 1e-3;

/// Solid steps per coupling step of the multi-rate rows (`[coupling] solid_substeps`): the
/// explicit DDA sub-cycles inside each coupling step with the water's loads held.
const SUBSTEPS: u32 = 8;

/// The coupled rows of a map: every fluid solver's variants for `study`, each with its own
/// table, over its partners (the solid registry's first, or every solid solver) and couplings,
/// in the registry's order (the fluid solvers' entries: [`shared::registry::Advice::study_variants`]).
/// With the blocks' velocities held over the fluid's step an incompressible fluid answers a
/// block's acceleration one step late at any dt, so the added-mass limit of explicit coupling is
/// a density ratio that no smaller step moves (Causin, Gerbeau & Nobile 2005); relaxing those
/// loads with an artificial added mass of ρ_w V (`[coupling] added_mass = 1`,
/// `shared::coupling::load_relaxation`) moves that limit; moving the blocks inside the pressure
/// solve removes the lag.
fn coupled_rows(study: &str, plan: &Plan) -> Vec<Config> {
    let mut rows = Vec::new();
    for fluid in fluid_node::REGISTRY.entries {
        for variant in (fluid.advice.study_variants)(study) {
            let solids = if variant.every_partner {
                solid_node::REGISTRY.names()
            } else {
                vec![solid_node::REGISTRY.first().name]
            };
            for solid in solids {
                for c in variant.couplings {
                    rows.push(Config {
                        fluid: fluid.name.into(),
                        solid: solid.into(),
                        scheme: c.scheme,
                        dx: 0.02,
                        dt_factor: 1.0,
                        density: None,
                        penalty_stiffness: None,
                        end: plan.coupled_end,
                        solid_substeps: if c.subcycled { SUBSTEPS } else { 1 },
                        added_mass: c.added_mass,
                        fluid_table: variant.table,
                        fluid_label: variant.label,
                    });
                }
            }
        }
    }
    rows
}

/// Runs `coupler stability`; returns the exit code.
pub fn run(args: StabilityArgs) -> u8 {
    match run_inner(&args) {
        Ok(()) => 0,
        Err(e) => {
            eprintln!("coupler stability: error: {e}");
            1
        }
    }
}

fn wanted(args: &StabilityArgs, what: &str) -> bool {
    args.only.is_empty() || args.only.iter().any(|o| o == what)
}

fn run_inner(args: &StabilityArgs) -> Result<(), String> {
    let plan = if args.quick { &QUICK } else { &FULL };
    if args.rows.is_some() && args.only != ["density"] && args.only != ["dt"] {
        return Err(
            "--rows reruns rows of one map, the density or the dt map. Fix: add --only density or --only dt"
                .into(),
        );
    }
    if let Some(rows) = &args.rows {
        rows_exist(plan, &args.only[0], rows)?;
    }
    if args.replot {
        return replot(args);
    }
    std::fs::create_dir_all(&args.out)
        .map_err(|e| format!("cannot create {}: {e}", args.out.display()))?;
    let scratch = Scratch::new("stability")?;
    if wanted(args, "dt") {
        dt_map(plan, &args.out, &scratch, args.rows.as_deref())?;
    }
    if wanted(args, "stiffness") {
        stiffness_map(plan, &args.out)?;
    }
    if wanted(args, "density") {
        density_map(plan, &args.out, &scratch, args.rows.as_deref())?;
    }
    if wanted(args, "damping") {
        damping(plan, &args.out)?;
    }
    Ok(())
}

/// `--replot`: the maps `--only` names (default all three; the damping table has none)
/// redrawn from their CSV files in --out, each of which must be there. `--only dt` redrew every
/// map, and an absent CSV was found after the maps before it were redrawn.
fn replot(args: &StabilityArgs) -> Result<(), String> {
    let maps: Vec<(&str, &str, &str)> = MAPS
        .into_iter()
        .filter(|(name, _)| wanted(args, name))
        .map(|(_, map)| map)
        .collect();
    let only = if args.only.is_empty() {
        String::new()
    } else {
        format!(" --only {}", args.only.join(","))
    };
    if maps.is_empty() {
        return Err(format!(
            "--replot{only}: the damping table has no map to redraw. Fix: --only dt, stiffness \
             or density, or run `coupler stability{only}` without --replot"
        ));
    }
    let absent: Vec<String> = maps
        .iter()
        .map(|m| args.out.join(m.0).with_extension("csv"))
        .filter(|p| !p.is_file())
        .map(|p| p.display().to_string())
        .collect();
    if !absent.is_empty() {
        let verb = if absent.len() == 1 { "does" } else { "do" };
        return Err(format!(
            "--replot{only}: {} {verb} not exist. Fix: run `coupler stability{only}` without \
             --replot (it writes the CSV files), or name with --out the directory that holds them",
            absent.join(", ")
        ));
    }
    for map in maps {
        let trials = chart::read_trials(&args.out.join(map.0))?;
        summarise(&trials);
        draw(&args.out, map, &trials)?;
    }
    Ok(())
}

/// The labels of the rows of `map` (`dt` or `density`), in the map's order.
fn row_labels(plan: &Plan, map: &str) -> Vec<String> {
    if map == "density" {
        return coupled_rows(study::STABILITY_DENSITY, plan)
            .iter()
            .map(Config::label)
            .collect();
    }
    let solids = solid_node::REGISTRY.names().into_iter().map(resting_label);
    let fluids = fluid_node::REGISTRY.names().into_iter().map(dam_label);
    let coupled = coupled_rows(study::STABILITY_DT, plan)
        .into_iter()
        .map(|c| floating_label(&c));
    solids.chain(fluids).chain(coupled).collect()
}

/// `--rows` that matches no row of `map` ran nothing, redrew the map from its CSV and exited 0
/// (or failed on a missing CSV, naming the file): refused with the rows there are.
fn rows_exist(plan: &Plan, map: &str, rows: &str) -> Result<(), String> {
    let labels = row_labels(plan, map);
    if labels.iter().any(|l| l.contains(rows)) {
        return Ok(());
    }
    Err(format!(
        "--rows '{rows}' matches no row of the {map} map. Fix: give text from one of its rows: {}",
        labels.join("; ")
    ))
}

/// `kept` with its rows matching `rows` replaced by `rerun`: where the first of them was, or at
/// the end for rows new to the map.
fn merge_rows(kept: Vec<Trial>, rerun: Vec<Trial>, rows: &str) -> Vec<Trial> {
    let at = kept.iter().position(|t| t.method.contains(rows));
    let mut out: Vec<Trial> = kept
        .into_iter()
        .filter(|t| !t.method.contains(rows))
        .collect();
    let at = at.unwrap_or(out.len()).min(out.len());
    out.splice(at..at, rerun);
    out
}

fn report(t: &Trial) {
    println!(
        "  {:<34} {:>8}  {:<8} {}",
        t.method,
        format!("{}", t.value),
        if t.stable { "stable" } else { "UNSTABLE" },
        t.detail
    );
}

/// The first value at which a row went unstable, for the summary lines.
fn first_unstable(trials: &[Trial], method: &str) -> Option<f64> {
    trials
        .iter()
        .filter(|t| t.method == method && !t.stable)
        .map(|t| t.value)
        .reduce(f64::min)
}

fn summarise(trials: &[Trial]) {
    let mut methods: Vec<&str> = Vec::new();
    for t in trials {
        if !methods.contains(&t.method.as_str()) {
            methods.push(&t.method);
        }
    }
    for m in methods {
        let last_stable = trials
            .iter()
            .filter(|t| t.method == m && t.stable)
            .map(|t| t.value)
            .reduce(f64::max);
        match first_unstable(trials, m) {
            Some(u) => println!(
                "  → {m}: stable up to {}, first failure at {u}",
                last_stable.map_or("none".into(), |v| v.to_string())
            ),
            None => println!("  → {m}: stable everywhere tried"),
        }
    }
}

fn coupled_trial(scratch: &Scratch, method: &str, value: f64, config: &Config) -> Trial {
    let r = coupled_sweep::floating(None, scratch, config);
    let stable = r.outcome.completed();
    let sinks = config.density.is_some_and(|rho| rho > 1000.0);
    // A completed run that warned (a heavy block's landing burst, a solve short of its
    // tolerance) says so in the map: stable is not the same as clean.
    let warned = r
        .outcome
        .last_warning
        .as_ref()
        .map(|w| format!("; {} warning(s), the last: {w}", r.outcome.warnings))
        .unwrap_or_default();
    let detail = if stable && sinks {
        let h = coupled_sweep::block_height(&coupled_sweep::floating_scene());
        match crate::studies::runner::final_block(&r.outcome.dir, coupled_sweep::BLOCK, h) {
            Ok((bottom, v)) => format!(
                "completed; sank: block bottom at z = {bottom:.4} m, speed {v:.3} m/s at t = {}{warned}",
                config.end
            ),
            Err(e) => format!("completed; {e}{warned}"),
        }
    } else if stable {
        match &r.draft {
            Ok((d, v)) => format!(
                "completed; mean draft {d:.4} m (reference {:.4}), |vz| ≤ {v:.3} m/s{warned}",
                r.reference
            ),
            Err(e) => format!("completed; {e}{warned}"),
        }
    } else {
        format!(
            "{} (exit {}): {}",
            r.outcome.status,
            r.outcome.exit_code,
            r.outcome.detail()
        )
    };
    Trial {
        method: method.into(),
        value,
        stable,
        detail,
    }
}

/// The dt map's label of a solid solver's row (a block resting on springs).
fn resting_label(solver: &str) -> String {
    format!("{solver} DDA, resting block")
}

/// The dt map's label of a fluid solver's row (the dam break).
fn dam_label(solver: &str) -> String {
    format!("{solver} SPH, dam break")
}

/// The dt map's label of a coupled row (the floating block).
fn floating_label(config: &Config) -> String {
    format!("floating block, {}", config.label())
}

/// The dt map; with `rows`, only the rows whose label contains it are run, and the other rows
/// are kept from the map's CSV in `out` (as [`density_map`] does).
fn dt_map(plan: &Plan, out: &Path, scratch: &Scratch, rows: Option<&str>) -> Result<(), String> {
    println!("dt factor: every step × factor of the method's own proposal");
    let skip = |label: &str| rows.is_some_and(|r| !label.contains(r));
    let mut trials = Vec::new();
    for solver in solid_node::REGISTRY.names() {
        let method = resting_label(solver);
        if skip(&method) {
            continue;
        }
        for &f in plan.dt_factors {
            // Undamped springs, k = 1e6 N/m: the explicit proposal is 0.5·2/ω_max, Ω = 1.
            let r = solid_sweep::resting(solver, 1e6, f, None, 1.0);
            let t = Trial {
                method: method.clone(),
                value: f,
                stable: r.stable,
                detail: format!("ω·dt = {:.2}: {}", r.omega_dt, r.detail),
            };
            report(&t);
            trials.push(t);
        }
    }
    for solver in fluid_node::REGISTRY.names() {
        let method = dam_label(solver);
        if skip(&method) {
            continue;
        }
        for &f in plan.dt_factors {
            let r = fluid_sweep::dam_break(solver, plan.dam_per_a, f);
            let t = Trial {
                method: method.clone(),
                value: f,
                stable: r.result.is_ok(),
                detail: match &r.result {
                    Ok(_) => format!(
                        "completed; front error {:.3} against Martin & Moyce{}",
                        r.experiment_error(),
                        r.last_warning
                            .as_ref()
                            .map(|w| format!("; warning: {w}"))
                            .unwrap_or_default()
                    ),
                    Err(e) => e.clone(),
                },
            };
            report(&t);
            trials.push(t);
        }
    }
    for row in coupled_rows(study::STABILITY_DT, plan) {
        for &f in plan.coupled_dt_factors {
            let config = Config {
                dt_factor: f,
                ..row.clone()
            };
            let label = floating_label(&config);
            if skip(&label) {
                continue;
            }
            let t = coupled_trial(scratch, &label, f, &config);
            report(&t);
            trials.push(t);
        }
    }
    if let Some(r) = rows {
        trials = merge_rows(chart::read_trials(&out.join(DT_MAP.0))?, trials, r);
    }
    summarise(&trials);
    draw(out, DT_MAP, &trials)
}

fn stiffness_map(plan: &Plan, out: &Path) -> Result<(), String> {
    let m = solid_sweep::RESTING_MASS;
    let k_crit = m / (STIFFNESS_DT * STIFFNESS_DT);
    println!(
        "contact stiffness at fixed dt = {STIFFNESS_DT} s (block {m} kg on four springs; explicit limit ω·dt = 2 at k = m/dt² = {k_crit:.2e} N/m)"
    );
    let mut trials = Vec::new();
    for solver in solid_node::REGISTRY.names() {
        for &k in plan.stiffness {
            let r = solid_sweep::resting(solver, k, 1.0, Some(STIFFNESS_DT), 1.0);
            let t = Trial {
                method: format!("{solver} DDA, dt = 1 ms"),
                value: k,
                stable: r.stable,
                detail: format!("ω·dt = {:.2}: {}", r.omega_dt, r.detail),
            };
            report(&t);
            trials.push(t);
        }
    }
    summarise(&trials);
    draw(out, STIFFNESS_MAP, &trials)
}

/// The density map; with `rows`, only the rows whose label contains it are run, and the other
/// rows are kept from the map's CSV in `out` (in their order, the rerun rows in their place).
fn density_map(
    plan: &Plan,
    out: &Path,
    scratch: &Scratch,
    rows: Option<&str>,
) -> Result<(), String> {
    println!(
        "block-to-water density ratio under each coupling scheme (floating-block tank, real processes)"
    );
    let mut trials = Vec::new();
    for row in coupled_rows(study::STABILITY_DENSITY, plan) {
        for &ratio in plan.density {
            let config = Config {
                density: Some(1000.0 * ratio),
                ..row.clone()
            };
            if rows.is_some_and(|r| !config.label().contains(r)) {
                continue;
            }
            let t = coupled_trial(scratch, &config.label(), ratio, &config);
            report(&t);
            trials.push(t);
        }
    }
    if let Some(r) = rows {
        trials = merge_rows(chart::read_trials(&out.join(DENSITY_MAP.0))?, trials, r);
    }
    summarise(&trials);
    draw(out, DENSITY_MAP, &trials)
}

fn damping(plan: &Plan, out: &Path) -> Result<(), String> {
    println!("numerical damping of Shi's implicit scheme: restitution of an undamped bounce");
    let path = out.join("stability_implicit_damping.csv");
    let mut f = std::fs::File::create(&path)
        .map_err(|e| format!("cannot write {}: {e}", path.display()))?;
    let w = |f: &mut std::fs::File, s: String| {
        writeln!(f, "{s}").map_err(|e| format!("cannot write {}: {e}", path.display()))
    };
    w(
        &mut f,
        "omega_dt,restitution_measured,spread,newmark_exact,exp_minus_pi_omega_over_4".into(),
    )?;
    for &om in plan.damping_omegas {
        // Past Ω = 4 the scheme has no half cycle to compare with: an empty cell, not a NaN.
        let exact = solid_node::verification::newmark_restitution(om);
        let (exact_text, exact_cell) = match exact {
            Some(x) => (format!("{x:.4}"), x.to_string()),
            None => ("none (real roots past Ω = 4)".into(), String::new()),
        };
        let asym = (-std::f64::consts::PI * om / 4.0).exp();
        match solid_node::verification::mean_restitution(solid_node::verification::IMPLICIT, om) {
            Ok((e, spread)) => {
                println!(
                    "  Ω = {om:<5} e = {e:.4} (spread {spread:.3}); exact Newmark {exact_text}; exp(−πΩ/4) = {asym:.4}"
                );
                w(&mut f, format!("{om},{e},{spread},{exact_cell},{asym}"))?;
            }
            Err(e) => {
                println!("  Ω = {om:<5} failed: {e}");
                w(&mut f, format!("{om},,,{exact_cell},{asym}"))?;
            }
        }
    }
    println!("  table: {}", path.display());
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The coupled rows the registry's entries ask for: the maps' rows as they were when the
    /// study named them itself (same labels, order and tables).
    #[test]
    fn the_coupled_rows_come_from_the_registry_in_their_order() {
        let rows = |study| {
            coupled_rows(study, &QUICK)
                .iter()
                .map(|c| (c.label(), c.fluid_table))
                .collect::<Vec<_>>()
        };
        let held = "blocks_in_solve = false";
        let in_solve = "blocks_in_solve = true";
        assert_eq!(
            rows(study::STABILITY_DT),
            [
                ("wcsph+explicit/parallel", ""),
                ("wcsph+explicit/serial", ""),
                ("wcsph+explicit/parallel ×8 substeps", ""),
                ("dfsph+explicit/parallel", held),
                ("dfsph+explicit/parallel ×8 substeps", held),
                ("dfsph (blocks in solve)+explicit/parallel", in_solve),
                (
                    "dfsph (blocks in solve)+explicit/parallel ×8 substeps",
                    in_solve
                ),
            ]
            .map(|(l, t)| (l.to_string(), t))
        );
        assert_eq!(
            rows(study::STABILITY_DENSITY),
            [
                ("wcsph+explicit/parallel", ""),
                ("wcsph+explicit/serial", ""),
                ("wcsph+implicit/parallel", ""),
                ("wcsph+implicit/serial", ""),
                ("dfsph+explicit/parallel", held),
                ("dfsph+explicit/parallel ×8 substeps", held),
                ("dfsph+explicit/parallel +1 ρV added mass", held),
                ("dfsph+explicit/parallel ×8 substeps +1 ρV added mass", held),
                ("dfsph (blocks in solve)+explicit/parallel", in_solve),
                (
                    "dfsph (blocks in solve)+explicit/parallel ×8 substeps",
                    in_solve
                ),
            ]
            .map(|(l, t)| (l.to_string(), t))
        );
    }

    fn trial(method: &str, value: f64) -> Trial {
        Trial {
            method: method.into(),
            value,
            stable: true,
            detail: String::new(),
        }
    }

    #[test]
    fn rerun_rows_replace_theirs_in_place_and_new_rows_go_last() {
        let kept = vec![
            trial("a", 1.0),
            trial("b x", 1.0),
            trial("b x", 2.0),
            trial("c", 1.0),
        ];
        let merged = merge_rows(kept.clone(), vec![trial("b x", 3.0)], "x");
        let rows: Vec<_> = merged
            .iter()
            .map(|t| (t.method.as_str(), t.value))
            .collect();
        assert_eq!(rows, [("a", 1.0), ("b x", 3.0), ("c", 1.0)]);
        let merged = merge_rows(kept, vec![trial("d y", 1.0)], "y");
        assert_eq!(merged.len(), 5);
        assert_eq!(merged[4].method, "d y");
    }
}
