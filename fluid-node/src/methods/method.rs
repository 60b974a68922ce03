//! What makes one SPH method differ from another: its kernel, equation of state, force
//! evaluation, integrator and stable step. Everything else (particles, neighbours, the blocks'
//! boundary particles, paper Eq. 22, instruments, checks, output) is the [`FluidSystem`] every
//! method shares, and [`crate::sph::Sph`] turns any method into a coupled solver. A new SPH
//! method is one folder implementing this trait plus one line in [`crate::REGISTRY`] (the
//! recipe, a doc-test: [`crate::methods`]).

use crate::kernels::Kernel;
use crate::system::{FluidSystem, Initial, Layout};
use shared::math::{Real, Vector};
use shared::protocol::BlockLoad;
use shared::registry::{SolverParams, Variant};
use shared::scene::{CouplingScheme, FieldError, Scene};
use shared::solver::{SolverError, StepReport};

/// One SPH method.
/// Serde: a method is saved whole in a checkpoint (its history, e.g. the Verlet step
/// counter or DFSPH's warm-start factors, affects the steps to come).
pub trait SphMethod:
    Sized + Send + 'static + serde::Serialize + serde::de::DeserializeOwned
{
    /// `--solver` name, and the scene table `[fluid.<NAME>]` that holds [`Self::Params`].
    const NAME: &'static str;
    /// One line for `--list` and the docs.
    const DESCRIPTION: &'static str;
    /// Whether the method runs on several ranks (`crate::ranks`): its step computes the rates
    /// of `FluidSystem::owned` particles only and calls `FluidSystem::share_rates` after each
    /// evaluation, and everything else it does is per particle.
    const SPLITS: bool = false;
    /// The method's own parameters (every field optional; unset ones are derived).
    type Params: SolverParams;
    /// The kernel the instruments interpolate with.
    type Kernel: Kernel;

    /// Derives the method from its parameters and the filled scene.
    fn new(params: Self::Params, init: &Initial) -> Result<(Self, Layout), SolverError>;

    /// Once the system exists (particles sorted by cell, Eq. 22 stiffness known): initial
    /// pressures and step limits.
    fn start(&mut self, sys: &mut FluidSystem);

    /// Force evaluation(s) and integration over `dt`. The system has begun the step (grid and
    /// Eq. 22 forces current); it checks, re-sorts and samples after. A method that finds its
    /// own step unstable (an implicit solve far from converged) says so with
    /// [`SolverError::Unstable`], naming the cause.
    fn step(&mut self, sys: &mut FluidSystem, dt: Real) -> Result<StepReport, SolverError>;

    /// At a new pose of the moving blocks: their boundary pressures, then the water's force on
    /// them, pair by pair the reverse of this method's pressure force on the fluid
    /// ([`crate::boundary::Boundary::react`]).
    fn react(&mut self, sys: &mut FluidSystem);

    /// The force of each fixed boundary particle near fluid particle `i` on it, this method's
    /// wall term at the state the step left (the pressures its step computed last), passed to
    /// `visit(boundary particle, force)`: what a probe reading the wall sums, reversed
    /// ([`crate::instruments::wall_load`]).
    fn fixed_wall_forces(&self, sys: &FluidSystem, i: usize, visit: &mut dyn FnMut(usize, Vector));

    /// Whether this method moves the free blocks within its step, so that its loads are the
    /// forces of the step just taken ([`shared::solver::FluidSolver::loads_follow_step`]).
    fn loads_follow_step(&self, sys: &FluidSystem) -> bool {
        let _ = sys;
        false
    }

    /// The loads of the step just taken, when [`Self::loads_follow_step`] (the water's force on
    /// each moving block over the step, Eq. 22 included), into `loads`.
    fn step_loads(&self, sys: &FluidSystem, loads: &mut [BlockLoad]) {
        let _ = (sys, loads);
    }

    fn kernel(&self) -> &Self::Kernel;

    /// Density check after a step: whether a low density is an instability too (false for
    /// summed densities, low at a free surface by construction), and the reference density.
    fn density_check(&self) -> (bool, Real);

    /// Largest stable step for the current largest speed and acceleration.
    fn dt_proposal(&self, v_max: Real, a_max: Real) -> Real;

    /// What this method's own settings may have to do with an instability the system found
    /// after a step (a density past its bound, a particle out of the domain), appended to its
    /// message by [`crate::sph::Sph`]: e.g. a Courant number raised past the range its
    /// integrator was measured stable in. None by default.
    fn unstable_hint(&self) -> Option<String> {
        None
    }

    /// Particle-steps per second of one thread, measured by `fluid-bench` (docs/PERFORMANCE.md,
    /// "Fluid: cost per particle-step"): the registry's
    /// [`shared::registry::Advice::particle_steps_per_second`], what a run's wall time is
    /// estimated with. `None`: not measured (the estimate then takes the slowest measured).
    const PARTICLE_STEPS_PER_SECOND: Option<f64> = None;

    /// The step this method would take on a scene's water of depth `depth` at spacing `dx`,
    /// before it is built (`coupler check`'s estimate of a run's steps; the registry's
    /// [`shared::registry::Advice::estimate_dt`]). The default is a speed-of-sound method's:
    /// CFL 0.2 over h = 1.3 dx at the default sound speed c0 = 10·sqrt(2 g H)
    /// ([`Initial::default_sound_speed`]), or the viscous limit 0.125 h²/ν of the scene's
    /// `fluid.kinematic_viscosity` when shorter (`crate::core::dt`; far longer for water).
    fn estimate_dt(scene: &Scene, dx: Real, depth: Real) -> Option<Real> {
        let g = scene.gravity.iter().map(|x| x * x).sum::<f64>().sqrt();
        let c0 = 10.0 * (2.0 * g * depth).sqrt().max(1e-6);
        let h = 1.3 * dx;
        let nu = scene.fluid.as_ref().map_or(0.0, |f| f.kinematic_viscosity);
        let viscous = if nu > 0.0 {
            0.125 * h * h / nu
        } else {
            Real::INFINITY
        };
        Some((0.2 * 1.3 * dx / c0).min(viscous))
    }

    /// The errors of this method's parameters that only the scene shows (a speed of sound too
    /// low for the water's depth), beyond [`SolverParams::check`] of the table alone; the
    /// registry's `check` runs both: none by default.
    fn check_against(params: &Self::Params, scene: &Scene) -> Vec<FieldError> {
        let _ = (params, scene);
        Vec::new()
    }

    /// Warnings about the scene's combination of options for this method under `scheme`
    /// (the registry's [`shared::registry::Advice::warnings`]): none by default.
    fn warnings(scene: &Scene, scheme: CouplingScheme) -> Vec<String> {
        let _ = (scene, scheme);
        Vec::new()
    }

    /// This method's table `[fluid.<NAME>]` (TOML) for the validation study named, when it runs
    /// with other than its defaults (the registry's [`shared::registry::Advice::study_table`]):
    /// none by default.
    fn study_table(study: &str) -> Option<&'static str> {
        let _ = study;
        None
    }

    /// The ways the study named ([`shared::registry::study`]) runs this method, in the order of
    /// its rows (the registry's [`shared::registry::Advice::study_variants`]): none by default,
    /// the method takes no part.
    fn study_variants(study: &str) -> &'static [Variant] {
        let _ = study;
        &[]
    }

    /// Why the validation's check `check` ([`crate::validation::Check::name`]) at
    /// `resolution` fails by design of this method as published (the registry's
    /// [`shared::registry::Advice::known_limitation`]): none by default.
    fn known_limitation(check: &str, resolution: usize) -> Option<&'static str> {
        let _ = (check, resolution);
        None
    }
}
