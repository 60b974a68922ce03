//! The verification cases of `solid-validate` (shortened where they are long), as tests.

use solid_node::verification::{self as v, Row};

/// `case`'s rows for every solver of the registry.
fn each<R: IntoIterator<Item = Row>>(case: impl Fn(&'static str) -> R) -> Vec<Row> {
    solid_node::REGISTRY
        .names()
        .into_iter()
        .flat_map(case)
        .collect()
}

fn check(rows: &[Row]) {
    // As `solid-validate` decides: ordinary rows pass, known limitations fail.
    let unexpected: Vec<Row> = rows.iter().filter(|r| !r.as_expected()).cloned().collect();
    assert!(
        unexpected.is_empty(),
        "cases not as documented:\n{}",
        v::markdown(&unexpected)
    );
}

#[test]
fn free_fall_is_exact() {
    check(&each(|s| [v::free_fall(s)]));
}

#[test]
fn spinning_block_keeps_its_size() {
    check(&each(|s| [v::spinning_block(s)]));
}

#[test]
fn incline_sticks_and_slides() {
    check(&each(v::incline_rows));
}

#[test]
fn slide_or_topple_classification() {
    check(&each(v::slide_or_topple));
}

#[test]
fn restitution_of_both_schemes() {
    check(&each(v::restitution_rows));
}

#[test]
fn explicit_past_its_limit_is_reported_unstable() {
    check(&v::explicit_limit_rows());
}

#[test]
fn stack_stays_at_rest() {
    check(&each(|s| [v::stack_row(s, 3.0)]));
}

/// Boxes cut by one joint set, flush, pressed several contact margins deep: each holds the
/// one above on its springs (without contact/narrow_phase.rs's `over_face` the column sinks
/// into itself).
#[test]
fn flush_column_holds_on_its_springs() {
    check(&each(|s| [v::flush_column_row(s)]));
}

#[test]
fn default_scene_wedge_slides_smoothly() {
    check(&each(v::default_wedge_rows));
}

#[test]
fn newmark_restitution_tends_to_shi_asymptote() {
    for w in [1e-3, 1e-2] {
        let e = v::newmark_restitution(w).unwrap();
        let a = (-std::f64::consts::PI * w / 4.0).exp();
        assert!((e / a - 1.0).abs() < 0.2 * w, "Ω = {w}: {e} vs {a}");
    }
    // Ω = 2 turns a quarter period per step (e = 1/3 exactly); past Ω = 4 no half cycle.
    assert!((v::newmark_restitution(2.0).unwrap() - 1.0 / 3.0).abs() < 1e-12);
    assert!(v::newmark_restitution(3.99).is_some());
    assert!(v::newmark_restitution(4.01).is_none());
}

#[test]
fn deformable_block_resting_strain() {
    check(&each(v::deformable::resting_rows));
}

#[test]
fn deformable_block_free_vibration() {
    check(&each(v::deformable::vibration_rows));
}

#[test]
fn deformable_block_explicit_limit_names_the_elastic_mode() {
    check(&v::deformable::elastic_limit_rows());
}

#[test]
fn stiff_deformable_block_slides_like_the_rigid_one() {
    check(&each(|s| [v::deformable::incline_rigid_vs_deformable(s)]));
}

#[test]
fn newmark_vibration_theory() {
    // Small Ω: period stretch 1 + Ω²/... → 1, decay per period exp(−πΩ/2).
    for w in [1e-3, 1e-2] {
        let (stretch, decay) = v::deformable::newmark_vibration(w);
        assert!((stretch - 1.0).abs() < w, "{stretch}");
        let a = (-std::f64::consts::PI * w / 2.0).exp();
        assert!((decay / a - 1.0).abs() < 0.2 * w, "Ω = {w}: {decay} vs {a}");
    }
}

#[test]
fn jointed_slopes_stand_or_fail_by_their_factor_of_safety() {
    let rows = v::jointed_rows(v::EXPLICIT);
    println!("{}", v::markdown(&rows));
    assert_eq!(rows.len(), 6);
    check(&rows);
}

#[test]
fn jointed_slopes_stand_or_fail_by_their_factor_of_safety_implicit() {
    let rows = v::jointed_rows("implicit");
    println!("{}", v::markdown(&rows));
    assert_eq!(rows.len(), 6);
    check(&rows);
}
