//! rockwave's water: SPH solvers behind the [`shared::solver::FluidSolver`] interface.
//!
//! A solver is a [`scheme::SphMethod`] (what one SPH method does differently: kernel, equation of
//! state, forces, integrator, stable step) run by [`sph::Sph`], which implements the coupling
//! interface once over the [`system::FluidSystem`] every scheme shares. The schemes:
//!
//! - [`muller`]: the paper's scheme (Müller et al. 2003; paper Eqs. 11–21), `--solver muller`;
//! - [`wcsph`]: weakly compressible SPH in the DualSPHysics standard, `--solver wcsph`;
//! - [`dfsph`]: divergence-free SPH (Bender & Koschier 2015, 2017), `--solver dfsph`, which
//!   steps on the flow speed instead of a numerical speed of sound.
//!
//! They are listed once, in [`REGISTRY`], which the node binary, `fluid-validate`,
//! `fluid-bench` and the coupler's sweeps read. The shared parts: [`kernel`]/[`kernels`]
//! (smoothing kernels), [`particles`] (struct-of-arrays state), [`neighbors`] (cell grid,
//! counting sort, neighbour lists; [`candidates`] their branch-free test), [`fill`] (water volumes on a lattice), [`boundary`] (the blocks' boundary
//! particles, [`walls`] on fixed blocks and [`bodies`] on moving ones), [`penalty`] (paper Eq. 22
//! both ways), [`terrain`] (the `[[terrain]]` ground: boundary
//! particles under its surface and Eq. 22 against its triangles), [`dt`] (stable step), [`gauges`] (wave gauges and pressure probes) and
//! [`system`]; [`tasks`] sets how finely a parallel pass is cut; [`phases`] times a step's phases for `fluid-bench --phases`. [`validation`]
//! holds the cases run by `fluid-validate` and by the tests.

pub mod bodies;
pub mod boundary;
pub mod candidates;
pub mod dfsph;
pub mod dt;
pub mod fill;
pub mod fixed_sum;
pub mod gauges;
pub mod kernel;
pub mod kernels;
pub mod lanes;
pub mod muller;
pub mod muller_pairs;
pub mod neighbors;
pub mod particles;
pub mod penalty;
pub mod phases;
pub mod scatter;
pub mod scheme;
pub mod sph;
pub mod survey;
pub mod system;
pub mod tasks;
pub mod terrain;
pub mod validation;
pub mod walls;
pub mod wcsph;
pub mod wcsph_pairs;

use scheme::SphMethod;
use shared::registry::{Entry, Registry, check_params};
use shared::scene::{FieldError, Scene};
use shared::solver::{SetupContext, SolverError};
use sph::{Sph, SphSolver};

/// Every fluid solver, by name: add a scheme here with one `entry` line.
pub static REGISTRY: Registry<dyn SphSolver> = Registry {
    role: "fluid",
    entries: &[
        entry::<wcsph::Wcsph>(),
        entry::<muller::Muller>(),
        entry::<dfsph::Dfsph>(),
    ],
};

/// The registry entry of scheme `S`: built as [`Sph<S>`], its parameters in `[fluid.<S::NAME>]`.
pub const fn entry<S: SphMethod>() -> Entry<dyn SphSolver> {
    Entry {
        name: S::NAME,
        description: S::DESCRIPTION,
        build: build_scheme::<S>,
        check: check_scheme::<S>,
    }
}

fn build_scheme<S: SphMethod>(ctx: &SetupContext) -> Result<Box<dyn SphSolver>, SolverError> {
    Ok(Box::new(Sph::<S>::new(ctx)?))
}

fn check_scheme<S: SphMethod>(scene: &Scene) -> Vec<FieldError> {
    match &scene.fluid {
        Some(f) => check_params::<S::Params>(&f.solvers, "fluid", S::NAME),
        None => Vec::new(),
    }
}

/// The fluid registry's checks of a scene: `[fluid] solver` names a solver, every
/// `[fluid.<name>]` table belongs to one and holds valid parameters.
pub fn check_scene(scene: &Scene) -> Vec<FieldError> {
    match &scene.fluid {
        Some(f) => REGISTRY.check(scene, &f.solvers, &f.solver),
        None => Vec::new(),
    }
}

/// Runs `f` on one of rayon's workers (in place if the caller is one already), and returns its
/// result. Whatever drives a solver step after step does it in here: each parallel pass of a
/// step then starts on a pool thread, which keeps the first half of the work and hands the
/// second to the other worker, pass after pass. Called from a thread outside the pool, every
/// pass is injected into the pool and the caller sleeps until it is done: a wake-up per pass
/// (a few dozen per step), and the halves change threads, and caches, between passes. The
/// fluid node, `fluid-validate` and the sweeps run their loops here (docs/PERFORMANCE.md:
/// 9 % of the default scene's wall time, 40 % of `fluid-validate --quick`'s).
pub fn on_pool<R: Send>(f: impl FnOnce() -> R + Send) -> R {
    rayon::scope(|_| f())
}

/// Uniform numbers in [0, 1) from a 64-bit LCG (Knuth's MMIX constants), for the unit tests'
/// scattered particles: the same sequence from the same seed on every machine.
#[cfg(test)]
pub(crate) fn uniform(mut seed: u64) -> impl FnMut() -> f64 {
    move || {
        seed = seed
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (seed >> 11) as f64 / (1u64 << 53) as f64
    }
}

#[cfg(test)]
mod tests {
    /// `on_pool` moves the closure onto a worker of the pool, and stays in place on one.
    #[test]
    fn on_pool_runs_on_a_worker() {
        assert_eq!(
            rayon::current_thread_index(),
            None,
            "the test thread is not a worker"
        );
        let outer = super::on_pool(|| {
            let here = rayon::current_thread_index();
            assert_eq!(super::on_pool(rayon::current_thread_index), here);
            here
        });
        assert!(outer.is_some());
    }
}
