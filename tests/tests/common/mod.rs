//! Helpers shared by the integration tests: where the binaries are, fresh run ids and
//! directories, and running the coupler as a real process.
#![allow(dead_code)]

use shared::transport::RunId;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Output, Stdio};
use std::time::{Duration, Instant};

/// The directory cargo put this package's binaries in; the workspace's other binaries
/// (coupler, fluid-node, solid-node) are built into the same one by `cargo test --workspace`.
pub fn bin_dir() -> PathBuf {
    Path::new(env!("CARGO_BIN_EXE_toy-fluid-node"))
        .parent()
        .unwrap()
        .to_path_buf()
}

pub fn bin(name: &str) -> PathBuf {
    let p = bin_dir().join(name);
    assert!(
        p.is_file(),
        "{} is missing: run the tests with `cargo test --release --workspace`",
        p.display()
    );
    p
}

pub fn toy_fluid(solver: &str) -> String {
    format!("{} --solver {solver}", env!("CARGO_BIN_EXE_toy-fluid-node"))
}

pub fn toy_solid() -> String {
    format!(
        "{} --solver ballistic",
        env!("CARGO_BIN_EXE_toy-solid-node")
    )
}

pub fn scene(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("scenes")
        .join(name)
}

/// A fresh run id and an empty, not yet existing output directory for it.
pub fn fresh(tag: &str) -> (RunId, PathBuf) {
    let id = RunId::fresh();
    let dir = std::env::temp_dir().join(format!("rockwave-test-{tag}-{id}"));
    (id, dir)
}

/// `coupler run` with the given arguments plus `--run-id`, `--out` and `--quiet`.
pub fn coupler(id: &RunId, out: &Path, args: &[&str]) -> Command {
    let mut c = Command::new(bin("coupler"));
    c.arg("run")
        .args(args)
        .args(["--run-id", id.as_str(), "--quiet", "--out"])
        .arg(out);
    c.stdin(Stdio::null());
    c
}

/// Runs `cmd` to its end with its output captured. Bounded (10 min, far beyond any test run
/// here even on a loaded machine), so a hang fails its test instead of stalling CI.
pub fn run(mut cmd: Command) -> Output {
    let child = cmd
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("coupler starts");
    wait_output(child, Duration::from_secs(600)).0
}

pub fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).to_string()
}

/// Files of the run still in /dev/shm or /tmp/iceoryx2.
pub fn leftovers(id: &RunId) -> Vec<PathBuf> {
    shared::transport::run_files(id)
}

/// Child processes of `pid` (from /proc).
pub fn children(pid: u32) -> Vec<u32> {
    let mut out = Vec::new();
    if let Ok(tasks) = std::fs::read_dir(format!("/proc/{pid}/task")) {
        for t in tasks.flatten() {
            if let Ok(s) = std::fs::read_to_string(t.path().join("children")) {
                out.extend(s.split_whitespace().filter_map(|p| p.parse::<u32>().ok()));
            }
        }
    }
    out
}

/// The command line of a process.
pub fn cmdline(pid: u32) -> String {
    std::fs::read(format!("/proc/{pid}/cmdline"))
        .map(|b| String::from_utf8_lossy(&b).replace('\0', " "))
        .unwrap_or_default()
}

/// Waits for `child` to exit, at most `timeout`; returns its output and how long it took.
pub fn wait_output(child: Child, timeout: Duration) -> (Output, Duration) {
    let start = Instant::now();
    let pid = child.id();
    let (tx, rx) = std::sync::mpsc::channel();
    std::thread::spawn(move || {
        let _ = tx.send(child.wait_with_output());
    });
    match rx.recv_timeout(timeout) {
        Ok(out) => (out.expect("wait"), start.elapsed()),
        Err(_) => {
            unsafe_kill(pid, 9);
            panic!("process {pid} did not exit within {timeout:?}");
        }
    }
}

pub fn unsafe_kill(pid: u32, signal: i32) {
    let _ = Command::new("kill")
        .arg(format!("-{signal}"))
        .arg(pid.to_string())
        .status();
}

/// Polls until `f` holds or `timeout` passes (test helper; the product itself never polls).
pub fn eventually(timeout: Duration, mut f: impl FnMut() -> bool) -> bool {
    let start = Instant::now();
    while start.elapsed() < timeout {
        if f() {
            return true;
        }
        std::thread::sleep(Duration::from_millis(20));
    }
    f()
}

pub fn summary(dir: &Path) -> serde_json::Value {
    let text = std::fs::read_to_string(dir.join("summary.json")).expect("summary.json written");
    serde_json::from_str(&text).expect("summary.json is JSON")
}

/// `coupler run` of the toy scene with the toy nodes, long enough (1000 s) to be interrupted.
pub fn long_toy_run(id: &RunId, out: &Path) -> Command {
    let scene = scene("toy_hover.toml");
    coupler(
        id,
        out,
        &[
            scene.to_str().unwrap(),
            "--end",
            "1000",
            "--fluid-cmd",
            &toy_fluid("hover"),
            "--solid-cmd",
            &toy_solid(),
        ],
    )
}

/// Waits until the coupler `pid` has both nodes running and stepping; returns their pids.
pub fn running_nodes(pid: u32) -> Vec<u32> {
    // Generous: on a loaded 2-core machine the nodes can take seconds to start. On failure
    // the coupler is stopped, so a failed test leaves no 1000 s run behind.
    if !eventually(Duration::from_secs(30), || children(pid).len() == 2) {
        unsafe_kill(pid, 15);
        panic!("the nodes did not start within 30 s");
    }
    std::thread::sleep(Duration::from_millis(300));
    children(pid)
}

/// The result files of a run directory that runs compare byte for byte (CSVs, .pvd series and
/// frames), sorted by name.
pub fn result_files(dir: &Path) -> Vec<String> {
    let mut names: Vec<String> = std::fs::read_dir(dir)
        .unwrap_or_else(|e| panic!("{}: {e}", dir.display()))
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|n| {
            matches!(n.as_str(), "gauges.csv" | "blocks.csv" | "probes.csv")
                || n.ends_with(".pvd")
                || ((n.starts_with("particles_") || n.starts_with("blocks_"))
                    && n.ends_with(".vtp"))
        })
        .collect();
    names.sort();
    names
}

/// Where two byte strings first differ: None if equal, else a message with the 1-based line
/// and column and a short excerpt of both lines around the difference.
pub fn first_difference(a: &[u8], b: &[u8]) -> Option<String> {
    if a == b {
        return None;
    }
    let at = a
        .iter()
        .zip(b)
        .position(|(x, y)| x != y)
        .unwrap_or(a.len().min(b.len()));
    let line = a[..at].iter().filter(|&&c| c == b'\n').count() + 1;
    let line_start = a[..at]
        .iter()
        .rposition(|&c| c == b'\n')
        .map_or(0, |p| p + 1);
    let column = at - line_start + 1;
    // The prefix up to `at` is common, so the line starts at the same byte in both.
    let excerpt = |s: &[u8]| {
        let from = at.saturating_sub(40).max(line_start);
        let line_end = s[at..]
            .iter()
            .position(|&c| c == b'\n')
            .map_or(s.len(), |p| at + p);
        String::from_utf8_lossy(&s[from..line_end.min(at + 40)]).into_owned()
    };
    Some(format!(
        "line {line}, column {column} (byte {at}; sizes {} and {} bytes):\n  first:  …{}…\n  second: …{}…",
        a.len(),
        b.len(),
        excerpt(a),
        excerpt(b)
    ))
}
