//! Which node of an orphaned run is the last one out.
//!
//! When the coupler dies, both nodes notice and stop at about the same time, and the last one
//! out must remove the run's shared memory. Asking iceoryx2 whether the other node is alive
//! is not enough: each can see the other still alive while both are on their way out, and then
//! neither tidies up (seen under load). So each node holds a shared `flock(2)` on one file of
//! the run for its whole life; on the way out it drops its own and tries an exclusive lock:
//! whoever gets it holds the only remaining claim, so at least one node (the later) succeeds.
//! Two that both succeed both tidy up, which is harmless. The kernel releases a killed node's
//! lock, so a SIGKILLed node never blocks the other.

use crate::transport::{RunId, SHM_ROOT};
use std::fs::File;
use std::os::fd::AsRawFd;
use std::path::PathBuf;

/// A node's claim on its run, held from start to exit.
pub struct Presence {
    _file: File,
}

fn path(id: &RunId) -> PathBuf {
    // Inside the run's file prefix, so that removing the run's files removes it too.
    PathBuf::from(SHM_ROOT).join(format!("{}nodes.lock", id.file_prefix()))
}

fn open(id: &RunId) -> Option<File> {
    std::fs::OpenOptions::new()
        .read(true)
        .write(true)
        .create(true)
        .truncate(false)
        .open(path(id))
        .ok()
}

fn flock(file: &File, op: i32) -> bool {
    // SAFETY: flock(2) on a descriptor we own.
    unsafe { libc::flock(file.as_raw_fd(), op) == 0 }
}

impl Presence {
    /// Claims a place in run `id` (None if the file cannot be made: the caller then falls
    /// back to asking iceoryx2).
    pub fn hold(id: &RunId) -> Option<Self> {
        let file = open(id)?;
        flock(&file, libc::LOCK_SH | libc::LOCK_NB).then_some(Self { _file: file })
    }

    /// Drops this node's claim; true when no other node of the run holds one.
    pub fn release_is_last(self, id: &RunId) -> bool {
        drop(self);
        open(id).is_some_and(|f| flock(&f, libc::LOCK_EX | libc::LOCK_NB))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_later_of_two_claims_is_the_last() {
        let id = RunId::parse(&format!("rwtest{:x}", std::process::id())).unwrap();
        let a = Presence::hold(&id).expect("claim a");
        let b = Presence::hold(&id).expect("claim b");
        assert!(!a.release_is_last(&id), "b still holds its claim");
        assert!(b.release_is_last(&id), "b is the last");
        let _ = std::fs::remove_file(path(&id));
    }
}
