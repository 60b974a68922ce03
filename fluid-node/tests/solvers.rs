//! The fluid solvers through the `FluidSolver` interface, at coarse resolutions: validation cases
//! with tolerances (the same code `fluid-validate` runs finer), output files, failure messages.

mod common;

use fluid_node::REGISTRY;
use fluid_node::validation::*;
use shared::scene::{CouplingScheme, Scene};
use shared::solver::{SetupContext, SolverError};

#[test]
fn wcsph_still_water_is_hydrostatic() {
    let (depth, dx) = (0.1, 0.1 / 8.0);
    let s = still_water("wcsph", depth, dx, 0.3, None).unwrap();
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
fn muller_still_water_holds_the_column() {
    // The paper's symmetric (p_i + p_j)/2 form carries about half the pressure gradient of the
    // consistent form, so pressure is not hydrostatic (see docs/VALIDATION.md); the column
    // must still stand: surface in place, pressure rising with depth.
    let (depth, dx) = (0.1, 0.1 / 8.0);
    let s = still_water("muller", depth, dx, 0.3, None).unwrap();
    assert!(
        (s.surface - depth).abs() <= dx,
        "surface {} for depth {depth}",
        s.surface
    );
    let p: Vec<f64> = s.probes.iter().map(|x| x.1).collect();
    assert!(
        p[0] < p[1] && p[1] < p[2],
        "pressure does not rise with depth: {p:?}"
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
fn wcsph_dam_break_front_follows_martin_moyce() {
    check_front(&dam_break("wcsph", 2, 8, None).unwrap());
}

#[test]
fn muller_dam_break_fronts_and_self_convergence() {
    let runs: Vec<DamBreak> = [4, 8, 16]
        .iter()
        .map(|&n| dam_break("muller", 2, n, None).unwrap())
        .collect();
    check_front(&runs[2]);
    let three: [DamBreak; 3] = runs.try_into().unwrap();
    let (e1, e2, order) = self_convergence(&three);
    assert!(
        e2 < e1,
        "no self-convergence: |ΔZ| {e1:.3} then {e2:.3} (order {order:.2})"
    );
    check_front(&dam_break("muller", 1, 8, None).unwrap());
}

fn ctx_for<'a>(scene: &'a shared::scene::Scene, dir: &'a TempRunDir) -> SetupContext<'a> {
    SetupContext {
        scene,
        run_dir: dir.path(),
        scheme: CouplingScheme::Parallel,
        peer_present: false,
    }
}

#[test]
fn unknown_solver_and_wall_treatment_are_named() {
    // A scene file naming an unknown wall treatment is refused when it is read, naming the field.
    let good = still_water_scene("wcsph", 0.1, 0.025, 0.1, None);
    let text = toml::to_string(&good).unwrap();
    let bad = text.replace("walls = \"particles\"", "walls = \"magic\"");
    assert_ne!(bad, text);
    let e = Scene::parse(&bad, "t").unwrap_err().to_string();
    assert!(e.contains("fluid.walls") && e.contains("magic"), "{e}");
    // An unknown solver is refused with the names there are.
    let dir = TempRunDir::new("t").unwrap();
    let e = REGISTRY
        .build("isph", &ctx_for(&good, &dir))
        .err()
        .unwrap()
        .to_string();
    assert!(
        e.contains("isph") && e.contains("muller") && e.contains("wcsph") && e.contains("dfsph"),
        "{e}"
    );
}

/// Each solver reads its own table: a bad value or an unknown key in it is named with its field
/// and line by the registry's check, and a table that belongs to no solver is refused.
#[test]
fn solver_tables_are_checked_by_the_registry() {
    let good = still_water_scene("wcsph", 0.1, 0.025, 0.1, None);
    let text = toml::to_string(&good).unwrap();
    let checked = |extra: &str| scene_errors(&format!("{text}\n{extra}"));
    assert_eq!(
        checked("[fluid.wcsph]\ngamma = 7.0\nintegrator = \"verlet\"\n"),
        ""
    );
    let e = checked("[fluid.wcsph]\ngamma = nan\n");
    assert!(
        e.contains("fluid.wcsph.gamma") && e.contains("line ") && e.contains("fix"),
        "{e}"
    );
    let e = checked("[fluid.wcsph]\nintegrator = \"rk4\"\n");
    assert!(
        e.contains("fluid.wcsph") && e.contains("rk4") && e.contains("verlet"),
        "{e}"
    );
    let e = checked("[fluid.muller]\nstifness = 3.0\n");
    assert!(e.contains("fluid.muller") && e.contains("stifness"), "{e}");
    let e = checked("[fluid.muller]\nsupport_ratio = 0.0\n");
    assert!(e.contains("fluid.muller.support_ratio"), "{e}");
    let e = checked("[fluid.isph]\ncfl = 0.4\n");
    assert!(
        e.contains("fluid.isph") && e.contains("[fluid.wcsph]"),
        "{e}"
    );
    let e = checked("").is_empty();
    assert!(e);
    let bad_default = text.replace("solver = \"wcsph\"", "solver = \"sph\"");
    let e = Scene::parse_checked(&bad_default, "t", &[&fluid_node::check_scene])
        .unwrap_err()
        .to_string();
    assert!(e.contains("fluid.solver") && e.contains("muller"), "{e}");
    // A solver built from a scene whose table was never checked still refuses it, by field.
    let mut scene = good;
    scene.fluid.as_mut().unwrap().solvers.insert(
        "wcsph".into(),
        toml::Value::Table(toml::from_str("sound_speed = 0.0").unwrap()),
    );
    let e = REGISTRY
        .build("wcsph", &ctx_for(&scene, &dir_for_test()))
        .err()
        .unwrap()
        .to_string();
    assert!(e.contains("fluid.wcsph.sound_speed"), "{e}");
}

fn dir_for_test() -> TempRunDir {
    TempRunDir::new("t").unwrap()
}

#[test]
fn a_step_far_beyond_the_proposal_stops_with_the_limit_named() {
    for solver in REGISTRY.names() {
        let scene = dam_break_scene(solver, 2, 0.1, 6, None);
        let dir = TempRunDir::new("t").unwrap();
        let mut s = REGISTRY.build(solver, &ctx_for(&scene, &dir)).unwrap();
        let dt = 50.0 * s.dt_proposal();
        let mut err = None;
        for _ in 0..200 {
            if let Err(e) = s.advance(dt) {
                err = Some(e);
                break;
            }
        }
        match err {
            Some(SolverError::Unstable(m)) => {
                assert!(
                    m.starts_with(&format!("{solver}:")) && m.contains("limit exceeded"),
                    "{m}"
                );
            }
            other => panic!("{solver}: expected an instability, got {other:?}"),
        }
    }
}

#[test]
fn too_soft_muller_stiffness_warns_with_the_compression() {
    let mut scene = still_water_scene("muller", 0.1, 0.0125, 0.1, None);
    // A hundredth of the default k: the column compresses by several per cent.
    let c2 = 100.0 * 2.0 * 9.81 * 0.1;
    scene.fluid.as_mut().unwrap().solvers.insert(
        "muller".into(),
        toml::Value::Table(toml::from_str(&format!("stiffness = {}", 0.01 * c2)).unwrap()),
    );
    let dir = TempRunDir::new("t").unwrap();
    let mut s = REGISTRY.build("muller", &ctx_for(&scene, &dir)).unwrap();
    let mut warning = None;
    for _ in 0..400 {
        let dt = s.dt_proposal();
        let r = s.advance(dt).unwrap();
        if r.warning.is_some() {
            warning = r.warning;
            break;
        }
    }
    let w = warning.expect("a too-soft EOS must warn");
    assert!(w.contains("compression") && w.contains('%'), "{w}");
}

#[test]
fn frames_gauges_and_probes_are_written() {
    let scene = still_water_scene("wcsph", 0.1, 0.025, 0.05, None);
    let dir = TempRunDir::new("t").unwrap();
    let mut s = REGISTRY.build("wcsph", &ctx_for(&scene, &dir)).unwrap();
    let steps = run(s.as_mut(), &scene, 0.05, |_, _| {}).unwrap();
    s.write_frame(3, 0.05).unwrap();
    let vtp =
        String::from_utf8_lossy(&std::fs::read(dir.path().join("particles_00003.vtp")).unwrap())
            .into_owned();
    for name in ["density", "pressure", "velocity"] {
        assert!(
            vtp.contains(&format!("Name=\"{name}\"")),
            "{name} missing from the frame"
        );
    }
    let gauges = std::fs::read_to_string(dir.path().join("gauges.csv")).unwrap();
    // The surface column, then the highest water (spray included) at the same gauge.
    assert_eq!(gauges.lines().next().unwrap(), "time,centre,centre_spray");
    let last: Vec<f64> = gauges
        .lines()
        .last()
        .unwrap()
        .split(',')
        .map(|v| v.parse().unwrap())
        .collect();
    assert!(
        (last[1] - 0.1).abs() < 0.025 && last[2] >= last[1] - 0.025,
        "still water 0.1 m deep at dx = 0.025: {last:?}"
    );
    // At most one row per step and per output.interval/50 (here 0.001 s) of simulated time.
    let times: Vec<f64> = gauges
        .lines()
        .skip(1)
        .map(|l| l.split(',').next().unwrap().parse().unwrap())
        .collect();
    assert!(
        times.len() >= 20 && times.len() as u64 <= steps,
        "{} gauge rows for {steps} steps",
        times.len()
    );
    assert!(
        times.windows(2).all(|w| w[1] - w[0] >= 0.001 - 1e-6),
        "rows closer than interval/50: {times:?}"
    );
    let probes = std::fs::read_to_string(dir.path().join("probes.csv")).unwrap();
    assert_eq!(probes.lines().next().unwrap(), "time,p25,p50,p75");
    let last: Vec<f64> = probes
        .lines()
        .last()
        .unwrap()
        .split(',')
        .map(|v| v.parse().unwrap())
        .collect();
    assert!(
        last[1] > 0.0 && last[3] > last[1],
        "probe pressures {last:?}"
    );
}

#[test]
fn default_scene_couples_with_the_moving_wedge() {
    // The paper's sliding wedge (embedded default), coarsened: both solvers build, take the
    // wedge's geometry, push on it once water reaches it, and step.
    let mut scene = shared::scene::Scene::default_scene();
    scene.set_dx(0.08);
    let moving = scene.moving_blocks();
    let state = common::wedge_in_surface(&scene);
    for solver in REGISTRY.names() {
        let dir = TempRunDir::new("t").unwrap();
        let mut s = REGISTRY.build(solver, &ctx_for(&scene, &dir)).unwrap();
        s.read_geometry(&[state], &[]);
        let mut loads = vec![shared::protocol::BlockLoad::default(); moving.len()];
        s.prepare_step();
        s.write_loads(&mut loads);
        assert_eq!(loads[0].block, moving[0] as u32);
        let f = loads[0].force;
        // The water pushes the wedge up (and the particles down): Eq. 22 both ways.
        assert!(
            f[2] > 0.0 && f.iter().all(|x| x.is_finite()),
            "{solver}: load {f:?}"
        );
        for _ in 0..5 {
            s.prepare_step();
            s.write_loads(&mut loads);
            let dt = s.dt_proposal().min(scene.time.dt_max);
            s.advance(dt).unwrap();
        }
        s.finish().unwrap();
    }
}
