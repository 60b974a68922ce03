//! `fluid-bench --ranks N`: the bench's dam break on N MPI ranks (the fluid split into slabs,
//! `fluid_node::ranks`), each rank with the first of `--threads` threads. Started outside MPI,
//! the bench starts itself again under `mpirun -n N` (`ROCKWAVE_MPIRUN` replaces `mpirun`);
//! under MPI, rank 0 prints one row per size with the run's particle-steps per second, and one
//! row per rank: the particles it owns and holds in its halo, the bytes it sent and the time
//! it spent in messages (waiting included) per step, the imbalance of the measured work and of
//! the compute time (the last the cuts were judged by), the times the cuts moved, and its peak
//! resident memory.

use super::bench::{Bench, default_steps};
use fluid_node::core::phases::PhaseClock;
use fluid_node::ranks::{self, comm::Comm};
use std::sync::Arc;

/// Starts the bench again as `ranks` MPI ranks (this process is not one), and returns its exit
/// status.
pub fn launch(ranks: usize) -> std::process::ExitCode {
    let words = std::env::var("ROCKWAVE_MPIRUN").unwrap_or_else(|_| "mpirun".into());
    let mut words = words.split_whitespace();
    let program = words.next().unwrap_or("mpirun");
    let me = std::env::current_exe().expect("the bench's own path");
    let mut cmd = std::process::Command::new(program);
    cmd.args(words)
        // One core per rank is the point of the comparison; a 1-thread rank must not be
        // pinned with the other onto one core, nor kept from the second.
        .args([
            "--oversubscribe",
            "--bind-to",
            "none",
            "-n",
            &ranks.to_string(),
        ])
        .arg(me)
        .args(std::env::args().skip(1))
        .env("OMPI_ALLOW_RUN_AS_ROOT", "1")
        .env("OMPI_ALLOW_RUN_AS_ROOT_CONFIRM", "1");
    match cmd.status() {
        Ok(s) if s.success() => std::process::ExitCode::SUCCESS,
        Ok(s) => {
            eprintln!("fluid-bench: the ranks ended with {s}");
            std::process::ExitCode::FAILURE
        }
        Err(e) => {
            eprintln!(
                "fluid-bench: cannot start '{program}' ({e}): install Debian's openmpi-bin libopenmpi-dev, or name the launcher in ROCKWAVE_MPIRUN"
            );
            std::process::ExitCode::FAILURE
        }
    }
}

/// One rank's figures of one size, as gathered on rank 0.
fn words(v: &[f64]) -> Vec<u8> {
    v.iter().flat_map(|x| x.to_le_bytes()).collect()
}

/// [`words`] read back.
fn floats(b: &[u8]) -> Vec<f64> {
    b.chunks_exact(8)
        .map(|c| f64::from_le_bytes(c.try_into().unwrap()))
        .collect()
}

/// The rows of every size, as one of the MPI ranks.
pub fn run(comm: Arc<dyn Comm>, rows: &super::Rows) {
    let super::Rows {
        solver,
        sizes,
        threads,
        params,
        from,
        timed,
        phases,
    } = *rows;
    let rank = comm.rank();
    ranks::install(comm.clone());
    if rank == 0 {
        println!(
            "| solver | particles | ranks × threads | steps timed | s/step | particle-steps/s |"
        );
        println!("|---|---|---|---|---|---|");
    }
    let mut per_rank = Vec::new();
    let mut timed_phases = Vec::new();
    for &n in sizes {
        let sc = super::scene::scene(solver, n, params);
        let mut bench = Bench::new(threads, solver, &sc);
        bench.warm_up(from);
        let count = bench.solver.system().global_len();
        let steps = timed.unwrap_or_else(|| default_steps(count));
        let stats = |b: &Bench| b.solver.system().share.as_ref().map(|x| x.stats);
        let before = stats(&bench).unwrap_or_default();
        bench.solver.phases_mut().reset();
        bench.solver.phases_mut().set_enabled(phases);
        // Every rank starts the clock together.
        comm.max(&mut [0.0]);
        let mut secs = [bench.run(steps)];
        comm.max(&mut secs);
        let clocks = comm.gather(words(&bench.solver.system().phases.to_words()));
        if phases && rank == 0 {
            for (r, b) in clocks.iter().enumerate() {
                timed_phases.push(super::phase_table::Timed {
                    solver: solver.to_string(),
                    particles: count,
                    threads,
                    rank: Some(r),
                    steps,
                    secs: secs[0],
                    clock: PhaseClock::from_words(&floats(b)),
                });
            }
        }
        let after = stats(&bench).unwrap_or_default();
        let owned = bench
            .solver
            .system()
            .owned()
            .map_or(count, |o| o.iter().filter(|&&x| x).count());
        let mine = [
            owned as f64,
            after.halo as f64,
            (after.bytes_sent - before.bytes_sent) as f64 / steps as f64,
            (after.waiting - before.waiting).as_secs_f64() / steps as f64,
            after.imbalance,
            after.time_imbalance,
            after.rebalances as f64,
            super::peak_rss_mb().unwrap_or(f64::NAN),
        ];
        let all = comm.gather(words(&mine));
        if rank == 0 {
            let secs = secs[0];
            println!(
                "| {solver} | {count} | {} × {threads} | {steps} | {:.4} | {:.3e} |",
                comm.size(),
                secs / steps as f64,
                (count * steps) as f64 / secs
            );
            for (r, b) in all.iter().enumerate() {
                let v = floats(b);
                per_rank.push(format!(
                        "| {count} | {r} | {:.0} | {:.0} | {:.0} | {:.1} | {:.1} | {:.3} / {:.3} | {:.0} | {:.0} |",
                        v[0],
                        v[1],
                        v[2] / 1e3,
                        1e3 * v[3],
                        100.0 * v[3] / (secs / steps as f64),
                        v[4],
                        v[5],
                        v[6],
                        v[7]
                    ));
            }
        }
    }
    if rank == 0 {
        println!();
        println!(
            "| particles | rank | owned | halo | kB sent per step | ms in messages per step | % of the step | imbalance, busiest ÷ mean: work / compute time | cuts moved | peak RSS so far [MB] |"
        );
        println!("|---|---|---|---|---|---|---|---|---|---|");
        for row in per_rank {
            println!("{row}");
        }
        super::phase_table::print(&timed_phases);
    }
    drop(ranks::uninstall());
}
