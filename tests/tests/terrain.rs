//! A scene with a `[[terrain]]` (scenes/fjord.toml: a DEM valley, a jointed slide, water) through
//! all three processes: two runs at once write byte-identical results, and a run whose coupler
//! is SIGKILLed after a checkpoint and resumed ends identical to the uninterrupted one (the
//! terrain is not checkpointed: every node reads it again from the scene's file).

mod common;
use common::*;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::time::Duration;

fn fjord() -> String {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../scenes/fjord.toml")
        .display()
        .to_string()
}

fn spawn(id: &shared::transport::RunId, dir: &Path, extra: &[&str]) -> Child {
    let scene = fjord();
    let mut args = vec![scene.as_str(), "--end", "0.6"];
    args.extend_from_slice(extra);
    let mut cmd = coupler(id, dir, &args);
    cmd.stdout(Stdio::piped()).stderr(Stdio::piped());
    cmd.spawn().expect("coupler starts")
}

fn finish(child: Child, what: &str) {
    let (out, took) = wait_output(child, Duration::from_secs(180));
    assert!(
        out.status.success(),
        "{what} failed after {took:?}: {}",
        stderr(&out)
    );
}

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

fn assert_identical(a: &Path, b: &Path, what: &str) {
    let names = result_files(a);
    assert!(
        names.iter().any(|n| n == "gauges.csv") && names.iter().any(|n| n == "blocks.csv"),
        "{what}: {names:?}"
    );
    assert_eq!(names, result_files(b), "{what}: different sets of files");
    for n in &names {
        let (x, y) = (
            std::fs::read(a.join(n)).unwrap(),
            std::fs::read(b.join(n)).unwrap(),
        );
        assert!(
            x == y,
            "{what}: {n} differs between {} and {}",
            a.display(),
            b.display()
        );
    }
}

#[test]
fn terrain_runs_are_deterministic_and_resume_exactly() {
    let (id_a, a) = fresh("terrain-a");
    let (id_b, b) = fresh("terrain-b");
    let (id_c, c) = fresh("terrain-killed");
    let ra = spawn(&id_a, &a, &[]);
    let rb = spawn(&id_b, &b, &[]);
    let rc = spawn(&id_c, &c, &["--checkpoint-interval", "0.2"]);
    assert!(
        eventually(Duration::from_secs(90), || newest_checkpoint(&c).is_some()),
        "no checkpoint in {}",
        c.display()
    );
    unsafe_kill(rc.id(), 9);
    let (out, _) = wait_output(rc, Duration::from_secs(30));
    assert!(!out.status.success());
    finish(ra, "run a");
    finish(rb, "run b");
    assert_identical(&a, &b, "two runs of the fjord");
    // The slide moved: the solid node read the terrain and the blocks slid on it.
    let blocks = std::fs::read_to_string(a.join("blocks.csv")).unwrap();
    assert!(blocks.lines().count() > 5, "{blocks}");

    assert!(eventually(Duration::from_secs(10), || {
        !shared::transport::run_has_live_nodes(&id_c)
    }));
    shared::transport::remove_run_files(&id_c);
    let (id_r, _) = fresh("terrain-resume");
    let mut cmd = std::process::Command::new(bin("coupler"));
    cmd.args(["run", "--quiet", "--run-id", id_r.as_str(), "--resume"])
        .arg(&c)
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped());
    finish(cmd.spawn().unwrap(), "the resumed run");
    assert_identical(&a, &c, "killed and resumed against uninterrupted");
    for d in [&a, &b, &c] as [&PathBuf; 3] {
        let _ = std::fs::remove_dir_all(d);
    }
}

/// The size estimate `coupler check` and `coupler run` print before anything is allocated
/// counts the terrain: the water under the ground is left out and the boundary particles under
/// the terrain surface are counted. Both within 1.5× of what the fluid node then creates for
/// the coarse fjord (measured 1.98e4 estimated against 17 873 water particles, 2.23e4 against
/// 22 043 boundary; before, 6.50e4 and 6.50e4 from the water box and the domain's walls).
#[test]
fn the_size_estimate_counts_the_terrain() {
    let (id, dir) = fresh("terrain-estimate");
    let scene = fjord();
    let out = run(coupler(&id, &dir, &[scene.as_str(), "--end", "0.02"]));
    assert!(out.status.success(), "{}", stderr(&out));
    let err = stderr(&out);
    let line = err
        .lines()
        .find(|l| l.contains("estimate:"))
        .unwrap_or_else(|| panic!("no estimate line: {err}"));
    let numbers: Vec<f64> = line
        .split_whitespace()
        .filter_map(|w| w.parse().ok())
        .collect();
    let (water, boundary) = (numbers[0], numbers[1]);
    let made: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.join("fluid.json")).unwrap()).unwrap();
    let count = |k: &str| made[k].as_f64().unwrap_or_else(|| panic!("{k} in {made}"));
    for (what, estimated, actual) in [
        ("water", water, count("particles")),
        ("boundary", boundary, count("boundary_particles_fixed")),
    ] {
        let ratio = estimated / actual;
        assert!(
            (1.0 / 1.5..1.5).contains(&ratio),
            "{what}: estimated {estimated:.3e}, made {actual}: {line}"
        );
    }
    let _ = std::fs::remove_dir_all(&dir);
}

/// `coupler check --dx` estimates the scene at another spacing: half the fjord's dx holds about
/// 8× the water (3D), and what each fluid rank would hold follows (said also by a check that
/// then refuses the ranks, on a fluid node built without MPI); a spacing that is no length is
/// refused naming the flag.
#[test]
fn check_estimates_the_scene_at_another_dx() {
    let scene = fjord();
    let water = |dx: Option<&str>| {
        let mut args = vec!["check", scene.as_str(), "--fluid-ranks", "2"];
        args.extend(dx.map(|d| ["--dx", d]).into_iter().flatten());
        let out = Command::new(bin("coupler")).args(&args).output().unwrap();
        let text = String::from_utf8_lossy(&out.stdout).into_owned();
        let without_mpi = stderr(&out).contains("cannot run as 2 MPI ranks: built without MPI");
        assert!(
            out.status.success() || without_mpi,
            "{args:?}: {}",
            stderr(&out)
        );
        assert!(text.contains("on 2 fluid ranks"), "{text}");
        let line = text.lines().find(|l| l.starts_with("estimate:")).unwrap();
        line.split_whitespace()
            .find_map(|w| w.parse::<f64>().ok())
            .unwrap()
    };
    let ratio = water(Some("2")) / water(None);
    assert!(
        (6.0..10.0).contains(&ratio),
        "water at dx = 2 m over 4 m: {ratio}"
    );
    let out = Command::new(bin("coupler"))
        .args(["check", scene.as_str(), "--dx", "0"])
        .output()
        .unwrap();
    assert!(!out.status.success());
    assert!(
        stderr(&out).contains("--dx 0: must be a positive length in metres"),
        "{}",
        stderr(&out)
    );
}
