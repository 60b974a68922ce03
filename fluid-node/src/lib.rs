//! rockwave's water: SPH solvers behind the [`shared::solver::FluidSolver`] interface.
//!
//! - [`muller`]: the paper's scheme (Müller et al. 2003; paper Eqs. 11–21), `--solver muller`.
//! - [`wcsph`]: weakly compressible SPH in the DualSPHysics standard, `--solver wcsph`.
//!
//! Both are built from the same parts: [`kernel`]/[`kernels`] (smoothing kernels),
//! [`particles`] (struct-of-arrays state), [`neighbors`] (cell grid, counting sort), [`fill`]
//! (water volumes on a lattice), [`walls`] (boundary particles on fixed blocks), [`penalty`]
//! (paper Eq. 22 both ways), [`dt`] (stable step), [`gauges`] (wave gauges and pressure probes)
//! and [`system`] (what a solver owns besides its equations). [`validation`] holds the
//! validation cases run by `fluid-validate` and by the tests.

pub mod dt;
pub mod fill;
pub mod gauges;
pub mod kernel;
pub mod kernels;
pub mod muller;
pub mod neighbors;
pub mod particles;
pub mod penalty;
pub mod system;
pub mod validation;
pub mod walls;
pub mod wcsph;

use shared::solver::{FluidSolver, SetupContext, SolverError};

/// Solver names accepted by `--solver`.
pub const SOLVERS: &[&str] = &["muller", "wcsph"];

/// Builds the named solver for a scene.
pub fn build(name: &str, ctx: &SetupContext) -> Result<Box<dyn FluidSolver>, SolverError> {
    match name {
        "muller" => Ok(Box::new(muller::Muller::new(ctx)?)),
        "wcsph" => Ok(Box::new(wcsph::Wcsph::new(ctx)?)),
        other => Err(SolverError::Failed(format!(
            "unknown fluid solver '{other}': choose one of {}",
            SOLVERS.join(", ")
        ))),
    }
}
