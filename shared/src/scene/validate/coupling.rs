//! `[coupling]`: the Eq. 22 penalty, the solid's sub-steps and the added mass.

use super::checker::Checker;
use crate::scene::schema::Scene;

/// `[coupling]`.
pub(super) fn check(c: &mut Checker, s: &Scene) {
    c.key("coupling", |c| {
        let k = &s.coupling;
        if let Some(v) = k.penalty_stiffness {
            c.positive(
                "penalty_stiffness",
                v,
                "give K_S in N/m, or leave it out to derive one",
            );
        }
        if let Some(v) = k.penalty_damping
            && !(v >= 0.0 && v.is_finite())
        {
            c.fail(
                "penalty_damping",
                v,
                "must be >= 0",
                "give K_D in N·s/m, or leave it out",
            );
        }
        if let Some(v) = k.margin {
            c.positive(
                "margin",
                v,
                "give the Eq. 22 contact margin in metres, e.g. dx/2",
            );
        }
        if !(1..=10_000).contains(&k.solid_substeps) {
            c.fail(
                "solid_substeps",
                k.solid_substeps,
                "must be in 1..=10000",
                "1 is single-rate; 4 to 20 let an explicit solid sub-cycle inside a long fluid step",
            );
        }
        if !(0.0..=100.0).contains(&k.added_mass) {
            c.fail(
                "added_mass",
                k.added_mass,
                "must be in 0..=100 (times ρ_water × the block's volume)",
                "0 is off; 0.5 to 2 stabilise light blocks under an incompressible fluid",
            );
        }
    });
}
