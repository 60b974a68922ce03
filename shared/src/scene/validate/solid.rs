//! `[solid]`: the block-contact physics every solid solver shares, and the stray keys that are
//! not solver tables.

use super::checker::Checker;
use crate::scene::schema::Scene;

/// `[solid]` and `[solid.contact]`.
pub(super) fn check(c: &mut Checker, s: &Scene) {
    c.key("solid", |c| {
        // Keys that are not [solid] fields are solver tables; a stray value is a typo.
        for (key, value) in &s.solid.solvers {
            if !value.is_table() {
                c.fail(
                    key,
                    value,
                    "is not a field of [solid]",
                    "fields are solver, contact; solver parameters go in their own table, e.g. [solid.implicit]",
                );
            }
        }
        c.key("contact", |c| {
            let k = &s.solid.contact;
            if let Some(kn) = k.normal_stiffness {
                c.positive(
                    "normal_stiffness",
                    kn,
                    "give a spring in N/m, or leave it out to derive one",
                );
            }
            if !(k.shear_ratio >= 0.0 && k.shear_ratio.is_finite()) {
                c.fail(
                    "shear_ratio",
                    k.shear_ratio,
                    "must be >= 0",
                    "e.g. shear_ratio = 0.4",
                );
            }
            if !(0.0..90.0).contains(&k.friction_angle) {
                c.fail(
                    "friction_angle",
                    k.friction_angle,
                    "must be in [0, 90) degrees",
                    "e.g. friction_angle = 30.0",
                );
            }
            if !(k.cohesion >= 0.0 && k.cohesion.is_finite()) {
                c.fail(
                    "cohesion",
                    k.cohesion,
                    "must be >= 0",
                    "give cohesion in Pa, 0 for a clean joint",
                );
            }
            if !(k.allowed_penetration > 0.0 && k.allowed_penetration < 0.1) {
                c.fail(
                    "allowed_penetration",
                    k.allowed_penetration,
                    "must be in (0, 0.1)",
                    "e.g. allowed_penetration = 1e-4",
                );
            }
            if !(0.0..=1.0).contains(&k.damping_ratio) {
                c.fail(
                    "damping_ratio",
                    k.damping_ratio,
                    "must be in [0, 1]",
                    "0 keeps bounces elastic",
                );
            }
        });
    });
}
