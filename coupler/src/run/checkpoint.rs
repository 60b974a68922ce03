//! The coupler's checkpoints: its own state, and putting a run directory back to one.
//!
//! A checkpoint after step k is three files in `<run>/checkpoints/`: each node's
//! (`fluid-k.ckpt`, `solid-k.ckpt`, written by the node itself when asked, see
//! `shared::checkpoint`) and then the coupler's (`coupler-k.ckpt`, [`CouplerCheckpoint`]),
//! written only after both nodes confirmed theirs: a coupler file makes the checkpoint
//! complete. Older checkpoints are removed once a newer one is complete.
//!
//! Rolling a run directory back to a checkpoint ([`rollback`]) cuts the CSV files the nodes
//! append to back to their recorded lengths, removes the frames written after it and rewrites
//! the .pvd series from the recorded entries, so that the continued run writes exactly what an
//! uninterrupted one would have.

use crate::run::stats::RunStats;
use shared::checkpoint as files;
use std::path::{Path, PathBuf};

/// The time series the nodes append to: cut back on resume.
pub const SERIES: [&str; 3] = ["gauges.csv", "probes.csv", "blocks.csv"];

/// What the coupler needs to continue a run after `step` steps.
#[derive(Debug, Clone, serde::Serialize, serde::Deserialize)]
pub struct CouplerCheckpoint {
    /// `shared::checkpoint::scene_hash` of the scene as run (its `scene.toml`).
    pub scene_hash: u64,
    /// The solvers the nodes ran and the coupling scheme: a resumed run uses the same.
    pub fluid_solver: Option<String>,
    pub solid_solver: Option<String>,
    pub scheme: shared::scene::CouplingScheme,
    /// `--dt-factor` of the run (it changes every grant).
    pub dt_factor: f64,
    /// Steps taken and the time reached (the time the step grant continues from).
    pub step: u64,
    pub time: f64,
    /// The next frame's number and the next output time.
    pub frame: u32,
    pub next_output: f64,
    /// The next simulated time a checkpoint is due.
    pub next_checkpoint: Option<f64>,
    /// The run's statistics so far (steps, dt range, frames, compute seconds, warnings).
    pub stats: RunStats,
    /// The .pvd series' entries (time, file).
    pub particles: Vec<(f64, String)>,
    pub blocks: Vec<(f64, String)>,
    /// Length in bytes of each of [`SERIES`] that exists.
    pub series: Vec<(String, u64)>,
}

impl CouplerCheckpoint {
    /// Writes this checkpoint's coupler file (atomically) and removes every older checkpoint
    /// file.
    pub fn write(&self, run_dir: &Path) -> Result<(), String> {
        files::write_file(&files::coupler_file(run_dir, self.step), self)?;
        prune(run_dir, self.step);
        Ok(())
    }
}

/// The lengths of the run's time series now, each synced to disk first (the nodes flushed
/// them before answering the checkpoint command).
pub fn series_lengths(run_dir: &Path) -> Result<Vec<(String, u64)>, String> {
    let mut out = Vec::new();
    for name in SERIES {
        let path = run_dir.join(name);
        let Ok(f) = std::fs::File::open(&path) else {
            continue;
        };
        let len = f
            .sync_all()
            .and_then(|_| f.metadata())
            .map_err(|e| format!("cannot sync '{}': {e}", path.display()))?
            .len();
        out.push((name.to_string(), len));
    }
    Ok(out)
}

/// The step of a checkpoint file `<who>-<step>.ckpt`.
fn step_of(name: &str, who: &str) -> Option<u64> {
    name.strip_prefix(who)?
        .strip_prefix('-')?
        .strip_suffix(".ckpt")?
        .parse()
        .ok()
}

/// Removes every checkpoint file of a step other than `keep` (and leftovers of interrupted
/// writes).
fn prune(run_dir: &Path, keep: u64) {
    let Ok(entries) = std::fs::read_dir(files::dir(run_dir)) else {
        return;
    };
    for e in entries.flatten() {
        let name = e.file_name().to_string_lossy().into_owned();
        let step = ["coupler", "fluid", "solid"]
            .iter()
            .find_map(|who| step_of(&name, who));
        if step.is_some_and(|s| s != keep) || name.ends_with(".partial") {
            let _ = std::fs::remove_file(e.path());
        }
    }
}

/// The last complete checkpoint of a run directory (the newest coupler file), if any.
pub fn latest(run_dir: &Path) -> Result<Option<CouplerCheckpoint>, String> {
    let Ok(entries) = std::fs::read_dir(files::dir(run_dir)) else {
        return Ok(None);
    };
    let newest = entries
        .flatten()
        .filter_map(|e| step_of(&e.file_name().to_string_lossy(), "coupler"))
        .max();
    match newest {
        Some(step) => files::read_file(&files::coupler_file(run_dir, step)).map(Some),
        None => Ok(None),
    }
}

/// A frame file a node writes (`particles_NNNNN.vtp`, `blocks_NNNNN.vtp`), and its number.
fn frame_of(name: &str) -> Option<u32> {
    let rest = name
        .strip_prefix("particles_")
        .or_else(|| name.strip_prefix("blocks_"))?;
    let number = rest
        .strip_suffix(".vtp")
        .or_else(|| rest.strip_suffix(".vtp.partial"))?;
    (number.len() == 5).then(|| number.parse().ok()).flatten()
}

/// Removes the frames numbered `from` and later (`keep_static`: blocks_00000.vtp stands for
/// every frame of a scene without moving blocks and stays).
fn remove_frames(run_dir: &Path, from: u32) -> Result<(), String> {
    let entries = std::fs::read_dir(run_dir)
        .map_err(|e| format!("cannot read the run directory '{}': {e}", run_dir.display()))?;
    for e in entries.flatten() {
        let name = e.file_name().to_string_lossy().into_owned();
        if frame_of(&name).is_some_and(|n| n >= from) {
            std::fs::remove_file(e.path())
                .map_err(|err| format!("cannot remove '{}': {err}", e.path().display()))?;
        }
    }
    Ok(())
}

/// Cuts the time series back to `series` (each must be at least that long: it was synced at
/// the checkpoint).
fn cut_series(run_dir: &Path, series: &[(String, u64)]) -> Result<(), String> {
    for (name, len) in series {
        let path: PathBuf = run_dir.join(name);
        let f = std::fs::OpenOptions::new()
            .write(true)
            .open(&path)
            .map_err(|e| {
                format!(
                    "cannot open '{}' to continue it: {e}. Fix: the run directory lost a file the checkpoint needs; start the run again",
                    path.display()
                )
            })?;
        let have = f.metadata().map(|m| m.len()).unwrap_or(0);
        if have < *len {
            return Err(format!(
                "'{}' holds {have} bytes, fewer than the {len} it had at the checkpoint: the file was cut or replaced. Fix: start the run again",
                path.display()
            ));
        }
        f.set_len(*len)
            .and_then(|_| f.sync_all())
            .map_err(|e| format!("cannot cut '{}' back: {e}", path.display()))?;
    }
    Ok(())
}

/// Puts the run directory back to checkpoint `ck`: series cut back, later frames removed.
/// (The .pvd files are rewritten by `RunDir::restore`.)
pub fn rollback(run_dir: &Path, ck: &CouplerCheckpoint) -> Result<(), String> {
    cut_series(run_dir, &ck.series)?;
    remove_frames(run_dir, ck.frame)
}

/// Puts the run directory back to its start, for a restart without a checkpoint: every frame
/// the nodes wrote goes (the restarted nodes write their time series afresh).
pub fn rollback_to_start(run_dir: &Path, static_blocks: bool) -> Result<(), String> {
    let entries = std::fs::read_dir(run_dir)
        .map_err(|e| format!("cannot read the run directory '{}': {e}", run_dir.display()))?;
    for e in entries.flatten() {
        let name = e.file_name().to_string_lossy().into_owned();
        let keep = static_blocks && name == "blocks_00000.vtp";
        if frame_of(&name).is_some() && !keep {
            std::fs::remove_file(e.path())
                .map_err(|err| format!("cannot remove '{}': {err}", e.path().display()))?;
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_are_parsed() {
        assert_eq!(step_of("coupler-0000000042.ckpt", "coupler"), Some(42));
        assert_eq!(step_of("fluid-0000000042.ckpt", "coupler"), None);
        assert_eq!(frame_of("particles_00012.vtp"), Some(12));
        assert_eq!(frame_of("blocks_00003.vtp.partial"), Some(3));
        assert_eq!(frame_of("blocks.pvd"), None);
        assert_eq!(frame_of("particles_1.vtp"), None);
    }
}
