//! Multi-rate coupling (`--solid-substeps N`): the solid node takes up to N steps of its own
//! inside each coupling step, with the water's loads held, and proposes N times its stable
//! step, so the solid's stability limit no longer binds the shared step. Checked through the
//! whole system (real coupler and nodes): the results are those of single-rate within the
//! cases' tolerances, with fewer coupling steps where the solid bound them.

mod common;

use common::*;
use std::path::Path;

/// The last row of blocks.csv for `block`: (time, x, y, z).
fn last_position(dir: &Path, block: &str) -> [f64; 4] {
    let text = std::fs::read_to_string(dir.join("blocks.csv")).expect("blocks.csv");
    let row = text
        .lines()
        .rev()
        .find(|l| l.split(',').nth(1) == Some(block))
        .expect("rows of the block");
    let v: Vec<f64> = row
        .split(',')
        .map(|c| c.parse().unwrap_or(f64::NAN))
        .collect();
    [v[0], v[2], v[3], v[4]]
}

fn steps(dir: &Path) -> u64 {
    summary(dir)["stats"]["steps"].as_u64().expect("steps")
}

/// Runs `args` with `--solid-substeps n`; returns the output directory.
fn run_with(tag: &str, args: &[&str], n: u32) -> std::path::PathBuf {
    let (id, out) = fresh(tag);
    let n = n.to_string();
    let mut all = args.to_vec();
    all.extend(["--solid-substeps", &n]);
    let o = run(coupler(&id, &out, &all));
    assert!(
        o.status.success(),
        "{tag} with {n} substeps: {}",
        stderr(&o)
    );
    assert!(leftovers(&id).is_empty());
    out
}

/// A block sliding down a 30° incline with φ = 20°, dry (no fluid node): the solid binds every
/// coupling step single-rate; with 8 substeps the coupling step is 8 times longer, and
/// the distance still follows d(t) = ½ g (sin α − cos α tan φ) t² within the 0.5 % the
/// verification table allows.
#[test]
fn a_sliding_block_gives_the_same_distance_in_fewer_coupling_steps() {
    let incline = solid_node::verification::Incline {
        alpha: 30.0,
        phi: 20.0,
        cohesion: 0.0,
        b: 0.4,
        h: 0.2,
    };
    let dir = tempfile::Builder::new()
        .prefix("rockwave-multirate-")
        .tempdir()
        .unwrap();
    let file = dir.path().join("incline.toml");
    let mut scene = incline.scene();
    scene.time.end = 1.0;
    // Let the coupling step grow past the scene's usual 1 ms cap.
    scene.time.dt_max = 0.01;
    std::fs::write(&file, toml::to_string(&scene).unwrap()).unwrap();
    let args = [file.to_str().unwrap()];
    let (single, multi) = (
        run_with("incline1", &args, 1),
        run_with("incline8", &args, 8),
    );
    let start = {
        let text = std::fs::read_to_string(single.join("blocks.csv")).unwrap();
        let row: Vec<f64> = text
            .lines()
            .nth(1)
            .unwrap()
            .split(',')
            .map(|c| c.parse().unwrap_or(f64::NAN))
            .collect();
        [row[2], row[3], row[4]]
    };
    let down = incline.downhill();
    let reference = incline.reference_distance(1.0);
    for out in [&single, &multi] {
        let end = &summary(out)["final_block_positions"]["rock"];
        let [x, y, z] = [0, 1, 2].map(|k| end[k].as_f64().expect("final position"));
        let d = (x - start[0]) * down.x + (y - start[1]) * down.y + (z - start[2]) * down.z;
        let error = (d - reference).abs() / reference;
        assert!(
            error < 0.005,
            "{}: d(1 s) = {d:.5} m against {reference:.5} m ({:.3} %)",
            out.display(),
            100.0 * error
        );
    }
    let (n1, n8) = (steps(&single), steps(&multi));
    assert!(
        n8 * 3 < n1,
        "coupling steps: {n1} single-rate, {n8} with 8 substeps"
    );
    for d in [single, multi] {
        let _ = std::fs::remove_dir_all(d);
    }
}

/// The paper's wedge (embedded default scene), coarse: sub-cycling the solid changes the wedge's
/// position at 0.5 s by far less than the coarse run's own resolution, and the crest at the
/// gauges by less than 10 % (the acceptance band of a wave against a reference run).
#[test]
fn the_coarse_wedge_is_the_same_multi_rate() {
    let args = ["--dx", "0.08", "--end", "0.5"];
    let (single, multi) = (run_with("wedge1", &args, 1), run_with("wedge8", &args, 8));
    let a = last_position(&single, "wedge");
    let b = last_position(&multi, "wedge");
    let gap = ((a[1] - b[1]).powi(2) + (a[3] - b[3]).powi(2)).sqrt();
    assert!(
        gap < 1e-3,
        "wedge positions {a:?} and {b:?} differ by {gap} m"
    );
    let (s1, s8) = (summary(&single), summary(&multi));
    for (name, g) in s1["gauges"].as_object().unwrap() {
        // A gauge that stayed dry has no crest: 0 on both sides then.
        let crest = |g: &serde_json::Value| g["crest"]["amount"].as_f64().unwrap_or(0.0);
        let (c1, c8) = (crest(g), crest(&s8["gauges"][name]));
        assert!(
            (c1 - c8).abs() <= 0.1 * c1.abs().max(0.005),
            "gauge {name}: crest {c1} single-rate, {c8} multi-rate"
        );
    }
    assert!(steps(&multi) <= steps(&single));
    for d in [single, multi] {
        let _ = std::fs::remove_dir_all(d);
    }
}
