//! `[fluid.dfsph]`: the divergence-free solver's parameters and their checks.

use super::{MAX_SMOOTHING_RATIO, SMOOTHING_RATIO};
use serde::Deserialize;
use shared::registry::{ParamCheck, SolverParams};

/// The values of `[fluid.dfsph] wall_pressure`; the first is the default.
pub const WALL_PRESSURE: [&str; 2] = ["mirrored", "extrapolated"];

/// `[fluid.dfsph]`: parameters of the divergence-free solver. Unset values take the defaults.
#[derive(Debug, Clone, Default, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct DfsphParams {
    /// Courant number on the particle diameter dx: dt = cfl·dx/v_max; default 0.4 (Bender & Koschier).
    pub cfl: Option<f64>,
    /// Constant-density solve: stop when the mean compression is below this [%]; default 0.05.
    pub density_tolerance: Option<f64>,
    /// Divergence solve: stop when the mean of (Dρ/Dt)·dt/ρ0 is below this [% per step];
    /// default 0.1.
    pub divergence_tolerance: Option<f64>,
    /// Constant-density solve: also iterate until an iteration changes the pressure field by
    /// less than this, Σ|Δk|/Σ|k| [%]; default off. 5 halves the step-to-step pressure noise
    /// (for pressure studies against fixed walls; see the module doc before coupling with it).
    pub pressure_tolerance: Option<f64>,
    /// Jacobi relaxation ω, in (0, 1], of a pressure solve once an iteration has left its mean
    /// error above the tolerance and larger than before (plain Jacobi until then); default 0.5
    /// (IISPH's relaxed Jacobi). 1: plain Jacobi throughout, the papers', which overshoots the
    /// short pressure waves of a regular lattice (module doc, "Relaxed Jacobi").
    pub relaxation: Option<f64>,
    /// Iteration cap of each solve; default 100.
    pub max_iterations: Option<i64>,
    /// XSPH viscosity coefficient ε (0 disables, ≤ 1); default 0.01.
    pub viscosity: Option<f64>,
    /// Smoothing length h over dx (Wendland C2 support 2h); default [`SMOOTHING_RATIO`], at
    /// most [`MAX_SMOOTHING_RATIO`].
    pub smoothing_ratio: Option<f64>,
    /// A particle with fewer neighbours than this fraction of a full lattice's is left out of
    /// the divergence solve (spray; [`DEFICIENT_FRACTION`]); default 0.6, 0 disables.
    pub deficient_fraction: Option<f64>,
    /// A particle near the free surface (fewer neighbours than [`SURFACE_FRACTION`] of a full
    /// lattice's) keeps the larger of its summed density and the density the last step
    /// predicted for it (continuity), so gravity cannot pack the surface layers whose sums are
    /// deficient; default true ([`CONTINUED_SURFACE`]); false: the summed density everywhere,
    /// as SPlisHSPlasH (module doc).
    pub continued_surface: Option<bool>,
    /// Free blocks move inside the two pressure solves (their inertia in the solve, Gissler et
    /// al. 2019), so the water's answer to a block's motion is not one step late; default
    /// true. False: the blocks keep the velocity the solid node sent over the step (the
    /// explicit partitioned coupling, with its added-mass limit).
    pub blocks_in_solve: Option<bool>,
    /// How the walls and blocks take part in the pressure: "mirrored" (default), each
    /// boundary particle takes the pressure around the fluid particle it faces (the Shepard
    /// mean of its neighbourhood's) inside the two solves, with the hydrostatic difference
    /// between them held over the step; or
    /// "extrapolated", Adami's extrapolation of the last step's pressure held over the step
    /// (module doc, "Pressure acceleration").
    pub wall_pressure: Option<String>,
}

impl SolverParams for DfsphParams {
    fn check(&self, c: &mut ParamCheck) {
        // The two fractions in (0, 1].
        for (field, value, why, example) in [
            (
                "cfl",
                self.cfl,
                "must be a finite number in (0, 1] (a particle may not cross more than its diameter per step)",
                "e.g. cfl = 0.4",
            ),
            (
                "relaxation",
                self.relaxation,
                "must be a Jacobi relaxation in (0, 1]",
                "e.g. relaxation = 0.5 (the default); 1 keeps plain Jacobi throughout",
            ),
        ] {
            if let Some(v) = value
                && !(v.is_finite() && v > 0.0 && v <= 1.0)
            {
                c.fail(field, v, why, example);
            }
        }
        for (field, value, example, most) in [
            ("density_tolerance", self.density_tolerance, "0.05", 10.0),
            (
                "divergence_tolerance",
                self.divergence_tolerance,
                "0.1",
                10.0,
            ),
            ("pressure_tolerance", self.pressure_tolerance, "5", 100.0),
        ] {
            if let Some(v) = value
                && !(v.is_finite() && v > 0.0 && v <= most)
            {
                c.fail(
                    field,
                    v,
                    &format!("must be a percentage in (0, {most}]"),
                    &format!("e.g. {field} = {example} (per cent)"),
                );
            }
        }
        if let Some(w) = &self.wall_pressure
            && !WALL_PRESSURE.contains(&w.as_str())
        {
            c.fail(
                "wall_pressure",
                w,
                "must be \"mirrored\" or \"extrapolated\"",
                "e.g. wall_pressure = \"mirrored\" (the default)",
            );
        }
        if let Some(n) = self.max_iterations
            && !(1..=10_000).contains(&n)
        {
            c.fail(
                "max_iterations",
                n,
                "must be an integer in [1, 10000]",
                "e.g. max_iterations = 100",
            );
        }
        if let Some(v) = self.viscosity
            && !(v.is_finite() && (0.0..=1.0).contains(&v))
        {
            c.fail(
                "viscosity",
                v,
                "must be an XSPH coefficient in [0, 1]",
                "e.g. viscosity = 0.01; 0 disables it",
            );
        }
        if let Some(f) = self.deficient_fraction
            && !(f.is_finite() && (0.0..=1.0).contains(&f))
        {
            c.fail(
                "deficient_fraction",
                f,
                "must be a fraction of a full neighbourhood in [0, 1]",
                "e.g. deficient_fraction = 0.6; 0 solves every particle",
            );
        }
        if let Some(r) = self.smoothing_ratio
            && !(r.is_finite() && (0.5..=MAX_SMOOTHING_RATIO).contains(&r))
        {
            c.fail(
                "smoothing_ratio",
                r,
                &format!(
                    "must be a finite number in [0.5, {MAX_SMOOTHING_RATIO}] for dfsph: the support 2h must reach the nearest neighbours, and past h = {MAX_SMOOTHING_RATIO} dx its Jacobi pressure solves diverge from their first iteration in water at rest (at 2.0 they do nothing for 20 steps while the water compresses, then one catches up and throws it apart)"
                ),
                &format!(
                    "e.g. smoothing_ratio = {SMOOTHING_RATIO} (the default), at most {MAX_SMOOTHING_RATIO}; or a wider kernel with solver = \"wcsph\""
                ),
            );
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `[fluid.dfsph]` from TOML text, as the registry reads it.
    fn params(text: &str) -> Result<DfsphParams, Vec<shared::scene::FieldError>> {
        let mut tables = shared::scene::SolverTables::new();
        tables.insert("dfsph".into(), toml::from_str(text).unwrap());
        shared::registry::params::<DfsphParams>(&tables, "fluid", "dfsph")
    }

    /// `wall_pressure` takes "mirrored" (the default when unset) or "extrapolated"; anything
    /// else is an error naming the field, the value and the fix.
    #[test]
    fn wall_pressure_is_mirrored_or_extrapolated_and_a_bad_value_is_named() {
        assert_eq!(WALL_PRESSURE[0], "mirrored");
        for ok in WALL_PRESSURE {
            let p = params(&format!("wall_pressure = \"{ok}\"")).unwrap();
            assert_eq!(p.wall_pressure.as_deref(), Some(ok));
        }
        assert_eq!(params("").unwrap().wall_pressure, None);
        let errors = params("wall_pressure = \"mirror\"").unwrap_err();
        let text = errors[0].to_string();
        assert!(
            text.contains("fluid.dfsph.wall_pressure")
                && text.contains("\"mirror\"")
                && text.contains("\"mirrored\" or \"extrapolated\""),
            "{text}"
        );
    }

    /// `smoothing_ratio` up to [`MAX_SMOOTHING_RATIO`]; a wider kernel, whose solves diverge
    /// (module doc of [`MAX_SMOOTHING_RATIO`]), is refused by name with the largest that works.
    #[test]
    fn a_kernel_wider_than_the_solves_take_is_refused_by_name() {
        for ok in ["0.5", "1.3", "1.8"] {
            let p = params(&format!("smoothing_ratio = {ok}")).unwrap();
            assert_eq!(p.smoothing_ratio, Some(ok.parse().unwrap()));
        }
        for bad in ["2.0", "0.4", "nan"] {
            let errors = params(&format!("smoothing_ratio = {bad}")).unwrap_err();
            let text = errors[0].to_string();
            assert!(
                text.contains("fluid.dfsph.smoothing_ratio")
                    && text.contains("[0.5, 1.8]")
                    && text.contains("at most 1.8"),
                "{bad}: {text}"
            );
        }
    }

    /// `relaxation` takes a Jacobi relaxation in (0, 1]; 0, a value past 1 (which would
    /// amplify the overshooting modes it is there to damp) and NaN are refused by name.
    #[test]
    fn relaxation_outside_zero_to_one_is_refused_by_name() {
        for ok in ["0.5", "1.0", "0.25"] {
            let p = params(&format!("relaxation = {ok}")).unwrap();
            assert_eq!(p.relaxation, Some(ok.parse().unwrap()));
        }
        for bad in ["0.0", "1.5", "-0.5", "nan"] {
            let errors = params(&format!("relaxation = {bad}")).unwrap_err();
            let text = errors[0].to_string();
            assert!(
                text.contains("fluid.dfsph.relaxation") && text.contains("(0, 1]"),
                "{bad}: {text}"
            );
        }
    }
}
