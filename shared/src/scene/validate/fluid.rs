//! `[fluid]`: the water, its particle spacing and the stray keys that are not solver tables.

use super::checker::Checker;
use crate::scene::error::Seg;
use crate::scene::schema::Scene;

/// `[fluid]`, when the scene has one.
pub(super) fn check(c: &mut Checker, s: &Scene) {
    let d = &s.domain;
    if let Some(f) = &s.fluid {
        c.key("fluid", |c| {
            c.positive("density", f.density, "water is density = 1000.0");
            c.positive(
                "dx",
                f.dx,
                "give the particle spacing in metres, e.g. dx = 0.02",
            );
            let smallest = (0..3)
                .map(|k| d.max[k] - d.min[k])
                .fold(f64::INFINITY, f64::min);
            if f.dx.is_finite() && f.dx > 0.0 && f.dx * 4.0 > smallest {
                c.fail(
                    "dx",
                    f.dx,
                    "is too coarse for the domain (fewer than 4 particles across)",
                    "use a smaller dx",
                );
            }
            if !(f.kinematic_viscosity.is_finite() && f.kinematic_viscosity >= 0.0) {
                c.fail(
                    "kinematic_viscosity",
                    f.kinematic_viscosity,
                    "must be >= 0",
                    "water is 1e-6 m²/s",
                );
            }
            if !(f.density_ratio_bound.is_finite() && f.density_ratio_bound > 1.0) {
                c.fail(
                    "density_ratio_bound",
                    f.density_ratio_bound,
                    "must be > 1",
                    "e.g. density_ratio_bound = 1.3",
                );
            }
            for (i, w) in f.water.iter().enumerate() {
                c.key("water", |c| {
                    c.at(Seg::Index(i), |c| c.shape(&w.shape, d, true))
                });
            }
            // Keys that are not [fluid] fields are solver tables; a stray value is a typo.
            for (key, value) in &f.solvers {
                if !value.is_table() {
                    c.fail(
                        key,
                        value,
                        "is not a field of [fluid]",
                        "fields are solver, density, dx, kinematic_viscosity, density_ratio_bound, walls, water; solver parameters go in their own table, e.g. [fluid.wcsph]",
                    );
                }
            }
        });
    }
}
