//! The phase clock (`fluid_node::core::phases`, `fluid-bench --phases`) reads time and nothing else:
//! every solver stepped with it on takes the same steps to the bit as with it off, and on it
//! has seen the phases every step enters.

mod common;

use fluid_node::REGISTRY;
use fluid_node::core::phases::Phase;
use fluid_node::sph::SphSolver;
use fluid_node::validation::*;
use shared::scene::Scene;

/// Builds `solver` twice on `scene`, the clock on in the second; `drive` steps each the same
/// way and returns its step sizes. Asserts the two agree to the bit; returns the timed one.
fn same_with_and_without(
    solver: &str,
    scene: &Scene,
    mut drive: impl FnMut(&mut dyn SphSolver) -> Vec<f64>,
) -> Box<dyn SphSolver> {
    let (da, db) = (
        TempRunDir::new("phases-off").unwrap(),
        TempRunDir::new("phases-on").unwrap(),
    );
    let mut off = build(solver, scene, da.path()).unwrap();
    let mut on = build(solver, scene, db.path()).unwrap();
    on.phases_mut().set_enabled(true);
    let (dt_off, dt_on) = (drive(off.as_mut()), drive(on.as_mut()));
    assert_eq!(
        dt_off.iter().map(|d| d.to_bits()).collect::<Vec<_>>(),
        dt_on.iter().map(|d| d.to_bits()).collect::<Vec<_>>(),
        "{solver}: step sizes"
    );
    assert!(
        common::bits(off.as_ref()) == common::bits(on.as_ref()),
        "{solver}: particles differ"
    );
    let clock = &off.system().phases;
    assert!(
        Phase::ALL.iter().all(|&p| clock.calls(p) == 0),
        "{solver}: the clock that was off recorded"
    );
    on.finish().unwrap();
    on
}

#[test]
fn every_solver_steps_the_same_with_the_clock_on() {
    // Every registry solver as configured by default, and WCSPH also with the lists rebuilt
    // every step and with its two-evaluation integrator. Force passes per step: WCSPH's (and
    // Riemann's, which is WCSPH's) leapfrog evaluates once, and on the first step once more
    // (the rates at the start).
    let steps: u64 = 25;
    let leapfrog = |s: &str| matches!(s, "wcsph" | "riemann");
    let mut cases: Vec<(&str, &str, u64)> = REGISTRY
        .names()
        .iter()
        .map(|&s| (s, "", if leapfrog(s) { steps + 1 } else { steps }))
        .collect();
    cases.push(("wcsph", "skin = 0", steps + 1));
    cases.push(("wcsph", "integrator = \"symplectic\"", 2 * steps));
    for (solver, param, forces) in cases {
        let mut scene = dam_break_scene(solver, 2, 0.1, 6, None);
        if !param.is_empty() {
            scene.fluid.as_mut().unwrap().solvers.insert(
                solver.into(),
                toml::Value::Table(toml::from_str(param).unwrap()),
            );
        }
        let what = format!("{solver} {param}");
        let on = same_with_and_without(solver, &scene, |s| {
            fluid_node::on_pool(|| common::advance(s, steps as usize))
        });
        let (clock, sorts) = (&on.system().phases, on.system().sorts);
        // Every sort but the one at set-up (before the clock was on) is timed, with its lists.
        for p in [Phase::Sort, Phase::Permutation, Phase::FluidLists] {
            assert_eq!(clock.calls(p), sorts - 1, "{what}: {p:?}");
        }
        for p in [
            Phase::WallLists,
            Phase::Penalty,
            Phase::Density,
            Phase::WallPressures,
            Phase::Integration,
            Phase::Gauges,
        ] {
            // Müller's integration is inside its force pass.
            if solver == "muller" && p == Phase::Integration {
                continue;
            }
            assert!(clock.calls(p) > 0, "{what}: {p:?} never entered");
        }
        assert_eq!(clock.calls(Phase::Survey), steps, "{what}");
        assert_eq!(clock.calls(Phase::Forces), forces, "{what}");
        assert!(clock.sum() > std::time::Duration::ZERO);
    }
}

/// With a moving block: the loads on it and (DFSPH) the blocks in the solve, clock on and off.
#[test]
fn every_solver_with_a_moving_block_steps_the_same_with_the_clock_on() {
    let (scene, state) = common::wedge_scene();
    for solver in REGISTRY.names() {
        let on = same_with_and_without(solver, &scene, |s| {
            fluid_node::on_pool(|| {
                common::wedge_steps(s, state, scene.time.dt_max, 5)
                    .iter()
                    .map(|(dt, _)| *dt)
                    .collect()
            })
        });
        assert!(
            on.system().phases.calls(Phase::BlockLoads) > 0,
            "{solver}: no loads timed"
        );
    }
}
