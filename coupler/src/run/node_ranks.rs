//! Whether the fluid node's binary can run as the ranks a run asks for, asked before anything
//! is written (`fluid-node --ranks-support`, [`fluid_node::ranks::probe`]). A node built
//! without MPI refused only once the launcher had started it: after the run directory was
//! made, and after a `--resume` had cut the run's frames and tables back to its checkpoint.

use crate::run::launch::NodeCommand;
use std::io::Read;
use std::path::Path;
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

/// How long a node may take to answer: the built-in one answers before it reads anything; a
/// program that hangs on the question is taken for one that does not know it.
const ANSWER_TIMEOUT: Duration = Duration::from_secs(5);

/// `program arg`'s standard output if it exits within `limit`; `None` if it cannot be started
/// or takes longer (it is killed).
pub fn answer_within(
    program: &Path,
    arg: &str,
    env: &[(String, String)],
    limit: Duration,
) -> Option<String> {
    let mut child = Command::new(program)
        .arg(arg)
        .envs(env.iter().map(|(k, v)| (k, v)))
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::null())
        .spawn()
        .ok()?;
    let started = Instant::now();
    loop {
        match child.try_wait() {
            Ok(Some(_)) => break,
            Ok(None) if started.elapsed() < limit => {
                // No exit event for a child in std; the answer takes milliseconds.
                std::thread::sleep(Duration::from_millis(5))
            }
            _ => {
                let _ = child.kill();
                let _ = child.wait();
                return None;
            }
        }
    }
    let mut said = String::new();
    child.stdout.take()?.read_to_string(&mut said).ok()?;
    Some(said)
}

/// What asked for `ranks` fluid ranks, as the refusals name it: `--fluid-ranks N` (`flag`),
/// else the scene's `[fluid] ranks = N`.
pub fn asked(flag: Option<u32>, ranks: u32) -> String {
    match flag {
        Some(n) => format!("--fluid-ranks {n}"),
        None => format!("[fluid] ranks = {ranks}"),
    }
}

/// Refuses `ranks` fluid ranks (asked by `asked`, e.g. `--fluid-ranks 2`) when the node at
/// `program` says it cannot run as several; a node that gives no answer (one of one's own,
/// through `--fluid-cmd`) is let through, as before, and answers for itself when started.
pub fn refuse_without_mpi(
    node: &NodeCommand,
    program: &Path,
    ranks: u32,
    asked: &str,
) -> Result<(), String> {
    let flag = fluid_node::ranks::probe::FLAG;
    let said = answer_within(program, flag, &node.env, ANSWER_TIMEOUT);
    match said.as_deref().and_then(fluid_node::ranks::probe::read) {
        Some(Err(why)) => Err(format!(
            "{asked}: the fluid node '{}' cannot run as {ranks} MPI ranks: {why} (--fluid-ranks 1)",
            program.display()
        )),
        _ => Ok(()),
    }
}
