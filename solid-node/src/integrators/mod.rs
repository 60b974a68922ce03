//! The time integrators: the seam between the shared DDA machinery (blocks, contacts, loads) and
//! one scheme's update, and what the schemes share.
//!
//! - here: [`DdaMethod`] (a scheme as the registry lists it) and [`Integrator`] (what it does with
//!   the block system);
//! - [`explicit`]: central differences (paper Eqs. 5–8); [`implicit`]: Shi's Newmark β = ½,
//!   γ = 1 with open–close iterations (paper Eq. 4);
//! - [`linear_system`]: the block-sparse system of the implicit scheme;
//! - [`stability`]: the explicit limit 2/ω_max; [`energy`]: the detection of instability.

pub mod energy;
pub mod explicit;
pub mod implicit;
pub mod linear_system;
pub mod stability;

use crate::integrators::energy::EnergyMonitor;
use crate::world::World;
use shared::math::Real;
use shared::registry::SolverParams;
use shared::scene::Scene;
use shared::solver::{SolverError, StepReport};

/// A time integration scheme as [`crate::REGISTRY`] lists it: its name, its parameter table
/// `[solid.<NAME>]` and how it makes its [`Integrator`] for a scene.
pub trait DdaMethod {
    /// As given to `--solver` and in `[solid] solver = "…"`.
    const NAME: &'static str;
    /// One line for `--list` and the docs.
    const DESCRIPTION: &'static str;
    /// The scheme's own parameters, read from `[solid.<NAME>]`.
    type Params: SolverParams;
    /// The integrator for `scene` with checked parameters.
    fn integrator(params: &Self::Params, scene: &Scene) -> Box<dyn Integrator>;
}

pub trait Integrator: Send {
    /// The `--solver` name (its [`DdaMethod::NAME`]).
    fn name(&self) -> &'static str;
    /// Prepares the scheme's own state from the world at t = 0 (contacts already detected).
    fn init(&mut self, world: &mut World);
    /// Advances the world by exactly `dt`.
    fn advance(
        &mut self,
        world: &mut World,
        dt: Real,
        energy: &mut EnergyMonitor,
    ) -> Result<StepReport, SolverError>;
    /// Step proposed for the next advance.
    fn dt_proposal(&self, world: &World) -> Real;
    /// Checkpoint: the integrator's history (previous step, half-step velocities, the
    /// open–close trials, its scratch), encoded with `shared::checkpoint::encode`.
    fn save(&self) -> Result<Vec<u8>, String>;
    /// Restores [`Integrator::save`].
    fn restore(&mut self, state: &[u8]) -> Result<(), String>;
    /// The next advances are trial steps whose state will be restored (the look-ahead's,
    /// `dda/look_ahead.rs`): work that only the kept steps use may be skipped. Ends at the
    /// next [`Integrator::restore`].
    fn begin_trial(&mut self) {}
    /// A copy of the integrator, history and all (the look-ahead's second set of trials).
    fn duplicate(&self) -> Box<dyn Integrator>;
}
