//! Every solver takes the same steps to the bit on any number of threads. The passes are cut
//! into tasks of a few hundred particles (`fluid_node::core::tasks`) and rayon hands them to whichever
//! thread is free; each particle's values are still computed by one task, in its own order, and
//! the totals a step depends on are added exactly (`fluid_node::core::exact_sum`). A pass
//! whose result followed the cut or the schedule fails this.

mod common;

use fluid_node::REGISTRY;
use fluid_node::validation::*;

#[test]
fn every_solver_gives_the_same_bits_on_one_two_and_three_threads() {
    // The default scene, coarse: fixed walls, the wedge moving through the surface (its
    // boundary particles, Eq. 22 and the loads on it), a few thousand particles.
    let (scene, state) = common::wedge_scene();
    for solver in REGISTRY.names() {
        // Per step: the step size, and the load on the wedge (force, torque), as bits.
        let run = |threads: usize| {
            let dir = TempRunDir::new("threads").unwrap();
            let mut s = build(solver, &scene, dir.path()).unwrap();
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap();
            let steps: Vec<(u64, Vec<u64>)> = pool.install(|| {
                common::wedge_steps(s.as_mut(), state, scene.time.dt_max, 8)
                    .iter()
                    .map(|(dt, load)| {
                        let load = load.force.iter().chain(&load.torque);
                        (dt.to_bits(), load.map(|x| x.to_bits()).collect())
                    })
                    .collect()
            });
            (steps, common::bits(s.as_ref()))
        };
        let one = run(1);
        assert!(
            one.1.len() / 11 > 4 * fluid_node::core::tasks::PARTICLES,
            "{solver}: {} particles make too few tasks to test",
            one.1.len() / 11
        );
        assert!(
            one.0
                .iter()
                .flat_map(|(_, load)| load)
                .any(|&b| f64::from_bits(b) != 0.0),
            "{solver}: no load on the wedge"
        );
        for threads in [2, 3] {
            let other = run(threads);
            assert_eq!(
                one.0, other.0,
                "{solver}: step sizes or wedge loads on {threads} threads"
            );
            assert!(
                one.1 == other.1,
                "{solver}: particles differ on {threads} threads"
            );
        }
    }
}
