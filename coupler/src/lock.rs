//! One coupler per run id: a lock file held for the whole run.
//!
//! The lock is `flock(2)` on `/dev/shm/rockwave.<run id>.lock` (beside the run's iceoryx2
//! files, outside their `<run id>_` prefix so that cleaning a run never removes it). The kernel
//! releases a `flock` when its holder dies, even by SIGKILL, so a dead coupler's id is free
//! again at once; the pid written into the file only names the holder in the message.

use shared::transport::{RunId, SHM_ROOT};
use std::fs::File;
use std::io::{Read, Seek, Write};
use std::os::fd::AsRawFd;
use std::path::PathBuf;

/// Held while a coupler uses a run id; dropping it frees the id.
pub struct RunLock {
    path: PathBuf,
    file: File,
}

impl RunLock {
    /// The lock file of run `id`.
    pub fn path(id: &RunId) -> PathBuf {
        PathBuf::from(SHM_ROOT).join(format!("rockwave.{id}.lock"))
    }

    /// Takes run `id` for this process, or says which live coupler has it.
    pub fn acquire(id: &RunId) -> Result<RunLock, String> {
        let path = Self::path(id);
        loop {
            let mut file = std::fs::OpenOptions::new()
                .read(true)
                .write(true)
                .create(true)
                .truncate(false)
                .open(&path)
                .map_err(|e| format!("cannot open the run lock '{}': {e}", path.display()))?;
            // SAFETY: flock(2) on a descriptor we own.
            if unsafe { libc::flock(file.as_raw_fd(), libc::LOCK_EX | libc::LOCK_NB) } != 0 {
                let mut holder = String::new();
                let _ = file.read_to_string(&mut holder);
                let holder = holder.trim();
                return Err(format!(
                    "run id {id} is in use by a live coupler{}; a second run with the same id would \
                     stop it and remove its files. Fix: choose another --run-id (or none, for a fresh \
                     one), or wait for that run to end",
                    if holder.is_empty() {
                        String::new()
                    } else {
                        format!(" (pid {holder})")
                    }
                ));
            }
            // The previous holder may have removed the file between our open and our lock:
            // then we hold a lock on a file nobody else can find. Take the one at the path.
            use std::os::unix::fs::MetadataExt;
            let same = match (file.metadata(), std::fs::metadata(&path)) {
                (Ok(a), Ok(b)) => a.ino() == b.ino() && a.dev() == b.dev(),
                _ => false,
            };
            if !same {
                continue;
            }
            file.set_len(0)
                .and_then(|_| file.rewind())
                .and_then(|_| writeln!(file, "{}", std::process::id()))
                .map_err(|e| format!("cannot write the run lock '{}': {e}", path.display()))?;
            return Ok(RunLock { path, file });
        }
    }
}

/// Removes the lock files of couplers that died without removing theirs (SIGKILL): a free lock
/// is taken and dropped, which removes it; a held one is left alone. Returns how many went.
pub fn remove_stale_locks() -> usize {
    let Ok(entries) = std::fs::read_dir(SHM_ROOT) else {
        return 0;
    };
    let mut removed = 0;
    for e in entries.flatten() {
        let name = e.file_name().to_string_lossy().to_string();
        let Some(id) = name
            .strip_prefix("rockwave.")
            .and_then(|n| n.strip_suffix(".lock"))
            .and_then(|n| RunId::parse(n).ok())
        else {
            continue;
        };
        if RunLock::acquire(&id).is_ok() {
            removed += 1;
        }
    }
    removed
}

impl Drop for RunLock {
    fn drop(&mut self) {
        // Removed while still locked, so nobody can take the old file after us.
        let _ = std::fs::remove_file(&self.path);
        let _ = &self.file;
    }
}
