//! Divergence-free SPH (fluid-node/src/methods/dfsph/) at coarse resolutions: hydrostatics, the
//! Martin & Moyce fronts with self-convergence, the steps it saves over WCSPH, its parameter
//! checks and its convergence warning.

mod common;

use fluid_node::REGISTRY;
use fluid_node::methods::dfsph::Dfsph;
use fluid_node::sph::{Sph, SphSolver};
use fluid_node::validation::*;
use shared::scene::{CouplingScheme, Scene};
use shared::solver::{SetupContext, Solver};

/// Still water with `pressure_tolerance = 5` (the setting for pressure studies; the case sets
/// it, `methods::dfsph::PRESSURE_STUDY`): the probes' means are hydrostatic within 5 % of ρ0 g H.
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

/// The still-water row whatever the order of the sums (issue 44): the neighbour grid's cells
/// shifted by 0, 0.31 and 0.62 of a support (the domain's corner moved; the water, the walls
/// and the probes stay) sort the particles otherwise, so every neighbour sum adds in another
/// order and the runs part after a few steps; DFSPH's pressure of a step moves by a fifth of
/// ρ0 g H, so each run's probes differ. The row is each probe's time mean over the second half,
/// every step (`PROBE_ROWS` windows): within 5 % of ρ0 g H for each order, and within 1 % of
/// each other. Measured on 29 Nov 2026: 2.91, 2.62, 2.55 %. Before the windows (the mean of 25
/// snapshots) the same three orders read 3.70, 5.61, 2.96 %, and without the case's
/// `pressure_tolerance` 2.43, 1.92, 10.72 %.
#[test]
fn dfsph_still_water_is_hydrostatic_in_any_summation_order() {
    let (depth, dx, end) = (0.1, 0.1 / 8.0, 0.3);
    let errors: Vec<f64> = [0.0, 0.31, 0.62]
        .iter()
        .map(|shift| {
            let mut scene = still_water_scene("dfsph", depth, dx, end, None);
            let support = 2.6 * dx;
            for c in &mut scene.domain.min {
                *c -= shift * support;
            }
            let s = still_water_run(&scene, depth, end).unwrap();
            eprintln!(
                "dfsph still water, grid shifted {shift} support: error {:.4}, probes {:?}",
                s.max_error, s.probes
            );
            assert!(
                s.max_error <= HYDROSTATIC_TOLERANCE,
                "grid shifted by {shift} of a support: pressure error {:.3} of ρgH: {:?}",
                s.max_error,
                s.probes
            );
            s.max_error
        })
        .collect();
    let spread = errors.iter().cloned().fold(f64::MIN, f64::max)
        - errors.iter().cloned().fold(f64::MAX, f64::min);
    assert!(
        spread <= 0.01,
        "the row moves by {:.2} % of ρgH with the order of the sums: {errors:?}",
        100.0 * spread
    );
}

fn check_front(r: &DamBreak) {
    let mean = r.mean_deviation();
    assert!(
        mean >= FRONT_MEAN_BAND.0 && mean <= FRONT_MEAN_BAND.1,
        "mean front deviation {mean:+.3}: {:?}",
        r.deviations()
    );
    let worst = r.deviations().iter().fold(0.0f64, |m, d| m.max(d.abs()));
    assert!(
        worst <= FRONT_MAX_DEVIATION,
        "worst front deviation {worst:.3}"
    );
}

#[test]
fn dfsph_dam_break_fronts_and_self_convergence() {
    let runs: Vec<DamBreak> = [4, 8, 16]
        .iter()
        .map(|&n| dam_break("dfsph", 2, n, None).unwrap())
        .collect();
    for r in &runs {
        eprintln!(
            "dfsph dam break a/dx = {}: {} steps, mean deviation {:+.3}",
            r.per_a,
            r.steps,
            r.mean_deviation()
        );
    }
    check_front(&runs[2]);
    let three: [DamBreak; 3] = runs.try_into().unwrap();
    let (e1, e2, order) = self_convergence(&three);
    assert!(
        e2 < e1,
        "no self-convergence: |ΔZ| {e1:.3} then {e2:.3} (order {order:.2})"
    );
    check_front(&dam_break("dfsph", 1, 8, None).unwrap());
}

fn ctx_for<'a>(scene: &'a Scene, dir: &'a TempRunDir) -> SetupContext<'a> {
    SetupContext {
        scene,
        run_dir: dir.path(),
        scheme: CouplingScheme::Parallel,
        peer_present: false,
    }
}

/// The point of DFSPH: its step follows the flow speed, not a numerical speed of sound. The same
/// dam break (a/dx = 8) with the scene's dt_max raised out of the way, so each solver takes its
/// own proposal: step COUNTS (deterministic), not wall time.
#[test]
fn dfsph_takes_at_least_five_times_fewer_steps_than_wcsph() {
    let (a, per_a) = (0.1, 8);
    let steps = |solver: &str| {
        let mut scene = dam_break_scene(solver, 2, a, per_a, None);
        scene.time.dt_max = 0.05;
        let dir = TempRunDir::new("ratio").unwrap();
        let mut s = build(solver, &scene, dir.path()).unwrap();
        let scale = 2f64.sqrt() * (9.81 / a).sqrt();
        let mut curve = Vec::new();
        let steps = run(s.as_mut(), &scene, scene.time.end, |s, t| {
            curve.push((t * scale, front(s, a / per_a as f64) / a));
        })
        .unwrap();
        DamBreak {
            n2: 2,
            per_a,
            curve,
            particles: s.system().len(),
            steps,
            seconds: 0.0,
        }
    };
    let (d, w) = (steps("dfsph"), steps("wcsph"));
    eprintln!(
        "dam break a/dx = {per_a}, dt_max out of the way: dfsph {} steps (front {:+.3}), wcsph {} steps (front {:+.3}), ratio {:.1}",
        d.steps,
        d.mean_deviation(),
        w.steps,
        w.mean_deviation(),
        w.steps as f64 / d.steps as f64
    );
    assert!(
        5 * d.steps <= w.steps,
        "dfsph took {} steps, wcsph {}: fewer than 5× fewer",
        d.steps,
        w.steps
    );
    // At its own step, the front is still Martin & Moyce's.
    check_front(&d);
}

/// The iteration counts of the two solves, from the scheme itself, on still water: the warm start
/// keeps the constant-density solve short, and every step converges below the cap.
#[test]
fn dfsph_solves_converge_on_still_water() {
    let scene = still_water_scene("dfsph", 0.1, 0.0125, 0.1, None);
    let dir = TempRunDir::new("iters").unwrap();
    let mut s = Sph::<Dfsph>::new(&ctx_for(&scene, &dir)).unwrap();
    let (mut worst, mut total, mut total_div) = (0, 0, 0);
    let mut steps = 0;
    while s.sys.time < 0.1 {
        let dt = s.dt_proposal().min(scene.time.dt_max);
        let r = s.advance(dt).unwrap();
        assert!(r.warning.is_none(), "{:?}", r.warning);
        let st = s.method.stats;
        assert!(st.density_error <= 0.0005, "{st:?}");
        worst = worst.max(st.density_iterations);
        total += st.density_iterations;
        total_div += st.divergence_iterations;
        steps += 1;
    }
    eprintln!(
        "still water: {steps} steps, density iterations mean {:.1} (worst {worst}), divergence iterations mean {:.1}",
        total as f64 / steps as f64,
        total_div as f64 / steps as f64
    );
    assert!(worst < 100, "a density solve hit the cap");
}

/// A cap too low for the tolerance: the step returns, and says so with the error reached.
#[test]
fn dfsph_warns_when_the_density_solve_does_not_converge() {
    let mut scene = dam_break_scene("dfsph", 2, 0.1, 8, None);
    scene.fluid.as_mut().unwrap().solvers.insert(
        "dfsph".into(),
        toml::Value::Table(
            toml::from_str("max_iterations = 1\ndensity_tolerance = 0.0001").unwrap(),
        ),
    );
    let dir = TempRunDir::new("warn").unwrap();
    let mut s = REGISTRY.build("dfsph", &ctx_for(&scene, &dir)).unwrap();
    let mut warning = None;
    for _ in 0..100 {
        let dt = s.dt_proposal().min(scene.time.dt_max);
        if let Some(w) = s.advance(dt).unwrap().warning {
            warning = Some(w);
            break;
        }
    }
    let w = warning.expect("a capped solve must warn");
    assert!(
        w.starts_with("dfsph: density solve did not converge: mean error ")
            && w.contains("% after 1 iterations (tolerance 0.000 %)"),
        "{w}"
    );
}

/// `[fluid.dfsph]` values are checked by field, with a fix.
#[test]
fn dfsph_parameters_are_checked() {
    let mut good = still_water_scene("dfsph", 0.1, 0.025, 0.1, None);
    // The still-water case sets its own [fluid.dfsph]; this test writes the table itself.
    good.fluid.as_mut().unwrap().solvers.remove("dfsph");
    let text = toml::to_string(&good).unwrap();
    let checked = |extra: &str| scene_errors(&format!("{text}\n[fluid.dfsph]\n{extra}\n"));
    assert_eq!(
        checked(
            "cfl = 0.4\ndensity_tolerance = 0.05\ndivergence_tolerance = 0.1\nmax_iterations = 100\nviscosity = 0.01\npressure_tolerance = 5.0\ndeficient_fraction = 0.6\nrelaxation = 0.5"
        ),
        ""
    );
    for (bad, field) in [
        ("cfl = nan", "cfl"),
        ("cfl = 2.0", "cfl"),
        ("density_tolerance = -0.05", "density_tolerance"),
        ("divergence_tolerance = 50.0", "divergence_tolerance"),
        ("max_iterations = 0", "max_iterations"),
        ("viscosity = -1.0", "viscosity"),
        ("smoothing_ratio = 0.1", "smoothing_ratio"),
        ("pressure_tolerance = 0.0", "pressure_tolerance"),
        ("deficient_fraction = 1.5", "deficient_fraction"),
        ("relaxation = 0.0", "relaxation"),
        ("relaxation = 1.5", "relaxation"),
    ] {
        let e = checked(bad);
        assert!(
            e.contains(&format!("fluid.dfsph.{field}")) && e.contains("fix"),
            "{bad}: {e}"
        );
    }
    let e = checked("tolerance = 0.1");
    assert!(e.contains("fluid.dfsph") && e.contains("tolerance"), "{e}");
}

/// Two droplets of 4×4×4 particles (dx = 1 cm, faces 2 cm apart) approach head on at 1 m/s
/// each in zero gravity, with `[fluid.dfsph]` `extra`; returns the largest particle speed over
/// the steps before their particles are within one spacing (t ≤ 7 ms).
fn droplets_approaching(extra: &str) -> f64 {
    let dx = 0.01;
    let text = format!(
        "name = \"droplets\"\ngravity = [0.0, 0.0, 0.0]\n[time]\nend = 0.007\ndt_max = 1e-3\n\
         [domain]\nmin = [0.0, 0.0, 0.0]\nmax = [0.3, 0.3, 0.3]\n[output]\ninterval = 0.007\n\
         [fluid]\nsolver = \"dfsph\"\ndensity = 1000.0\ndx = {dx}\n\
         [fluid.dfsph]\n{extra}\n\
         [[fluid.water]]\nshape = {{ type = \"box\", min = [0.1, 0.1, 0.1], max = [0.14, 0.14, 0.14] }}\n\
         [[fluid.water]]\nshape = {{ type = \"box\", min = [0.16, 0.1, 0.1], max = [0.2, 0.14, 0.14] }}\n"
    );
    let scene = Scene::parse(&text, "droplets (test)").unwrap();
    let dir = TempRunDir::new("droplets").unwrap();
    let mut s = Sph::<Dfsph>::new(&ctx_for(&scene, &dir)).unwrap();
    let p = &mut s.sys.particles;
    for (x, v) in p.position.iter().zip(p.velocity.iter_mut()) {
        v.x = if x.x < 0.15 { 1.0 } else { -1.0 };
    }
    let mut fastest: f64 = 0.0;
    while s.sys.time < scene.time.end - 1e-12 {
        let dt = s.dt_proposal().min(scene.time.dt_max);
        s.advance(dt).unwrap();
        let v = s.sys.particles.velocity.iter().map(|v| v.norm());
        fastest = v.fold(fastest, f64::max);
    }
    fastest
}

/// Spray is left out of the divergence solve ([`fluid_node::methods::dfsph::DEFICIENT_FRACTION`], as
/// SPlisHSPlasH does): two droplets far below a full neighbourhood close in without the solve
/// touching them. With the rule off (`deficient_fraction = 0`) the solve's large factor on
/// sparse particles already pushes them apart before they meet; in the default scene at
/// dx = 0.04 m that threw a 49 m/s jet out of the domain top. With the summed density (the
/// rule's own effect): with the continued surface density, DFSPH's default, every particle of
/// a droplet is a surface particle that keeps ρ0, so the constant-density solve resists the
/// droplets' approach from a support away, as water does (fastest 1.106 m/s with the rule,
/// 1.123 m/s without, 29 Nov 2026).
#[test]
fn dfsph_leaves_spray_out_of_the_divergence_solve() {
    let with_rule = droplets_approaching("continued_surface = false");
    let without = droplets_approaching("continued_surface = false\ndeficient_fraction = 0.0");
    eprintln!(
        "droplets closing at 1 m/s each: fastest {with_rule:.4} m/s with the rule, {without:.4} m/s without"
    );
    assert!(with_rule < 1.001, "fastest {with_rule} m/s");
    assert!(without > 1.05, "without the rule: fastest {without} m/s");
}

/// Still water run `end` seconds with `table` as its `[fluid.dfsph]`: the mean free surface
/// over the second half, minus the initial depth, in spacings.
fn surface_settling(depth: f64, dx: f64, end: f64, table: &str) -> f64 {
    let mut scene = still_water_scene("dfsph", depth, dx, end, None);
    let table = toml::from_str(table).expect("valid table");
    if let Some(f) = scene.fluid.as_mut() {
        f.solvers.insert("dfsph".into(), toml::Value::Table(table));
    }
    let dir = TempRunDir::new("settling").unwrap();
    let mut s = build("dfsph", &scene, dir.path()).unwrap();
    let particles = s.system().len();
    let steps = run(s.as_mut(), &scene, end, |_, _| {}).unwrap();
    drop(s);
    let r = hydrostatics(dir.path(), &scene, depth, end, particles, steps).unwrap();
    (r.surface - depth) / dx
}

/// DFSPH corrects only compression of the summed density, and a particle within a support of
/// the free surface has a deficient sum: gravity packs the top layers (Example 1 lost 2.5 cm of
/// level, a quarter spacing, in 6 s; docs/PERFORMANCE.md). With `continued_surface` (on by default) such a
/// particle keeps the density the last step predicted for it when that is larger, and the
/// surface stays where it was. Measured over 4 s at dx = 0.02 m: summed −0.073 spacings with
/// the mirrored walls (−0.15 with the walls' pressure extrapolated), continued +0.016.
#[test]
fn dfsph_free_surface_holds_its_level_with_the_continued_density() {
    let (depth, dx, end) = (0.2, 0.02, 4.0);
    let summed = surface_settling(depth, dx, end, "continued_surface = false");
    // The default.
    let continued = surface_settling(depth, dx, end, "");
    eprintln!(
        "surface settling over {end} s: summed {summed:+.3} dx, continued {continued:+.3} dx"
    );
    assert!(summed < -0.05);
    assert!(continued.abs() < 0.05 && continued.abs() < 0.5 * summed.abs());
}

/// A DFSPH run gives the same bits on any number of threads: a dam break stepped on 1, 2 and 3
/// threads ends with the same particles. Where its solves stop depends on sums over all
/// particles (the mean errors), added exactly for this (`fluid_node::core::exact_sum`;
/// rayon's own sums round by the split, which a mean at its tolerance's edge would show only
/// rarely); every other pass writes each particle's own values. A reduction whose order
/// follows the threads, in a pass that feeds the state, fails this.
#[test]
fn dfsph_gives_the_same_bits_on_any_number_of_threads() {
    let mut scene = dam_break_scene("dfsph", 2, 0.1, 16, None);
    // A pressure study's stopping rule too: its Σ|Δk| / Σ|k| is the other exact sum.
    let mut table = toml::Table::new();
    table.insert("pressure_tolerance".into(), toml::Value::Float(5.0));
    scene
        .fluid
        .as_mut()
        .unwrap()
        .solvers
        .insert("dfsph".into(), toml::Value::Table(table));
    let run = |threads: usize| {
        let dir = TempRunDir::new("dfsph-threads").unwrap();
        let mut s = build("dfsph", &scene, dir.path()).unwrap();
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap();
        pool.install(|| {
            for _ in 0..60 {
                s.advance(2e-3).unwrap();
            }
        });
        let p = &s.system().particles;
        let bits = |v: &[shared::math::Vector]| {
            v.iter()
                .flat_map(|x| x.iter().map(|c| c.to_bits()))
                .collect::<Vec<u64>>()
        };
        (bits(&p.position), bits(&p.velocity))
    };
    let one = run(1);
    // More particles than one block of the exact sums.
    assert!(
        one.0.len() / 3 > fluid_node::core::exact_sum::BLOCK,
        "{} particles",
        one.0.len() / 3
    );
    let moved = one.1.iter().filter(|&&b| f64::from_bits(b) != 0.0).count();
    assert!(
        moved > one.1.len() / 2,
        "the dam break has not started to flow"
    );
    for threads in [2, 3] {
        assert!(
            run(threads) == one,
            "{threads} threads gave other bits than 1"
        );
    }
}

/// DFSPH moving a free block inside its solves (its default) gives the same bits on 1, 2 and
/// 3 ranks (threads of this test, `fluid_node::ranks::comm::ThreadRanks`): every particle and
/// the loads the block was moved with. The coarse default scene's wedge, set free (1/m, I⁻¹
/// and its weight, as a solid node sends them) and held at its pose at every step, as
/// [`common::wedge_steps`] drives it.
#[test]
fn dfsph_moves_a_free_block_to_the_same_bits_on_one_two_and_three_ranks() {
    use fluid_node::ranks::comm::{Comm, ThreadRanks};
    use std::sync::Arc;
    let (scene, mut state) = common::wedge_scene();
    // Across the cuts of 2 and of 3 ranks (x ≈ 2.9 and 2.3 m): the blocks' sums read the
    // halo's values.
    state.centroid[0] = 2.6;
    let mass = 200.0;
    state.inverse_mass = 1.0 / mass;
    state.inverse_inertia = [1.0 / 20.0, 1.0 / 20.0, 1.0 / 20.0, 0.0, 0.0, 0.0];
    state.other_force = [0.0, 0.0, -9.81 * mass];
    let run = |comm: Option<Arc<dyn Comm>>| {
        let dir = TempRunDir::new("dfsph-ranks-block").unwrap();
        let ctx = ctx_for(&scene, &dir);
        let mut s = Sph::<Dfsph>::on_ranks(&ctx, comm).unwrap();
        let steps = common::wedge_steps(&mut s, state, scene.time.dt_max, 12);
        let loads: Vec<[u64; 3]> = steps
            .iter()
            .map(|(_, l)| l.force.map(f64::to_bits))
            .collect();
        (s.sys.gathered_bits(), loads)
    };
    let (one, loads) = run(None);
    let one = one.unwrap();
    assert!(
        loads.iter().any(|l| f64::from_bits(l[2]) > 0.0),
        "the water never pushed the block"
    );
    for n in [2, 3] {
        let results: Vec<_> = std::thread::scope(|sc| {
            let handles: Vec<_> = ThreadRanks::handles(n)
                .into_iter()
                .map(|c| {
                    let run = &run;
                    sc.spawn(move || run(Some(c)))
                })
                .collect();
            handles.into_iter().map(|h| h.join().unwrap()).collect()
        });
        let (got, got_loads) = &results[0];
        let got = got.as_ref().expect("rank 0 gathers");
        assert_eq!(got.len(), one.len(), "{n} ranks: particle count");
        let first = got.iter().zip(&one).position(|(a, b)| a != b);
        assert_eq!(first, None, "{n} ranks: the first particle that differs");
        assert_eq!(got_loads, &loads, "{n} ranks: the block's loads");
    }
}

/// A solve that does nothing, step after step, stops the run by name (`methods/dfsph/stall.rs`):
/// the widest kernel the solves take (`smoothing_ratio = 1.8`) with plain Jacobi
/// (`relaxation = 1.0`), both accepted, leaves the Lobovský column (H = 0.3 m, H/dx = 15) unheld
/// from its third step (the 8-layer still-water column of the tests above is held). Without
/// the rule it ran 50 steps compressing (its mean error 0.08 → 6.5 %) and stopped on the
/// density bound, a message that points at the step.
#[test]
fn a_solve_that_does_nothing_step_after_step_stops_the_run_by_name() {
    let mut case = ImpactCase::new(0.3, 15, Some(1e-3));
    case.params = "smoothing_ratio = 1.8\nrelaxation = 1.0".into();
    let scene = impact_scene("dfsph", &case);
    let dir = TempRunDir::new("stall").unwrap();
    let mut s = REGISTRY.build("dfsph", &ctx_for(&scene, &dir)).unwrap();
    let mut steps = 0;
    let err = loop {
        let dt = s.dt_proposal().min(scene.time.dt_max);
        match s.advance(dt) {
            Ok(_) => steps += 1,
            Err(e) => break e.to_string(),
        }
        assert!(steps < 300, "still running after {steps} steps");
    };
    eprintln!("stopped after {steps} steps: {err}");
    assert!(
        err.contains("dfsph: the constant-density solve has done nothing for 10 steps in a row")
            && err.contains("relaxation = 0.5 (the default; this run has 1)")
            && err.contains("smoothing_ratio = 1.3 (the default; this run has 1.80)"),
        "{err}"
    );
    // Stopped by the rule, before the density bound (1.3 ρ0) could.
    assert!(steps < 60, "{steps} steps");
}

/// The runs of stalled steps are in the checkpoint: the same column, saved a few steps into
/// its stall and restored into a fresh solver, stops at the very step of the uninterrupted run
/// with the same message (before they were saved, the resumed run counted afresh and went on).
#[test]
fn a_run_resumed_in_the_middle_of_a_stall_stops_where_it_would_have() {
    let mut case = ImpactCase::new(0.3, 15, Some(1e-3));
    case.params = "smoothing_ratio = 1.8\nrelaxation = 1.0".into();
    let scene = impact_scene("dfsph", &case);
    let dir = TempRunDir::new("stall-resume").unwrap();
    // Steps until the run stops, and its message, from `s` having taken `done` steps.
    let run_out = |s: &mut Box<dyn SphSolver>, mut done: usize| loop {
        let dt = s.dt_proposal().min(scene.time.dt_max);
        match s.advance(dt) {
            Ok(_) => done += 1,
            Err(e) => break (done, e.to_string()),
        }
        assert!(done < 300, "still running after {done} steps");
    };
    let mut whole = REGISTRY.build("dfsph", &ctx_for(&scene, &dir)).unwrap();
    let (stop, message) = run_out(&mut whole, 0);
    // Saved after 6 steps: the density solve has stalled since its 3rd.
    let saved_at = 6;
    assert!(stop > saved_at + 2, "stopped after {stop} steps: {message}");
    let mut first = REGISTRY.build("dfsph", &ctx_for(&scene, &dir)).unwrap();
    for _ in 0..saved_at {
        let dt = first.dt_proposal().min(scene.time.dt_max);
        first.advance(dt).unwrap();
    }
    let state = first.save_state().unwrap();
    let mut resumed = REGISTRY.build("dfsph", &ctx_for(&scene, &dir)).unwrap();
    resumed.restore_state(&state, dir.path()).unwrap();
    assert_eq!(run_out(&mut resumed, saved_at), (stop, message));
}
