//! Which fluid rank died, from the MPI launcher's own words.
//!
//! When one rank of the fluid node dies, the launcher (`mpirun`, `srun`) ends the others and
//! exits, and the coupler sees only the launcher's exit. The launcher names the rank on its
//! standard error: the coupler reads that stream line by line, passes every line on to its own
//! standard error unchanged, and keeps the first that names a dead rank for its message
//! ([`crate::run::error::RunError::Died`]).

use std::io::{BufRead, BufReader, Read, Write};
use std::sync::{Arc, Mutex};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

/// The launcher's standard error, passed on, and the first line it said about a dead rank.
pub struct RankReport {
    said: Arc<Mutex<Option<String>>>,
    reader: JoinHandle<()>,
}

impl RankReport {
    /// Reads `stream` (the launcher's standard error) on a thread of its own until it closes.
    pub fn follow(stream: impl Read + Send + 'static) -> RankReport {
        let said = Arc::new(Mutex::new(None));
        let keep = said.clone();
        let reader = std::thread::spawn(move || {
            for line in BufReader::new(stream).lines() {
                let Ok(line) = line else { break };
                let _ = writeln!(std::io::stderr().lock(), "{line}");
                if let Some(death) = rank_death(&line) {
                    keep.lock().unwrap().get_or_insert(death);
                }
            }
        });
        RankReport { said, reader }
    }

    /// What the launcher said about a dead rank, once it has said all it will (its stream
    /// closed) or `wait` has passed.
    pub fn said(&self, wait: Duration) -> Option<String> {
        let start = Instant::now();
        while !self.reader.is_finished() && start.elapsed() < wait {
            // The stream closes when the launcher and its ranks have exited: moments after
            // the death that brought us here. No event to block on across a pipe's end.
            std::thread::sleep(Duration::from_millis(10));
        }
        self.said.lock().unwrap().clone()
    }
}

/// The part of a launcher's line that names a dead rank: Open MPI's "process rank 2 with PID
/// … exited on signal 9 (Killed)", Slurm's "srun: error: node: task 2: Killed", MPICH Hydra's
/// "RANK 2 PID … KILLED BY SIGNAL: 9".
pub fn rank_death(line: &str) -> Option<String> {
    let text = line
        .trim()
        .trim_start_matches(['=', ' '])
        .trim_end_matches(['=', ' ']);
    let named = text.contains("process rank ")
        || (text.starts_with("srun: error:") && text.contains(": task "))
        || (text.starts_with("RANK ") && text.contains(" PID "));
    named.then(|| {
        text.strip_prefix("mpirun noticed that ")
            .unwrap_or(text)
            .trim_end_matches('.')
            .to_string()
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_launchers_lines_that_name_a_dead_rank() {
        for (line, says) in [
            (
                "mpirun noticed that process rank 2 with PID 0 on node vm exited on signal 9 (Killed).",
                Some("process rank 2 with PID 0 on node vm exited on signal 9 (Killed)"),
            ),
            (
                "srun: error: node07: task 1: Killed",
                Some("srun: error: node07: task 1: Killed"),
            ),
            (
                "=   RANK 3 PID 4242 RUNNING AT node02",
                Some("RANK 3 PID 4242 RUNNING AT node02"),
            ),
            (
                "Primary job  terminated normally, but 1 process returned",
                None,
            ),
            ("fluid-node: warning: fluid.water[0]: x extent", None),
        ] {
            assert_eq!(rank_death(line).as_deref(), says, "{line}");
        }
    }

    #[test]
    fn the_first_death_is_kept_once_the_stream_closes() {
        let text = "a line\nmpirun noticed that process rank 1 with PID 7 on node a exited on signal 9 (Killed).\nmpirun noticed that process rank 2 with PID 8 on node a exited on signal 15 (Terminated).\n";
        let report = RankReport::follow(std::io::Cursor::new(text.as_bytes().to_vec()));
        assert_eq!(
            report.said(Duration::from_secs(5)).as_deref(),
            Some("process rank 1 with PID 7 on node a exited on signal 9 (Killed)")
        );
        let quiet = RankReport::follow(std::io::Cursor::new(b"nothing\n".to_vec()));
        assert_eq!(quiet.said(Duration::from_secs(5)), None);
    }
}
