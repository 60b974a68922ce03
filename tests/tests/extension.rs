//! "Adding a solver is one file plus one registry line", kept true: a third SPH method
//! (`lite`, tests/src/extension/lite.rs) and a second DDA integrator (`euler`,
//! tests/src/extension/euler.rs), written against the node crates' public API alone and listed
//! by the node binaries `extended-fluid-node` and `extended-solid-node` beside the built-in
//! solvers, run coupled through the coupler like any other node (`--fluid-cmd`, `--solid-cmd`).
//!
//! The scene (tests/scenes/dropped_block.toml): a 0.2 m block of density 500 kg/m³ dropped from
//! 0.12 m above 0.3 m of water. Checked against physics: free fall before the water is near
//! (z = z0 − ½ g t², symplectic Euler's error ½ g t Δt, under 0.3 mm here), the water catching
//! the block before the floor would, and the block floating at Archimedes' draft
//! (ρ_b/ρ_w · h = 0.1 m: the centroid at 0.3 m).

mod common;
use common::*;

const G: f64 = 9.81;
/// The block's centroid at t = 0 [m].
const Z0: f64 = 0.52;
/// Its centroid when floating: the water's surface (0.3 m) less the draft (0.1 m) plus half
/// its height.
const Z_FLOAT: f64 = 0.3;

fn extended(node: &str, solver: &str) -> String {
    format!("{} --solver {solver}", bin(node).display())
}

#[test]
fn the_nodes_list_the_added_solvers_beside_the_built_in_ones() {
    for (node, added) in [
        ("extended-fluid-node", "lite"),
        ("extended-solid-node", "euler"),
    ] {
        let out = std::process::Command::new(bin(node))
            .arg("--list-solvers")
            .output()
            .unwrap();
        let list = String::from_utf8_lossy(&out.stdout).to_string();
        let builtin = std::process::Command::new(bin(node.trim_start_matches("extended-")))
            .arg("--list-solvers")
            .output()
            .unwrap();
        let builtin = String::from_utf8_lossy(&builtin.stdout).to_string();
        assert_eq!(list, format!("{builtin}{added}\n"), "{node}");
    }
}

#[test]
fn a_method_and_an_integrator_added_from_outside_run_coupled() {
    let (id, out) = fresh("extension");
    let fluid = extended("extended-fluid-node", "lite");
    let solid = extended("extended-solid-node", "euler");
    let scene = scene("dropped_block.toml");
    let o = run(coupler(
        &id,
        &out,
        &[
            scene.to_str().unwrap(),
            "--fluid-cmd",
            &fluid,
            "--solid-cmd",
            &solid,
        ],
    ));
    assert!(o.status.success(), "{}", stderr(&o));
    let summary = summary(&out);
    assert_eq!(summary["status"], "completed");
    assert_eq!(summary["fluid_solver"], "lite");
    assert_eq!(summary["solid_solver"], "euler");

    let text = std::fs::read_to_string(out.join("blocks.csv")).unwrap();
    let mut lines = text.lines();
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    let col = |name: &str| header.iter().position(|h| *h == name).unwrap();
    let (t, z, vz) = (col("time"), col("z"), col("vz"));
    let rows: Vec<Vec<f64>> = lines
        .map(|l| {
            l.split(',')
                .map(|c| c.parse().unwrap_or(f64::NAN))
                .collect()
        })
        .collect();
    assert!(rows.len() > 100, "{} rows", rows.len());

    // Free fall until the block's boundary particles come within a kernel support of the
    // water (at t ≈ 0.12 s).
    for r in rows.iter().filter(|r| r[t] <= 0.1) {
        let exact = Z0 - 0.5 * G * r[t] * r[t];
        assert!(
            (r[z] - exact).abs() < 1e-3,
            "t = {}: z = {} against {exact}",
            r[t],
            r[z]
        );
        assert!(
            (r[vz] + G * r[t]).abs() < 1e-3,
            "t = {}: vz = {}",
            r[t],
            r[vz]
        );
    }
    // The water's loads reach the solid: the block, entering at 1.5 m/s, never comes near
    // the floor (its centroid would stop at 0.1 m there) ...
    let lowest = rows.iter().map(|r| r[z]).fold(f64::INFINITY, f64::min);
    assert!(lowest > 0.2, "the block sank to z = {lowest}");
    // ... and floats at Archimedes' draft over the last 0.3 s (its heave about it included).
    let late: Vec<f64> = rows.iter().filter(|r| r[t] >= 0.5).map(|r| r[z]).collect();
    let mean = late.iter().sum::<f64>() / late.len() as f64;
    assert!(
        (mean - Z_FLOAT).abs() < 0.02,
        "mean centroid {mean} m over t ≥ 0.5 s, against {Z_FLOAT} m floating"
    );
    assert!(leftovers(&id).is_empty());
    let _ = std::fs::remove_dir_all(&out);
}
