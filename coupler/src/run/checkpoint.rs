//! The coupler's checkpoints: its own state, and putting a run directory back to one.
//!
//! A checkpoint after step k is three files in `<run>/checkpoints/`: each node's
//! (`fluid-k.ckpt`, `solid-k.ckpt`, written by the node itself when asked, see
//! `shared::checkpoint`) and then the coupler's (`coupler-k.ckpt`, [`CouplerCheckpoint`]),
//! written only after both nodes confirmed theirs: a coupler file makes the checkpoint
//! complete. The last [`KEPT`] complete checkpoints are kept; older ones are removed once a
//! newer one is complete.
//!
//! Every file is checked before a run continues from it ([`latest`]): its checksum, length,
//! owner and step (`shared::checkpoint`), the node files of the roles the run needs included,
//! so that a damaged, cut, renamed or missing file is refused by name before anything of the run
//! directory is cut back. A damaged last checkpoint is not skipped silently: the error names the
//! file and how to fall back to the one before it (delete the damaged step's files).
//!
//! Rolling a run directory back to a checkpoint ([`rollback`]) cuts the CSV files the nodes
//! append to back to their recorded lengths, removes the frames written after it and rewrites
//! the .pvd series from the recorded entries, so that the continued run writes exactly what an
//! uninterrupted one would have.

use crate::run::session::Session;
use crate::run::stats::RunStats;
use shared::checkpoint as files;
use shared::scene::Scene;
use std::path::{Path, PathBuf};

/// How many complete checkpoints a run directory keeps: the last one and the one before it, so
/// that a last checkpoint damaged on the disk (or cut by a crash of the disk itself) still
/// leaves one to resume from, at the cost of twice the disk.
pub const KEPT: usize = 2;

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
    /// Writes this checkpoint's coupler file (atomically; the error names it), which makes it
    /// complete, and removes the files of every checkpoint but the last [`KEPT`] complete ones.
    pub fn write(&self, run_dir: &Path) -> Result<(), String> {
        files::write_file(
            &files::coupler_file(run_dir, self.step),
            COUPLER,
            self.step,
            self,
        )?;
        prune(run_dir);
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

/// The owner name of the coupler's checkpoint files.
const COUPLER: &str = "coupler";
/// Every owner of checkpoint files.
const OWNERS: [&str; 3] = [COUPLER, "fluid", "solid"];

/// The steps of the complete checkpoints in a run directory (those with a coupler file),
/// newest first.
fn complete_steps(run_dir: &Path) -> Vec<u64> {
    let Ok(entries) = std::fs::read_dir(files::dir(run_dir)) else {
        return Vec::new();
    };
    let mut steps: Vec<u64> = entries
        .flatten()
        .filter_map(|e| step_of(&e.file_name().to_string_lossy(), COUPLER))
        .collect();
    steps.sort_unstable_by(|a, b| b.cmp(a));
    steps
}

/// Removes the files of every step but the last [`KEPT`] complete checkpoints' (older
/// checkpoints, node files of a checkpoint that never completed) and leftovers of interrupted
/// writes.
fn prune(run_dir: &Path) {
    let keep: Vec<u64> = complete_steps(run_dir).into_iter().take(KEPT).collect();
    let Ok(entries) = std::fs::read_dir(files::dir(run_dir)) else {
        return;
    };
    for e in entries.flatten() {
        let name = e.file_name().to_string_lossy().into_owned();
        let step = OWNERS.iter().find_map(|who| step_of(&name, who));
        if step.is_some_and(|s| !keep.contains(&s)) || name.ends_with(".partial") {
            let _ = std::fs::remove_file(e.path());
        }
    }
}

/// The last complete checkpoint of a run directory (the newest coupler file), if any, with the
/// files of the nodes `scene` runs checked whole. A file that is damaged, cut, renamed or
/// missing is refused by name, with the checkpoint to fall back to.
pub fn latest(run_dir: &Path, scene: &Scene) -> Result<Option<CouplerCheckpoint>, String> {
    let roles: Vec<&str> = Session::roles(scene)
        .into_iter()
        .map(|r| r.name())
        .collect();
    let steps = complete_steps(run_dir);
    let Some(&step) = steps.first() else {
        return Ok(None);
    };
    checked(run_dir, step, &roles).map(Some).map_err(|e| {
        let fix = match steps.get(1) {
            Some(before) => format!(
                "{}to continue from the checkpoint before it (step {before}), delete this step's files: rm {}",
                if e.lost {
                    String::new()
                } else {
                    format!("{}; or, ", e.fix)
                },
                step_files(run_dir, step).join(" ")
            ),
            None => format!(
                "{} (no earlier checkpoint is kept to fall back to)",
                e.fix
            ),
        };
        format!(
            "the last checkpoint (step {step}) cannot be used: {}. Fix: {fix}",
            e.problem
        )
    })
}

/// Checkpoint `step`'s coupler file, read (first: the file that makes the checkpoint), once
/// every node file `roles` needs is checked too.
fn checked(run_dir: &Path, step: u64, roles: &[&str]) -> Result<CouplerCheckpoint, files::Refused> {
    let ck = files::read_file(&files::coupler_file(run_dir, step), COUPLER, step)?;
    for role in roles {
        files::verify_file(&files::node_file(run_dir, role, step), role, step)?;
    }
    Ok(ck)
}

/// The files of checkpoint `step` in a run directory, for a message.
fn step_files(run_dir: &Path, step: u64) -> Vec<String> {
    OWNERS
        .iter()
        .map(|who| match *who {
            COUPLER => files::coupler_file(run_dir, step),
            role => files::node_file(run_dir, role, step),
        })
        .filter(|p| p.exists())
        .map(|p| p.display().to_string())
        .collect()
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

    /// A complete checkpoint after `step` steps in `run_dir`: the coupler's file and both
    /// nodes' (their payload is not the coupler's business: any value).
    fn complete(run_dir: &Path, step: u64) {
        std::fs::create_dir_all(files::dir(run_dir)).unwrap();
        for role in ["fluid", "solid"] {
            let path = files::node_file(run_dir, role, step);
            files::write_file(&path, role, step, &vec![step as f64; 64]).unwrap();
        }
        let ck = CouplerCheckpoint {
            scene_hash: 7,
            fluid_solver: None,
            solid_solver: None,
            scheme: Default::default(),
            dt_factor: 1.0,
            step,
            time: step as f64 * 1e-3,
            frame: 0,
            next_output: 0.0,
            next_checkpoint: None,
            stats: RunStats::default(),
            particles: Vec::new(),
            blocks: Vec::new(),
            series: Vec::new(),
        };
        ck.write(run_dir).unwrap();
    }

    fn flip(path: &Path, at: usize) {
        let mut bytes = std::fs::read(path).unwrap();
        let at = at.min(bytes.len() - 1);
        bytes[at] ^= 0x40;
        std::fs::write(path, bytes).unwrap();
    }

    #[test]
    fn the_last_two_complete_checkpoints_are_kept() {
        let run = tempfile::tempdir().unwrap();
        let scene = Scene::default_scene();
        for step in [10, 20, 30] {
            complete(run.path(), step);
        }
        assert_eq!(complete_steps(run.path()), vec![30, 20]);
        assert!(!files::node_file(run.path(), "fluid", 10).exists());
        assert_eq!(latest(run.path(), &scene).unwrap().unwrap().step, 30);
    }

    /// A damaged node file of the last checkpoint is refused by name before anything is cut
    /// back, with the files to delete to fall back to the one before it.
    #[test]
    fn a_damaged_last_checkpoint_names_the_file_and_the_fallback() {
        let run = tempfile::tempdir().unwrap();
        let scene = Scene::default_scene();
        complete(run.path(), 10);
        complete(run.path(), 20);
        let solid = files::node_file(run.path(), "solid", 20);
        flip(&solid, 100);
        let e = latest(run.path(), &scene).unwrap_err();
        assert!(
            e.contains(&format!("'{}' is damaged", solid.display()))
                && e.contains("the last checkpoint (step 20) cannot be used")
                && e.contains("checkpoint before it (step 10)")
                && e.contains(&format!(
                    "rm {}",
                    files::coupler_file(run.path(), 20).display()
                )),
            "{e}"
        );
        // The fix as written works.
        for f in step_files(run.path(), 20) {
            std::fs::remove_file(f).unwrap();
        }
        assert_eq!(latest(run.path(), &scene).unwrap().unwrap().step, 10);
        // No earlier one: the message says so.
        flip(&files::coupler_file(run.path(), 10), 30);
        let e = latest(run.path(), &scene).unwrap_err();
        assert!(e.contains("no earlier checkpoint is kept"), "{e}");
    }

    #[test]
    fn a_renamed_truncated_or_missing_file_is_refused() {
        let run = tempfile::tempdir().unwrap();
        let scene = Scene::default_scene();
        complete(run.path(), 10);
        // The coupler file renamed to a later step.
        std::fs::rename(
            files::coupler_file(run.path(), 10),
            files::coupler_file(run.path(), 50),
        )
        .unwrap();
        let e = latest(run.path(), &scene).unwrap_err();
        assert!(
            e.contains("coupler-0000000050.ckpt' holds step 10, its name says step 50")
                && e.contains("give it back its own name (coupler-0000000010.ckpt)"),
            "{e}"
        );
        std::fs::rename(
            files::coupler_file(run.path(), 50),
            files::coupler_file(run.path(), 10),
        )
        .unwrap();
        // A node file cut short.
        let fluid = files::node_file(run.path(), "fluid", 10);
        let bytes = std::fs::read(&fluid).unwrap();
        std::fs::write(&fluid, &bytes[..bytes.len() / 2]).unwrap();
        let e = latest(run.path(), &scene).unwrap_err();
        assert!(e.contains("fluid-0000000010.ckpt' is truncated"), "{e}");
        // A node file missing.
        std::fs::remove_file(&fluid).unwrap();
        let e = latest(run.path(), &scene).unwrap_err();
        assert!(
            e.contains("fluid-0000000010.ckpt") && e.contains("Fix:"),
            "{e}"
        );
    }

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
