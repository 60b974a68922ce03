//! Checkpoint files: how a node and the coupler save what a run needs to continue exactly.
//!
//! Every checkpoint file is `MAGIC`, the format version (u32, little endian), then one
//! bincode-encoded (standard configuration) value. The version comes first and outside the
//! encoding so that a file of another version is named as such instead of failing to decode.
//!
//! A node's file is a [`NodeCheckpoint`]: a [`NodeHeader`] (role, solver, scene hash, step,
//! time: checked on resume, a mismatch is named), the runtime's own state (data it sent but the
//! peer has not consumed yet, the added-mass watch) and the solver's state, each encoded by its
//! owner. The coupler never reads a node's state: like a preCICE participant, a solver shows
//! nothing but its coupling interface, and saves and restores itself
//! ([`crate::solver::Solver::save_state`]).
//!
//! Files are written atomically ([`write_atomic`]): a temporary name, fsync, rename, fsync of the
//! directory, so a checkpoint either exists whole or not at all, even across a power cut.

use serde::Serialize;
use serde::de::DeserializeOwned;
use std::io::Write;
use std::path::{Path, PathBuf};

/// Version of every checkpoint format (node and coupler). Bump on any change of what is saved.
pub const FORMAT_VERSION: u32 = 7;
/// First bytes of every checkpoint file.
pub const MAGIC: [u8; 8] = *b"RWCKPT\r\n";

/// The directory of a run's checkpoints.
pub fn dir(run_dir: &Path) -> PathBuf {
    run_dir.join("checkpoints")
}

/// The checkpoint file of node `role` ("fluid", "solid") after `step` steps.
pub fn node_file(run_dir: &Path, role: &str, step: u64) -> PathBuf {
    dir(run_dir).join(format!("{role}-{step:010}.ckpt"))
}

/// The coupler's checkpoint file after `step` steps. It is written last, after both nodes
/// confirmed theirs: its existence makes the checkpoint complete.
pub fn coupler_file(run_dir: &Path, step: u64) -> PathBuf {
    dir(run_dir).join(format!("coupler-{step:010}.ckpt"))
}

/// FNV-1a (64 bit) of the scene text as run: a cheap, stable fingerprint (no dependency, the
/// same on every platform) to refuse resuming a run with another scene.
pub fn scene_hash(scene_toml: &str) -> u64 {
    fnv1a(0xcbf2_9ce4_8422_2325, scene_toml.as_bytes())
}

fn fnv1a(start: u64, bytes: &[u8]) -> u64 {
    bytes.iter().fold(start, |h, &b| {
        (h ^ b as u64).wrapping_mul(0x0000_0100_0000_01b3)
    })
}

/// [`scene_hash`] continued over the bytes of each terrain file the scene reads, in order: a
/// terrain file replaced under the same path makes another run, which a resume must refuse.
/// A file that cannot be read adds its path and the error instead (so it differs too).
pub fn run_hash(scene: &crate::scene::Scene, scene_toml: &str) -> u64 {
    scene.terrain.iter().fold(scene_hash(scene_toml), |h, t| {
        match std::fs::read(&t.file) {
            Ok(bytes) => fnv1a(h, &bytes),
            Err(e) => fnv1a(h, format!("{}: {e}", t.file.display()).as_bytes()),
        }
    })
}

/// Encodes a value (bincode, standard configuration) for a checkpoint.
pub fn encode<T: Serialize>(value: &T) -> Result<Vec<u8>, String> {
    bincode::serde::encode_to_vec(value, bincode::config::standard())
        .map_err(|e| format!("cannot encode the checkpoint state: {e}"))
}

/// Decodes a value [`encode`] wrote; `what` names it in the error.
pub fn decode<T: DeserializeOwned>(bytes: &[u8], what: &str) -> Result<T, String> {
    let (value, used) = bincode::serde::decode_from_slice(bytes, bincode::config::standard())
        .map_err(|e| format!("{what}: undecodable checkpoint state: {e}"))?;
    if used != bytes.len() {
        return Err(format!(
            "{what}: {} bytes left over after the checkpoint state: the file was written by another version",
            bytes.len() - used
        ));
    }
    Ok(value)
}

/// Writes `MAGIC`, the format version and `value` to `path` atomically.
pub fn write_file<T: Serialize>(path: &Path, value: &T) -> Result<(), String> {
    let mut bytes = Vec::from(MAGIC);
    bytes.extend_from_slice(&FORMAT_VERSION.to_le_bytes());
    bytes.extend(encode(value)?);
    write_atomic(path, &bytes).map_err(|e| format!("cannot write '{}': {e}", path.display()))
}

/// Reads a file [`write_file`] wrote, naming the file and what is wrong with it.
pub fn read_file<T: DeserializeOwned>(path: &Path) -> Result<T, String> {
    let bytes = std::fs::read(path)
        .map_err(|e| format!("cannot read the checkpoint '{}': {e}", path.display()))?;
    let name = path.display();
    if bytes.len() < 12 || bytes[..8] != MAGIC {
        return Err(format!("'{name}' is not a rockwave checkpoint"));
    }
    let version = u32::from_le_bytes(bytes[8..12].try_into().expect("4 bytes"));
    if version != FORMAT_VERSION {
        return Err(format!(
            "'{name}' has checkpoint format version {version}, this build reads version {FORMAT_VERSION}. \
             Fix: resume it with the build that wrote it, or start the run again"
        ));
    }
    decode(&bytes[12..], &name.to_string())
}

/// Writes `bytes` to `path` so that the file exists whole or not at all: a temporary file in
/// the same directory, fsync, rename over `path`, then fsync of the directory (the rename itself
/// is only durable once the directory is).
pub fn write_atomic(path: &Path, bytes: &[u8]) -> std::io::Result<()> {
    let parent = path.parent().unwrap_or(Path::new("."));
    let mut tmp = path.as_os_str().to_owned();
    tmp.push(".partial");
    let tmp = PathBuf::from(tmp);
    {
        let mut f = std::fs::File::create(&tmp)?;
        f.write_all(bytes)?;
        f.sync_all()?;
    }
    std::fs::rename(&tmp, path)?;
    std::fs::File::open(parent)?.sync_all()
}

/// What identifies a node's checkpoint; checked against the run that resumes it.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct NodeHeader {
    /// "fluid" or "solid".
    pub role: String,
    pub solver: String,
    pub scene_hash: u64,
    /// Steps taken when it was written, and the time reached.
    pub step: u64,
    pub time: f64,
}

impl NodeHeader {
    /// Whether this checkpoint is the one `expected` describes; the error names every field
    /// that differs and the file.
    pub fn check(&self, expected: &NodeHeader, file: &Path) -> Result<(), String> {
        let mut problems = Vec::new();
        if self.role != expected.role {
            problems.push(format!(
                "it is the {} node's, not the {} node's",
                self.role, expected.role
            ));
        }
        if self.solver != expected.solver {
            problems.push(format!(
                "it was written by solver '{}', this node runs '{}' (fix: resume with --{}-solver {})",
                self.solver, expected.solver, expected.role, self.solver
            ));
        }
        if self.scene_hash != expected.scene_hash {
            problems.push(format!(
                "it was written for another scene (scene hash {:016x}, this run's {:016x}; fix: resume with the run directory's own scene.toml)",
                self.scene_hash, expected.scene_hash
            ));
        }
        if self.step != expected.step || self.time.to_bits() != expected.time.to_bits() {
            problems.push(format!(
                "it holds step {} (t = {} s), the coupler resumes step {} (t = {} s)",
                self.step, self.time, expected.step, expected.time
            ));
        }
        if problems.is_empty() {
            Ok(())
        } else {
            Err(format!(
                "cannot resume from '{}': {}",
                file.display(),
                problems.join("; ")
            ))
        }
    }
}

/// A node's checkpoint file.
#[derive(Debug, Clone, serde::Serialize, serde::Deserialize)]
pub struct NodeCheckpoint {
    pub header: NodeHeader,
    /// The runtime's state (encoded by the role's runtime).
    pub runtime: Vec<u8>,
    /// The solver's state ([`crate::solver::Solver::save_state`]).
    pub solver: Vec<u8>,
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_file_round_trips_and_a_wrong_version_is_named() {
        let dir = std::env::temp_dir().join(format!("rw-ckpt-unit-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("x.ckpt");
        let value = (
            3u64,
            vec![1.5f64, -0.0, f64::MIN_POSITIVE],
            "fluid".to_string(),
        );
        write_file(&path, &value).unwrap();
        let back: (u64, Vec<f64>, String) = read_file(&path).unwrap();
        assert_eq!(back.0, 3);
        assert_eq!(back.1[1].to_bits(), (-0.0f64).to_bits());
        assert!(!dir.join("x.ckpt.partial").exists());
        let mut bytes = std::fs::read(&path).unwrap();
        bytes[8] = 99;
        std::fs::write(&path, &bytes).unwrap();
        let e = read_file::<(u64, Vec<f64>, String)>(&path).unwrap_err();
        assert!(e.contains("format version 99"), "{e}");
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn a_terrain_file_changed_under_the_same_path_changes_the_run_hash() {
        let dir = std::env::temp_dir().join(format!("rw-ckpt-terrain-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let file = dir.join("t.asc");
        std::fs::write(&file, "ncols 2").unwrap();
        let spec = toml::from_str(&format!("file = {:?}", file.display().to_string())).unwrap();
        let mut scene = crate::scene::Scene::default_scene();
        let text = "the same scene text";
        assert_eq!(
            run_hash(&scene, text),
            scene_hash(text),
            "no terrain: the text alone"
        );
        scene.terrain.push(spec);
        let a = run_hash(&scene, text);
        assert_eq!(a, run_hash(&scene, text));
        std::fs::write(&file, "ncols 3").unwrap();
        let b = run_hash(&scene, text);
        assert_ne!(a, b, "a changed terrain file");
        std::fs::remove_dir_all(&dir).unwrap();
        let gone = run_hash(&scene, text);
        assert!(gone != a && gone != b, "a missing terrain file");
    }

    #[test]
    fn a_mismatch_names_the_field() {
        let h = NodeHeader {
            role: "fluid".into(),
            solver: "wcsph".into(),
            scene_hash: 1,
            step: 10,
            time: 0.1,
        };
        let mut other = h.clone();
        other.solver = "muller".into();
        let e = h.check(&other, Path::new("f.ckpt")).unwrap_err();
        assert!(
            e.contains("solver 'wcsph'") && e.contains("'muller'"),
            "{e}"
        );
        other = h.clone();
        other.scene_hash = 2;
        assert!(
            h.check(&other, Path::new("f"))
                .unwrap_err()
                .contains("another scene")
        );
        assert!(h.check(&h, Path::new("f")).is_ok());
    }
}
