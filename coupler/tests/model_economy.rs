//! "Model no more than a scene needs" inside the solid solver: fixed blocks carry no unknowns
//! and are never checked against each other, and blocks are rigid (6 unknowns, shape kept
//! exactly) unless the scene asks for deformation (`elastic = {...}`: 12 unknowns, and the
//! shape then changes under load). The process-level half (no fluid node for a
//! dry scene, no solid node without moving blocks, --target-error) is in tests/tests/limits.rs.

use shared::math::STANDARD_GRAVITY as G;
use shared::solver::Solver;
use solid_node::verification::{Harness, block_toml, box_corners, scene};

/// A row of `n` fixed boxes that overlap their neighbours, and one free block dropped on them.
fn crowded_floor(n: usize) -> shared::scene::Scene {
    let mut blocks: Vec<String> = (0..n)
        .map(|i| {
            let x = i as f64 * 0.5;
            // 0.6 m long every 0.5 m: each overlaps the next by 0.1 m.
            block_toml(
                &format!("slab{i}"),
                "fixed",
                2500.0,
                &box_corners([x, -1.0, -0.5], [x + 0.6, 1.0, 0.0]),
                "",
            )
        })
        .collect();
    blocks.push(block_toml(
        "rock",
        "free",
        2500.0,
        &box_corners([1.0, -0.1, 0.0], [1.2, 0.1, 0.2]),
        "",
    ));
    scene(
        "crowded",
        [0.0, 0.0, -G],
        20.0,
        "",
        "damping_ratio = 0.2",
        &blocks,
    )
}

#[test]
fn fixed_blocks_have_no_unknowns_and_no_contacts_among_themselves() {
    for solver in solid_node::REGISTRY.names() {
        let mut h = Harness::new(&crowded_floor(20), solver).unwrap();
        let rock = h.solver.block_index("rock").unwrap();
        // Only the free block is integrated.
        assert_eq!(h.world().free, vec![rock], "{solver}");
        let fixed_before: Vec<_> = h
            .world()
            .blocks
            .iter()
            .filter(|b| b.name != "rock")
            .map(|b| b.position)
            .collect();
        h.run_until(0.2, None, |w| {
            // 19 overlapping fixed pairs exist; none is ever a broad-phase candidate or a contact.
            for &(a, b) in &w.broad.pairs {
                assert!(
                    a as usize == rock || b as usize == rock,
                    "{solver}: fixed pair ({a}, {b}) checked"
                );
            }
            assert!(!w.contacts.is_empty() || w.time < 0.01);
            for c in &w.contacts {
                assert!(
                    c.p as usize == rock || c.q as usize == rock,
                    "{solver}: contact between fixed blocks"
                );
            }
        })
        .unwrap();
        assert!(!h.world().contacts.is_empty(), "{solver}: the rock landed");
        // Fixed blocks never moved (they have nothing to move with).
        let fixed_after: Vec<_> = h
            .world()
            .blocks
            .iter()
            .filter(|b| b.name != "rock")
            .map(|b| b.position)
            .collect();
        assert_eq!(fixed_before, fixed_after, "{solver}");
    }
}

#[test]
fn blocks_are_rigid_unless_the_scene_asks() {
    // A free block spinning and landing on the floor keeps every corner-to-corner distance:
    // rigid 6-DOF bodies with exactly integrated rotations, unless the scene gives it
    // `elastic`, when it has 12 unknowns and the landing deforms it.
    for solver in solid_node::REGISTRY.names() {
        for elastic in [false, true] {
            let extra = if elastic {
                "\nelastic = { young_modulus = 1e6, poisson_ratio = 0.25 }"
            } else {
                ""
            };
            let worst = landing_shape_change(solver, extra);
            if elastic {
                assert!(
                    worst > 1e-4,
                    "{solver}: a soft block must deform: {worst:e}"
                );
            } else {
                assert!(
                    worst < 1e-12,
                    "{solver}: the block changed shape by {worst:e}"
                );
            }
        }
    }
}

/// The largest relative change of a corner-to-corner distance of a block that lands on the
/// floor, spinning, over 0.5 s; also checks its number of unknowns.
fn landing_shape_change(solver: &str, extra: &str) -> f64 {
    let text = block_toml(
        "rock",
        "free",
        2500.0,
        &box_corners([-0.1, -0.2, 0.05], [0.1, 0.2, 0.35]),
        &format!("angular_velocity = [3.0, 5.0, 1.0]\nvelocity = [0.0, 0.0, -1.0]{extra}"),
    );
    let floor = block_toml(
        "floor",
        "fixed",
        2500.0,
        &box_corners([-2.0, -2.0, -0.5], [2.0, 2.0, 0.0]),
        "",
    );
    let s = scene(
        "rigid",
        [0.0, 0.0, -G],
        10.0,
        "",
        "damping_ratio = 0.1",
        &[floor, text],
    );
    let mut h = Harness::new(&s, solver).unwrap();
    let unknowns = if extra.is_empty() { 6 } else { 12 };
    assert_eq!(h.solver.unknowns(), unknowns, "{solver}");
    let i = h.solver.block_index("rock").unwrap();
    let dists = |w: &solid_node::world::World| -> Vec<f64> {
        let v = &w.blocks[i].world_vertices;
        let mut d = Vec::new();
        for a in 0..v.len() {
            for b in a + 1..v.len() {
                d.push((v[a] - v[b]).norm());
            }
        }
        d
    };
    let before = dists(h.world());
    let mut worst: f64 = 0.0;
    let mut touched = false;
    h.run_until(0.5, None, |w| {
        touched |= !w.contacts.is_empty();
        for (a, b) in dists(w).iter().zip(&before) {
            worst = worst.max((a - b).abs() / b);
        }
    })
    .unwrap();
    assert!(touched, "{solver}: the block hit the floor");
    assert!(h.solver.dt_proposal() > 0.0);
    worst
}
