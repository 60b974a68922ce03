//! One coupler per run id and per run directory: lock files held for the whole run.
//!
//! The run id's lock is `flock(2)` on `/dev/shm/rockwave.<run id>.lock` (beside the run's
//! iceoryx2 files, outside their `<run id>_` prefix so that cleaning a run never removes it).
//! The run directory's is `flock(2)` on `<run dir>/coupler.lock` ([`DIR_LOCK`]), taken by a new
//! run once its directory exists and by `--resume` before it reads anything there: two
//! couplers writing one directory (two resumes of it, or a resume of a run still going) would
//! cut each other's files back. The kernel releases a `flock` when its holder dies, even by
//! SIGKILL, so a dead coupler's id or directory is free again at once; the pid written into the
//! file only names the holder in the message.

use shared::transport::{RunId, SHM_ROOT};
use std::fs::File;
use std::io::{Read, Seek, Write};
use std::os::fd::AsRawFd;
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

/// The lock file's name in a run directory (removed when its run ends; one left by a killed
/// coupler is free and taken again by the next).
pub const DIR_LOCK: &str = "coupler.lock";

/// How long a lock held by no live, named process is waited for before the id is refused.
const BUSY_GRACE: Duration = Duration::from_secs(1);

/// Held while a coupler uses a run id; dropping it frees the id.
pub struct RunLock {
    path: PathBuf,
    file: File,
    /// What the file said before this coupler took it: a dead coupler's pid and, in a run
    /// directory, the run id it ran ([`Self::name_run`]).
    previous: String,
}

impl RunLock {
    /// The lock file of run `id`.
    pub fn path(id: &RunId) -> PathBuf {
        PathBuf::from(SHM_ROOT).join(format!("rockwave.{id}.lock"))
    }

    /// Takes run `id` for this process, or says which live coupler has it.
    pub fn acquire(id: &RunId) -> Result<RunLock, String> {
        Self::take(Self::path(id), |holder| {
            format!(
                "run id {id} is in use by a live coupler{holder}; a second run with the same id would \
                 stop it and remove its files. Fix: choose another --run-id (or none, for a fresh \
                 one), or wait for that run to end"
            )
        })
    }

    /// Takes run directory `run_dir` (which must exist) for this process, or says which live
    /// coupler has it.
    pub fn directory(run_dir: &Path) -> Result<RunLock, String> {
        Self::take(run_dir.join(DIR_LOCK), |holder| {
            format!(
                "the run directory '{}' is in use by a live coupler{holder}: two runs writing one \
                 directory would cut each other's files. Fix: wait for that run to end (or stop it), \
                 then resume it once",
                run_dir.display()
            )
        })
    }

    /// Takes the lock at `path`; `busy` says who holds it (" (pid N)" or nothing) in the error.
    fn take(path: PathBuf, busy: impl Fn(&str) -> String) -> Result<RunLock, String> {
        let mut busy_since = None;
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
                // A holder that names no live process is a sweep testing the lock (it holds it
                // for microseconds) or a coupler between taking it and writing its pid; ask
                // again shortly rather than refuse a free id. A live holder is refused at once.
                let pid = holder.lines().next().unwrap_or_default();
                let live = pid
                    .parse::<u32>()
                    .is_ok_and(shared::transport::process_alive);
                if !live && busy_since.get_or_insert_with(Instant::now).elapsed() < BUSY_GRACE {
                    std::thread::sleep(Duration::from_millis(5));
                    continue;
                }
                return Err(busy(&if pid.is_empty() {
                    String::new()
                } else {
                    format!(" (pid {pid})")
                }));
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
            let mut previous = String::new();
            let _ = file.read_to_string(&mut previous);
            let mut lock = RunLock {
                path,
                file,
                previous,
            };
            lock.write(&std::process::id().to_string())?;
            return Ok(lock);
        }
    }
}

impl RunLock {
    /// Replaces the file's text with `text` (a line).
    fn write(&mut self, text: &str) -> Result<(), String> {
        self.file
            .set_len(0)
            .and_then(|_| self.file.rewind())
            .and_then(|_| writeln!(self.file, "{text}"))
            .map_err(|e| format!("cannot write the run lock '{}': {e}", self.path.display()))
    }

    /// Notes the run id this coupler runs in its directory's lock, under its pid: a coupler
    /// that takes the directory after this one dies knows whose files to remove.
    pub fn name_run(&mut self, id: &RunId) -> Result<(), String> {
        self.write(&format!("{}\n{id}", std::process::id()))
    }

    /// The run id the directory's previous coupler noted ([`Self::name_run`]), if it died
    /// holding the lock (a coupler that ends removes the file).
    pub fn previous_run(&self) -> Option<RunId> {
        RunId::parse(self.previous.lines().nth(1)?.trim()).ok()
    }
}

/// Removes the lock files of couplers that died without removing theirs (SIGKILL): a lock whose
/// file names a dead process is taken and dropped, which removes it. A file naming a live
/// process, or a new one naming none (a coupler that has just made it and not yet written its
/// pid), is not touched: taking it even for a moment would make that coupler's `acquire` wait.
/// Returns how many went.
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
        let holder = std::fs::read_to_string(e.path()).unwrap_or_default();
        let stale = match holder.trim().parse::<u32>() {
            Ok(pid) => !shared::transport::process_alive(pid),
            // Named nobody for a minute: its coupler died before writing its pid.
            Err(_) => e
                .metadata()
                .and_then(|m| m.modified())
                .is_ok_and(|t| t.elapsed().unwrap_or_default() > Duration::from_secs(60)),
        };
        if !stale {
            continue;
        }
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

#[cfg(test)]
mod tests {
    use super::*;

    /// Takes run `id`'s lock as a sweep does: a file naming no process, locked for `held`.
    fn held_by_a_sweep(id: &RunId, held: Duration) -> std::thread::JoinHandle<()> {
        let file = File::create(RunLock::path(id)).unwrap();
        // SAFETY: flock(2) on a descriptor we own.
        assert_eq!(unsafe { libc::flock(file.as_raw_fd(), libc::LOCK_EX) }, 0);
        std::thread::spawn(move || {
            std::thread::sleep(held);
            drop(file);
        })
    }

    /// CI saw a coupler refuse its own fresh id: another run's sweep held that lock for a moment.
    #[test]
    fn a_coupler_waits_out_a_sweep_holding_its_id() {
        let id = RunId::fresh();
        let sweep = held_by_a_sweep(&id, Duration::from_millis(50));
        let lock = RunLock::acquire(&id).expect("an id held only by a sweep is taken");
        sweep.join().unwrap();
        drop(lock);
        // A lock held longer than the grace by no live process is still refused, by name.
        let id = RunId::fresh();
        let sweep = held_by_a_sweep(&id, BUSY_GRACE + Duration::from_millis(500));
        let err = RunLock::acquire(&id)
            .err()
            .expect("refused after the grace");
        assert!(err.contains("in use by a live coupler"), "{err}");
        sweep.join().unwrap();
        let _ = std::fs::remove_file(RunLock::path(&id));
    }

    /// The sweep leaves alone a lock file that names nobody yet: its coupler is between making
    /// the file and writing its pid.
    #[test]
    fn a_sweep_leaves_a_lock_file_being_made() {
        let id = RunId::fresh();
        File::create(RunLock::path(&id)).unwrap();
        remove_stale_locks();
        assert!(RunLock::path(&id).exists(), "a lock being made was swept");
        std::fs::remove_file(RunLock::path(&id)).unwrap();
    }

    /// Two couplers on one run directory (two `--resume` of it at once): the second is refused
    /// at once, naming the directory and the holder's pid; the directory is free again once the
    /// first ends.
    #[test]
    fn a_run_directory_is_taken_by_one_coupler_at_a_time() {
        let dir = tempfile::tempdir().unwrap();
        let first = RunLock::directory(dir.path()).unwrap();
        let started = Instant::now();
        let err = RunLock::directory(dir.path())
            .err()
            .expect("a second coupler on the directory is refused");
        assert!(started.elapsed() < BUSY_GRACE, "refused at once");
        assert!(
            err.contains(&format!("'{}'", dir.path().display()))
                && err.contains(&format!("pid {}", std::process::id()))
                && err.contains("Fix:"),
            "{err}"
        );
        drop(first);
        assert!(!dir.path().join(DIR_LOCK).exists(), "its file goes with it");
        drop(RunLock::directory(dir.path()).expect("free again"));
        let gone = dir.path().join("none");
        let err = RunLock::directory(&gone).err().unwrap();
        assert!(err.contains("none"), "{err}");
    }

    /// A coupler notes its run id in its directory's lock; the coupler that takes the
    /// directory after it died (a resume) reads it.
    #[test]
    fn the_next_coupler_of_a_directory_learns_the_dead_one_s_run() {
        let dir = tempfile::tempdir().unwrap();
        let id = RunId::fresh();
        let mut lock = RunLock::directory(dir.path()).unwrap();
        assert_eq!(lock.previous_run(), None, "a new directory");
        lock.name_run(&id).unwrap();
        let text = std::fs::read_to_string(dir.path().join(DIR_LOCK)).unwrap();
        assert_eq!(text, format!("{}\n{id}\n", std::process::id()));
        let err = RunLock::directory(dir.path()).err().unwrap();
        assert!(
            err.contains(&format!("(pid {})", std::process::id())),
            "{err}"
        );
        drop(lock);
        // A coupler killed by SIGKILL leaves its file (the kernel drops its flock).
        std::fs::write(dir.path().join(DIR_LOCK), format!("999999999\n{id}\n")).unwrap();
        let next = RunLock::directory(dir.path()).unwrap();
        assert_eq!(next.previous_run(), Some(id));
    }

    #[test]
    fn a_dead_couplers_lock_is_swept_and_a_live_ones_is_kept() {
        let (dead, live) = (RunId::fresh(), RunId::fresh());
        // No process has pid 0x7fff_fff0 (above Linux's pid_max of 2^22).
        std::fs::write(RunLock::path(&dead), "2147483632\n").unwrap();
        let held = RunLock::acquire(&live).unwrap();
        remove_stale_locks();
        assert!(
            !RunLock::path(&dead).exists(),
            "the dead coupler's lock stays"
        );
        assert!(
            RunLock::path(&live).exists(),
            "a live coupler's lock was removed"
        );
        let err = RunLock::acquire(&live).err().expect("a held id is refused");
        assert!(
            err.contains(&format!("pid {}", std::process::id())),
            "{err}"
        );
        drop(held);
        assert!(!RunLock::path(&live).exists());
    }
}
