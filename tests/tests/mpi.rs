//! The fluid node on real MPI ranks (`--features tests/mpi`, which builds the fluid node with
//! MPI; Debian's openmpi-bin and libopenmpi-dev): a small dam break writes byte-identical results
//! on 1, 2, 3 and 4 ranks and over TCP only, and with Müller's and DFSPH on 1 and 2; a rank killed
//! mid-run stops the run at once and a stopped one at the step timeout, both named by rank, with
//! what was written kept and nothing of the run left (processes, shared memory); and what ranks
//! cannot do is refused before anything is written: a missing launcher, more ranks than the
//! water fills. A run checkpointed on 2 ranks and killed resumes
//! on 3, and a rank killed under `--retries` restarts from the checkpoint, both to the bits of an
//! uninterrupted run on one; a block sliding into water gives the same bits on 1 and 2 ranks.
#![cfg(feature = "mpi")]

mod common;
use common::*;
use shared::transport::RunId;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

/// The narrow dam break (`fluid_node::validation::narrow_dam_break`) to t = 0.2 s: ~1 400 WCSPH
/// steps, 5 frames, a few seconds per run. The tank holds 5 slabs at most.
fn dam_break_text() -> String {
    fluid_node::validation::narrow_dam_break(0.2, 0.05)
}

/// The most ranks the dam break's tank holds: 0.6 m over slabs of at least 4 cells of
/// 2.6 × 1.1 × 0.01 m (coupler/src/run/per_rank.rs).
const MOST_RANKS: u32 = 5;

/// `--step-timeout` of the killed-rank run: a step here takes milliseconds, so the coupler's
/// silence limit is not what ends the run; the run must end well within it.
const STEP_TIMEOUT_S: f64 = 10.0;

/// Writes `text` as a scene file beside the run directory `dir` (which must not exist yet).
fn scene_file(dir: &Path, text: &str) -> PathBuf {
    let path = dir.with_extension("toml");
    std::fs::write(&path, text).unwrap();
    path
}

/// `summary.json` without what depends on the machine and the moment: the run id, wall and
/// CPU times, compute shares, memory.
fn comparable_summary(dir: &Path) -> serde_json::Value {
    fn strip(v: &mut serde_json::Value) {
        match v {
            serde_json::Value::Object(map) => {
                map.retain(|k, _| {
                    !(k == "run_id"
                        || k == "memory"
                        || ["wall", "cpu", "compute", "rss"]
                            .iter()
                            .any(|w| k.contains(w)))
                });
                map.values_mut().for_each(strip);
            }
            serde_json::Value::Array(items) => items.iter_mut().for_each(strip),
            _ => {}
        }
    }
    let mut s = summary(dir);
    strip(&mut s);
    s
}

/// The files two runs of the dam break must hold byte for byte: the series, frames and .pvd
/// collections ([`result_files`]) and the fluid's description.
fn compared_files(dir: &Path) -> Vec<String> {
    let mut names = result_files(dir);
    names.push("fluid.json".into());
    names
}

/// Runs the dam break with `args`; panics with its stderr unless it completes.
fn dam_break(tag: &str, args: &[&str]) -> PathBuf {
    run_scene(tag, &dam_break_text(), args)
}

/// `coupler run` of scene `text` (written beside a fresh run directory named for `tag`) with
/// `args`, to its end: the run's id, directory, scene file and output.
fn run_tagged(
    tag: &str,
    text: &str,
    args: &[&str],
) -> (RunId, PathBuf, PathBuf, std::process::Output) {
    let (id, dir) = fresh(&format!("mpi-{tag}"));
    let scene = scene_file(&dir, text);
    let all: Vec<&str> = [scene.to_str().unwrap()]
        .into_iter()
        .chain(args.iter().copied())
        .collect();
    let out = run(coupler(&id, &dir, &all));
    (id, dir, scene, out)
}

/// Runs scene `text` with `args`; panics with its stderr unless it completes, or if it leaves
/// shared memory behind.
fn run_scene(tag: &str, text: &str, args: &[&str]) -> PathBuf {
    let start = Instant::now();
    let (id, dir, scene, out) = run_tagged(tag, text, args);
    assert!(
        out.status.success(),
        "{tag} failed after {:?}: {}",
        start.elapsed(),
        stderr(&out)
    );
    eprintln!("{tag}: {:.1} s", start.elapsed().as_secs_f64());
    assert!(
        leftovers(&id).is_empty(),
        "{tag}: shared memory left behind"
    );
    std::fs::remove_file(scene).unwrap();
    dir
}

#[test]
fn the_dam_break_writes_the_same_bits_on_any_rank_count_and_over_tcp() {
    let one = dam_break("1-rank", &[]);
    let names = compared_files(&one);
    for n in [
        "gauges.csv",
        "probes.csv",
        "particles_00000.vtp",
        "fluid.json",
    ] {
        assert!(names.iter().any(|m| m == n), "{n} not written");
    }
    let frames = names.iter().filter(|n| n.starts_with("particles_")).count();
    assert!(frames >= 4, "{frames} particle frames");
    let reference = comparable_summary(&one);
    let steps = reference["stats"]["steps"].as_u64().unwrap();
    assert!(steps >= 300, "only {steps} steps");
    let gauges = std::fs::read_to_string(one.join("gauges.csv")).unwrap();
    assert!(gauges.lines().count() > 10, "gauges.csv: {gauges}");
    same_bits_as(
        &one,
        &dam_break_text(),
        &[
            ("2-ranks", &["--fluid-ranks", "2"]),
            ("3-ranks", &["--fluid-ranks", "3"]),
            ("4-ranks", &["--fluid-ranks", "4"]),
            (
                "2-ranks-tcp",
                &[
                    "--fluid-ranks",
                    "2",
                    "--mpirun",
                    "mpirun --mca btl tcp,self",
                ],
            ),
        ],
    );
}

/// Runs scene `text` with each of `runs` (tag, arguments): every file of the run `one` and its
/// summary (timings and memory aside), the same bits. Removes the runs and `one`.
fn same_bits_as(one: &Path, text: &str, runs: &[(&str, &[&str])]) {
    let names = compared_files(one);
    let reference = comparable_summary(one);
    for (tag, args) in runs {
        let dir = run_scene(tag, text, args);
        assert_eq!(compared_files(&dir), names, "{tag}: other files written");
        for n in &names {
            let a = std::fs::read(one.join(n)).unwrap();
            let b = std::fs::read(dir.join(n)).unwrap();
            if let Some(diff) = first_difference(&a, &b) {
                panic!(
                    "{tag}: {n} differs from one rank's ({} against {}), first at {diff}",
                    dir.display(),
                    one.display()
                );
            }
        }
        assert_eq!(
            comparable_summary(&dir),
            reference,
            "{tag}: summary.json (timings and memory aside)"
        );
        std::fs::remove_dir_all(dir).unwrap();
    }
    std::fs::remove_dir_all(one).unwrap();
}

/// The dam break with the fluid solver `solver`.
fn dam_break_with(solver: &str) -> String {
    let text = dam_break_text();
    assert!(text.contains("solver = \"wcsph\""));
    text.replace("solver = \"wcsph\"", &format!("solver = \"{solver}\""))
}

#[test]
fn the_other_solvers_write_the_same_bits_on_one_and_two_ranks() {
    for solver in ["muller", "dfsph", "riemann"] {
        let text = dam_break_with(solver);
        let one = run_scene(&format!("{solver}-1-rank"), &text, &[]);
        let steps = summary(&one)["stats"]["steps"].as_u64().unwrap();
        assert!(steps >= 100, "{solver}: only {steps} steps");
        let two = format!("{solver}-2-ranks");
        same_bits_as(&one, &text, &[(two.as_str(), &["--fluid-ranks", "2"])]);
    }
}

/// The MPI rank of a process, from the environment its launcher gave it (Open MPI's
/// `OMPI_COMM_WORLD_RANK`, MPICH's `PMI_RANK`).
fn mpi_rank(pid: u32) -> Option<u32> {
    let env = std::fs::read(format!("/proc/{pid}/environ")).ok()?;
    env.split(|&b| b == 0).find_map(|var| {
        let var = String::from_utf8_lossy(var);
        ["OMPI_COMM_WORLD_RANK=", "PMI_RANK="]
            .iter()
            .find_map(|k| var.strip_prefix(k).and_then(|r| r.parse().ok()))
    })
}

/// Processes whose command line names the run (the launcher and the ranks carry `--prefix
/// <run id>`).
fn processes_of(id: &RunId) -> Vec<(u32, String)> {
    std::fs::read_dir("/proc")
        .unwrap()
        .flatten()
        .filter_map(|e| e.file_name().to_str()?.parse::<u32>().ok())
        .map(|pid| (pid, cmdline(pid)))
        .filter(|(_, cmd)| cmd.contains(id.as_str()) && !cmd.contains("coupler"))
        .collect()
}

/// Entries of /dev/shm (read only) whose name contains `what`.
fn shm_entries(what: &str) -> Vec<String> {
    std::fs::read_dir("/dev/shm")
        .map(|d| {
            d.flatten()
                .map(|e| e.file_name().to_string_lossy().into_owned())
                .filter(|n| n.contains(what))
                .collect()
        })
        .unwrap_or_default()
}

/// A run of the dam break on 3 ranks, stepping, and the follower rank chosen to be signalled.
struct Stepping {
    id: RunId,
    dir: PathBuf,
    scene: PathBuf,
    /// The coupler, until it is waited for.
    child: Option<std::process::Child>,
    /// The highest rank's pid and its MPI rank (when its environment says).
    victim: u32,
    rank: Option<u32>,
    shm_running: usize,
    vader_before: Vec<String>,
}

/// Starts the dam break on 3 ranks with the coupler's `--step-timeout` `timeout` [s] and waits
/// until it steps; picks the highest rank as the victim.
fn three_ranks_stepping(tag: &str, timeout: f64) -> Stepping {
    let (id, dir) = fresh(tag);
    let scene = scene_file(&dir, &dam_break_text());
    let vader_before = shm_entries("vader_segment");
    let timeout = timeout.to_string();
    let mut cmd = coupler(
        &id,
        &dir,
        &[
            scene.to_str().unwrap(),
            "--fluid-ranks",
            "3",
            "--end",
            "100",
            "--step-timeout",
            &timeout,
        ],
    );
    let child = cmd
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("coupler starts");
    let pid = child.id();
    // Stepping: the gauges have rows.
    let gauges = dir.join("gauges.csv");
    let stepping = eventually(Duration::from_secs(60), || {
        std::fs::read_to_string(&gauges).is_ok_and(|t| t.lines().count() >= 3)
    });
    if !stepping {
        unsafe_kill(pid, 15);
        panic!("the run did not step within 60 s");
    }
    let launcher = children(pid)
        .into_iter()
        .find(|&c| !children(c).is_empty() && cmdline(c).contains("mpirun"))
        .expect("the coupler's mpirun child");
    let ranks = children(launcher);
    assert_eq!(ranks.len(), 3, "ranks under mpirun: {ranks:?}");
    // A follower: the highest rank, or without a rank in the environment the highest pid.
    let victim = ranks
        .iter()
        .copied()
        .max_by_key(|&p| (mpi_rank(p), p))
        .unwrap();
    let rank = mpi_rank(victim);
    assert_ne!(rank, Some(0), "rank 0 is the node itself");
    let shm_running = shm_entries(id.as_str()).len();
    Stepping {
        id,
        dir,
        scene,
        child: Some(child),
        victim,
        rank,
        shm_running,
        vader_before,
    }
}

impl Stepping {
    /// Sends `signal` to the victim and waits for the coupler to end; returns its stderr's
    /// error line and the time it took. The run must have failed.
    fn signal_victim(&mut self, signal: i32) -> (String, Duration) {
        let child = self.child.take().expect("signalled once");
        let killed = Instant::now();
        unsafe_kill(self.victim, signal);
        let (out, _) = wait_output(child, Duration::from_secs_f64(STEP_TIMEOUT_S + 60.0));
        let took = killed.elapsed();
        let err = stderr(&out);
        eprintln!(
            "signal {signal} to rank {:?} (pid {}); the coupler exited {:?} after {:.2} s",
            self.rank,
            self.victim,
            out.status.code(),
            took.as_secs_f64()
        );
        assert!(!out.status.success(), "{err}");
        let error = err
            .lines()
            .find(|l| l.starts_with("coupler: error:"))
            .unwrap_or_else(|| panic!("no error line: {err}"))
            .to_string();
        assert!(
            error.contains("fluid node"),
            "the fluid node is named: {error}"
        );
        (error, took)
    }

    /// What was written stays, and nothing else of the run: no rank, no launcher, no shared
    /// memory. Removes the run.
    fn only_results_left(self) {
        assert!(self.dir.join("scene.toml").is_file());
        let text = std::fs::read_to_string(self.dir.join("gauges.csv")).unwrap();
        assert!(
            text.starts_with("time,") && text.lines().count() >= 3,
            "gauges.csv kept: {text}"
        );
        assert!(self.dir.join("particles_00000.vtp").is_file());
        let id = &self.id;
        assert!(
            eventually(Duration::from_secs(5), || processes_of(id).is_empty()),
            "processes of the run left: {:?}",
            processes_of(id)
        );
        assert!(leftovers(id).is_empty(), "{:?}", leftovers(id));
        assert!(
            shm_entries(id.as_str()).is_empty(),
            "/dev/shm after (held {} entries of the run while it ran): {:?}",
            self.shm_running,
            shm_entries(id.as_str())
        );
        // Open MPI's shared-memory segments carry its job id, not the run's: reported, not
        // asserted (other runs of the suite may hold theirs).
        let vader_after = shm_entries("vader_segment");
        let new: Vec<&String> = vader_after
            .iter()
            .filter(|n| !self.vader_before.contains(n))
            .collect();
        eprintln!(
            "Open MPI segments in /dev/shm: {:?} before, {new:?} new after",
            self.vader_before
        );
        std::fs::remove_file(&self.scene).unwrap();
        std::fs::remove_dir_all(&self.dir).unwrap();
    }
}

#[test]
fn a_killed_rank_stops_the_run_at_once_named_and_leaves_nothing_behind() {
    let mut run = three_ranks_stepping("mpi-killed-rank", STEP_TIMEOUT_S);
    let (error, took) = run.signal_victim(9);
    // About a second here: well within the step timeout, which is not what ended it.
    assert!(
        took.as_secs_f64() < STEP_TIMEOUT_S / 2.0,
        "the coupler took {took:?} to stop: {error}"
    );
    // The launcher's word on the rank reaches the coupler's own error.
    if let Some(r) = run.rank {
        assert!(
            error.contains(&format!("its launcher reports: process rank {r} ")),
            "rank {r} is named: {error}"
        );
    }
    run.only_results_left();
}

/// `--step-timeout` of the stopped-rank run [s]: what ends it.
const STOPPED_TIMEOUT_S: f64 = 3.0;

#[test]
fn a_stopped_rank_ends_the_run_at_the_step_timeout_named_and_leaves_nothing_behind() {
    let mut run = three_ranks_stepping("mpi-stopped-rank", STOPPED_TIMEOUT_S);
    let (error, took) = run.signal_victim(19); // SIGSTOP
    assert!(
        took.as_secs_f64() < STOPPED_TIMEOUT_S + 5.0,
        "the coupler took {took:?} to stop: {error}"
    );
    assert!(error.contains("hung at step"), "{error}");
    let who = match run.rank {
        Some(r) => format!("stopped: rank {r} (pid {})", run.victim),
        None => format!("stopped: pid {}", run.victim),
    };
    assert!(error.contains(&who), "{who}: {error}");
    run.only_results_left();
}

/// `coupler run` of the dam break with `args` that must be refused before anything is
/// written; returns its stderr.
fn refused_run(tag: &str, text: &str, args: &[&str]) -> String {
    let (id, dir, scene, out) = run_tagged(tag, text, args);
    let err = stderr(&out);
    assert!(!out.status.success(), "{tag}: {err}");
    assert!(!dir.exists(), "{tag}: {} was written: {err}", dir.display());
    assert!(leftovers(&id).is_empty(), "{tag}: shared memory");
    std::fs::remove_file(scene).unwrap();
    err
}

#[test]
fn a_missing_launcher_is_named_with_the_packages_before_anything_is_written() {
    let err = refused_run(
        "no-launcher",
        &dam_break_text(),
        &["--fluid-ranks", "2", "--mpirun", "/nonexistent/mpirun"],
    );
    for says in [
        "'/nonexistent/mpirun' is not installed",
        "openmpi-bin libopenmpi-dev",
        "--fluid-ranks 1",
    ] {
        assert!(err.contains(says), "{says}: {err}");
    }
}

#[test]
fn more_ranks_than_the_water_fills_are_refused_naming_the_most() {
    let too_many = (MOST_RANKS + 1).to_string();
    let err = refused_run(
        "too-many-ranks",
        &dam_break_text(),
        &["--fluid-ranks", &too_many],
    );
    for says in [
        format!("--fluid-ranks {too_many}: more ranks than the water can fill"),
        format!("at most {MOST_RANKS} ranks"),
        format!("Fix: --fluid-ranks {MOST_RANKS} or fewer"),
    ] {
        assert!(err.contains(&says), "{says}: {err}");
    }
}

/// Panics unless `names` in `b` equal those in `a` to the byte, naming the first difference.
fn assert_same_files(a: &Path, b: &Path, names: &[&str], what: &str) {
    for n in names {
        let (x, y) = (std::fs::read(a.join(n)).unwrap(), std::fs::read(b.join(n)));
        let y = y.unwrap_or_else(|e| panic!("{what}: {n}: {e}"));
        if let Some(diff) = first_difference(&x, &y) {
            panic!("{what}: {n} differs from one rank's, first at {diff}");
        }
    }
}

/// Starts scene `text` on 2 ranks with a checkpoint every 0.1 s (and `args`), and returns once
/// the first checkpoint is written: the run's id, directory, scene file and coupler.
fn checkpointing_on_two_ranks(
    tag: &str,
    text: &str,
    args: &[&str],
) -> (RunId, PathBuf, PathBuf, std::process::Child) {
    let (id, dir) = fresh(&format!("mpi-{tag}"));
    let scene = scene_file(&dir, text);
    let all: Vec<&str> = [
        scene.to_str().unwrap(),
        "--fluid-ranks",
        "2",
        "--checkpoint-interval",
        "0.1",
    ]
    .into_iter()
    .chain(args.iter().copied())
    .collect();
    let mut child = coupler(&id, &dir, &all)
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let checkpointed = eventually(Duration::from_secs(120), || {
        assert!(
            child.try_wait().unwrap().is_none(),
            "{tag}: the run ended before a checkpoint"
        );
        // A finished coupler file only: `coupler-*.ckpt.partial` is one still being written
        // (renamed into place when whole), and killing the run then leaves no checkpoint.
        std::fs::read_dir(dir.join("checkpoints")).is_ok_and(|d| {
            d.flatten().any(|e| {
                let name = e.file_name().to_string_lossy().into_owned();
                name.starts_with("coupler-") && name.ends_with(".ckpt")
            })
        })
    });
    assert!(checkpointed, "{tag}: no checkpoint within 120 s");
    (id, dir, scene, child)
}

/// The dam break run to `end` seconds.
fn longer(end: f64) -> String {
    fluid_node::validation::narrow_dam_break(end, 0.05)
}

#[test]
fn a_run_checkpointed_on_two_ranks_and_killed_resumes_on_three_to_the_same_bits() {
    let text = longer(0.4);
    // One rank, straight through.
    let one = run_scene("resume-one", &text, &[]);
    // Two ranks, a checkpoint every 0.1 s, the coupler killed after the first.
    let (id, dir, scene, mut child) = checkpointing_on_two_ranks("resume-two", &text, &[]);
    child.kill().unwrap();
    child.wait().unwrap();
    std::fs::remove_file(&scene).unwrap();
    // Resumed on three ranks.
    let out = run({
        let mut c = Command::new(bin("coupler"));
        c.args(["run", "--quiet", "--fluid-ranks", "3", "--resume"])
            .arg(&dir)
            .stdin(Stdio::null());
        c
    });
    assert!(out.status.success(), "resume: {}", stderr(&out));
    assert!(leftovers(&id).is_empty(), "shared memory left behind");
    let names = ["gauges.csv", "probes.csv", "particles_00008.vtp"];
    assert_same_files(&one, &dir, &names, "resumed on 3 ranks");
    std::fs::remove_dir_all(one).unwrap();
    std::fs::remove_dir_all(dir).unwrap();
}

#[test]
fn a_block_sliding_into_water_gives_the_same_bits_on_one_and_two_ranks() {
    // scenes/sliding_wedge.toml cut short: the wedge (an explicit-DDA block on a slope, two-way
    // coupled) is in the water within 0.3 s.
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../scenes/sliding_wedge.toml");
    let text = std::fs::read_to_string(path)
        .unwrap()
        .replace("end = 2.5", "end = 0.3")
        .replace("interval = 0.05", "interval = 0.1");
    let one = run_scene("wedge-1", &text, &[]);
    let two = run_scene("wedge-2", &text, &["--fluid-ranks", "2"]);
    let names = result_files(&one);
    assert!(names.iter().any(|n| n == "blocks.csv"), "{names:?}");
    let names: Vec<&str> = names.iter().map(String::as_str).collect();
    assert_same_files(&one, &two, &names, "2 ranks");
    let dirs = [one, two];
    for d in dirs {
        std::fs::remove_dir_all(d).unwrap();
    }
}

#[test]
fn a_rank_killed_under_retries_restarts_from_the_checkpoint_to_the_same_bits() {
    let text = longer(0.4);
    let one = run_scene("retries-one", &text, &[]);
    let (id, dir, scene, child) =
        checkpointing_on_two_ranks("retries-two", &text, &["--retries", "1"]);
    let pid = child.id();
    let launcher = children(pid)
        .into_iter()
        .find(|&c| cmdline(c).contains("mpirun"))
        .expect("the coupler's mpirun child");
    let follower = children(launcher)
        .into_iter()
        .find(|&p| mpi_rank(p) == Some(1))
        .expect("rank 1 under mpirun");
    unsafe_kill(follower, 9);
    let (out, _) = wait_output(child, Duration::from_secs(180));
    let err = stderr(&out);
    assert!(
        out.status.success(),
        "the retry did not finish the run: {err}"
    );
    assert!(err.contains("restart 1 of 1"), "{err}");
    assert!(leftovers(&id).is_empty(), "shared memory left behind");
    for n in ["gauges.csv", "probes.csv", "particles_00008.vtp"] {
        let (a, b) = (
            std::fs::read(one.join(n)).unwrap(),
            std::fs::read(dir.join(n)).unwrap(),
        );
        if let Some(diff) = first_difference(&a, &b) {
            panic!("{n}: the restarted run differs from one rank's, first at {diff}");
        }
    }
    std::fs::remove_file(&scene).unwrap();
    std::fs::remove_dir_all(one).unwrap();
    std::fs::remove_dir_all(dir).unwrap();
}
