//! Probes whose face reads the wall (`reading = "wall"`, fluid-node/src/instruments/wall_load.rs)
//! in still water, for every solver: the load on a side wall and on the floor is hydrostatic.

use fluid_node::REGISTRY;
use fluid_node::validation::*;
use shared::scene::{FaceReading, ProbeFace, ProbeSpec};

/// Still water 0.1 m deep at H/dx = 8 in a tank 0.2 m long: faces 1 cm across on the right
/// wall at a quarter, half and three quarters of the depth (each across two rows of the wall's
/// particles, whose mean is the load at the face's centre), one on the floor, and a strip at
/// half the depth along the middle half of the wall's width (`span`). Their means
/// over the second half of the run are ρ0 g (η − z) within 2.5 % of ρ0 g H, η the gauge's
/// surface (the interior probes' rows allow 5 %). Measured on 30 Nov 2026: WCSPH and Riemann
/// within 0.6 % at every face, DFSPH within 1.2 %, Müller within 1.9 % (its floor).
#[test]
fn a_wall_reading_is_hydrostatic_for_every_solver() {
    let (depth, dx, end) = (0.1, 0.1 / 8.0, 0.3);
    for solver in REGISTRY.names() {
        let mut scene = still_water_scene(solver, depth, dx, end, None);
        let face = |normal| {
            Some(ProbeFace {
                diameter: 0.01,
                normal,
                reading: FaceReading::Wall,
                span: None,
            })
        };
        // And a strip: the face swept along the middle half of the wall's width.
        let strip = Some(ProbeFace {
            span: Some([0.0, 0.5 * depth, 0.0]),
            ..face([-1.0, 0.0, 0.0]).unwrap()
        });
        let zs = [0.25 * depth, 0.5 * depth, 0.75 * depth];
        for (k, z) in zs.iter().enumerate() {
            scene.probes.push(ProbeSpec {
                name: format!("wall{k}"),
                position: [2.0 * depth, 0.5 * depth, *z],
                window: Some(end / PROBE_ROWS),
                face: face([-1.0, 0.0, 0.0]),
            });
        }
        scene.probes.push(ProbeSpec {
            name: "floor".into(),
            position: [depth, 0.5 * depth, 0.0],
            window: Some(end / PROBE_ROWS),
            face: face([0.0, 0.0, 1.0]),
        });
        scene.probes.push(ProbeSpec {
            name: "strip".into(),
            position: [2.0 * depth, 0.5 * depth, 0.5 * depth],
            window: Some(end / PROBE_ROWS),
            face: strip,
        });
        let dir = TempRunDir::new("wall-load").unwrap();
        let mut s = build(solver, &scene, dir.path()).unwrap();
        run(s.as_mut(), &scene, end, |_, _| {}).unwrap();
        drop(s);
        let late = |file: &str, col: usize| {
            let text = std::fs::read_to_string(dir.path().join(file)).unwrap();
            let rows: Vec<f64> = text
                .lines()
                .skip(1)
                .map(|l| l.split(',').map(|v| v.parse::<f64>().unwrap()).collect())
                .filter(|r: &Vec<f64>| r[0] >= 0.5 * end)
                .map(|r| r[col])
                .collect();
            rows.iter().sum::<f64>() / rows.len() as f64
        };
        let surface = late("gauges.csv", 1);
        let rho_g = 1000.0 * 9.81;
        // probes.csv: the case's three interior probes, then the five faces.
        let heights = zs.iter().copied().chain([0.0, 0.5 * depth]);
        for (k, z) in heights.enumerate() {
            let read = late("probes.csv", 4 + k);
            let expected = rho_g * (surface - z);
            let e = (read - expected) / (rho_g * depth);
            eprintln!(
                "{solver}: face at z = {z:.4}: {read:.1} Pa against {expected:.1} ({:+.2} % of ρ0 g H)",
                100.0 * e
            );
            assert!(
                e.abs() <= 0.025,
                "{solver}: the face at z = {z} reads {read:.1} Pa, hydrostatic {expected:.1}: {:+.1} % of ρ0 g H",
                100.0 * e
            );
        }
    }
}

/// The wall takes the same impulse wherever the lattice puts its face. The Lobovský impact
/// (H = 300 mm, H/dx = 15, Riemann) with the tank 1.61 m long, 80.5 spacings (the wall's
/// boundary particles a whole spacing behind its face, and the water pressed into Eq. 22's
/// backstop a quarter spacing in front of it), and 1.62 m, on the lattice (the backstop idle):
/// sensor 1's wall load over the impact time agrees within 10 % (measured 30 Nov 2026: 493.6
/// and 461.1 Pa·s, 7 %). The reading counts the backstop's force; without it (the reading of
/// commit aefe4fa, whose tank was 1.61 m) the tank off the lattice read 165 Pa·s, a third.
#[test]
fn the_wall_takes_the_same_impulse_wherever_the_lattice_puts_its_face() {
    let mut on = ImpactCase::new(0.3, 15, Some(IMPACT_WINDOW));
    on.end_star = 3.3;
    assert!((on.length - 1.62).abs() < 1e-9, "{}", on.length);
    let off = ImpactCase {
        length: TANK_LENGTH,
        ..on.clone()
    };
    let impulse = |case: &ImpactCase| {
        let r = impact("riemann", case).unwrap();
        r.impulse(WALL, LOBOVSKY_H600_S1_IMPACT_TIME)
            .expect("the wall's load sees the impact")
            .0
    };
    let (on, off) = (impulse(&on), impulse(&off));
    eprintln!("sensor 1's wall-load impulse: {on:.1} Pa·s on the lattice, {off:.1} off it");
    assert!(
        (off / on - 1.0).abs() <= 0.10,
        "the wall off the lattice takes {off:.1} Pa·s, on it {on:.1}: {:+.0} %",
        100.0 * (off / on - 1.0)
    );
}
