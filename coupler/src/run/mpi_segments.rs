//! The shared-memory segments an MPI library leaves in /dev/shm when a rank is killed: Open
//! MPI's `vader_segment.<host>.<job>.<rank>` (4.x) and `sm_segment.…` (5.x). A rank unlinks its
//! own segment as it ends; one killed by SIGKILL cannot, and the launcher does not. After a run
//! on ranks ends, the coupler removes the segments no live process maps, so a killed rank leaves
//! nothing behind (the run's own iceoryx2 files go by their prefix: `shared::transport`).
//!
//! The segments carry the MPI job's id, not the run's: a segment some process still maps
//! belongs to a live job (another run, another user's program) and is kept, and so is one made
//! in the last second, whose rank may be about to map it.

use std::collections::HashSet;
use std::path::{Path, PathBuf};
use std::time::{Duration, SystemTime};

/// Name prefixes of the MPI libraries' shared-memory segments.
const PREFIXES: [&str; 2] = ["vader_segment.", "sm_segment."];

/// A segment younger than this is kept (its rank may not have mapped it yet).
const MIN_AGE: Duration = Duration::from_secs(1);

/// Removes the MPI segments in /dev/shm that no live process maps; returns how many.
pub fn remove_orphans() -> usize {
    remove_orphans_in(Path::new("/dev/shm"), &mapped_files(), MIN_AGE)
}

/// The files some live process maps (from every `/proc/<pid>/maps` this user may read).
fn mapped_files() -> HashSet<PathBuf> {
    let mut mapped = HashSet::new();
    let Ok(procs) = std::fs::read_dir("/proc") else {
        return mapped;
    };
    for p in procs.flatten() {
        if !p
            .file_name()
            .to_string_lossy()
            .bytes()
            .all(|b| b.is_ascii_digit())
        {
            continue;
        }
        let Ok(maps) = std::fs::read_to_string(p.path().join("maps")) else {
            continue;
        };
        // The path is the sixth field and may hold spaces; a deleted file ends " (deleted)".
        for line in maps.lines() {
            if let Some(at) = line.find('/') {
                mapped.insert(PathBuf::from(line[at..].trim_end_matches(" (deleted)")));
            }
        }
    }
    mapped
}

/// [`remove_orphans`] in `dir`, with the mapped files and the age given (for the tests).
fn remove_orphans_in(dir: &Path, mapped: &HashSet<PathBuf>, min_age: Duration) -> usize {
    let Ok(entries) = std::fs::read_dir(dir) else {
        return 0;
    };
    let now = SystemTime::now();
    let mut removed = 0;
    for entry in entries.flatten() {
        let name = entry.file_name();
        let name = name.to_string_lossy();
        if !PREFIXES.iter().any(|p| name.starts_with(p)) {
            continue;
        }
        let path = entry.path();
        if mapped.contains(&path) {
            continue;
        }
        let age = entry
            .metadata()
            .and_then(|m| m.modified())
            .ok()
            .and_then(|t| now.duration_since(t).ok());
        if age.is_some_and(|a| a >= min_age) && std::fs::remove_file(&path).is_ok() {
            removed += 1;
        }
    }
    removed
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn only_unmapped_segments_of_an_mpi_library_go() {
        let dir = tempfile::tempdir().unwrap();
        let touch = |name: &str| {
            let path = dir.path().join(name);
            std::fs::write(&path, b"x").unwrap();
            path
        };
        let orphan = touch("vader_segment.host.1f2e0001.1");
        let orphan5 = touch("sm_segment.host.1000.0");
        let live = touch("vader_segment.host.2a3b0001.0");
        let other = touch("rw0123456789ab_node.lock");
        let mapped = HashSet::from([live.clone()]);
        assert_eq!(remove_orphans_in(dir.path(), &mapped, Duration::ZERO), 2);
        assert!(!orphan.exists() && !orphan5.exists());
        assert!(live.exists(), "a segment a process maps is kept");
        assert!(
            other.exists(),
            "only the MPI libraries' segments are touched"
        );
        // Too young: kept.
        let young = touch("vader_segment.host.3c4d0001.0");
        assert_eq!(remove_orphans_in(dir.path(), &mapped, MIN_AGE), 0);
        assert!(young.exists());
    }

    #[test]
    fn a_file_this_process_maps_is_seen_as_mapped() {
        // The coupler's own binary is mapped by this test process.
        let me = std::env::current_exe().unwrap();
        assert!(mapped_files().contains(&me), "{me:?}");
    }
}
