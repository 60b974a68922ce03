//! Helpers shared by fluid-node's integration tests.
#![allow(dead_code)] // each test file uses its own part

use fluid_node::sph::SphSolver;

/// Every particle's position, velocity, acceleration, density and pressure, as bits.
pub fn bits(s: &dyn SphSolver) -> Vec<u64> {
    let p = &s.system().particles;
    p.position
        .iter()
        .chain(&p.velocity)
        .chain(&p.acceleration)
        .flat_map(|v| v.iter().copied())
        .chain(p.density.iter().copied())
        .chain(p.pressure.iter().copied())
        .map(f64::to_bits)
        .collect()
}

/// Steps `s` `steps` times at its own proposed step, with no blocks; returns the steps taken.
pub fn advance(s: &mut dyn SphSolver, steps: usize) -> Vec<f64> {
    (0..steps)
        .map(|_| {
            s.prepare_step();
            let dt = s.dt_proposal();
            s.advance(dt).unwrap();
            dt
        })
        .collect()
}

/// The default scene, coarse (dx 0.08 m: a few thousand particles, fixed walls), and its wedge
/// placed in the surface ([`wedge_in_surface`]).
pub fn wedge_scene() -> (shared::scene::Scene, shared::protocol::BlockState) {
    let mut scene = shared::scene::Scene::default_scene();
    scene.set_dx(0.08);
    let state = wedge_in_surface(&scene);
    (scene, state)
}

/// The scene's first moving block (the default scene's wedge) placed over deep water, its lowest
/// edge just in the surface (0.035 m under the still-water line, above the top particle layer:
/// a block teleported deeper would put its boundary particles on top of fluid particles),
/// moving down at 1 m/s.
pub fn wedge_in_surface(scene: &shared::scene::Scene) -> shared::protocol::BlockState {
    let wedge = scene.moving_blocks()[0];
    let poly = shared::geometry::Polyhedron::from_shape(&scene.blocks[wedge].shape).unwrap();
    shared::protocol::BlockState {
        block: wedge as u32,
        centroid: [poly.centroid.x + 1.2, poly.centroid.y, 0.62],
        orientation: [0.0, 0.0, 0.0, 1.0],
        velocity: [0.0, 0.0, -1.0],
        vertex_count: poly.vertices.len() as u32,
        ..Default::default()
    }
}

/// Steps `s` `steps` times with the moving wedge held at `state` (read each step), as the
/// coupler's runtime drives a solver: the loads of the state a step starts from, or, for a
/// solver whose loads follow its step (DFSPH moving a free block), of the step just taken.
/// Returns each step's size and the load on the wedge after it.
pub fn wedge_steps(
    s: &mut dyn SphSolver,
    state: shared::protocol::BlockState,
    dt_max: f64,
    steps: usize,
) -> Vec<(f64, shared::protocol::BlockLoad)> {
    let mut loads = vec![shared::protocol::BlockLoad::default(); 1];
    (0..steps)
        .map(|_| {
            s.read_geometry(&[state], &[]);
            let after = s.loads_follow_step();
            s.prepare_step();
            if !after {
                s.write_loads(&mut loads);
            }
            let dt = s.dt_proposal().min(dt_max);
            s.advance(dt).unwrap();
            if after {
                s.write_loads(&mut loads);
            }
            (dt, loads[0])
        })
        .collect()
}
