//! `[fluid]`: the water, its particle spacing and the stray keys that are not solver tables.

use super::checker::{Checker, Reach};
use crate::scene::error::Seg;
use crate::scene::schema::{MAX_FLUID_RANKS, MAX_ROW_DRAW, Scene};

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
            if let Some(shift) = f.row_shift {
                let along = shift.iter().filter(|a| **a != 0.0).count();
                let fix = "give one axis a fraction of dx in (0, 0.5], e.g. row_shift = [0.25, 0.0, 0.0] for the rows along x; or leave it out for the lattice";
                if shift.iter().any(|a| !a.is_finite()) || along != 1 {
                    c.fail(
                        "row_shift",
                        shift,
                        "must shift the rows along exactly one axis, by a finite fraction of dx",
                        fix,
                    );
                } else if shift.iter().any(|a| *a < 0.0 || *a > 0.5) {
                    c.fail(
                        "row_shift",
                        shift,
                        "must be between 0 and 0.5 spacings: past half a spacing rows would pass their neighbours' places and the walls' clearance",
                        fix,
                    );
                }
            }
            if f.row_draw != 0 && f.row_shift.is_none() {
                c.fail(
                    "row_draw",
                    f.row_draw,
                    "draws among shifted rows, and row_shift is absent: the fill is the lattice, the same for every draw",
                    "give row_shift too, e.g. row_shift = [0.25, 0.0, 0.0], or leave row_draw out",
                );
            } else if f.row_draw > MAX_ROW_DRAW {
                c.fail(
                    "row_draw",
                    f.row_draw,
                    &format!("must be at most {MAX_ROW_DRAW}: past it the sequence's multipliers grow so large that a row's fraction keeps too few digits"),
                    "number the draws of an ensemble 0, 1, 2, …",
                );
            }
            if let Some((problem, fix)) = fluid_ranks_problem(f.ranks) {
                c.fail("ranks", f.ranks, &problem, &fix);
            }
            for (i, w) in f.water.iter().enumerate() {
                c.key("water", |c| {
                    c.at(Seg::Index(i), |c| c.shape(&w.shape, d, Reach::Inside))
                });
            }
            // Keys that are not [fluid] fields are solver tables; a stray value is a typo.
            for (key, value) in &f.solvers {
                if !value.is_table() {
                    c.fail(
                        key,
                        value,
                        "is not a field of [fluid]",
                        "fields are solver, density, dx, kinematic_viscosity, density_ratio_bound, walls, ranks, row_shift, row_draw, water; solver parameters go in their own table, e.g. [fluid.wcsph]",
                    );
                }
            }
        });
    }
}

/// What is wrong with a count of fluid ranks (`[fluid] ranks`, `coupler run --fluid-ranks`): the
/// problem and the fix, or `None` for a count from 1 to [`MAX_FLUID_RANKS`].
pub fn fluid_ranks_problem(ranks: u32) -> Option<(String, String)> {
    match ranks {
        0 => Some((
            "must be at least 1: rank 0 is the fluid node the coupler talks to".into(),
            "ranks = 1 runs the fluid node as one process, ranks = N as N MPI ranks".into(),
        )),
        n if n > MAX_FLUID_RANKS => Some((
            format!("is past the limit of {MAX_FLUID_RANKS} ranks"),
            format!(
                "use at most {MAX_FLUID_RANKS} (`coupler check` says how many the scene's water can fill)"
            ),
        )),
        _ => None,
    }
}

#[cfg(test)]
mod tests {
    use crate::scene::{DEFAULT_SCENE, MAX_FLUID_RANKS, Scene};

    fn with_ranks(line: &str) -> Result<Scene, String> {
        let text = DEFAULT_SCENE.replace("\ndx = 0.04\n", &format!("\ndx = 0.04\n{line}\n"));
        Scene::parse(&text, "t.toml").map_err(|e| e.to_string())
    }

    /// `[fluid] ranks` is 1 by default and not written back then (scene.toml of a run stays as
    /// it was); 0 and past the limit are named with the fix.
    #[test]
    fn fluid_ranks_are_checked_and_written_only_when_not_one() {
        let one = Scene::default_scene();
        assert_eq!(one.fluid.as_ref().unwrap().ranks, 1);
        assert!(!toml::to_string(&one).unwrap().contains("ranks"));
        let three = with_ranks("ranks = 3").unwrap();
        assert_eq!(three.fluid.as_ref().unwrap().ranks, 3);
        let text = toml::to_string(&three).unwrap();
        assert!(text.contains("ranks = 3"), "{text}");
        let msg = with_ranks("ranks = 0").unwrap_err();
        assert!(
            msg.contains("fluid.ranks = 0") && msg.contains("at least 1") && msg.contains("fix:"),
            "{msg}"
        );
        let msg = with_ranks(&format!("ranks = {}", MAX_FLUID_RANKS + 1)).unwrap_err();
        assert!(
            msg.contains("fluid.ranks = 4097") && msg.contains("at most 4096"),
            "{msg}"
        );
        assert!(with_ranks(&format!("ranks = {MAX_FLUID_RANKS}")).is_ok());
    }
}
