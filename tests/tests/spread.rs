//! `coupler spread` end to end: every member is a real coupled run, the base member is the
//! scene's own run to the byte, and a misspelt key stops the spread before any run starts.

mod common;

use common::{bin, fresh};
use std::process::{Command, Stdio};

/// The default scene, coarse and short: a second per run.
const COARSE: [&str; 4] = ["--dx", "0.08", "--end", "0.3"];

fn spread(out: &std::path::Path, args: &[&str]) -> std::process::Output {
    Command::new(bin("coupler"))
        .arg("spread")
        .args(args)
        .arg("--out")
        .arg(out)
        .arg("--")
        .args(COARSE)
        .stdin(Stdio::null())
        .output()
        .expect("coupler starts")
}

#[test]
fn a_spread_runs_its_members_and_its_base_is_the_scenes_own_run() {
    let (_, out) = fresh("spread");
    let o = spread(
        &out,
        &[
            "--vary",
            "fluid.wcsph.alpha=0,0.05",
            "--window",
            "G1=0.1:0.3",
        ],
    );
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let csv = std::fs::read_to_string(out.join("spread.csv")).unwrap();
    let rows: Vec<Vec<&str>> = csv.lines().map(|l| l.split(',').collect()).collect();
    assert_eq!(
        rows[0][..7],
        ["member", "key", "value", "status", "steps", "wall_s", "G1"]
    );
    assert_eq!(rows.len(), 4, "base and two members:\n{csv}");
    for r in &rows[1..] {
        assert_eq!(r[3], "completed", "{csv}");
    }
    let g1: Vec<f64> = rows[1..].iter().map(|r| r[6].parse().unwrap()).collect();
    assert!(
        g1.iter().all(|&c| c > 0.0),
        "every member reads a crest: {g1:?}"
    );
    assert_ne!(g1[1], g1[2], "α changes the run: {g1:?}");

    // The base member is `coupler run` of the scene as written: the same gauges to the byte.
    let (id, plain) = fresh("spread-plain");
    let run = common::coupler(&id, &plain, &COARSE).output().unwrap();
    assert!(
        run.status.success(),
        "{}",
        String::from_utf8_lossy(&run.stderr)
    );
    assert_eq!(
        std::fs::read(plain.join("gauges.csv")).unwrap(),
        std::fs::read(out.join("runs/00/gauges.csv")).unwrap()
    );
    let table = std::fs::read_to_string(out.join("spread.md")).unwrap();
    assert!(table.contains("| G1 | 0.1–0.3 |"), "{table}");
    std::fs::remove_dir_all(&out).ok();
    std::fs::remove_dir_all(&plain).ok();
}

#[test]
fn a_misspelt_key_or_gauge_is_named_before_any_run_starts() {
    let (_, out) = fresh("spread-bad");
    let o = spread(&out, &["--vary", "fluid.wcsph.alpah=0,0.02"]);
    assert!(!o.status.success());
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(err.contains("alpah"), "the key is named: {err}");
    assert!(left_nothing(&out), "no run started, nothing left in --out");
    std::fs::remove_dir_all(&out).ok();

    let (_, out) = fresh("spread-bad-window");
    let o = spread(
        &out,
        &["--vary", "fluid.wcsph.alpha=0", "--window", "G9=0.1:0.3"],
    );
    assert!(!o.status.success());
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(
        err.contains("no gauge 'G9'") && err.contains("G1, G2, G3, G4"),
        "the window's gauge is named with the scene's: {err}"
    );
    assert!(left_nothing(&out));
    std::fs::remove_dir_all(&out).ok();
}

/// A spread refused before its first run takes back what it wrote: `out` is gone (the spread
/// made it) or empty.
fn left_nothing(out: &std::path::Path) -> bool {
    std::fs::read_dir(out).map_or(true, |mut d| d.next().is_none())
}
