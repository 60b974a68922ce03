//! The verification cases of `solid-validate` (shortened where they are long), as tests.

use solid_node::verification::{self as v, Row};

fn check(rows: &[Row]) {
    let failed: Vec<&Row> = rows.iter().filter(|r| !r.pass).collect();
    assert!(
        failed.is_empty(),
        "failed cases:\n{}",
        v::markdown(&rows.iter().filter(|r| !r.pass).cloned().collect::<Vec<_>>())
    );
}

#[test]
fn free_fall_is_exact() {
    check(&[v::free_fall("explicit"), v::free_fall("implicit")]);
}

#[test]
fn spinning_block_keeps_its_size() {
    check(&[v::spinning_block("explicit"), v::spinning_block("implicit")]);
}

#[test]
fn incline_sticks_and_slides() {
    let mut rows = v::incline_rows("explicit");
    rows.extend(v::incline_rows("implicit"));
    check(&rows);
}

#[test]
fn slide_or_topple_classification() {
    let mut rows = v::slide_or_topple("explicit");
    rows.extend(v::slide_or_topple("implicit"));
    check(&rows);
}

#[test]
fn restitution_of_both_schemes() {
    let mut rows = v::restitution_rows("explicit");
    rows.extend(v::restitution_rows("implicit"));
    check(&rows);
}

#[test]
fn explicit_past_its_limit_is_reported_unstable() {
    check(&v::explicit_limit_rows());
}

#[test]
fn stack_stays_at_rest() {
    check(&[v::stack_row("explicit", 3.0), v::stack_row("implicit", 3.0)]);
}

#[test]
fn default_scene_wedge_slides_smoothly() {
    let mut rows = v::default_wedge_rows("explicit");
    rows.extend(v::default_wedge_rows("implicit"));
    check(&rows);
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
    let mut rows = v::deformable::resting_rows("explicit");
    rows.extend(v::deformable::resting_rows("implicit"));
    check(&rows);
}

#[test]
fn deformable_block_free_vibration() {
    let mut rows = v::deformable::vibration_rows("explicit");
    rows.extend(v::deformable::vibration_rows("implicit"));
    check(&rows);
}

#[test]
fn deformable_block_explicit_limit_names_the_elastic_mode() {
    check(&v::deformable::elastic_limit_rows());
}

#[test]
fn stiff_deformable_block_slides_like_the_rigid_one() {
    check(&[
        v::deformable::incline_rigid_vs_deformable("explicit"),
        v::deformable::incline_rigid_vs_deformable("implicit"),
    ]);
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
