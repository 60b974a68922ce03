//! Each method fails where theory says it does, and the failure is caught and named rather than
//! written out (the theory: docs/REFERENCES.md §4); and a scene runs only the nodes it needs.
//! Every run here is a real `coupler run` with real nodes; the stepping is pushed with
//! `--dt-factor`.
//!
//! - explicit DDA: the central-difference scheme diverges above ω·dt = 2. Its proposal is
//!   0.5 · 2/ω_max, so dt × 1.5 (ω·dt = 1.5) must complete and dt × 3 (ω·dt = 3) must stop with
//!   exit code 2 and a message naming the solid node, the explicit solver and the energy growth.
//! - SPH: WCSPH's proposal is the CFL step 0.2·h/(c + v); × 10 puts sound across more than a
//!   smoothing length per step, which must be caught (density ratio, NaN or domain) and named.
//! - Müller's linear EOS made too soft: a warning with the measured compression, run completed.
//! - Light blocks under explicit partitioned coupling (both schemes lag the loads one step):
//!   the floating block at ρ_b/ρ_w = 0.001 must be stopped as an added-mass instability, by
//!   name, before anything flies off; at 0.05 it floats.
//!
//! A dry scene runs no fluid node and a scene without moving blocks no solid node: the tests
//! give the absent node a command that does not exist, and the run must still succeed.

mod common;

use common::*;
use std::path::{Path, PathBuf};

/// Writes `text` as a scene file in a fresh temporary directory.
fn scene_file(tag: &str, text: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!(
        "rockwave-limits-{tag}-{}",
        shared::transport::RunId::fresh()
    ));
    std::fs::create_dir_all(&dir).unwrap();
    let p = dir.join("scene.toml");
    std::fs::write(&p, text).unwrap();
    p
}

/// A 0.2 × 0.2 × 0.4 m rock resting on a floor on undamped springs, no water.
const DRY_RESTING: &str = r#"
name = "dry_resting"
[time]
end = 0.5
dt_max = 0.05
[domain]
min = [-1.0, -1.0, -1.0]
max = [1.0, 1.0, 1.0]
[output]
interval = 0.1
vtk = false
[solid]
solver = "explicit"
[solid.contact]
normal_stiffness = 1e6
shear_ratio = 0.0
[[block]]
name = "floor"
kind = "fixed"
shape = { type = "box", min = [-1.0, -1.0, -0.5], max = [1.0, 1.0, 0.0] }
[[block]]
name = "rock"
kind = "free"
shape = { type = "box", min = [-0.1, -0.1, 0.0], max = [0.1, 0.1, 0.4] }
"#;

/// A small dam break in a slab tank, all walls fixed: no moving blocks.
fn dam_break(solver: &str, extra: &str) -> String {
    format!(
        r#"
name = "small_dam_break"
[time]
end = 0.15
[domain]
min = [-0.05, -0.05, -0.05]
max = [0.45, 0.09, 0.5]
[output]
interval = 0.05
vtk = false
[fluid]
solver = "{solver}"
dx = 0.01
{extra}
[[fluid.water]]
shape = {{ type = "box", min = [0.0, 0.0, 0.0], max = [0.1, 0.04, 0.2] }}
[[block]]
name = "floor"
kind = "fixed"
shape = {{ type = "box", min = [-0.05, -0.05, -0.05], max = [0.45, 0.09, 0.0] }}
[[block]]
name = "left"
kind = "fixed"
shape = {{ type = "box", min = [-0.05, -0.05, -0.05], max = [0.0, 0.09, 0.5] }}
[[block]]
name = "right"
kind = "fixed"
shape = {{ type = "box", min = [0.4, -0.05, -0.05], max = [0.45, 0.09, 0.5] }}
[[block]]
name = "south"
kind = "fixed"
shape = {{ type = "box", min = [-0.05, -0.05, -0.05], max = [0.45, 0.0, 0.5] }}
[[block]]
name = "north"
kind = "fixed"
shape = {{ type = "box", min = [-0.05, 0.04, -0.05], max = [0.45, 0.09, 0.5] }}
[[gauge]]
name = "g"
x = 0.05
y = 0.02
"#
    )
}

/// No file of the run holds a NaN or an infinity: a failure is reported, never written out.
fn assert_no_nan(dir: &Path) {
    for e in std::fs::read_dir(dir).unwrap().flatten() {
        let p = e.path();
        if p.extension().is_some_and(|x| x == "vtp") {
            // Binary frames hold raw bytes: read the values back and look at them.
            let frame = shared::vtk::read_vtp(&p).unwrap();
            for a in &frame.arrays {
                assert!(
                    a.values.to_f64().iter().all(|v| v.is_finite()),
                    "{} holds a NaN or an infinity in {}",
                    p.display(),
                    a.name
                );
            }
        }
        if p.extension().is_some_and(|x| x == "csv") {
            let text = String::from_utf8_lossy(&std::fs::read(&p).unwrap()).to_lowercase();
            assert!(
                !text.contains("nan") && !text.contains("inf,") && !text.contains(",inf"),
                "{} holds a NaN or an infinity",
                p.display()
            );
        }
    }
}

fn run_scene(
    tag: &str,
    scene: &Path,
    args: &[&str],
) -> (shared::transport::RunId, PathBuf, std::process::Output) {
    let (id, out) = fresh(tag);
    let mut all = vec![scene.to_str().unwrap()];
    all.extend_from_slice(args);
    let o = run(coupler(&id, &out, &all));
    (id, out, o)
}

#[test]
fn explicit_dda_fails_past_omega_dt_two_and_says_so() {
    let scene = scene_file("dda", DRY_RESTING);
    // No water: the fluid node is never started, so a missing fluid executable does not matter.
    let absent = "--fluid-cmd=/nonexistent/fluid-node";
    let (id, out, o) = run_scene("dda-ok", &scene, &["--dt-factor", "1.5", absent]);
    assert!(o.status.success(), "ω·dt = 1.5 must run: {}", stderr(&o));
    let s = summary(&out);
    assert_eq!(s["status"], "completed");
    assert!(
        s["fluid_solver"].is_null(),
        "a dry scene ran a fluid node: {s}"
    );
    assert!(leftovers(&id).is_empty());
    let _ = std::fs::remove_dir_all(&out);

    let (id, out, o) = run_scene("dda-bad", &scene, &["--dt-factor", "3", absent]);
    assert_eq!(
        o.status.code(),
        Some(2),
        "ω·dt = 3 must stop as unstable: {}",
        stderr(&o)
    );
    let s = summary(&out);
    assert_eq!(s["status"], "unstable");
    let msg = s["message"].as_str().unwrap();
    assert!(
        msg.contains("solid node") && msg.contains("explicit") && msg.contains("energy"),
        "the message must name the node, the solver and the energy growth: {msg}"
    );
    assert!(msg.contains("step") && msg.contains("t = "), "{msg}");
    assert_no_nan(&out);
    assert!(leftovers(&id).is_empty());
    let _ = std::fs::remove_dir_all(&out);
    let _ = std::fs::remove_dir_all(scene.parent().unwrap());
}

/// The validation tank's floating block with another density.
fn floating_block_of_density(tag: &str, density: f64) -> PathBuf {
    let path = Path::new(env!("CARGO_MANIFEST_DIR"))
        .parent()
        .unwrap()
        .join("scenes/validation/floating_block.toml");
    let text = std::fs::read_to_string(path).unwrap();
    assert!(text.contains("density = 500.0"));
    scene_file(
        tag,
        &text.replace("density = 500.0", &format!("density = {density:.1}")),
    )
}

#[test]
fn light_block_under_explicit_coupling_is_an_added_mass_instability_by_name() {
    for scheme in ["parallel", "serial"] {
        let light = floating_block_of_density("light", 1.0);
        let (id, out, o) = run_scene("added-mass", &light, &["--end", "0.05", "--scheme", scheme]);
        assert_eq!(o.status.code(), Some(2), "{scheme}: {}", stderr(&o));
        let s = summary(&out);
        assert_eq!(s["status"], "unstable");
        let msg = s["message"].as_str().unwrap();
        assert!(
            msg.contains("solid node")
                && msg.contains("added-mass instability")
                && msg.contains("'block'")
                && msg.contains("ρ_b/ρ_w = 0.0010"),
            "{scheme}: the message must name the instability and the block: {msg}"
        );
        // Caught while the block is still in the tank (unchecked, it leaves the domain at
        // 1 km/s a few steps later).
        assert!(!msg.contains("left the domain"), "{msg}");
        assert_no_nan(&out);
        assert!(leftovers(&id).is_empty());
        let _ = std::fs::remove_dir_all(&out);
        let _ = std::fs::remove_dir_all(light.parent().unwrap());
    }
    let buoyant = floating_block_of_density("buoyant", 50.0);
    let (id, out, o) = run_scene("buoyant", &buoyant, &["--end", "0.05"]);
    assert!(
        o.status.success(),
        "ρ_b/ρ_w = 0.05 must float: {}",
        stderr(&o)
    );
    assert_eq!(summary(&out)["status"], "completed");
    assert!(leftovers(&id).is_empty());
    let _ = std::fs::remove_dir_all(&out);
    let _ = std::fs::remove_dir_all(buoyant.parent().unwrap());
}

#[test]
fn sph_fails_past_its_cfl_limit_and_says_so() {
    let scene = scene_file("cfl", &dam_break("wcsph", ""));
    // No moving blocks: the solid node is never started.
    let absent = "--solid-cmd=/nonexistent/solid-node";
    let (id, out, o) = run_scene("cfl-ok", &scene, &[absent]);
    assert!(o.status.success(), "dt × 1 must run: {}", stderr(&o));
    let s = summary(&out);
    assert_eq!(s["status"], "completed");
    assert!(
        s["solid_solver"].is_null(),
        "a scene without moving blocks ran a solid node: {s}"
    );
    assert!(leftovers(&id).is_empty());
    let _ = std::fs::remove_dir_all(&out);

    let (id, out, o) = run_scene("cfl-bad", &scene, &["--dt-factor", "10", absent]);
    assert_eq!(
        o.status.code(),
        Some(2),
        "dt × 10 must stop as unstable: {}",
        stderr(&o)
    );
    let s = summary(&out);
    assert_eq!(s["status"], "unstable");
    let msg = s["message"].as_str().unwrap();
    assert!(
        msg.contains("fluid node") && msg.contains("wcsph") && msg.contains("limit exceeded"),
        "the message must name the node, the solver and the limit: {msg}"
    );
    assert_no_nan(&out);
    assert!(leftovers(&id).is_empty());
    let _ = std::fs::remove_dir_all(&out);
    let _ = std::fs::remove_dir_all(scene.parent().unwrap());
}

#[test]
fn too_soft_muller_eos_is_flagged_with_its_compression() {
    // k = 2 m²/s²: a sound speed of 1.4 m/s against a 2 m/s surge; the default is 10× the
    // flow speed squared.
    let scene = scene_file(
        "soft",
        &dam_break("muller", "[fluid.muller]\nstiffness = 2.0\n"),
    );
    let (id, out, o) = run_scene("soft", &scene, &["--end", "0.1"]);
    let s = summary(&out);
    let warning = s["stats"]["last_warning"]
        .as_str()
        .unwrap_or_default()
        .to_string();
    assert!(
        o.status.success() || s["status"] == "unstable",
        "{}",
        stderr(&o)
    );
    assert!(
        warning.contains("compression") && warning.contains("stiffness"),
        "a too-soft EOS must be flagged: warning {warning:?}, summary {s}"
    );
    // The warning carries the measured compression, above the 1 % promise.
    let pct: f64 = warning
        .split("compression ")
        .nth(1)
        .and_then(|r| r.split(" %").next())
        .and_then(|v| v.trim().parse().ok())
        .unwrap_or_else(|| panic!("no measured compression in {warning:?}"));
    assert!(pct > 1.0, "measured compression {pct} %");
    assert!(leftovers(&id).is_empty());
    let _ = std::fs::remove_dir_all(&out);
    let _ = std::fs::remove_dir_all(scene.parent().unwrap());
}

#[test]
fn target_error_picks_the_spacing_from_the_measured_curve() {
    let scene = scene_file("target", &dam_break("wcsph", ""));
    // The targets the committed curve (written by `coupler chart`) meets at 20 and 40
    // particles across the 0.2 m column: dx = 0.01 and 0.005 m.
    let fit = std::fs::read_to_string(
        Path::new(env!("CARGO_MANIFEST_DIR")).join("../docs/charts/fluid_convergence.csv"),
    )
    .unwrap();
    let line = fit
        .lines()
        .find(|l| l.starts_with("wcsph,"))
        .expect("wcsph fitted");
    let v: Vec<f64> = line
        .split(',')
        .skip(1)
        .map(|x| x.parse().unwrap())
        .collect();
    let (c, p) = (v[0], v[1]);
    let targets: Vec<String> = [20.0f64, 40.0]
        .iter()
        .map(|n| format!("{}", 1.0001 * c * n.powf(-p)))
        .collect();
    let mut chosen = Vec::new();
    for target in &targets {
        let (id, out, o) = run_scene(
            "target",
            &scene,
            &["--target-error", target, "--end", "0.002"],
        );
        let err = stderr(&o);
        assert!(o.status.success(), "{err}");
        assert!(
            err.contains("--target-error") && err.contains("N ="),
            "{err}"
        );
        // The spacing run is the one written into the run's scene.toml.
        let text = std::fs::read_to_string(out.join("scene.toml")).unwrap();
        let dx: f64 = text
            .lines()
            .find(|l| l.trim_start().starts_with("dx ="))
            .and_then(|l| l.split('=').nth(1))
            .and_then(|v| v.trim().parse().ok())
            .expect("dx in scene.toml");
        assert!(
            err.contains(&format!("dx = {dx:.5}")),
            "printed dx differs from run dx {dx}: {err}"
        );
        chosen.push(dx);
        assert!(leftovers(&id).is_empty());
        let _ = std::fs::remove_dir_all(&out);
    }
    assert!(
        (chosen[0] - 0.01).abs() < 1e-9 && (chosen[1] - 0.005).abs() < 1e-9,
        "a tighter target must give the finer spacing the curve asks for: {chosen:?}"
    );
    let _ = std::fs::remove_dir_all(scene.parent().unwrap());
}
