//! Every fluid solver continues exactly from its own checkpoint: a solver saved after some steps
//! and restored into one freshly built from the same scene takes the next steps to the bit
//! (particles, step proposals, gauge and probe rows). Through the coupler and three processes
//! this is `tests/tests/checkpoint.rs`; here every registry solver and the Verlet integrator.

mod common;

use common::advance;
use fluid_node::REGISTRY;
use fluid_node::validation::*;
use shared::scene::Scene;

fn continues_exactly(solver: &str, scene: &Scene, what: &str) {
    let (da, db, scratch) = (
        TempRunDir::new("ckpt-a").unwrap(),
        TempRunDir::new("ckpt-b").unwrap(),
        TempRunDir::new("ckpt-scratch").unwrap(),
    );
    let mut a = build(solver, scene, da.path()).unwrap();
    advance(a.as_mut(), 25);
    let state = a.save_state().unwrap();
    for f in ["gauges.csv", "probes.csv"] {
        if da.path().join(f).exists() {
            std::fs::copy(da.path().join(f), db.path().join(f)).unwrap();
        }
    }
    let mut b = build(solver, scene, scratch.path()).unwrap();
    b.restore_state(&state, db.path()).unwrap();
    assert_eq!(
        a.dt_proposal().to_bits(),
        b.dt_proposal().to_bits(),
        "{what}"
    );
    let (ta, tb) = (advance(a.as_mut(), 25), advance(b.as_mut(), 25));
    assert_eq!(ta, tb, "{what}: step sizes");
    assert!(
        common::bits(a.as_ref()) == common::bits(b.as_ref()),
        "{what}: particles differ"
    );
    a.finish().unwrap();
    b.finish().unwrap();
    for f in ["gauges.csv", "probes.csv"] {
        let read = |d: &TempRunDir| std::fs::read(d.path().join(f)).ok();
        assert_eq!(read(&da), read(&db), "{what}: {f}");
    }
    if !scene.probes.is_empty() {
        let text = std::fs::read_to_string(da.path().join("probes.csv")).unwrap();
        let rows: Vec<&str> = text.lines().skip(1).collect();
        assert!(rows.len() >= 3, "{what}: {} probe rows", rows.len());
    }
}

/// The dam break with two probes near the column's foot, one with an averaging window (its
/// running average is part of the state: the window, longer than the steps after the restart,
/// reaches back before it).
fn scene_with_probes(solver: &str) -> Scene {
    let mut scene = dam_break_scene(solver, 2, 0.1, 6, None);
    // A sensor's face: its seven points' averages go through the checkpoint too.
    let face = Some(shared::scene::ProbeFace {
        diameter: 0.02,
        normal: [0.0, 0.0, 1.0],
        reading: Default::default(),
        span: None,
    });
    // And a face reading the wall: the floor's load under the column.
    let wall = Some(shared::scene::ProbeFace {
        diameter: 0.02,
        normal: [0.0, 0.0, 1.0],
        reading: shared::scene::FaceReading::Wall,
        span: None,
    });
    for (name, window, face, z) in [
        ("p_inst", None, None, 0.02),
        ("p_avg", Some(0.008), None, 0.02),
        ("p_face", Some(0.008), face, 0.02),
        ("p_wall", Some(0.008), wall, 0.0),
    ] {
        scene.probes.push(shared::scene::ProbeSpec {
            name: name.into(),
            position: [
                0.05,
                scene.domain.min[1] + 0.5 * (scene.domain.max[1] - scene.domain.min[1]),
                z,
            ],
            window,
            face,
        });
    }
    scene
}

#[test]
fn every_solver_continues_exactly_from_its_checkpoint() {
    for solver in REGISTRY.names() {
        let scene = scene_with_probes(solver);
        continues_exactly(solver, &scene, solver);
    }
    let mut scene = dam_break_scene("wcsph", 2, 0.1, 6, None);
    scene.fluid.as_mut().unwrap().solvers.insert(
        "wcsph".into(),
        toml::Value::Table(toml::from_str("integrator = \"verlet\"").unwrap()),
    );
    continues_exactly("wcsph", &scene, "wcsph with Verlet");
}

/// Water over a `[[terrain]]`: the terrain's boundary particles and Eq. 22 are rebuilt from the
/// scene's file by the fresh solver (they are not in the checkpoint), and the run continues to
/// the bit.
#[test]
fn water_over_a_terrain_continues_exactly_from_its_checkpoint() {
    let files = TempRunDir::new("ckpt-terrain-files").unwrap();
    let scene = terrain_basin_scene("wcsph", 0.1, 0.1 / 8.0, 0.004, files.path());
    continues_exactly("wcsph", &scene, "wcsph over a terrain");
}
