//! The whole run with its restarts (`--retries`): a node that dies or hangs sends every node
//! back to the last complete checkpoint (or to t = 0), once per failure.

use super::{RunOptions, Session};
use crate::run::error::RunError;
use crate::run::output::RunDir;
use crate::run::stats::RunStats;
use shared::transport;
use std::time::Instant;

impl Session {
    /// Runs the whole thing: start, step to the end, stop. The run directory receives what was
    /// written whatever the outcome; `stats` tells how far it got.
    ///
    /// With `retries`, a node that dies or hangs is restarted: every process of the attempt is
    /// ended, the run directory and the coupler go back to the last complete checkpoint (or to
    /// t = 0 without one), and fresh nodes resume from their checkpoint files. A node that
    /// fails again at the same step stops the run with its cause.
    pub fn execute(mut opts: RunOptions, dir: &mut RunDir) -> (RunStats, Result<(), RunError>) {
        let id = opts.run_id.clone();
        let started = Instant::now();
        let mut failures: Vec<(String, u64)> = Vec::new();
        let mut restarts = 0u32;
        let (mut stats, result) = loop {
            let (stats, result) = match Session::open(opts.clone()) {
                Ok(mut session) => {
                    let result = session.start(dir).and_then(|_| session.advance_to_end(dir));
                    let result = session.stop(result);
                    (session.stats.clone(), result)
                }
                Err(e) => (RunStats::default(), Err(e)),
            };
            // The session is gone, and with it every node of this attempt.
            let Err(e) = &result else {
                break (stats, result);
            };
            let Some(failure) = e.restartable() else {
                break (stats, result);
            };
            let from_step = opts.resume.as_ref().map_or(0, |c| c.step);
            if failures.contains(&failure) {
                let Err(cause) = result else { unreachable!() };
                let again = RunError::Again {
                    cause: Box::new(cause),
                    from_step,
                };
                break (stats, Err(again));
            }
            if restarts >= opts.retries {
                break (stats, result);
            }
            failures.push(failure);
            restarts += 1;
            transport::remove_run_files(&id);
            if opts.fluid_ranks > 1 {
                crate::run::mpi_segments::remove_orphans();
            }
            let back = match crate::run::checkpoint::latest(dir.path(), &opts.scene) {
                Ok(Some(ck)) => crate::run::checkpoint::rollback(dir.path(), &ck)
                    .and_then(|_| {
                        dir.restore_series(ck.particles.clone(), ck.blocks.clone())
                            .map_err(|e| format!("cannot rewrite the .pvd series: {e}"))
                    })
                    .map(|_| Some(ck)),
                Ok(None) => {
                    crate::run::checkpoint::rollback_to_start(dir.path(), dir.static_blocks())
                        .and_then(|_| {
                            dir.restore_series(Vec::new(), Vec::new())
                                .map_err(|e| format!("cannot rewrite the .pvd series: {e}"))
                        })
                        .map(|_| None)
                }
                Err(e) => Err(e),
            };
            match back {
                Ok(ck) => {
                    eprintln!(
                        "coupler: {e}; restart {restarts} of {}: every node goes back to {}",
                        opts.retries,
                        match &ck {
                            Some(c) =>
                                format!("the checkpoint at step {} (t = {:.6} s)", c.step, c.time),
                            None => "t = 0 (no checkpoint yet)".into(),
                        }
                    );
                    opts.resume = ck;
                }
                Err(msg) => {
                    let Err(cause) = result else { unreachable!() };
                    break (
                        stats,
                        Err(RunError::Input(format!(
                            "{cause}; the restart failed: {msg}"
                        ))),
                    );
                }
            }
        };
        stats.restarts = restarts;
        stats.resumed_from_step = opts.resume.as_ref().map(|c| c.step);
        stats.wall_seconds = started.elapsed().as_secs_f64();
        stats.coupler_cpu_seconds = shared::runtime::process_cpu_seconds();
        stats.coupler_peak_rss_bytes = shared::runtime::process_peak_rss_bytes();
        // Every process of the run is gone now (the session dropped its children): remove
        // whatever iceoryx2 left in /dev/shm and /tmp/iceoryx2, e.g. after a SIGKILL, and the
        // MPI segments of a killed rank.
        transport::remove_run_files(&id);
        if opts.fluid_ranks > 1 {
            crate::run::mpi_segments::remove_orphans();
        }
        (stats, result)
    }
}
