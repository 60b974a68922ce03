//! Divergence-free SPH (fluid-node/src/dfsph.rs) at coarse resolutions: hydrostatics, the
//! Martin & Moyce fronts with self-convergence, the steps it saves over WCSPH, its parameter
//! checks and its convergence warning.

use fluid_node::REGISTRY;
use fluid_node::validation::*;
use shared::scene::{Scene, Scheme};
use shared::solver::SetupContext;

#[test]
fn dfsph_still_water_is_hydrostatic() {
    let (depth, dx) = (0.1, 0.1 / 8.0);
    let s = still_water("dfsph", depth, dx, 0.3, None).unwrap();
    eprintln!(
        "dfsph still water: error {:.4}, surface {:.4}, {} steps, probes {:?}",
        s.max_error, s.surface, s.steps, s.probes
    );
    assert!(
        s.max_error <= HYDROSTATIC_TOLERANCE,
        "pressure error {:.3} of ρgH: {:?}",
        s.max_error,
        s.probes
    );
    assert!(
        (s.surface - depth).abs() <= dx,
        "surface {} for depth {depth}",
        s.surface
    );
}

#[test]
fn dfsph_dam_break_probe() {
    for n in [4, 8, 16] {
        let t = std::time::Instant::now();
        let r = dam_break("dfsph", 2, n, None).unwrap();
        eprintln!(
            "n {n}: steps {} particles {} mean {:+.3} dev {:?} {:.1}s",
            r.steps,
            r.particles,
            r.mean_deviation(),
            r.deviations()
                .iter()
                .map(|d| (d * 1000.0).round() / 1000.0)
                .collect::<Vec<_>>(),
            t.elapsed().as_secs_f64()
        );
    }
}
