//! `fluid-bench [--sizes 10000,100000,1000000] [--threads 1,2] [--solvers NAME,…]
//! [--param 'KEY = VALUE']… [--from T] [--steps N] [--phases]` (default: every solver of the
//! registry; `--param` adds a line to each solver's own table, e.g.
//! `--param 'integrator = "symplectic"'` for wcsph; `--from` times the steps after T simulated
//! seconds of flow instead of from rest; `--steps` sets the number of timed steps, by default
//! about 3·10⁶ particle-steps' worth, so a profiler can be given a longer window; `--phases`
//! below):
//! particle-steps per second on a 3D dam break (a water column a × a × 2a at one end of a
//! 4a × a tank) at about the given particle counts, with each thread count. The timed steps are
//! the full coupling step as the node runtime drives it (`prepare_step`, `write_loads`, `advance`), after
//! warm-up steps that let the reused buffers reach their size. Also printed: the listed
//! neighbour pairs per particle (fluid and boundary; each force pass visits every one), how
//! often per timed step a thread of the process went to sleep (voluntary context switches:
//! with 2 threads, each is a worker a later pass had to wake, ~30 µs on a virtual machine), and
//! the process's peak resident memory so far (VmHWM; run one size per process to read a size's
//! own peak).
//!
//! `--phases` also times each phase of the timed steps (sort, permutation, fluid and wall
//! lists, Eq. 22, density pass, wall pressures, forces, DFSPH's solves, integration, survey,
//! …: the calls a step already makes, `fluid_node::core::phases`) and prints, after the rows, one
//! table per solver and size: mean µs per step of each phase per thread count, and with 1 and
//! 2 threads their 2 ÷ 1 per phase (the `phase_table` module). Off, the clock costs a test of
//! a flag per phase; on or off, the steps are the same to the bit.
//!
//! `fluid-bench --paired BLOCK` instead steps a 1-thread and a 2-thread copy of each solver in
//! alternating blocks of BLOCK steps and reports their ratio pair by pair (the `paired`
//! module): the 2 ÷ 1 ratio without a minute between its two sides.
//!
//! `fluid-bench --ranks N` instead runs each size on N MPI ranks (built with `--features mpi`;
//! the `ranks` module): the run's particle-steps per second, and per rank its particles, halo,
//! bytes and time in messages per step, and the work's imbalance.
//!
//! `fluid-bench --ceiling ROUNDS` instead measures what 2 threads give over 1 on this machine
//! for loops with no serial part (the `ceiling` module), the yardstick for the solvers' own
//! 2 ÷ 1 ratios.

/// One solver stepping in its own pool, what every row times.
#[path = "fluid_bench/bench.rs"]
mod bench;
#[path = "fluid_bench/ceiling.rs"]
mod ceiling;
#[path = "fluid_bench/paired.rs"]
mod paired;
#[path = "fluid_bench/phase_table.rs"]
mod phase_table;
#[cfg(feature = "mpi")]
#[path = "fluid_bench/ranks.rs"]
mod ranks;
/// The dam-break scene of every row.
#[path = "fluid_bench/scene.rs"]
mod scene;

use bench::{Bench, default_steps};
use scene::scene;

/// VmHWM from /proc/self/status (Linux), in MB.
/// Voluntary context switches of the process's threads so far (Linux: the sum over
/// /proc/self/task/*/status): each is a thread that blocked, here a rayon worker that found no
/// work and went to sleep, and that a later pass had to wake (docs/journal/2026-11-performance.md,
/// "Inner loops, sixth round"). Threads that ended are not counted, so only differences over a live pool mean
/// anything.
fn thread_sleeps() -> Option<u64> {
    let mut sum = 0;
    for task in std::fs::read_dir("/proc/self/task").ok()? {
        let status = std::fs::read_to_string(task.ok()?.path().join("status")).ok()?;
        let line = status
            .lines()
            .find(|l| l.starts_with("voluntary_ctxt_switches:"))?;
        sum += line.split_whitespace().nth(1)?.parse::<u64>().ok()?;
    }
    Some(sum)
}

fn peak_rss_mb() -> Option<f64> {
    let status = std::fs::read_to_string("/proc/self/status").ok()?;
    let line = status.lines().find(|l| l.starts_with("VmHWM:"))?;
    let kb: f64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kb / 1024.0)
}

/// Particle-steps per second of the fluid solvers on a 3D dam break (module doc).
#[derive(clap::Parser)]
#[command(name = "fluid-bench")]
struct Args {
    /// Approximate particle counts, comma-separated.
    #[arg(
        long,
        allow_hyphen_values = true,
        value_delimiter = ',',
        default_value = "10000,100000,1000000"
    )]
    sizes: Vec<usize>,
    /// Thread counts, comma-separated (a rayon pool per row).
    #[arg(
        long,
        allow_hyphen_values = true,
        value_delimiter = ',',
        default_value = "1,2"
    )]
    threads: Vec<usize>,
    /// Solvers of the registry, comma-separated (default: all).
    #[arg(long, value_delimiter = ',')]
    solvers: Vec<String>,
    /// A line of each solver's own table, e.g. 'integrator = "symplectic"' (repeatable).
    #[arg(long)]
    param: Vec<String>,
    /// Step (untimed) until the dam break has flowed this many simulated seconds, so the timed
    /// steps see a developed flow (lists rebuilt more often than from rest); 0 to 0.8 s (near
    /// 0.9 s the surge throws water over the tank's top, out of the domain).
    #[arg(long, allow_hyphen_values = true, default_value_t = 0.0)]
    from: f64,
    /// Timed steps (default: about 3·10⁶ particle-steps' worth, at least 3).
    #[arg(long, allow_hyphen_values = true)]
    steps: Option<usize>,
    /// Instead of the solvers: 2 ÷ 1 threads of three loops without a serial part, over this
    /// many alternating rounds (the machine's ceiling for the solvers' ratios).
    #[arg(long, allow_hyphen_values = true, value_name = "ROUNDS")]
    ceiling: Option<usize>,
    /// Instead of the rows per thread count: a 1-thread and a 2-thread copy of each solver
    /// stepping in alternation, this many steps at a time (`--steps` per side), and the ratio of
    /// each pair of blocks.
    #[arg(long, allow_hyphen_values = true, value_name = "BLOCK")]
    paired: Option<usize>,
    /// Also time each phase of the timed steps and print, after the rows, a table per solver
    /// and size: µs per step of each phase per thread count, and their 2 ÷ 1.
    #[arg(long, conflicts_with_all = ["ceiling", "paired"])]
    phases: bool,
    /// Instead of the rows per thread count: each size on this many MPI ranks of the first
    /// `--threads` threads each, of the first solver (needs `--features mpi`).
    #[arg(long, allow_hyphen_values = true, conflicts_with_all = ["ceiling", "paired"])]
    ranks: Option<usize>,
}

fn main() {
    let args = <Args as clap::Parser>::parse();
    if !(0.0..=scene::LAST_FROM).contains(&args.from) {
        eprintln!(
            "fluid-bench: --from {} is outside the bench's flow: give 0 to {} s (its dam break ends at {} s)",
            shared::math::readable(args.from),
            scene::LAST_FROM,
            scene::END
        );
        std::process::exit(2);
    }
    if let Some(rounds) = args.ceiling {
        ceiling::run(rounds);
        return;
    }
    let (sizes, threads, params, from, timed, phases) = (
        args.sizes,
        args.threads,
        args.param,
        args.from,
        args.steps,
        args.phases,
    );
    let solvers: Vec<String> = if args.solvers.is_empty() {
        fluid_node::REGISTRY
            .names()
            .iter()
            .map(|s| s.to_string())
            .collect()
    } else {
        args.solvers
    };
    if let Some(block) = args.paired {
        paired::run(&solvers, &sizes, &params, block, from, timed);
        return;
    }
    if let Some(n) = args.ranks {
        let rows = Rows {
            solver: &solvers[0],
            sizes: &sizes,
            threads: threads[0],
            params: &params,
            from,
            timed,
            phases,
        };
        on_ranks(n, &rows);
        return;
    }
    println!(
        "| solver | particles | threads | from t [s] | steps timed | s/step | particle-steps/s | µs per particle-step | list rebuilds per step | listed pairs per particle (fluid + boundary) | thread sleeps per step | peak RSS so far [MB] |"
    );
    println!("|---|---|---|---|---|---|---|---|---|---|---|");
    let mut timed_phases: Vec<phase_table::Timed> = Vec::new();
    for solver in &solvers {
        for &n in &sizes {
            for &t in &threads {
                let sc = scene(solver, n, &params);
                let mut bench = Bench::new(t, solver, &sc);
                bench.warm_up(from);
                let count = bench.solver.system().len();
                let sorts = bench.solver.system().sorts;
                let steps = timed.unwrap_or_else(|| default_steps(count));
                // The timed steps alone (the clock was off until now).
                bench.solver.phases_mut().reset();
                bench.solver.phases_mut().set_enabled(phases);
                let sleeps = thread_sleeps();
                let secs = bench.run(steps);
                let sys = bench.solver.system();
                let sleeps = sleeps.zip(thread_sleeps()).map_or("–".into(), |(a, b)| {
                    format!("{:.2}", b.saturating_sub(a) as f64 / steps as f64)
                });
                if phases {
                    timed_phases.push(phase_table::Timed {
                        solver: solver.clone(),
                        particles: count,
                        threads: t,
                        rank: None,
                        steps,
                        secs,
                        clock: sys.phases.clone(),
                    });
                }
                let rate = (count * steps) as f64 / secs;
                let (fluid, boundary) = sys.listed_pairs();
                let per = |p: usize| p as f64 / count as f64;
                let rebuilds = (sys.sorts - sorts) as f64 / steps as f64;
                println!(
                    "| {solver} | {count} | {t} | {from} | {steps} | {:.4} | {:.3e} | {:.2} | {rebuilds:.2} | {:.1} + {:.1} | {sleeps} | {} |",
                    secs / steps as f64,
                    rate,
                    1e6 / rate,
                    per(fluid),
                    per(boundary),
                    peak_rss_mb().map_or("–".into(), |m| format!("{m:.0}"))
                );
            }
        }
    }
    phase_table::print(&timed_phases);
}

/// What `--ranks` measures: the first solver, each size, the first thread count.
#[cfg_attr(not(feature = "mpi"), allow(dead_code))]
struct Rows<'a> {
    solver: &'a str,
    sizes: &'a [usize],
    threads: usize,
    params: &'a [String],
    from: f64,
    timed: Option<usize>,
    /// Also a phase table per size, a column per rank.
    phases: bool,
}

/// `--ranks N`: started again under MPI, or, as one of the ranks, the rows.
#[cfg(feature = "mpi")]
fn on_ranks(n: usize, rows: &Rows) {
    if fluid_node::ranks::launched_ranks().is_none() {
        std::process::exit(if ranks::launch(n) == std::process::ExitCode::SUCCESS {
            0
        } else {
            1
        });
    }
    let comm = fluid_node::ranks::mpi::MpiRanks::init().unwrap_or_else(|e| {
        eprintln!("fluid-bench: {e}");
        std::process::exit(2)
    });
    ranks::run(std::sync::Arc::new(comm), rows);
}

#[cfg(not(feature = "mpi"))]
fn on_ranks(_: usize, _: &Rows) {
    eprintln!(
        "fluid-bench: --ranks needs MPI: build with `cargo build --release --features fluid-node/mpi` (Debian packages libopenmpi-dev openmpi-bin libclang-dev)"
    );
    std::process::exit(2);
}
