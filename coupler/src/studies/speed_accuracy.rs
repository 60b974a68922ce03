//! `coupler chart`: speed against accuracy. Each validation case with a known reference is run
//! over solvers × resolutions × dt factors (× coupling schemes for the coupled case); the error
//! against the reference and the wall time go into a CSV and a log–log chart with the Pareto
//! front marked (`chart::error_vs_time`):
//!
//! - fluid: the dam-break surge front against Martin & Moyce (in-process, `fluid_sweep`);
//! - solid: the block sliding down an incline against the closed form (in-process);
//! - coupled: the floating block's draft against (ρ_b/ρ_w)·h (real processes, `coupler run`);
//! - loads: the impact of a dam break on a wall (Lobovský et al. 2014, in-process,
//!   `fluid_node::validation::impact`): the peak at sensor 1 against the experiment's median
//!   (H = 300 mm) and the impulse against its median (H = 600 mm), every fluid solver.
//!
//! The fluid runs at dt factor 1 also give the convergence curve `--target-error` inverts
//! (`fluid_convergence.csv`, see `resolution`).

use crate::run::resolution::{self, ConvergenceFit};
use crate::studies::chart::{self, Sample};
use crate::studies::coupled_sweep::{self, Config};
use crate::studies::fluid_sweep::{self, DamRun};
use crate::studies::runner::Scratch;
use crate::studies::solid_sweep;
use clap::Args;
use shared::scene::CouplingScheme;
use std::path::{Path, PathBuf};

#[derive(Debug, Args)]
pub struct ChartArgs {
    /// Fewer, coarser runs (a few minutes instead of ~20).
    #[arg(long)]
    pub quick: bool,
    /// Where the CSV, SVG and PNG files go.
    #[arg(long, default_value = "docs/charts")]
    pub out: PathBuf,
    /// Only these charts (fluid, solid, coupled, loads); default all four.
    // A misspelt name ran nothing and said nothing: clap names the ones there are.
    #[arg(long, value_delimiter = ',', value_parser = ["fluid", "solid", "coupled", "loads"])]
    pub only: Vec<String>,
    /// Redraw the charts (with --only, those) from the CSV files already in --out, running
    /// nothing.
    #[arg(long)]
    pub replot: bool,
}

/// File stem, title and error label of each chart.
const FLUID_CHART: (&str, &str, &str) = (
    "fluid_speed_accuracy",
    "Dam break (Martin & Moyce, n² = 2): front error against wall time",
    "mean |Z − Z_ref| / Z_ref",
);
const FLUID_SELF_CHART: (&str, &str, &str) = (
    "fluid_self_convergence",
    "Dam break: front difference from the finest run against wall time",
    "mean |Z − Z_finest| / Z_finest",
);
const SOLID_CHART: (&str, &str, &str) = (
    "solid_speed_accuracy",
    "Block on a 30° incline (φ = 20°): sliding distance error against wall time",
    "|d(1 s) − d_ref| / d_ref",
);
const PEAK_CHART: (&str, &str, &str) = (
    "loads_peak_speed_accuracy",
    "Dam break on a wall (Lobovský, H = 300 mm): sensor-1 peak error against wall time",
    "|peak − median| / median",
);
const IMPULSE_CHART: (&str, &str, &str) = (
    "loads_impulse_speed_accuracy",
    "Dam break on a wall (Lobovský, H = 600 mm): sensor-1 impulse error against wall time",
    "|impulse − median| / median",
);
const COUPLED_CHART: (&str, &str, &str) = (
    "coupled_speed_accuracy",
    "Floating block (ρ_b/ρ_w = 0.5): draft error against wall time",
    "|draft − (ρ_b/ρ_w) h| / ((ρ_b/ρ_w) h)",
);

fn draw(out: &Path, c: (&str, &str, &str), samples: &[Sample]) -> Result<(), String> {
    let stem = out.join(c.0);
    chart::error_vs_time(&stem, c.1, c.2, samples)?;
    print_front(samples, "");
    println!("  chart: {}.{{csv,svg,png}}", stem.display());
    Ok(())
}

/// The sweep sizes of one mode.
struct Plan {
    fluid_per_a: &'static [usize],
    fluid_dt: &'static [f64],
    solid_k: &'static [f64],
    solid_dt: &'static [f64],
    coupled_dx: &'static [f64],
    coupled_fluid: fn() -> Vec<&'static str>,
    /// The solid solvers of the coupled runs (a function: the registry's list is built at run
    /// time).
    coupled_solid: fn() -> Vec<&'static str>,
    coupled_end: f64,
    /// The impact runs' particles per water height.
    impact_per_h: &'static [usize],
    /// One finer run of the default fluid solver (the registry's first) with explicit DDA, parallel: the 3 % check.
    coupled_fine: Option<f64>,
}

const FULL: Plan = Plan {
    fluid_per_a: &[4, 8, 16, 32],
    fluid_dt: &[0.5, 1.0, 2.0],
    solid_k: &[1e6, 1e7, 1e8, 1e9],
    solid_dt: &[0.25, 0.5, 1.0, 1.5],
    coupled_dx: &[0.04, 0.02],
    coupled_fluid: || fluid_node::REGISTRY.names(),
    coupled_solid: || solid_node::REGISTRY.names(),
    coupled_end: 1.0,
    impact_per_h: &[8, 15, 30],
    coupled_fine: Some(0.01),
};

const QUICK: Plan = Plan {
    fluid_per_a: &[4, 8, 16],
    fluid_dt: &[1.0, 2.0],
    solid_k: &[1e6, 1e7, 1e8],
    solid_dt: &[0.5, 1.0],
    coupled_dx: &[0.04, 0.02],
    // The default fluid solver only.
    coupled_fluid: || vec![fluid_node::REGISTRY.first().name],
    // The paper's scheme only.
    coupled_solid: || vec![solid_node::verification::EXPLICIT],
    coupled_end: 1.0,
    impact_per_h: &[8, 15],
    coupled_fine: None,
};

/// Runs `coupler chart`; returns the exit code.
pub fn run(args: ChartArgs) -> u8 {
    match run_inner(&args) {
        Ok(()) => 0,
        Err(e) => {
            eprintln!("coupler chart: error: {e}");
            1
        }
    }
}

/// A chart's file stem, title and error label.
type Chart = (&'static str, &'static str, &'static str);

/// The charts of each `--only` name, in the order they are drawn.
const CHARTS: [(&str, &[Chart]); 4] = [
    ("fluid", &[FLUID_CHART, FLUID_SELF_CHART]),
    ("solid", &[SOLID_CHART]),
    ("coupled", &[COUPLED_CHART]),
    ("loads", &[PEAK_CHART, IMPULSE_CHART]),
];

/// `--replot`: every chart whose CSV is in --out redrawn, the others skipped (a run with
/// `--only` writes some). A directory with none of them (empty, misspelt, not made yet) was
/// made if missing, each chart "skipped", and the command exited 0: refused, naming the files.
/// With `--only`, only those charts, and each one's CSV must be there: `--only loads` redrew
/// every chart there was.
fn replot(args: &ChartArgs) -> Result<(), String> {
    let out = &args.out;
    let charts: Vec<Chart> = CHARTS
        .iter()
        .filter(|(name, _)| wanted(args, name))
        .flat_map(|(_, charts)| charts.iter().copied())
        .collect();
    let csv = |c: &Chart| out.join(c.0).with_extension("csv");
    if !args.only.is_empty() {
        let absent: Vec<String> = charts
            .iter()
            .map(csv)
            .filter(|p| !p.is_file())
            .map(|p| p.display().to_string())
            .collect();
        if !absent.is_empty() {
            let only = args.only.join(",");
            let verb = if absent.len() == 1 { "does" } else { "do" };
            return Err(format!(
                "--replot --only {only}: {} {verb} not exist. Fix: run `coupler chart --only \
                 {only}` without --replot (it writes the CSV files), or name with --out the \
                 directory that holds them",
                absent.join(", ")
            ));
        }
    } else if !charts.iter().any(|c| csv(c).is_file()) {
        let names: Vec<String> = charts.iter().map(|c| format!("{}.csv", c.0)).collect();
        return Err(format!(
            "--replot: {} holds none of the charts' CSV files ({}). Fix: name with --out the \
             directory a `coupler chart` run wrote (default docs/charts), or run the charts \
             without --replot",
            out.display(),
            names.join(", ")
        ));
    }
    for c in charts {
        match chart::read_samples(&out.join(c.0)) {
            Ok(samples) => {
                println!("{}", c.1);
                draw(out, c, &samples)?
            }
            Err(e) => println!("{}: skipped ({e})", c.0),
        }
    }
    Ok(())
}

fn wanted(args: &ChartArgs, what: &str) -> bool {
    args.only.is_empty() || args.only.iter().any(|o| o == what)
}

fn run_inner(args: &ChartArgs) -> Result<(), String> {
    let plan = if args.quick { &QUICK } else { &FULL };
    if args.replot {
        return replot(args);
    }
    std::fs::create_dir_all(&args.out)
        .map_err(|e| format!("cannot create {}: {e}", args.out.display()))?;
    let mode = if args.quick { "quick" } else { "full" };
    if wanted(args, "fluid") {
        fluid(plan, &args.out, mode)?;
    }
    if wanted(args, "solid") {
        solid(plan, &args.out, mode)?;
    }
    if wanted(args, "coupled") {
        coupled(plan, &args.out, mode)?;
    }
    if wanted(args, "loads") {
        loads(plan, &args.out, mode)?;
    }
    Ok(())
}

/// The loads on a wall: every fluid solver at each resolution of the plan, the sensor-1 peak
/// at H = 300 mm and the impulse at H = 600 mm against the experiment's medians, with the
/// 1 ms sensor window of `fluid-validate`; each run read twice, as the water's pressure over
/// the sensor's face (series `<solver>`) and as the wall's load behind it (`<solver> wall`).
fn loads(plan: &Plan, out: &Path, mode: &str) -> Result<(), String> {
    use fluid_node::validation::{
        IMPACT_WINDOW, ImpactCase, LOBOVSKY_H300, LOBOVSKY_H600_S1_IMPACT_TIME,
        LOBOVSKY_H600_S1_IMPULSE, WALL, impact,
    };
    println!("loads: Lobovský dam break on a wall, sensor 1 ({mode} sweep)");
    let (mut peaks, mut impulses) = (Vec::new(), Vec::new());
    for solver in fluid_node::REGISTRY.names() {
        for &per_h in plan.impact_per_h {
            for height in [0.3, 0.6] {
                let case = ImpactCase::new(height, per_h, Some(IMPACT_WINDOW));
                let start = std::time::Instant::now();
                let r = impact(solver, &case);
                let wall_seconds = start.elapsed().as_secs_f64();
                for (at, series) in [(0, solver.to_string()), (WALL, format!("{solver} wall"))] {
                    let error = match &r {
                        Ok(r) if height == 0.3 => r.pulses[at].map_or(f64::NAN, |p| {
                            (p.peak - LOBOVSKY_H300[0].median).abs() / LOBOVSKY_H300[0].median
                        }),
                        Ok(r) => r
                            .impulse(at, LOBOVSKY_H600_S1_IMPACT_TIME)
                            .map_or(f64::NAN, |i| {
                                (i.0 - LOBOVSKY_H600_S1_IMPULSE).abs() / LOBOVSKY_H600_S1_IMPULSE
                            }),
                        Err(_) => f64::NAN,
                    };
                    println!(
                        "  {series:<13} H = {height} m  H/dx = {per_h:>3}  {wall_seconds:>8.2} s  {}",
                        match &r {
                            Ok(_) => format!("error {error:.3}"),
                            Err(e) => format!("FAILED: {e}"),
                        }
                    );
                    let sample = Sample {
                        series,
                        params: format!("H/dx={per_h}{}", if r.is_err() { " failed" } else { "" }),
                        wall_seconds,
                        error,
                    };
                    if height == 0.3 {
                        peaks.push(sample);
                    } else {
                        impulses.push(sample);
                    }
                }
            }
        }
    }
    draw(out, PEAK_CHART, &peaks)?;
    draw(out, IMPULSE_CHART, &impulses)?;
    Ok(())
}

fn print_front(samples: &[Sample], unit: &str) {
    println!("  Pareto front (fastest first):");
    for i in chart::pareto_front(samples) {
        let s = &samples[i];
        println!(
            "    {:<22} {:<28} {:>8.2} s  error {:.4}{unit}",
            s.series, s.params, s.wall_seconds, s.error
        );
    }
}

fn fluid(plan: &Plan, out: &Path, mode: &str) -> Result<(), String> {
    println!("fluid: dam break n² = 2, a = 0.1 m, against Martin & Moyce ({mode} sweep)");
    let mut samples = Vec::new();
    let mut self_samples = Vec::new();
    let mut fits = Vec::new();
    for solver in fluid_node::REGISTRY.names() {
        let mut at_one: Vec<DamRun> = Vec::new();
        let mut all: Vec<DamRun> = Vec::new();
        let finest = *plan.fluid_per_a.last().expect("resolutions");
        for &per_a in plan.fluid_per_a {
            for &f in plan.fluid_dt {
                // The finest resolution only at dt × 1: it is the self-convergence reference,
                // and the dearest run by far.
                if per_a == finest && f != 1.0 && plan.fluid_per_a.len() > 3 {
                    continue;
                }
                let r = fluid_sweep::dam_break(solver, per_a, f);
                let err = r.experiment_error();
                println!(
                    "  {solver:<7} a/dx = {per_a:>3}  dt×{f:<4} {:>8.2} s  {}",
                    r.wall_seconds,
                    match &r.result {
                        Ok(_) => format!("mean |Z − Z_ref|/Z_ref = {err:.4}"),
                        Err(e) => format!("FAILED: {e}"),
                    }
                );
                samples.push(Sample {
                    series: solver.to_string(),
                    params: format!(
                        "a/dx={per_a} dt×{f}{}",
                        if r.result.is_err() { " unstable" } else { "" }
                    ),
                    wall_seconds: r.wall_seconds,
                    error: err,
                });
                if r.result.is_ok() {
                    all.push(r.clone());
                }
                if f == 1.0 && r.result.is_ok() {
                    at_one.push(r);
                }
            }
        }
        // Against the finest run at dt × 1 (the converged solution as far as measured): the
        // discretisation error alone, which the experiment error mixes with the model's.
        if let Some(Ok(fine)) = at_one.last().map(|r| &r.result) {
            for r in all
                .iter()
                .filter(|r| !(r.per_a == finest && r.dt_factor == 1.0))
            {
                if let Ok(d) = &r.result {
                    self_samples.push(Sample {
                        series: solver.to_string(),
                        params: format!("a/dx={} dt×{}", r.per_a, r.dt_factor),
                        wall_seconds: r.wall_seconds,
                        error: fluid_sweep::front_difference(d, fine),
                    });
                }
            }
        }
        // Successive doublings at dt factor 1 give the convergence curve.
        let mut deltas = Vec::new();
        for w in at_one.windows(2) {
            if let (Ok(a), Ok(b)) = (&w[0].result, &w[1].result)
                && w[1].per_a == 2 * w[0].per_a
            {
                deltas.push((w[0].per_depth(), fluid_sweep::front_difference(a, b)));
            }
        }
        match ConvergenceFit::from_doublings(solver, &deltas) {
            Ok(fit) => {
                println!(
                    "  {solver}: discretisation error e ≈ {:.3}·N^-{:.2} (N = depth/dx; changes between doublings {:?})",
                    fit.c, fit.p, deltas
                );
                fits.push(fit);
            }
            Err(e) => println!("  {solver}: no convergence fit: {e}"),
        }
    }
    draw(out, FLUID_CHART, &samples)?;
    if !self_samples.is_empty() {
        println!("  against the finest run:");
        draw(out, FLUID_SELF_CHART, &self_samples)?;
    }
    if !fits.is_empty() {
        let path = out.join("fluid_convergence.csv");
        std::fs::write(&path, resolution::to_csv(&fits))
            .map_err(|e| format!("cannot write {}: {e}", path.display()))?;
        println!("  convergence curve written to {}", path.display());
    }
    Ok(())
}

fn solid(plan: &Plan, out: &Path, mode: &str) -> Result<(), String> {
    let inc = solid_sweep::INCLINE;
    println!(
        "solid: block sliding down an incline (α = {}°, φ = {}°), d(1 s) against ½ g (sin α − cos α tan φ) t² ({mode} sweep)",
        inc.alpha, inc.phi
    );
    let mut samples = Vec::new();
    for solver in solid_node::REGISTRY.names() {
        for &k in plan.solid_k {
            for &f in plan.solid_dt {
                let r = solid_sweep::incline(solver, k, f);
                let err = r.result.clone().unwrap_or(f64::NAN);
                println!(
                    "  {solver:<8} k = {k:.0e} N/m  dt×{f:<4} {:>8.4} s  {} steps  {}",
                    r.wall_seconds,
                    r.steps,
                    match &r.result {
                        Ok(e) => format!("|d − d_ref|/d_ref = {e:.2e}"),
                        Err(e) => format!("FAILED: {e}"),
                    }
                );
                samples.push(Sample {
                    series: solver.into(),
                    params: format!(
                        "k={k:.0e} dt×{f}{}",
                        if r.result.is_err() { " unstable" } else { "" }
                    ),
                    wall_seconds: r.wall_seconds,
                    error: err,
                });
            }
        }
    }
    draw(out, SOLID_CHART, &samples)?;
    Ok(())
}

fn coupled(plan: &Plan, out: &Path, mode: &str) -> Result<(), String> {
    println!(
        "coupled: floating block (density 500) draft against (ρ_b/ρ_w)·h = 0.1 m, real processes ({mode} sweep)"
    );
    let scratch = Scratch::new("chart")?;
    let mut samples = Vec::new();
    let mut configs = Vec::new();
    for fluid in (plan.coupled_fluid)() {
        for solid in (plan.coupled_solid)() {
            for scheme in [CouplingScheme::Parallel, CouplingScheme::Serial] {
                for &dx in plan.coupled_dx {
                    configs.push(Config {
                        fluid: fluid.into(),
                        solid: solid.into(),
                        scheme,
                        dx,
                        dt_factor: 1.0,
                        density: None,
                        penalty_stiffness: None,
                        end: plan.coupled_end,
                        solid_substeps: 1,
                        added_mass: 0.0,
                        fluid_table: "",
                        fluid_label: "",
                    });
                }
            }
        }
    }
    if let Some(dx) = plan.coupled_fine {
        configs.push(Config {
            fluid: fluid_node::REGISTRY.first().name.into(),
            solid: solid_node::verification::EXPLICIT.into(),
            scheme: CouplingScheme::Parallel,
            dx,
            dt_factor: 1.0,
            density: None,
            penalty_stiffness: None,
            end: plan.coupled_end,
            solid_substeps: 1,
            added_mass: 0.0,
            fluid_table: "",
            fluid_label: "",
        });
    }
    for config in &configs {
        let dx = config.dx;
        let r = coupled_sweep::floating(None, &scratch, config);
        let err = r.error();
        println!(
            "  {:<28} dx = {dx:<5} {:>8.2} s  {}",
            config.label(),
            r.outcome.wall_seconds,
            match &r.draft {
                Ok((d, v)) if r.outcome.completed() => format!(
                    "draft {d:.4} m (reference {:.4}), error {:.2} %, |vz| ≤ {v:.3} m/s",
                    r.reference,
                    100.0 * err
                ),
                _ => format!("{}: {}", r.outcome.status, r.outcome.detail()),
            }
        );
        samples.push(Sample {
            series: config.label(),
            params: format!(
                "dx={dx}{}",
                if err.is_nan() {
                    format!(" {}", r.outcome.status)
                } else {
                    String::new()
                }
            ),
            wall_seconds: r.outcome.wall_seconds,
            error: err,
        });
    }
    draw(out, COUPLED_CHART, &samples)?;
    Ok(())
}
