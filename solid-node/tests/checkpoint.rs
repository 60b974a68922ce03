//! Both solid schemes continue exactly from their own checkpoint: a solver saved while a block
//! slides down an incline (contacts with shear history, friction, the integrators' own
//! history) and restored into one freshly built from the same scene takes the next steps to the
//! bit, with the same blocks.csv, also for a deformable block.

use shared::protocol::{BlockLoad, BlockState};
use shared::scene::Scene;
use shared::solver::SolidSolver;
use solid_node::verification::Incline;

mod common;
use common::{Dir, build};

/// Steps with a small constant "water" load, as the runtime does (loads in, advance).
fn advance(s: &mut dyn SolidSolver, steps: usize) {
    for _ in 0..steps {
        let load = BlockLoad {
            force: [1.0, 0.0, 0.5],
            ..BlockLoad::default()
        };
        s.read_loads(&[load]);
        let dt = s.dt_proposal().min(1e-3);
        s.advance(dt).unwrap();
    }
}

fn geometry(s: &dyn SolidSolver) -> Vec<u64> {
    let mut blocks = vec![BlockState::default(); 1];
    let mut vertices = vec![[0.0; 3]; s.vertex_count()];
    s.write_geometry(&mut blocks, &mut vertices);
    let b = blocks[0];
    b.centroid
        .iter()
        .chain(&b.orientation)
        .chain(&b.velocity)
        .chain(&b.angular_velocity)
        .chain(&b.strain)
        .chain(vertices.iter().flatten())
        .map(|x| x.to_bits())
        .chain([s.dt_proposal().to_bits()])
        .collect()
}

fn continues_exactly(solver: &str, scene: &Scene, what: &str) {
    let (da, db, scratch) = (
        Dir::new(&format!("ckpt-{what}-a")),
        Dir::new(&format!("ckpt-{what}-b")),
        Dir::new(&format!("ckpt-{what}-s")),
    );
    let mut a = build(solver, scene, &da);
    advance(a.as_mut(), 120);
    let state = a.save_state().unwrap();
    std::fs::copy(da.0.join("blocks.csv"), db.0.join("blocks.csv")).unwrap();
    let mut b = build(solver, scene, &scratch);
    b.restore_state(&state, &db.0).unwrap();
    assert!(
        geometry(a.as_ref()) == geometry(b.as_ref()),
        "{what}: restored state"
    );
    advance(a.as_mut(), 120);
    advance(b.as_mut(), 120);
    assert!(
        geometry(a.as_ref()) == geometry(b.as_ref()),
        "{what}: continued"
    );
    a.finish().unwrap();
    b.finish().unwrap();
    let csv = |d: &Dir| std::fs::read_to_string(d.0.join("blocks.csv")).unwrap();
    assert_eq!(csv(&da), csv(&db), "{what}: blocks.csv");
    assert!(
        csv(&da).lines().count() > 20,
        "{what}: blocks.csv too short"
    );
}

#[test]
fn both_schemes_continue_exactly_from_their_checkpoint() {
    let inc = Incline::SLIDING;
    for solver in solid_node::REGISTRY.names() {
        continues_exactly(solver, &inc.scene(), solver);
        let soft = inc.scene_with("elastic = { young_modulus = 1e7, poisson_ratio = 0.25 }");
        continues_exactly(solver, &soft, &format!("{solver}-deformable"));
    }
}

/// With the slope a `[[terrain]]` mesh: the terrain is not in the checkpoint (it never
/// changes) but read again from the scene's file by the fresh solver, and the run continues
/// to the bit.
#[test]
fn a_block_on_a_terrain_continues_exactly_from_its_checkpoint() {
    let inc = Incline::SLIDING;
    let files = Dir::new("ckpt-terrain-files");
    let scene = solid_node::verification::incline_on_terrain_scene(&inc, 0.5, &files.0);
    for solver in solid_node::REGISTRY.names() {
        continues_exactly(solver, &scene, &format!("{solver}-terrain"));
    }
}
