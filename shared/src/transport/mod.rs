//! How the three processes of a run talk: the transport seam, and the run's identity.
//!
//! The node runtime and the coupler talk through the traits here and nothing else: an
//! [`Outbox`] and an [`Inbox`] per channel (one typed message, or a typed header with a slice
//! of elements), a [`Bell`] to wake the receiver after sending, and a [`Waiter`] to block on
//! (with a timeout) until something arrived. A [`Transport`] opens them; two implement it:
//!
//! - [`iceoryx::Run`] (the default): iceoryx2 shared memory on one host. Senders loan memory
//!   and the solver writes straight into it; receivers read in place. Zero copies.
//! - [`zenoh::ZenohRun`] (`--transport zenoh`): zenoh over TCP, so that nodes can run on other
//!   hosts. The same `#[repr(C)]` messages travel as their bytes (see [`crate::protocol`]).
//!
//! The traits hand the message to a closure instead of returning it: iceoryx2's samples borrow
//! shared memory, and the closure is how a solver writes into (or reads from) it in place.
//!
//! Every resource of a run carries the run's id: in iceoryx2's service names and file prefix,
//! in zenoh's key expressions (`rockwave/<id>/...`). Two runs never see each other, and a
//! run's leftovers (after a node was killed) can be found and removed by prefix.

pub mod iceoryx;
mod seam;
pub mod zenoh;

pub use iceoryx::{Ipc, Pub, Run, Sub, wait};
pub use seam::{
    Bell, Endpoints, Inbox, Kind, Outbox, Party, RunId, Transport, TransportError, Waiter, Wake,
    Wire, process_alive,
};

use iceoryx2::prelude::*;
use std::path::{Path, PathBuf};
use std::time::Duration;

/// Where iceoryx2 keeps its non-shared-memory files (node monitors, service descriptions).
pub const ICEORYX2_ROOT: &str = "/tmp/iceoryx2";
/// Where iceoryx2 keeps its shared-memory segments.
pub const SHM_ROOT: &str = "/dev/shm";

/// Joins run `id` as `party` (named `name` for iceoryx2) over the transport `kind`.
pub fn join(
    kind: Kind,
    id: &RunId,
    party: Party,
    name: &str,
    endpoints: &Endpoints,
    connect_timeout: Duration,
) -> Result<Box<dyn Transport>, TransportError> {
    match kind {
        Kind::Iceoryx2 => Ok(Box::new(Run::join(id, name)?)),
        Kind::Zenoh => Ok(Box::new(zenoh::ZenohRun::join(
            id,
            party,
            endpoints,
            connect_timeout,
        )?)),
    }
}

/// Removes every file of run `id` that iceoryx2 left behind. Call only when no process of the
/// run is alive any more (the coupler does, after its nodes exited; a node does when it finds
/// the coupler dead). Every file of the run carries its prefix, so removing by prefix is
/// complete; iceoryx2's stale-resource clean-up is not used, because it opens each dead port's
/// shared memory first and hangs on a zero-length one (see [`RunId::config`]). Returns the
/// number of files removed.
pub fn remove_run_files(id: &RunId) -> usize {
    let prefix = id.file_prefix();
    let mut removed = 0;
    for root in [Path::new(SHM_ROOT), Path::new(ICEORYX2_ROOT)] {
        removed += remove_prefixed(root, &prefix, 0);
    }
    removed
}

fn remove_prefixed(dir: &Path, prefix: &str, depth: usize) -> usize {
    let Ok(entries) = std::fs::read_dir(dir) else {
        return 0;
    };
    let mut removed = 0;
    for entry in entries.flatten() {
        let path = entry.path();
        let name = entry.file_name();
        let name = name.to_string_lossy();
        let is_dir = entry.file_type().is_ok_and(|t| t.is_dir());
        if name.starts_with(prefix) {
            let ok = if is_dir {
                std::fs::remove_dir_all(&path)
            } else {
                std::fs::remove_file(&path)
            };
            removed += ok.is_ok() as usize;
        } else if is_dir && depth < 3 {
            let inner = remove_prefixed(&path, prefix, depth + 1);
            removed += inner;
            // A node's folder that held only this run's files is this run's too. A folder
            // that was empty already may be another run's node being created: leave it.
            if inner > 0
                && depth > 0
                && std::fs::read_dir(&path).is_ok_and(|mut d| d.next().is_none())
            {
                let _ = std::fs::remove_dir(&path);
            }
        }
    }
    removed
}

/// Run ids that have files in /dev/shm, with the age of their newest file.
pub fn runs_with_files() -> Vec<(RunId, Duration)> {
    let mut found: Vec<(RunId, Duration)> = Vec::new();
    let Ok(entries) = std::fs::read_dir(SHM_ROOT) else {
        return found;
    };
    for entry in entries.flatten() {
        let name = entry.file_name().to_string_lossy().to_string();
        let Some((id, _)) = name.split_once('_') else {
            continue;
        };
        let Ok(id) = RunId::parse(id) else { continue };
        if !id.as_str().starts_with("rw") {
            continue;
        }
        let age = entry
            .metadata()
            .and_then(|m| m.modified())
            .ok()
            .and_then(|t| t.elapsed().ok())
            .unwrap_or_default();
        match found.iter_mut().find(|(r, _)| *r == id) {
            Some((_, a)) => *a = (*a).min(age),
            None => found.push((id, age)),
        }
    }
    found
}

/// Is any iceoryx2 node of run `id` still alive?
pub fn run_has_live_nodes(id: &RunId) -> bool {
    let mut alive = false;
    let _ = Node::<Ipc>::list(&id.config(), |state| {
        alive |= matches!(state, NodeState::Alive(_));
        CallbackProgression::Continue
    });
    alive
}

/// Removes the files of runs whose processes all died (a coupler killed with SIGKILL leaves
/// them). Runs younger than `min_age` are left alone: their nodes may still be starting.
pub fn remove_stale_runs(min_age: Duration) -> Vec<RunId> {
    let mut cleaned = Vec::new();
    for (id, age) in runs_with_files() {
        if age >= min_age && !run_has_live_nodes(&id) {
            remove_run_files(&id);
            cleaned.push(id);
        }
    }
    cleaned
}

/// The files of run `id` still present (for tests and `coupler clean --dry-run`).
pub fn run_files(id: &RunId) -> Vec<PathBuf> {
    fn walk(dir: &Path, prefix: &str, out: &mut Vec<PathBuf>, depth: usize) {
        let Ok(entries) = std::fs::read_dir(dir) else {
            return;
        };
        for e in entries.flatten() {
            let p = e.path();
            if e.file_name().to_string_lossy().starts_with(prefix) {
                out.push(p);
            } else if depth < 3 && e.file_type().is_ok_and(|t| t.is_dir()) {
                walk(&p, prefix, out, depth + 1);
            }
        }
    }
    let mut out = Vec::new();
    for root in [SHM_ROOT, ICEORYX2_ROOT] {
        walk(Path::new(root), &id.file_prefix(), &mut out, 0);
    }
    out
}
