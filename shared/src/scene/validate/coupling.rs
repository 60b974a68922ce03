//! `[coupling]`: the Eq. 22 penalty, the solid's sub-steps and the added mass.

use super::checker::Checker;
use crate::math::readable;
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
            penalty_step(c, s, v);
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
            margin_reach(c, s, v);
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

/// A margin past one particle spacing: Eq. 22 acts on every particle closer to a face than the
/// margin (half of it where boundary particles hold the walls), and the fill lays the water
/// half a spacing off each face, so a wider margin pushes the water at rest from the first
/// step. At 2.5 dx the default scene stopped at step 7 on the density bound (ρ/ρ0 = 1.32),
/// naming a particle, not the field; at 25 dx at step 1.
fn margin_reach(c: &mut Checker, s: &Scene, margin: f64) {
    let Some(f) = s.fluid.as_ref().filter(|_| s.has_fluid()) else {
        return;
    };
    if f.dx > 0.0 && margin > f.dx {
        c.fail(
            "margin",
            margin,
            &format!(
                "is {:.3} particle spacings (dx = {} m): Eq. 22 would reach past the water laid \
                 half a spacing off every face and push it from the first step",
                readable(margin / f.dx),
                readable(f.dx)
            ),
            &format!(
                "leave it out (dx/2 = {} m, the clearance of the initial lattice), or give at most dx",
                readable(0.5 * f.dx)
            ),
        );
    }
}

/// K_S so stiff that Eq. 22's explicit step on one particle, sqrt(m/K_S) with m = ρ dx³ (the
/// fluid's penalty limit, `fluid-node/src/core/dt.rs`), is below `time.dt_min`: the fluid node
/// proposes it at its first step and the run stops there as "step collapsed", naming the node
/// but not the field (K_S = 1e300 proposed dt = 2.5e-151 s).
fn penalty_step(c: &mut Checker, s: &Scene, ks: f64) {
    let Some(f) = s.fluid.as_ref().filter(|_| s.has_fluid()) else {
        return;
    };
    let mass = f.density * f.dx.powi(3);
    let dt = (mass / ks).sqrt();
    let dt_min = s.time.dt_min;
    if ks.is_finite() && ks > 0.0 && mass > 0.0 && dt_min > 0.0 && dt < dt_min {
        c.fail(
            "penalty_stiffness",
            ks,
            &format!(
                "makes Eq. 22's explicit step on one particle, sqrt(m/K_S) = {dt:.3e} s (m = ρ dx³ = \
                 {mass:.3e} kg), shorter than time.dt_min = {dt_min:e} s: the run would stop at its \
                 first step"
            ),
            &format!(
                "leave it out (derived: ½ ρ c0² dx, the water's own stiffness over one particle), \
                 or give at most m/dt_min² = {:.3e} N/m",
                mass / (dt_min * dt_min)
            ),
        );
    }
}
