//! Determinism through all three processes: the same scene, run several times at once (each run
//! with its own run id, shared memory and output directory), writes byte-identical results.
//!
//! Three configurations of the embedded default scene (the paper's sliding wedge), coarse:
//! WCSPH + explicit DDA + parallel coupling three times, Müller SPH + Shi's implicit DDA +
//! serial coupling twice, and DFSPH moving the wedge in its solve with the solid sub-cycled
//! twice, all seven runs at the same time on a machine with fewer cores than processes. Between the runs of one configuration, `gauges.csv`, `blocks.csv`, `probes.csv`,
//! the `.pvd` collections and every `particles_*.vtp` / `blocks_*.vtp` frame must be identical
//! to the byte; a difference names the first differing file, line and column.

mod common;
use common::*;
use shared::transport::RunId;
use std::path::{Path, PathBuf};
use std::time::Duration;

/// Coarse and short: a few seconds of wall time per run, long enough for the wedge to slide
/// ~0.14 m and push the water (7 output frames at the scene's 0.05 s interval).
const COARSE: [&str; 4] = ["--dx", "0.08", "--end", "0.3"];

struct Config {
    name: &'static str,
    args: &'static [&'static str],
    copies: usize,
}

const CONFIGS: [Config; 3] = [
    Config {
        name: "wcsph-explicit-parallel",
        args: &[],
        copies: 3,
    },
    Config {
        name: "muller-implicit-serial",
        args: &[
            "--fluid-solver",
            "muller",
            "--solid-solver",
            "implicit",
            "--scheme",
            "serial",
        ],
        copies: 2,
    },
    // DFSPH moving the wedge inside its pressure solve, the solid sub-cycling: the loads follow
    // the fluid's step, and the block sums run in a fixed order.
    Config {
        name: "dfsph-blocks-in-solve-multi-rate",
        args: &["--fluid-solver", "dfsph", "--solid-substeps", "8"],
        copies: 2,
    },
];

/// One launched run.
struct Run {
    config: usize,
    id: RunId,
    dir: PathBuf,
}

/// Data rows of a CSV file (the header is not counted).
fn csv_rows(path: &Path) -> Vec<Vec<String>> {
    let text = std::fs::read_to_string(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    text.lines()
        .skip(1)
        .map(|l| l.split(',').map(String::from).collect())
        .collect()
}

/// The results are not trivially equal: rows were written, frames hold particles, and the
/// wedge moved.
fn assert_nontrivial(run: &Run) {
    let dir = &run.dir;
    let name = CONFIGS[run.config].name;
    for f in ["gauges.csv", "blocks.csv"] {
        let rows = csv_rows(&dir.join(f)).len();
        assert!(rows > 1, "{name}: {f} has {rows} data rows");
    }
    let files = result_files(dir);
    for prefix in ["particles_", "blocks_"] {
        let frames = files.iter().filter(|n| n.starts_with(prefix)).count();
        assert!(frames >= 2, "{name}: {frames} {prefix}*.vtp frames");
    }
    // The XML header is text even when the frame's data is binary.
    let frame = String::from_utf8_lossy(&std::fs::read(dir.join("particles_00000.vtp")).unwrap())
        .into_owned();
    let points: usize = frame
        .split("NumberOfPoints=\"")
        .nth(1)
        .and_then(|s| s.split('"').next())
        .and_then(|n| n.parse().ok())
        .expect("NumberOfPoints in particles_00000.vtp");
    assert!(points > 1000, "{name}: {points} particles");
    // blocks.csv: time,block,x,y,z,...; the wedge's centroid from the first to the last row.
    let rows: Vec<Vec<String>> = csv_rows(&dir.join("blocks.csv"))
        .into_iter()
        .filter(|r| r[1] == "wedge")
        .collect();
    let xz = |r: &Vec<String>| -> (f64, f64) { (r[2].parse().unwrap(), r[4].parse().unwrap()) };
    let (first, last) = (xz(&rows[0]), xz(rows.last().unwrap()));
    let moved = ((last.0 - first.0).powi(2) + (last.1 - first.1).powi(2)).sqrt();
    assert!(moved > 0.05, "{name}: the wedge moved only {moved} m");
}

#[test]
fn concurrent_runs_of_the_same_scene_write_identical_files() {
    // Launch every run of both configurations at once.
    let mut runs = Vec::new();
    let mut children = Vec::new();
    for (k, config) in CONFIGS.iter().enumerate() {
        for copy in 0..config.copies {
            let (id, dir) = fresh(&format!("determinism-{}-{copy}", config.name));
            let args: Vec<&str> = COARSE.iter().chain(config.args).copied().collect();
            let mut cmd = coupler(&id, &dir, &args);
            cmd.stdout(std::process::Stdio::piped())
                .stderr(std::process::Stdio::piped());
            children.push(cmd.spawn().expect("coupler starts"));
            runs.push(Run { config: k, id, dir });
        }
    }
    for (child, run) in children.into_iter().zip(&runs) {
        let (out, took) = wait_output(child, Duration::from_secs(120));
        assert!(
            out.status.success(),
            "{} run {} failed after {took:?}: {}",
            CONFIGS[run.config].name,
            run.id,
            stderr(&out)
        );
        assert!(leftovers(&run.id).is_empty(), "shared memory left behind");
    }

    for (k, config) in CONFIGS.iter().enumerate() {
        let same: Vec<&Run> = runs.iter().filter(|r| r.config == k).collect();
        let reference = same[0];
        assert_nontrivial(reference);
        let names = result_files(&reference.dir);
        for n in [
            "gauges.csv",
            "blocks.csv",
            "particles_00000.vtp",
            "blocks_00000.vtp",
        ] {
            assert!(
                names.iter().any(|m| m == n),
                "{}: {n} not written",
                config.name
            );
        }
        for other in &same[1..] {
            assert_eq!(
                result_files(&other.dir),
                names,
                "{}: runs {} and {} wrote different sets of files",
                config.name,
                reference.id,
                other.id
            );
            for n in &names {
                let a = std::fs::read(reference.dir.join(n)).unwrap();
                let b = std::fs::read(other.dir.join(n)).unwrap();
                if let Some(diff) = first_difference(&a, &b) {
                    panic!(
                        "{}: {n} differs between {} and {}, first at {diff}",
                        config.name,
                        reference.dir.display(),
                        other.dir.display()
                    );
                }
            }
            // The step count and step sizes agree as well (summary.json also holds wall times).
            let (sa, sb) = (summary(&reference.dir), summary(&other.dir));
            for key in ["steps", "frames", "dt_min", "dt_max"] {
                assert_eq!(
                    sa["stats"][key], sb["stats"][key],
                    "{}: summary.json stats.{key}",
                    config.name
                );
            }
        }
    }
    for run in &runs {
        std::fs::remove_dir_all(&run.dir).unwrap();
    }
}

#[test]
fn first_difference_names_line_and_column() {
    assert_eq!(first_difference(b"a\nb\n", b"a\nb\n"), None);
    let d = first_difference(b"t,x\n0.1,2.5\n", b"t,x\n0.1,2.6\n").unwrap();
    assert!(d.starts_with("line 2, column 7"), "{d}");
    assert!(d.contains("0.1,2.5") && d.contains("0.1,2.6"), "{d}");
    let d = first_difference(b"a\nb\n", b"a\nb\nc\n").unwrap();
    assert!(d.starts_with("line 3, column 1"), "{d}");
}
