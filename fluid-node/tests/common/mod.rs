//! Helpers shared by fluid-node's integration tests.

use fluid_node::sph::SphSolver;

/// Steps `s` `steps` times at its own proposed step, with no blocks; returns the steps taken.
pub fn advance(s: &mut dyn SphSolver, steps: usize) -> Vec<f64> {
    (0..steps)
        .map(|_| {
            s.write_loads(&mut []);
            let dt = s.dt_proposal();
            s.advance(dt).unwrap();
            dt
        })
        .collect()
}
