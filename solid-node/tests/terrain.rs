//! Blocks on a `[[terrain]]` read from a file: the incline's Mohr–Coulomb reference with the
//! slope a triangle mesh, a block on a terrain bump that stays, and a cube resting across a
//! mesa's rim on its edge crossings alone (also on soft contacts pressed past the margin).

use solid_node::verification::{self as v, Row};

fn check(rows: &[Row]) {
    eprintln!("{}", v::markdown(rows));
    let unexpected: Vec<Row> = rows.iter().filter(|r| !r.as_expected()).cloned().collect();
    assert!(
        unexpected.is_empty(),
        "cases not as documented:\n{}",
        v::markdown(&unexpected)
    );
}

/// The rows of a case for both solvers of the registry.
fn for_both(rows: fn(&str) -> Vec<Row>) -> Vec<Row> {
    solid_node::REGISTRY
        .names()
        .into_iter()
        .flat_map(rows)
        .collect()
}

#[test]
fn incline_on_a_terrain_mesh_matches_mohr_coulomb() {
    check(&for_both(v::incline_on_terrain_rows));
}

#[test]
fn a_block_on_a_terrain_bump_tips_onto_it_and_stays() {
    check(&v::bump_rows(v::EXPLICIT));
}

#[test]
fn a_cube_across_a_terrain_ridge_rests_on_its_edge_crossings() {
    check(&for_both(v::mesa_rows));
}

#[test]
fn a_slab_pressed_in_near_a_terrain_rim_keeps_the_top_and_its_place() {
    check(&for_both(v::rim_rows));
}
