//! `coupler clean`: the shared memory and run locks that runs killed outright left behind.

use shared::transport::{self, RunId};

/// Runs `coupler clean` for every dead run with a generated id and the runs named in
/// `run_ids`; returns the process exit code.
pub fn run(run_ids: &[String]) -> u8 {
    let mut cleaned = transport::remove_stale_runs(std::time::Duration::ZERO).len();
    for id in run_ids {
        let id = match RunId::parse(id) {
            Ok(id) => id,
            Err(e) => {
                eprintln!("coupler: error: {e}");
                return 1;
            }
        };
        if transport::run_has_live_nodes(&id) {
            eprintln!("coupler: run {id} still has live processes; left alone");
        } else if transport::remove_run_files(&id) > 0 {
            cleaned += 1;
        }
    }
    let locks = crate::run::lock::remove_stale_locks();
    println!("removed the files of {cleaned} dead run(s) and {locks} stale run lock(s)");
    0
}
