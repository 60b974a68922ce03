//! `cargo run --release -p solid-node --bin solid-bench`: step cost of every solver for piles
//! of 10, 100 and 1000 blocks (boxes dropped in layers onto a floor, jittered and turned so
//! that vertex–face and edge–edge contacts both occur). Prints a markdown table.
//!
//! Options: `--steps N` timed steps per case (default 200), `--warm N` steps before timing
//! (default 300), `--sizes 10,100,1000`, `--solvers A,B` (default: every solver of
//! `solid_node::REGISTRY`), `--elastic E` to make every block of the pile deformable
//! (12 unknowns) with Young's modulus E [Pa], ν = 0.25, `--elastic-one E` only the first (the
//! rest rigid: what a scene with one deformable block costs a scheme with a global matrix,
//! whose blocks are then all 12×12), `--scene FILE` the blocks of a scene instead of the piles
//! (its solid alone, dry: a cut rock mass of `[[slide]]`s, say, sliding and breaking up without
//! water).

use shared::coupling::step::StepRule;
use solid_node::verification::{Harness, block_toml, box_corners, scene};
use std::time::Instant;

fn pile(n: usize, elastic: Option<f64>, only_first: bool) -> shared::scene::Scene {
    let extra = elastic.map_or(String::new(), |e| {
        format!("elastic = {{ young_modulus = {e:e}, poisson_ratio = 0.25 }}")
    });
    let side = (n as f64).cbrt().ceil() as usize;
    let mut seed = 2024u64;
    let mut rnd = move || {
        seed = seed
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (seed >> 11) as f64 / (1u64 << 53) as f64 - 0.5
    };
    let a = 0.2;
    let pitch = 0.23;
    let half = side as f64 * pitch / 2.0 + 0.5;
    let mut blocks = vec![block_toml(
        "floor",
        "fixed",
        2500.0,
        &box_corners([-half, -half, -0.3], [half, half, 0.0]),
        "",
    )];
    for k in 0..n {
        let (i, j, l) = (k % side, (k / side) % side, k / (side * side));
        let (cx, cy) = (
            (i as f64 + 0.5) * pitch - side as f64 * pitch / 2.0 + 0.01 * rnd(),
            (j as f64 + 0.5) * pitch - side as f64 * pitch / 2.0 + 0.01 * rnd(),
        );
        let cz = 0.002 + a / 2.0 + l as f64 * (a + 0.004);
        let turn = 0.17 * rnd();
        let (s, c) = turn.sin_cos();
        let v: Vec<[f64; 3]> = box_corners([-a / 2.0; 3], [a / 2.0; 3])
            .iter()
            .map(|p| {
                [
                    cx + c * p[0] - s * p[1],
                    cy + s * p[0] + c * p[1],
                    cz + p[2],
                ]
            })
            .collect();
        let extra = if only_first && k > 0 { "" } else { &extra };
        blocks.push(block_toml(&format!("b{k}"), "free", 2500.0, &v, extra));
    }
    scene(
        "pile",
        [0.0, 0.0, -9.81],
        half.max(5.0) + 2.0,
        "",
        "friction_angle = 30.0\ndamping_ratio = 0.1",
        &blocks,
    )
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let arg = |name: &str| {
        args.iter()
            .position(|a| a == name)
            .and_then(|i| args.get(i + 1))
            .cloned()
    };
    let steps: usize = arg("--steps").map_or(200, |s| s.parse().expect("--steps N"));
    let one = arg("--elastic-one");
    let only_first = one.is_some();
    let elastic: Option<f64> = arg("--elastic")
        .or(one)
        .map(|s| s.parse().expect("--elastic E"));
    let sizes: Vec<usize> = arg("--sizes").map_or(vec![10, 100, 1000], |s| {
        s.split(',')
            .map(|x| x.parse().expect("--sizes 10,100"))
            .collect()
    });
    println!(
        "| blocks | solver | warm-up steps | timed steps | dt [s] | contacts | ms / step | µs / block-step |"
    );
    println!("|---|---|---|---|---|---|---|---|");
    let scenes: Vec<(usize, shared::scene::Scene)> = match arg("--scene") {
        Some(path) => {
            let scene = shared::scene::Scene::load(std::path::Path::new(&path))
                .unwrap_or_else(|e| panic!("--scene {path}: {e}"));
            let n = scene
                .blocks
                .iter()
                .filter(|b| b.kind != shared::scene::BlockKind::Fixed)
                .count();
            vec![(n, scene)]
        }
        None => sizes
            .iter()
            .map(|&n| (n, pile(n, elastic, only_first)))
            .collect(),
    };
    for (n, scene) in scenes {
        let solvers: Vec<String> = arg("--solvers").map_or(
            solid_node::REGISTRY
                .names()
                .into_iter()
                .map(String::from)
                .collect(),
            |s| s.split(',').map(String::from).collect(),
        );
        for solver in &solvers {
            let mut h = Harness::new(&scene, solver).expect("pile scene builds");
            // Let the layers fall onto each other first: the timed steps then have the
            // contacts of a pile, not of blocks in the air.
            let warm: usize = arg("--warm").map_or(300, |s| s.parse().expect("--warm N"));
            let mut dt = 0.0;
            let mut run = |h: &mut Harness, k: usize| {
                // Granted as the coupler grants it (dt_max 1 ms), towards no output time.
                let rule = StepRule::new(1e-3, h.rule.dt_min);
                for _ in 0..k {
                    dt = h.step(&rule, f64::INFINITY).unwrap_or_else(|e| {
                        panic!("{solver} pile of {n}: {e}");
                    });
                }
            };
            run(&mut h, warm);
            let start = Instant::now();
            run(&mut h, steps);
            let per_step = start.elapsed().as_secs_f64() / steps as f64;
            let contacts = h.world().contacts.iter().filter(|c| c.gap < 0.0).count();
            println!(
                "| {n} | {solver} | {warm} | {steps} | {dt:.2e} | {contacts} | {:.3} | {:.2} |",
                per_step * 1e3,
                per_step * 1e6 / n as f64
            );
        }
    }
}
