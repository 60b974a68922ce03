//! Checkpoint files: how a node and the coupler save what a run needs to continue exactly.
//!
//! Every checkpoint file is an envelope around one bincode-encoded (standard configuration)
//! value:
//!
//! | bytes | what |
//! |---|---|
//! | 8 | [`MAGIC`] |
//! | 4 | the format version (u32, little endian) |
//! | 8 | whose it is: "coupler", "fluid" or "solid", ASCII padded with zero bytes |
//! | 8 | the step it holds (u64 LE) |
//! | 8 | the payload's length in bytes (u64 LE) |
//! | n | the payload |
//! | 4 | CRC-32 (IEEE) of every byte before it (u32 LE) |
//!
//! The version comes first and outside the encoding so that a file of another version is named
//! as such instead of failing to decode. The owner and step are checked against the name the
//! file is read under (a file renamed to another step, or a node's file named as the coupler's,
//! is refused), the length against the file's (a truncated file is named as such) and the
//! checksum against the content: a file damaged on a disk where it sat for days is refused
//! with its name rather than resumed to other results. The checksum guards against accidents
//! (bit rot, cut copies), not against someone forging a file.
//!
//! A node's file is a [`NodeCheckpoint`]: a [`NodeHeader`] (role, solver, scene hash, step,
//! time: checked on resume, a mismatch is named), the runtime's own state (data it sent but the
//! peer has not consumed yet, the added-mass watch) and the solver's state, each encoded by its
//! owner. The coupler never reads a node's state: like a preCICE participant, a solver shows
//! nothing but its coupling interface, and saves and restores itself
//! ([`crate::solver::Solver::save_state`]); it only checks the envelope ([`verify_file`]).
//!
//! Files are written atomically ([`write_atomic`]): a temporary name, fsync, rename, fsync of the
//! directory, so a checkpoint either exists whole or not at all, even across a power cut.

use serde::Serialize;
use serde::de::DeserializeOwned;
use std::io::Write;
use std::path::{Path, PathBuf};

/// Version of every checkpoint format (node and coupler). Bump on any change of what is saved.
pub const FORMAT_VERSION: u32 = 13;
/// First bytes of every checkpoint file.
pub const MAGIC: [u8; 8] = *b"RWCKPT\r\n";
/// Bytes before the payload: magic, version, owner, step, payload length.
const HEADER_LEN: usize = 8 + 4 + OWNER_LEN + 8 + 8;
/// Bytes of the owner's name field ("coupler", "fluid", "solid", zero-padded).
const OWNER_LEN: usize = 8;
/// Bytes of the checksum after the payload.
const CHECKSUM_LEN: usize = 4;

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

/// Why a checkpoint file is refused: the problem (naming the file) and the fix. A caller that
/// knows more (the coupler knows which earlier checkpoint is kept) names its own fix.
#[derive(Debug, Clone, PartialEq)]
pub struct Refused {
    pub problem: String,
    pub fix: String,
    /// Whether the file is lost (damaged, cut, unreadable), so that falling back to an earlier
    /// checkpoint is the fix, rather than a file to put right (renamed, of another version).
    pub lost: bool,
}

impl std::fmt::Display for Refused {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{}. Fix: {}", self.problem, self.fix)
    }
}

/// The fix of a damaged file, when the caller has none better.
const DAMAGED_FIX: &str = "resume from an earlier checkpoint (delete this step's files in checkpoints/, when an earlier one is kept), or start the run again";
/// The fix of a file under another file's name.
const RENAMED_FIX: &str = "give it back its own name, or remove it";

/// Writes `value` as checkpoint `owner`'s ("coupler", "fluid", "solid") state after `step`
/// steps to `path`, atomically, in the envelope above. The error names the file.
pub fn write_file<T: Serialize>(
    path: &Path,
    owner: &str,
    step: u64,
    value: &T,
) -> Result<(), String> {
    let payload = encode(value)?;
    let bytes = envelope(owner, step, &payload);
    write_atomic(path, &bytes).map_err(|e| {
        format!(
            "cannot write the checkpoint '{}': {e}. Fix: free space on that disk or make the run directory writable",
            path.display()
        )
    })
}

/// `payload` in the envelope of `owner`'s checkpoint after `step` steps.
fn envelope(owner: &str, step: u64, payload: &[u8]) -> Vec<u8> {
    assert!(owner.len() <= OWNER_LEN, "owner name '{owner}' too long");
    let mut bytes = Vec::with_capacity(HEADER_LEN + payload.len() + CHECKSUM_LEN);
    bytes.extend_from_slice(&MAGIC);
    bytes.extend_from_slice(&FORMAT_VERSION.to_le_bytes());
    let mut name = [0u8; OWNER_LEN];
    name[..owner.len()].copy_from_slice(owner.as_bytes());
    bytes.extend_from_slice(&name);
    bytes.extend_from_slice(&step.to_le_bytes());
    bytes.extend_from_slice(&(payload.len() as u64).to_le_bytes());
    bytes.extend_from_slice(payload);
    let sum = crc32fast::hash(&bytes);
    bytes.extend_from_slice(&sum.to_le_bytes());
    bytes
}

/// Reads a file [`write_file`] wrote as `owner`'s checkpoint after `step` steps (the name it
/// is read under says both), refusing a damaged, truncated, renamed or foreign file with its
/// name, what is wrong and the fix.
pub fn read_file<T: DeserializeOwned>(path: &Path, owner: &str, step: u64) -> Result<T, Refused> {
    let bytes = read_checked(path, owner, step)?;
    decode(
        &bytes[HEADER_LEN..bytes.len() - CHECKSUM_LEN],
        &format!("checkpoint '{}'", path.display()),
    )
    .map_err(|problem| Refused {
        problem,
        fix: "resume it with the build that wrote it, or start the run again".into(),
        lost: false,
    })
}

/// Checks a checkpoint file's envelope (as [`read_file`] does) without decoding its payload:
/// what the coupler checks of a node's file before a resume.
pub fn verify_file(path: &Path, owner: &str, step: u64) -> Result<(), Refused> {
    read_checked(path, owner, step).map(|_| ())
}

/// The whole file, once its envelope is checked.
fn read_checked(path: &Path, owner: &str, step: u64) -> Result<Vec<u8>, Refused> {
    let bytes = read_regular(path)?;
    check(&bytes, path, owner, step)?;
    Ok(bytes)
}

/// Checks the envelope of the bytes of file `path`, as `owner`'s checkpoint after `step` steps.
fn check(bytes: &[u8], path: &Path, owner: &str, step: u64) -> Result<(), Refused> {
    let name = path.display();
    let refuse = |problem: String| Refused {
        problem: format!("checkpoint '{name}' {problem}"),
        fix: DAMAGED_FIX.into(),
        lost: true,
    };
    if bytes.len() < 12 && MAGIC.starts_with(&bytes[..bytes.len().min(8)]) {
        return Err(refuse(format!(
            "is truncated: {} bytes, not even a whole header",
            bytes.len()
        )));
    }
    if bytes.len() < 8 || bytes[..8] != MAGIC {
        return Err(refuse(
            "is not a rockwave checkpoint (its first bytes are not the checkpoint marker: another file, or its start is damaged)"
                .into(),
        ));
    }
    let version = u32::from_le_bytes(bytes[8..12].try_into().expect("4 bytes"));
    if version != FORMAT_VERSION {
        return Err(Refused {
            problem: format!(
                "checkpoint '{name}' has format version {version}, this build reads version {FORMAT_VERSION}{}",
                if version > FORMAT_VERSION {
                    " (a version no build wrote yet means a damaged header)"
                } else {
                    ""
                }
            ),
            fix: "resume it with the build that wrote it, or start the run again".into(),
            lost: false,
        });
    }
    if bytes.len() < HEADER_LEN + CHECKSUM_LEN {
        return Err(refuse(format!(
            "is truncated: {} bytes, fewer than a header and checksum ({} bytes)",
            bytes.len(),
            HEADER_LEN + CHECKSUM_LEN
        )));
    }
    let u64_at = |at: usize| u64::from_le_bytes(bytes[at..at + 8].try_into().expect("8 bytes"));
    let announced = u64_at(HEADER_LEN - 8);
    let whole = (HEADER_LEN + CHECKSUM_LEN) as u64;
    let body = &bytes[..bytes.len() - CHECKSUM_LEN];
    let stored = u32::from_le_bytes(bytes[body.len()..].try_into().expect("4 bytes"));
    if crc32fast::hash(body) != stored {
        // Say which damage it is when the header tells: a file cut short (or grown).
        let problem = match announced.checked_add(whole) {
            Some(expected) if expected > bytes.len() as u64 => format!(
                "is truncated: {} bytes, its header announces {expected} (a write or copy cut short)",
                bytes.len()
            ),
            Some(expected) if expected < bytes.len() as u64 => format!(
                "has {} bytes more than its header announces ({expected}): something was appended, or the header is damaged",
                bytes.len() as u64 - expected
            ),
            _ => "is damaged: its checksum does not match its content (bits changed on the disk or in a copy)".to_string(),
        };
        return Err(refuse(problem));
    }
    // The content is what was written: now whether it is the file its name says.
    let owner_field = &bytes[12..12 + OWNER_LEN];
    let held_owner = String::from_utf8_lossy(owner_field)
        .trim_end_matches('\0')
        .to_string();
    let held_step = u64_at(12 + OWNER_LEN);
    if held_owner != owner {
        return Err(Refused {
            problem: format!(
                "checkpoint '{name}' is the {held_owner} checkpoint of step {held_step}, not the {owner} one its name says: it was renamed or copied over"
            ),
            fix: RENAMED_FIX.into(),
            lost: false,
        });
    }
    if held_step != step {
        return Err(Refused {
            problem: format!(
                "checkpoint '{name}' holds step {held_step}, its name says step {step}: it was renamed or copied over"
            ),
            fix: format!("give it back its own name ({owner}-{held_step:010}.ckpt), or remove it"),
            lost: false,
        });
    }
    if announced.checked_add(whole) != Some(bytes.len() as u64) {
        return Err(refuse(format!(
            "announces a {announced}-byte payload in a {}-byte file",
            bytes.len()
        )));
    }
    Ok(())
}

/// The bytes of a regular file (a pipe or device named as a checkpoint could block or never
/// end), read with the capacity its length says.
fn read_regular(path: &Path) -> Result<Vec<u8>, Refused> {
    let cannot = |e: std::io::Error| Refused {
        problem: format!("cannot read the checkpoint '{}': {e}", path.display()),
        fix: DAMAGED_FIX.into(),
        lost: true,
    };
    let mut f = std::fs::File::open(path).map_err(cannot)?;
    let meta = f.metadata().map_err(cannot)?;
    if !meta.is_file() {
        return Err(Refused {
            problem: format!(
                "checkpoint '{}' is not a regular file (a pipe, device or directory)",
                path.display()
            ),
            fix: "remove it".into(),
            lost: false,
        });
    }
    let mut bytes = Vec::with_capacity(meta.len() as usize);
    std::io::Read::read_to_end(&mut f, &mut bytes).map_err(cannot)?;
    Ok(bytes)
}

/// Writes `bytes` to `path` so that the file exists whole or not at all: a temporary file in
/// the same directory, fsync, rename over `path`, then fsync of the directory (the rename itself
/// is only durable once the directory is). A write that fails (a full disk) removes its
/// temporary file and leaves `path` as it was.
pub fn write_atomic(path: &Path, bytes: &[u8]) -> std::io::Result<()> {
    let parent = path.parent().unwrap_or(Path::new("."));
    let mut tmp = path.as_os_str().to_owned();
    tmp.push(".partial");
    let tmp = PathBuf::from(tmp);
    let written = std::fs::File::create(&tmp).and_then(|mut f| {
        f.write_all(bytes)?;
        f.sync_all()
    });
    if let Err(e) = written.and_then(|_| std::fs::rename(&tmp, path)) {
        let _ = std::fs::remove_file(&tmp);
        return Err(e);
    }
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

    type Value = (u64, Vec<f64>, String);

    /// A checkpoint file written in a fresh temporary directory.
    fn written() -> (tempfile::TempDir, PathBuf, Value) {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("solid-0000000042.ckpt");
        let value = (
            3u64,
            vec![1.5f64, -0.0, f64::MIN_POSITIVE],
            "fluid".to_string(),
        );
        write_file(&path, "solid", 42, &value).unwrap();
        (dir, path, value)
    }

    #[test]
    fn a_file_round_trips_and_a_wrong_version_is_named() {
        let (dir, path, value) = written();
        let back: Value = read_file(&path, "solid", 42).unwrap();
        assert_eq!(back.0, value.0);
        assert_eq!(back.1[1].to_bits(), (-0.0f64).to_bits());
        assert!(!dir.path().join("solid-0000000042.ckpt.partial").exists());
        let mut bytes = std::fs::read(&path).unwrap();
        bytes[8] = 99;
        std::fs::write(&path, &bytes).unwrap();
        let e = read_file::<Value>(&path, "solid", 42)
            .unwrap_err()
            .to_string();
        assert!(e.contains("format version 99") && e.contains("Fix:"), "{e}");
    }

    /// Every single flipped bit, anywhere (marker, header, payload, checksum), and nine at once
    /// as the issue found in a solid checkpoint, is refused with the file's name.
    #[test]
    fn a_flipped_bit_anywhere_is_refused_by_name() {
        let (_dir, path, _) = written();
        let good = std::fs::read(&path).unwrap();
        for byte in 0..good.len() {
            for bit in 0..8 {
                if byte == 8 {
                    continue; // the version byte: named as another version (test above)
                }
                let mut bad = good.clone();
                bad[byte] ^= 1 << bit;
                let e = check(&bad, &path, "solid", 42)
                    .err()
                    .unwrap_or_else(|| panic!("bit {bit} of byte {byte} flipped was read"))
                    .to_string();
                assert!(e.contains(&path.display().to_string()), "{e}");
                assert!(e.contains("Fix:"), "{e}");
            }
        }
        let mut bad = good.clone();
        for k in 0..9 {
            bad[HEADER_LEN + 2 * k] ^= 0x10;
        }
        std::fs::write(&path, &bad).unwrap();
        let e = read_file::<Value>(&path, "solid", 42)
            .unwrap_err()
            .to_string();
        assert!(e.contains("is damaged: its checksum does not match"), "{e}");
        assert!(verify_file(&path, "solid", 42).is_err());
    }

    #[test]
    fn a_truncated_file_is_named_as_such() {
        let (_dir, path, _) = written();
        let good = std::fs::read(&path).unwrap();
        for len in 0..good.len() {
            let e = check(&good[..len], &path, "solid", 42)
                .unwrap_err()
                .to_string();
            assert!(e.contains("is truncated"), "cut to {len} bytes: {e}");
            assert!(e.contains("solid-0000000042.ckpt"), "{e}");
        }
        let mut longer = good.clone();
        longer.extend_from_slice(b"tail");
        std::fs::write(&path, &longer).unwrap();
        let e = read_file::<Value>(&path, "solid", 42)
            .unwrap_err()
            .to_string();
        assert!(e.contains("bytes more than its header announces"), "{e}");
    }

    #[test]
    fn a_file_renamed_to_another_step_or_owner_is_refused() {
        let (dir, path, _) = written();
        let renamed = dir.path().join("solid-0000000099.ckpt");
        std::fs::rename(&path, &renamed).unwrap();
        let e = read_file::<Value>(&renamed, "solid", 99)
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("holds step 42, its name says step 99")
                && e.contains("solid-0000000042.ckpt")
                && e.contains("Fix:"),
            "{e}"
        );
        let e = verify_file(&renamed, "coupler", 42)
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("is the solid checkpoint of step 42, not the coupler one"),
            "{e}"
        );
    }

    #[test]
    fn a_path_that_is_not_a_regular_file_is_refused() {
        let dir = tempfile::tempdir().unwrap();
        let e = read_file::<Value>(dir.path(), "solid", 1)
            .unwrap_err()
            .to_string();
        assert!(e.contains("not a regular file"), "{e}");
        let e = read_file::<Value>(&dir.path().join("none.ckpt"), "solid", 1)
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("cannot read the checkpoint") && e.contains("none.ckpt"),
            "{e}"
        );
    }

    #[test]
    fn a_failed_write_names_the_file_and_leaves_no_partial_file() {
        let dir = tempfile::tempdir().unwrap();
        // A directory where the file should go: the rename over it fails.
        let path = dir.path().join("coupler-0000000001.ckpt");
        std::fs::create_dir(&path).unwrap();
        std::fs::write(path.join("x"), "x").unwrap();
        let e = write_file(&path, "coupler", 1, &1u32).unwrap_err();
        assert!(
            e.contains("cannot write the checkpoint") && e.contains("coupler-0000000001.ckpt"),
            "{e}"
        );
        assert!(!dir.path().join("coupler-0000000001.ckpt.partial").exists());
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
