//! The solid solvers through the coupling interface: what the runtime and the fluid side rely
//! on (geometry out, loads in, kinematic motion, errors, output files).

use shared::math::{Real, Vector};
use shared::protocol::{BlockLoad, BlockState};
use shared::scene::{CouplingScheme, MotionSpec, Scene, ShapeSpec};
use shared::solver::{SetupContext, SolidSolver, Solver, SolverError};
use solid_node::integrators::explicit::ExplicitParams;
use solid_node::verification::{EXPLICIT, Harness, block_toml, box_corners, floor_toml, scene};

fn space_scene(extra_blocks: &[String]) -> Scene {
    let mut blocks = vec![block_toml(
        "rock",
        "free",
        2000.0,
        &box_corners([-0.5, -0.25, -0.1], [0.5, 0.25, 0.1]),
        "",
    )];
    blocks.extend_from_slice(extra_blocks);
    scene(
        "space",
        [0.0, 0.0, 0.0],
        20.0,
        "[solid.implicit]\ndisplacement_limit = 10.0",
        "",
        &blocks,
    )
}

/// A 0.4 m rock cube resting on the floor under gravity, with `[solid.contact]` `contact`.
fn rock_on_floor(name: &str, contact: &str) -> Scene {
    scene(
        name,
        [0.0, 0.0, -9.81],
        5.0,
        "",
        contact,
        &[
            floor_toml(),
            block_toml(
                "rock",
                "free",
                2500.0,
                &box_corners([-0.2, -0.2, 0.0], [0.2, 0.2, 0.4]),
                "",
            ),
        ],
    )
}

#[test]
fn unknown_solver_is_refused_with_the_choices() {
    let s = space_scene(&[]);
    let dir = std::env::temp_dir();
    let ctx = SetupContext {
        scene: &s,
        run_dir: &dir,
        scheme: CouplingScheme::Parallel,
        peer_present: false,
    };
    let Err(SolverError::Failed(msg)) = solid_node::REGISTRY.build("verlet", &ctx) else {
        panic!("accepted an unknown solver")
    };
    assert!(
        msg.contains("verlet") && msg.contains("fix: use one of explicit, implicit"),
        "{msg}"
    );
}

#[test]
fn non_convex_block_is_rejected_by_name() {
    let mut s = space_scene(&[]);
    s.blocks[0].name = "dented".into();
    s.blocks[0].shape = ShapeSpec::Convex {
        vertices: vec![
            [0., 0., 0.],
            [1., 0., 0.],
            [0., 1., 0.],
            [0., 0., 1.],
            [0.1, 0.1, 0.1],
        ],
    };
    let dir = std::env::temp_dir();
    let ctx = SetupContext {
        scene: &s,
        run_dir: &dir,
        scheme: CouplingScheme::Parallel,
        peer_present: false,
    };
    let Err(SolverError::Failed(msg)) = solid_node::REGISTRY.build("explicit", &ctx) else {
        panic!("accepted a concave block")
    };
    assert!(
        msg.contains("dented") && msg.contains("not convex"),
        "{msg}"
    );
}

/// Constant force and torque from the "fluid" on a block in space: x = ½ F/m t², and about a
/// principal axis ω = τ/I t, for both schemes (constant loads are integrated exactly).
#[test]
fn fluid_loads_move_the_block() {
    for solver in solid_node::REGISTRY.names() {
        let s = space_scene(&[]);
        let mut h = Harness::new(&s, solver).unwrap();
        let (m, izz) = (h.block("rock").mass, h.block("rock").inertia[(2, 2)]);
        let load = BlockLoad {
            block: 0,
            _reserved: 0,
            force: [3.0, -1.0, 2.0],
            torque: [0.0, 0.0, 0.5],
            ..Default::default()
        };
        let t = 0.5;
        while h.time() < t - 1e-12 {
            h.solver.read_loads(&[load]);
            h.solver.advance(1e-3).unwrap();
        }
        let b = h.block("rock");
        let expect = Vector::from(load.force) * (0.5 * t * t / m);
        assert!(
            (b.position.coords - expect).norm() < 1e-9 * expect.norm(),
            "{solver}: {} vs {expect}",
            b.position
        );
        let w = 0.5 / izz * t;
        assert!(
            (b.angular_velocity.z - w).abs() < 1e-9 * w,
            "{solver}: ω {} vs {w}",
            b.angular_velocity
        );
        assert!(
            (b.velocity - Vector::from(load.force) * (t / m)).norm() < 1e-9,
            "{solver}: v {}",
            b.velocity
        );
    }
}

/// A piston oscillating sinusoidally follows MotionSpec exactly, and the geometry message
/// lists the moving blocks in scene order with their world corners.
#[test]
fn kinematic_piston_and_geometry_message() {
    for solver in solid_node::REGISTRY.names() {
        let piston = block_toml(
            "piston",
            "kinematic",
            2000.0,
            &box_corners([3.0, -0.5, -0.5], [3.2, 0.5, 0.5]),
            "motion = { type = \"sine\", amplitude = [0.3, 0.0, 0.0], period = 2.0, ramp = 0.5 }",
        );
        let wall = block_toml(
            "wall",
            "fixed",
            2000.0,
            &box_corners([-9.0, -9.0, -9.0], [-8.0, 9.0, 9.0]),
            "",
        );
        let s = space_scene(&[wall, piston]);
        let motion = MotionSpec::Sine {
            amplitude: [0.3, 0.0, 0.0],
            period: 2.0,
            phase: 0.0,
            ramp: 0.5,
        };
        let mut h = Harness::new(&s, solver).unwrap();
        h.run_until(0.7, Some(1e-3), |_| {}).unwrap();
        let p = h.block("piston");
        let t = h.time();
        assert!((t - 0.7).abs() < 1e-12);
        assert!(
            (p.position.x - (3.1 + motion.displacement(t).x)).abs() < 1e-12,
            "{solver}"
        );
        assert!((p.velocity - motion.velocity(t)).norm() < 1e-12, "{solver}");

        assert_eq!(s.moving_blocks(), vec![0, 2]);
        let n = h.solver.vertex_count();
        assert_eq!(n, 16);
        let mut states = vec![BlockState::default(); 2];
        let mut verts = vec![[0.0; 3]; n];
        h.solver.write_geometry(&mut states, &mut verts);
        assert_eq!((states[0].block, states[1].block), (0, 2));
        assert_eq!(
            (
                states[0].first_vertex,
                states[1].first_vertex,
                states[1].vertex_count
            ),
            (0, 8, 8)
        );
        let xs: Vec<Real> = verts[8..].iter().map(|v| v[0]).collect();
        let lo = xs.iter().cloned().fold(Real::INFINITY, Real::min);
        assert!(
            (lo - (3.0 + motion.displacement(t).x)).abs() < 1e-12,
            "{solver}: piston corners at {xs:?}"
        );
        assert_eq!(states[1].orientation, [0.0, 0.0, 0.0, 1.0]);
        assert!((states[1].velocity[0] - motion.velocity(t).x).abs() < 1e-12);
    }
}

/// A piston pushing a free block: the block is moved (contact with a kinematic block works).
#[test]
fn piston_pushes_a_block() {
    for solver in solid_node::REGISTRY.names() {
        let floor = block_toml(
            "floor",
            "fixed",
            2500.0,
            &box_corners([-2.0, -1.0, -0.5], [4.0, 1.0, 0.0]),
            "",
        );
        let piston = block_toml(
            "piston",
            "kinematic",
            2500.0,
            &box_corners([-0.6, -0.5, 0.01], [-0.4, 0.5, 0.5]),
            "motion = { type = \"linear\", velocity = [0.5, 0.0, 0.0] }",
        );
        let rock = block_toml(
            "rock",
            "free",
            2500.0,
            &box_corners([-0.2, -0.2, 0.0], [0.2, 0.2, 0.3]),
            "",
        );
        let s = scene(
            "push",
            [0.0, 0.0, -9.81],
            10.0,
            "",
            "friction_angle = 20.0\ndamping_ratio = 0.2",
            &[floor, piston, rock],
        );
        let mut h = Harness::new(&s, solver).unwrap();
        h.run_until(1.0, None, |_| {}).unwrap();
        // The piston face reaches the rock at t = 0.4 s and pushes it 0.3 m by t = 1 s.
        let x = h.block("rock").position.x;
        assert!((x - 0.3).abs() < 0.02, "{solver}: rock at x = {x}");
    }
}

#[test]
fn leaving_the_domain_is_unstable() {
    for solver in solid_node::REGISTRY.names() {
        let s = scene(
            "escape",
            [0.0, 0.0, 0.0],
            1.0,
            "[solid.implicit]\ndisplacement_limit = 10.0",
            "",
            &[block_toml(
                "rock",
                "free",
                2000.0,
                &box_corners([-0.1; 3], [0.1; 3]),
                "velocity = [5.0, 0.0, 0.0]",
            )],
        );
        let mut h = Harness::new(&s, solver).unwrap();
        let err = h.run_until(1.0, Some(1e-3), |_| {}).unwrap_err();
        let SolverError::Unstable(msg) = err else {
            panic!("{solver}: {err}")
        };
        assert!(
            msg.contains(solver) && msg.contains("left the domain") && msg.contains("rock"),
            "{msg}"
        );
        assert!(
            (h.time() - 0.2).abs() < 2e-3,
            "{solver}: left at {}",
            h.time()
        );
    }
}

#[test]
fn non_finite_load_is_unstable_not_nan_output() {
    for solver in solid_node::REGISTRY.names() {
        let mut h = Harness::new(&space_scene(&[]), solver).unwrap();
        h.solver.read_loads(&[BlockLoad {
            block: 0,
            _reserved: 0,
            force: [f64::NAN, 0.0, 0.0],
            torque: [0.0; 3],
            ..Default::default()
        }]);
        let err = h.solver.advance(1e-3).unwrap_err();
        assert!(
            matches!(err, SolverError::Unstable(ref m) if m.contains("non-finite")),
            "{solver}: {err}"
        );
    }
}

/// The implicit scheme cuts its step when a block moves more than displacement_limit of its
/// size per step, and still ends exactly at t + dt.
#[test]
fn implicit_substeps_end_exactly_on_the_coupler_step() {
    let s = scene(
        "fast",
        [0.0, 0.0, 0.0],
        50.0,
        "[solid.implicit]\ndisplacement_limit = 0.01",
        "",
        &[block_toml(
            "rock",
            "free",
            2000.0,
            &box_corners([-0.1; 3], [0.1; 3]),
            "velocity = [20.0, 0.0, 0.0]",
        )],
    );
    let mut h = Harness::new(&s, "implicit").unwrap();
    // 20 m/s × 1 ms = 0.02 m = 0.058 of the 0.35 m block: the step must be cut to a ninth.
    let report = h.solver.advance(1e-3).unwrap();
    assert!(report.warning.is_some_and(|w| w.contains("sub-steps")));
    assert_eq!(h.time(), 1e-3);
    assert!((h.block("rock").position.x - 0.02).abs() < 1e-12);
    let proposal = h.solver.dt_proposal();
    assert!(
        proposal < 1e-3 / 3.0 && proposal > 1e-4,
        "proposal {proposal}"
    );
}

/// Default normal spring: the lightest free block resting on one face sinks ε·size/4 on its four
/// corner springs, and dt_proposal follows 2/ω_max.
#[test]
fn default_stiffness_and_dt_proposal() {
    let s = rock_on_floor("rest", "damping_ratio = 0.5");
    let mut h = Harness::new(&s, "explicit").unwrap();
    h.run_until(0.5, None, |_| {}).unwrap();
    let b = h.block("rock");
    let sink = -b.aabb_min.z;
    let expect = s.solid.contact.allowed_penetration * b.size() / 4.0;
    assert!(
        (sink / expect - 1.0).abs() < 0.01,
        "sank {sink:e}, expected {expect:e}"
    );
    let k = h.world().penalty.normal;
    assert!(
        (k - b.mass * 9.81 / (s.solid.contact.allowed_penetration * b.size())).abs() < 1e-6 * k
    );
    // dt = safety · 2/ω_max, with ω_max from the contact springs: at least the vertical mode
    // sqrt(4k/m) and, for this block, below the set-up floor's worst face (its side: rocking
    // about the short axis, ω² = k·4·0.2²/I = 9.6 k/m).
    let omega = 2.0 * safety_factor(&s) / h.solver.dt_proposal();
    let w_vertical = (4.0 * k / b.mass).sqrt();
    assert!(
        omega >= w_vertical && omega <= (9.6 * k / b.mass).sqrt() * 1.0001,
        "ω_max {omega} vs vertical {w_vertical}"
    );
}

/// A contact stiffness whose explicit step is below `time.dt_min` before anything moves is
/// refused at set-up naming the stiffness, where it came from and the fix (the coupler used to
/// stop at step 0 on a collapsed proposal of 1.5e-150 s, naming the node only).
#[test]
fn a_contact_stiffness_past_any_step_is_refused_at_set_up_by_name() {
    let rest = |contact: &str| rock_on_floor("stiff", contact);
    // The scene's dt_min is 1e-12 s; the default stiffness is far from it.
    assert!(Harness::new(&rest(""), "explicit").is_ok());
    let err = match Harness::new(&rest("normal_stiffness = 1e300"), "explicit") {
        Ok(_) => panic!("built with a stiffness of 1e300 N/m"),
        Err(e) => e.to_string(),
    };
    assert!(
        err.contains("is below time.dt_min = 1e-12 s before anything moves")
            && err.contains("normal stiffness is 1.000e300 N/m ([solid.contact].normal_stiffness)")
            && err.contains("fix: leave [solid.contact] normal_stiffness out"),
        "{err}"
    );
}

#[test]
fn outputs_csv_and_vtp() {
    // The floor under the rock's bottom face (z = −0.1), touching it: a free block may not
    // start inside a fixed one.
    let floor = block_toml(
        "floor",
        "fixed",
        2500.0,
        &box_corners([-1.0, -1.0, -0.6], [1.0, 1.0, -0.1]),
        "",
    );
    let mut s = space_scene(&[floor]);
    s.output.vtk = true;
    s.output.interval = 0.02;
    let mut h = Harness::new(&s, "explicit").unwrap();
    h.run_until(0.1, Some(1e-4), |_| {}).unwrap();
    h.solver.write_frame(3, h.time()).unwrap();
    h.solver.finish().unwrap();
    let vtp =
        String::from_utf8_lossy(&std::fs::read(h.run_dir().join("blocks_00003.vtp")).unwrap())
            .into_owned();
    assert!(
        vtp.contains("PolyData") && vtp.contains("NumberOfPolys=\"12\""),
        "{}",
        &vtp[..vtp.len().min(600)]
    );
    let csv = std::fs::read_to_string(h.run_dir().join("blocks.csv")).unwrap();
    let lines: Vec<&str> = csv.lines().collect();
    assert!(lines[0].starts_with("time,block,x,y,z,vx,vy,vz,qi,qj,qk,qw,wx,wy,wz"));
    // 1000 steps of 0.1 ms, sampled at most every 1 ms (0.02/20): t = 0, 0.001, ..., 0.1.
    assert_eq!(lines.len() - 1, 101, "{} rows", lines.len() - 1);
    assert!(
        lines
            .iter()
            .skip(1)
            .all(|l| l.split(',').nth(1) == Some("rock"))
    );
}

/// The paper's wave maker (scenes/wave_maker.toml): the only moving block is a kinematic
/// piston, so there is no free block whose energy the monitor could watch; the run must go on
/// (it once stopped at step 0 with "energy grew NaN-fold", 0/0).
#[test]
fn piston_only_scene_runs() {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../scenes/wave_maker.toml");
    let s = shared::scene::Scene::load(&path).unwrap();
    for solver in solid_node::REGISTRY.names() {
        let mut h = Harness::new(&s, solver).unwrap();
        h.run_until(0.5, Some(2e-3), |_| {}).unwrap();
        assert!((h.time() - 0.5).abs() < 1e-12, "{solver}");
    }
}

/// `[solid.explicit] safety_factor` of a scene, as the explicit scheme reads it.
fn safety_factor(s: &shared::scene::Scene) -> Real {
    shared::registry::params::<ExplicitParams>(&s.solid.solvers, "solid", EXPLICIT)
        .unwrap()
        .safety_factor
}

/// The solid registry checks `[solid] solver` and each solver's own table `[solid.<name>]`:
/// every bad value, unknown key or unknown table is named with its field, line and fix.
#[test]
fn solver_tables_are_checked_by_the_registry() {
    let base = "name = \"t\"\n[time]\nend = 1.0\n[domain]\nmin = [-5.0, -5.0, -5.0]\nmax = [5.0, 5.0, 5.0]\n\
                [solid]\nsolver = \"implicit\"\n[solid.contact]\nfriction_angle = 30.0\n\
                [[block]]\nname = \"rock\"\nkind = \"free\"\ndensity = 2000.0\n\
                shape = { type = \"box\", min = [-0.1, -0.1, -0.1], max = [0.1, 0.1, 0.1] }\n";
    let checked = |text: &str| {
        Scene::parse_checked(text, "t", &[&solid_node::check_scene])
            .err()
            .map(|e| e.to_string())
            .unwrap_or_default()
    };
    let with = |extra: &str| format!("{base}{extra}");
    // The line of `key` in `text`, as the error should name it.
    let line_of = |text: &str, key: &str| {
        let n = text.lines().position(|l| l.starts_with(key)).unwrap() + 1;
        format!("line {n}: ")
    };
    assert_eq!(checked(base), "");
    assert_eq!(
        checked(&with(
            "[solid.implicit]\nmax_open_close = 8\ndisplacement_limit = 0.02\n\
             [solid.explicit]\nsafety_factor = 0.4\n"
        )),
        ""
    );
    for (table, field, value) in [
        ("implicit", "max_open_close", "0"),
        ("implicit", "displacement_limit", "nan"),
        ("implicit", "displacement_limit", "-0.01"),
        ("explicit", "safety_factor", "inf"),
        ("explicit", "safety_factor", "0.0"),
    ] {
        let t = with(&format!("[solid.{table}]\n{field} = {value}\n"));
        let e = checked(&t);
        assert!(
            e.contains(&format!("{}solid.{table}.{field} = ", line_of(&t, field)))
                && e.contains("fix: "),
            "{e}"
        );
    }
    // An unknown key: serde names it and what the table holds.
    let t = with("[solid.implicit]\nmax_open_closed = 3\n");
    let e = checked(&t);
    assert!(
        e.contains(&format!(
            "{}solid.implicit = ",
            line_of(&t, "[solid.implicit]")
        )) && e.contains("max_open_closed")
            && e.contains("max_open_close"),
        "{e}"
    );
    // A table that names no solver, and a stray value in [solid].
    let t = with("[solid.rk4]\nsafety_factor = 0.5\n");
    let e = checked(&t);
    assert!(
        e.contains(&format!("{}solid.rk4 = ", line_of(&t, "[solid.rk4]")))
            && e.contains("[solid.explicit], [solid.implicit]"),
        "{e}"
    );
    let t = base.replace("[solid]\n", "[solid]\nmax_open_close = 6\n");
    let e = checked(&t);
    assert!(
        e.contains(&format!(
            "{}solid.max_open_close = ",
            line_of(&t, "max_open_close")
        )) && e.contains("[solid.implicit]"),
        "{e}"
    );
    // A bad default solver.
    let t = base.replace("solver = \"implicit\"", "solver = \"verlet\"");
    let e = checked(&t);
    assert!(
        e.contains(&format!(
            "{}solid.solver = \"verlet\"",
            line_of(&t, "solver")
        )) && e.contains("explicit, implicit"),
        "{e}"
    );
    // A scene whose tables were never checked: building the solver still refuses, by field.
    let s = Scene::parse(&with("[solid.implicit]\nmax_open_close = 0\n"), "t").unwrap();
    let dir = std::env::temp_dir();
    let ctx = SetupContext {
        scene: &s,
        run_dir: &dir,
        scheme: CouplingScheme::Parallel,
        peer_present: false,
    };
    let Err(SolverError::Failed(msg)) = solid_node::REGISTRY.build("implicit", &ctx) else {
        panic!("built a solver from a bad table")
    };
    assert!(msg.contains("solid.implicit.max_open_close"), "{msg}");
    // The explicit scheme does not read [solid.implicit].
    assert!(Harness::new(&s, "explicit").is_ok());
}

/// Every scene of the repository passes the solid registry's checks.
#[test]
fn repository_scenes_pass_the_solid_checks() {
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../scenes");
    let mut dirs = vec![root];
    let mut seen = 0;
    while let Some(dir) = dirs.pop() {
        for entry in std::fs::read_dir(&dir).unwrap() {
            let path = entry.unwrap().path();
            if path.is_dir() {
                dirs.push(path);
            } else if path.extension().is_some_and(|e| e == "toml") {
                if let Err(e) = Scene::load_checked(&path, &[&solid_node::check_scene]) {
                    panic!("{e}");
                }
                seen += 1;
            }
        }
    }
    assert!(seen > 0);
}
