//! Long runs lose nothing: checkpoints, `--resume` and `--retries` through all three processes.
//!
//! The coarse default wedge (`--dx 0.08 --end 0.4`, 8 frames, ~650 steps of WCSPH and explicit
//! DDA) with a checkpoint every 0.1 s. Every interrupted run below must end with
//! `gauges.csv`, `blocks.csv`, `probes.csv`, the .pvd series and every frame identical to the
//! byte to those of an uninterrupted run without checkpoints:
//! - parallel scheme: a run with checkpoints (checkpoints change nothing), and a run whose
//!   coupler is SIGKILLed after a checkpoint and that `coupler run --resume` finishes;
//! - serial scheme: a run with `--retries 1` whose fluid node is SIGKILLed (by pid) after a
//!   checkpoint: the coupler restarts both nodes from it and completes.
//!
//! And: a node that dies again at the same step stops the run, naming the cause (the node's
//! hidden `--die-at-step` hook); a killed fluid node loses at most one output interval of
//! `gauges.csv`; `--resume` refuses a run without a checkpoint and an edited scene.

mod common;
use common::*;
use shared::transport::RunId;
use std::path::{Path, PathBuf};
use std::process::{Child, Stdio};
use std::time::Duration;

const COARSE: [&str; 4] = ["--dx", "0.08", "--end", "0.4"];
const CHECKPOINTS: [&str; 2] = ["--checkpoint-interval", "0.1"];
const SERIAL: [&str; 2] = ["--scheme", "serial"];

fn spawn(id: &RunId, dir: &Path, args: &[&str]) -> Child {
    let mut cmd = coupler(id, dir, args);
    cmd.stdout(Stdio::piped()).stderr(Stdio::piped());
    cmd.spawn().expect("coupler starts")
}

/// `coupler run --resume DIR` (the directory is the output: no --out).
fn resume(dir: &Path) -> std::process::Command {
    let mut c = std::process::Command::new(bin("coupler"));
    c.args(["run", "--quiet", "--resume"])
        .arg(dir)
        .stdin(Stdio::null());
    c
}

/// Runs to the end and asserts success.
fn finish(child: Child, what: &str) -> String {
    let (out, took) = wait_output(child, Duration::from_secs(180));
    assert!(
        out.status.success(),
        "{what} failed after {took:?}: {}",
        stderr(&out)
    );
    stderr(&out)
}

/// Every result file of `b` equals `a`'s to the byte.
fn assert_identical(a: &Path, b: &Path, what: &str) {
    let names = result_files(a);
    assert!(
        names.len() > 10 && names.iter().any(|n| n == "gauges.csv"),
        "{what}: too few results in {}: {names:?}",
        a.display()
    );
    assert_eq!(names, result_files(b), "{what}: different sets of files");
    for n in &names {
        let (x, y) = (
            std::fs::read(a.join(n)).unwrap(),
            std::fs::read(b.join(n)).unwrap(),
        );
        if x != y {
            let at = x.iter().zip(&y).position(|(p, q)| p != q);
            panic!(
                "{what}: {n} differs between {} and {} (sizes {} and {}, first at byte {at:?})",
                a.display(),
                b.display(),
                x.len(),
                y.len()
            );
        }
    }
}

/// The step of the newest complete checkpoint of a run directory.
fn newest_checkpoint(dir: &Path) -> Option<u64> {
    std::fs::read_dir(dir.join("checkpoints"))
        .ok()?
        .flatten()
        .filter_map(|e| {
            let n = e.file_name().to_string_lossy().into_owned();
            n.strip_prefix("coupler-")?
                .strip_suffix(".ckpt")?
                .parse()
                .ok()
        })
        .max()
}

/// Waits for the run's first complete checkpoint.
fn await_checkpoint(dir: &Path) -> u64 {
    assert!(
        eventually(Duration::from_secs(60), || newest_checkpoint(dir).is_some()),
        "no checkpoint in {}",
        dir.display()
    );
    newest_checkpoint(dir).unwrap()
}

/// The pid of the coupler's fluid node.
fn fluid_node(coupler: u32) -> u32 {
    let mut pid = None;
    assert!(
        eventually(Duration::from_secs(20), || {
            pid = children(coupler)
                .into_iter()
                .find(|&p| cmdline(p).contains("fluid-node"));
            pid.is_some()
        }),
        "no fluid node under coupler {coupler}"
    );
    pid.unwrap()
}

fn cleanup(dirs: &[&PathBuf]) {
    for d in dirs {
        let _ = std::fs::remove_dir_all(d);
    }
}

/// SIGKILLs the coupler `child` (writing into `dir`) as soon as its first checkpoint is
/// complete: its nodes follow it (parent-death signal), and what they wrote after the
/// checkpoint must go. Returns the checkpoint's step.
fn kill_at_first_checkpoint(dir: &Path, child: Child) -> u64 {
    let step = await_checkpoint(dir);
    unsafe_kill(child.id(), 9);
    let (out, _) = wait_output(child, Duration::from_secs(30));
    assert!(!out.status.success());
    assert!(step > 0);
    step
}

/// `coupler run --resume dir` to the end, as run `label`; returns its run id.
fn resume_to_the_end(dir: &Path, label: &str) -> RunId {
    let (id, _) = fresh(label);
    let mut cmd = resume(dir);
    cmd.args(["--run-id", id.as_str()])
        .stdout(Stdio::piped())
        .stderr(Stdio::piped());
    let log = finish(cmd.spawn().unwrap(), "the resumed run");
    assert!(log.contains("resuming"), "{log}");
    id
}

/// The killed coupler could not clean up; its nodes left on its death (a later coupler
/// removes such files after a minute, `coupler clean` at once).
fn remove_killed_run(id: &RunId) {
    assert!(eventually(Duration::from_secs(10), || {
        !shared::transport::run_has_live_nodes(id)
    }));
    shared::transport::remove_run_files(id);
}

#[test]
fn parallel_checkpoints_change_nothing_and_a_killed_coupler_resumes_exactly() {
    let (id_a, a) = fresh("ckpt-reference");
    let (id_b, b) = fresh("ckpt-on");
    let (id_c, c) = fresh("ckpt-killed");
    let with = |extra: &[&'static str]| -> Vec<&'static str> {
        COARSE.iter().chain(extra).copied().collect()
    };
    let ra = spawn(&id_a, &a, &with(&[]));
    let rb = spawn(&id_b, &b, &with(&CHECKPOINTS));
    let rc = spawn(&id_c, &c, &with(&CHECKPOINTS));

    let step = kill_at_first_checkpoint(&c, rc);

    finish(ra, "the reference run");
    let log = finish(rb, "the run with checkpoints");
    assert!(!log.contains("warning"), "{log}");
    assert_identical(&a, &b, "checkpoints on against off");
    let s = summary(&b);
    assert_eq!(s["stats"]["checkpoints"], 3, "{s}");

    let id_r = resume_to_the_end(&c, "ckpt-resume");
    assert_identical(&a, &c, "killed and resumed against uninterrupted");
    let s = summary(&c);
    assert_eq!(s["status"], "completed");
    assert_eq!(s["stats"]["resumed_from_step"], step, "{s}");
    assert_eq!(s["stats"]["steps"], summary(&a)["stats"]["steps"]);
    for id in [&id_a, &id_b, &id_r] {
        assert!(
            leftovers(id).is_empty(),
            "shared memory of {id} left behind"
        );
    }
    remove_killed_run(&id_c);

    // --resume refuses what it cannot continue: an edited scene (named), no checkpoint.
    let scene = c.join("scene.toml");
    let text = std::fs::read_to_string(&scene).unwrap();
    std::fs::write(
        &scene,
        text.replacen("interval = 0.05", "interval = 0.1", 1),
    )
    .unwrap();
    let out = run(resume(&c));
    assert_eq!(out.status.code(), Some(1));
    assert!(
        stderr(&out).contains("scene.toml is not what the checkpoint"),
        "{}",
        stderr(&out)
    );
    std::fs::remove_dir_all(a.join("checkpoints")).ok();
    let out = run(resume(&a));
    assert_eq!(out.status.code(), Some(1));
    assert!(
        stderr(&out).contains("no complete checkpoint"),
        "{}",
        stderr(&out)
    );
    cleanup(&[&a, &b, &c]);
}

/// Checkpoints every few wall-clock milliseconds change nothing (against `--no-checkpoints`);
/// a `--resume` of a run directory while its run goes on is refused at once, naming the
/// directory and the running coupler's pid; nine flipped bits in the last solid checkpoint are
/// refused by name, with the checkpoint to fall back to, before anything is cut back.
#[test]
fn wall_clock_checkpoints_change_nothing_and_a_resume_is_refused_what_it_cannot_trust() {
    let (id_a, a) = fresh("ckpt-none");
    let (id_b, b) = fresh("ckpt-wall");
    let with = |extra: &[&'static str]| -> Vec<&'static str> {
        COARSE.iter().chain(extra).copied().collect()
    };
    let ra = spawn(&id_a, &a, &with(&["--no-checkpoints"]));
    let rb = spawn(&id_b, &b, &with(&["--checkpoint-wall-minutes", "0.0005"]));
    await_checkpoint(&b);
    let started = std::time::Instant::now();
    let out = run(resume(&b));
    let e = stderr(&out);
    assert_eq!(out.status.code(), Some(1), "{e}");
    assert!(
        e.contains(&format!(
            "'{}' is in use by a live coupler (pid {})",
            b.display(),
            rb.id()
        )),
        "{e}"
    );
    assert!(
        started.elapsed() < Duration::from_secs(5),
        "refused at once"
    );
    let log = finish(ra, "the run without checkpoints");
    assert!(log.contains("no checkpoints (--no-checkpoints)"), "{log}");
    finish(rb, "the run with wall-clock checkpoints");
    assert_identical(&a, &b, "wall-clock checkpoints against none");
    assert!(summary(&b)["stats"]["checkpoints"].as_u64().unwrap() >= 2);
    assert!(!a.join("checkpoints").exists());

    // Nine bits flipped in the last solid checkpoint: refused by name, nothing cut back.
    let step = newest_checkpoint(&b).unwrap();
    let solid = shared::checkpoint::node_file(&b, "solid", step);
    let mut bytes = std::fs::read(&solid).unwrap();
    for k in 0..9 {
        let at = bytes.len() / 2 + 7 * k;
        bytes[at] ^= 0x04;
    }
    std::fs::write(&solid, bytes).unwrap();
    let out = run(resume(&b));
    let e = stderr(&out);
    assert_eq!(out.status.code(), Some(1), "{e}");
    assert!(
        e.contains(&format!("'{}' is damaged", solid.display()))
            && e.contains("to continue from the checkpoint before it"),
        "{e}"
    );
    assert_identical(&a, &b, "a refused resume cuts nothing back");
    cleanup(&[&a, &b]);
}

/// DFSPH moving the wedge inside its solve, multi-rate: the solid's look-ahead (the wedge's
/// response over the coming step, sent with its geometry) is in the solid's checkpoint, so a
/// killed coupler resumes to the byte of the uninterrupted run (sent again as the block on its
/// own, the resumed run would part from it at once).
#[test]
fn dfsph_with_the_blocks_in_its_solve_resumes_exactly() {
    let (id_a, a) = fresh("ckpt-dfsph-reference");
    let (id_c, c) = fresh("ckpt-dfsph-killed");
    // To 0.6 s: the coarse wedge reaches the water at about 0.39 s.
    const DFSPH: [&str; 8] = [
        "--dx",
        "0.08",
        "--end",
        "0.6",
        "--fluid-solver",
        "dfsph",
        "--solid-substeps",
        "8",
    ];
    let with = |extra: &[&'static str]| -> Vec<&'static str> {
        DFSPH.iter().chain(extra).copied().collect()
    };
    let ra = spawn(&id_a, &a, &with(&[]));
    // At 0.45 s the wedge is in the water: a checkpoint before it gets there would not show
    // its motion inside the solve (measured: the look-ahead first changes blocks.csv at
    // t = 0.395 s).
    let rc = spawn(&id_c, &c, &with(&["--checkpoint-interval", "0.45"]));
    let step = kill_at_first_checkpoint(&c, rc);
    finish(ra, "the reference run");
    let id_r = resume_to_the_end(&c, "ckpt-dfsph-resume");
    assert_identical(&a, &c, "DFSPH, killed and resumed against uninterrupted");
    assert_eq!(summary(&c)["stats"]["resumed_from_step"], step);
    for id in [&id_a, &id_r] {
        assert!(
            leftovers(id).is_empty(),
            "shared memory of {id} left behind"
        );
    }
    remove_killed_run(&id_c);
    cleanup(&[&a, &c]);
}

#[test]
fn serial_a_killed_fluid_node_is_restarted_and_the_run_ends_as_if_nothing_happened() {
    let (id_a, a) = fresh("retry-reference");
    let (id_d, d) = fresh("retry-killed");
    let args: Vec<&str> = COARSE.iter().chain(&SERIAL).copied().collect();
    let ra = spawn(&id_a, &a, &args);
    let mut with: Vec<&str> = args.clone();
    with.extend(CHECKPOINTS);
    with.extend(["--retries", "1"]);
    let rd = spawn(&id_d, &d, &with);

    await_checkpoint(&d);
    let fluid = fluid_node(rd.id());
    unsafe_kill(fluid, 9);

    finish(ra, "the reference run");
    let log = finish(rd, "the run with a killed fluid node");
    assert!(
        log.contains("killed by signal 9") && log.contains("restart 1 of 1"),
        "{log}"
    );
    assert_identical(
        &a,
        &d,
        "a restarted fluid node against an uninterrupted run",
    );
    let s = summary(&d);
    assert_eq!(s["stats"]["restarts"], 1, "{s}");
    for id in [&id_a, &id_d] {
        assert!(
            leftovers(id).is_empty(),
            "shared memory of {id} left behind"
        );
    }
    cleanup(&[&a, &d]);
}

#[test]
fn a_node_that_dies_again_at_the_same_step_stops_the_run_with_its_cause() {
    let (id, dir) = fresh("retry-again");
    let fluid = format!("{} --die-at-step 40", bin("fluid-node").display());
    let out = run(coupler(
        &id,
        &dir,
        &[
            "--dx",
            "0.08",
            "--end",
            "0.1",
            "--checkpoint-interval",
            "0.02",
            "--retries",
            "3",
            "--fluid-cmd",
            &fluid,
        ],
    ));
    let err = stderr(&out);
    assert_eq!(out.status.code(), Some(3), "{err}");
    assert!(err.contains("restart 1 of 3"), "{err}");
    assert!(!err.contains("restart 2 of 3"), "{err}");
    let s = summary(&dir);
    let msg = s["message"].as_str().unwrap();
    assert!(
        msg.contains("fluid node")
            && msg.contains("died at step 40")
            && msg.contains("SIGKILL")
            && msg.contains("again, after a restart from step"),
        "{msg}"
    );
    assert_eq!(s["status"], "failed");
    assert!(leftovers(&id).is_empty());
    cleanup(&[&dir]);
}

#[test]
fn a_killed_fluid_node_loses_at_most_one_output_interval_of_gauges() {
    let (id, dir) = fresh("flush");
    let child = spawn(&id, &dir, &COARSE);
    // After frame 3 (t = 0.15 s) the fluid node dies without a chance to flush anything.
    assert!(
        eventually(Duration::from_secs(60), || dir
            .join("particles_00003.vtp")
            .exists()),
        "no frame 3"
    );
    let fluid = fluid_node(child.id());
    unsafe_kill(fluid, 9);
    let (out, _) = wait_output(child, Duration::from_secs(30));
    assert_eq!(out.status.code(), Some(3), "{}", stderr(&out));
    let rows: Vec<f64> = std::fs::read_to_string(dir.join("gauges.csv"))
        .unwrap()
        .lines()
        .skip(1)
        .map(|l| l.split(',').next().unwrap().parse().unwrap())
        .collect();
    let last = rows.last().copied().unwrap_or(0.0);
    let reached = summary(&dir)["stats"]["time"].as_f64().unwrap();
    // Rows are sampled every output.interval / 50 = 1 ms at most: the last one before frame 3
    // may lie up to that before it.
    assert!(
        last >= 0.15 - 0.001 - 1e-9 && reached - last <= 0.05 + 1e-9,
        "gauges.csv ends at t = {last} s, the run reached {reached} s"
    );
    assert!(leftovers(&id).is_empty());
    cleanup(&[&dir]);
}

#[test]
fn a_node_that_hangs_again_at_the_same_step_stops_the_run_and_wall_clock_checkpoints_are_taken() {
    // The hidden --hang-after-steps hook: the node stops answering from step 80 on, at every
    // start; the coupler declares it hung after --step-timeout, restarts it once, and stops.
    // A wall-clock checkpoint every 6 ms is surely taken within 80 steps (each step is more
    // than 0.1 ms of work even at this resolution).
    let (id, dir) = fresh("retry-hang");
    let fluid = format!("{} --hang-after-steps 80", bin("fluid-node").display());
    let out = run(coupler(
        &id,
        &dir,
        &[
            "--dx",
            "0.08",
            "--end",
            "0.3",
            "--checkpoint-wall-minutes",
            "0.0001",
            "--retries",
            "1",
            "--step-timeout",
            "1",
            "--fluid-cmd",
            &fluid,
        ],
    ));
    let err = stderr(&out);
    assert_eq!(out.status.code(), Some(3), "{err}");
    assert!(
        err.contains("hung at step 80") && err.contains("restart 1 of 1"),
        "{err}"
    );
    let s = summary(&dir);
    let msg = s["message"].as_str().unwrap();
    assert!(
        msg.contains("hung at step 80") && msg.contains("again"),
        "{msg}"
    );
    // A checkpoint every 6 ms of wall time: there was one to go back to.
    assert!(s["stats"]["checkpoints"].as_u64().unwrap() >= 1, "{s}");
    assert!(s["stats"]["resumed_from_step"].as_u64().unwrap() > 0, "{s}");
    assert!(leftovers(&id).is_empty());
    cleanup(&[&dir]);
}
