//! rockwave's water: SPH solvers behind the [`shared::solver::FluidSolver`] interface.
//!
//! A solver is a [`methods::SphMethod`] (what one SPH method does differently: kernel, equation
//! of state, forces, integrator, stable step) run by [`sph::Sph`], which implements the coupling
//! interface once over the [`system::FluidSystem`] every method shares. The methods
//! ([`methods`]):
//!
//! - [`methods::muller`]: the paper's method (Müller et al. 2003; paper Eqs. 11–21), `--solver muller`;
//! - [`methods::wcsph`]: weakly compressible SPH in the DualSPHysics standard, `--solver wcsph`;
//! - [`methods::dfsph`]: divergence-free SPH (Bender & Koschier 2015, 2017), `--solver dfsph`,
//!   which steps on the flow speed instead of a numerical speed of sound.
//!
//! They are listed once, in [`REGISTRY`], which the node binary, `fluid-validate`,
//! `fluid-bench` and the coupler's sweeps read. The folders:
//!
//! - [`core`]: the machinery every method shares (particles, cell grid, neighbour lists, pair
//!   records, parallel passes, stable step, the water fill, the phase clock);
//! - [`kernels`]: the smoothing kernels behind the [`kernels::Kernel`] trait;
//! - [`methods`]: the SPH methods;
//! - [`boundary`]: the blocks' and the terrain's boundary particles, and paper Eq. 22;
//! - [`instruments`]: wave gauges, pressure probes and the after-step survey;
//! - [`system`]: the [`system::FluidSystem`] (and its checkpoint) the methods share, [`sph`] the
//!   adapter to the coupling interface;
//! - [`validation`]: the cases run by `fluid-validate` and by the tests.

pub mod boundary;
pub mod core;
pub mod instruments;
pub mod kernels;
pub mod methods;
pub mod ranks;
pub mod sph;
pub mod system;
pub mod validation;

use methods::SphMethod;
use shared::registry::{Advice, Entry, Registry, params};
use shared::scene::{FieldError, Scene};
use shared::solver::{SetupContext, SolverError};
use sph::{Sph, SphSolver};

/// Every fluid solver, by name: add a method here with one `entry` line (recipe: [`methods`]).
/// The first is the default solver ([`Registry::first`]).
pub static REGISTRY: Registry<dyn SphSolver> = Registry {
    role: "fluid",
    entries: &[
        entry::<methods::wcsph::Wcsph>(),
        entry::<methods::muller::Muller>(),
        entry::<methods::dfsph::Dfsph>(),
        entry::<methods::riemann::Riemann>(),
    ],
};

/// The registry entry of method `S`: built as [`Sph<S>`], its parameters in `[fluid.<S::NAME>]`.
pub const fn entry<S: SphMethod>() -> Entry<dyn SphSolver> {
    Entry {
        name: S::NAME,
        description: S::DESCRIPTION,
        build: build_method::<S>,
        check: check_method::<S>,
        advice: Advice {
            estimate_dt: S::estimate_dt,
            warnings: S::warnings,
            study_table: S::study_table,
            study_variants: S::study_variants,
            known_limitation: S::known_limitation,
            particle_steps_per_second: S::PARTICLE_STEPS_PER_SECOND,
            splits_over_ranks: S::SPLITS,
        },
    }
}

fn build_method<S: SphMethod>(ctx: &SetupContext) -> Result<Box<dyn SphSolver>, SolverError> {
    Ok(Box::new(Sph::<S>::new(ctx)?))
}

fn check_method<S: SphMethod>(scene: &Scene) -> Vec<FieldError> {
    match &scene.fluid {
        Some(f) => match params::<S::Params>(&f.solvers, "fluid", S::NAME) {
            Ok(p) => S::check_against(&p, scene),
            Err(errors) => errors,
        },
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
/// fluid node, `fluid-validate` and the sweeps run their loops here
/// (docs/journal/2026-11-performance.md, "Inner loops, third round").
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

    /// The registry's advice is each method's own: DFSPH's step on the flow speed and its
    /// warning about added mass with the blocks in its solve, the others' speed of sound; the
    /// studies' rows each takes part in, and its known limitations.
    #[test]
    fn the_registry_advises_per_method() {
        use shared::scene::CouplingScheme::{Parallel, Serial};
        let mut scene = shared::scene::Scene::default_scene();
        let (dx, depth) = (0.02, 0.5);
        let g = scene.gravity.iter().map(|x| x * x).sum::<f64>().sqrt();
        let advice = |name| super::REGISTRY.get(name).unwrap().advice;
        let dfsph = (advice("dfsph").estimate_dt)(&scene, dx, depth).unwrap();
        assert_eq!(dfsph, 0.4 * dx / (g * depth).sqrt());
        let wcsph = (advice("wcsph").estimate_dt)(&scene, dx, depth).unwrap();
        assert_eq!(wcsph, 0.2 * 1.3 * dx / (10.0 * (2.0 * g * depth).sqrt()));
        scene.coupling.added_mass = 0.5;
        assert_eq!((advice("dfsph").warnings)(&scene, Parallel).len(), 1);
        assert!((advice("dfsph").warnings)(&scene, Serial).is_empty());
        assert!((advice("wcsph").warnings)(&scene, Parallel).is_empty());
        assert!((advice("dfsph").study_table)("still_water").is_some());
        assert!((advice("muller").study_table)("still_water").is_none());
        use shared::registry::study;
        let variants = |name, s| (advice(name).study_variants)(s).len();
        assert_eq!(variants("wcsph", study::STABILITY_DT), 1);
        assert_eq!(variants("dfsph", study::STABILITY_DENSITY), 2);
        assert_eq!(variants("muller", study::STABILITY_DT), 0);
        assert_eq!(variants("muller", study::PENALTY_WALLS), 1);
        assert_eq!(variants("wcsph", study::PENALTY_WALLS), 0);
        assert!((advice("muller").known_limitation)("still_pressure", 0).is_some());
        assert!((advice("dfsph").known_limitation)("still_pressure", 0).is_none());
    }
}
