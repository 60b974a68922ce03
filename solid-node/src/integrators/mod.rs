//! The time integrators: the seam between the shared DDA machinery (blocks, contacts, loads) and
//! one scheme's update, and what the schemes share.
//!
//! - here: [`DdaMethod`] (a scheme as the registry lists it) and [`Integrator`] (what it does with
//!   the block system);
//! - [`explicit`]: central differences (paper Eqs. 5–8); [`implicit`]: Shi's Newmark β = ½,
//!   γ = 1 with open–close iterations (paper Eq. 4);
//! - [`linear_system`]: the block-sparse system of the implicit scheme;
//! - [`stability`]: the explicit limit 2/ω_max; [`energy`]: the detection of instability.
//!
//! # Adding a time integrator
//!
//! One file here and one line in [`crate::REGISTRY`]. The file holds the scheme's parameters
//! (`[solid.<NAME>]`, a [`SolverParams`]), a type implementing [`DdaMethod`] (name, one-line
//! description, how it builds its integrator) and [`Integrator`] (initialise, advance by `dt`,
//! propose the next step, save / restore / duplicate its own history for checkpoints and the
//! look-ahead). The blocks, contacts, loads, outputs and coupling come from
//! [`crate::dda::DdaSolver`]; the contacts' forces from [`World`]. A sketch through the public
//! API alone (semi-implicit Euler on the free blocks' translations; rotations, strains and the
//! work of prescribed motions, which a real scheme must handle, are in [`explicit`]):
//!
//! ```no_run
//! use serde::{Deserialize, Serialize};
//! use shared::math::{Real, Vector};
//! use shared::registry::{ParamCheck, SolverParams};
//! use shared::scene::Scene;
//! use shared::solver::{SolverError, StepReport};
//! use solid_node::integrators::energy::EnergyMonitor;
//! use solid_node::integrators::{DdaMethod, Integrator};
//! use solid_node::world::World;
//!
//! /// `[solid.euler]`: the step as a fraction of the scene's largest step.
//! #[derive(Debug, Clone, Deserialize, PartialEq)]
//! #[serde(deny_unknown_fields, default)]
//! pub struct EulerParams {
//!     pub fraction: f64,
//! }
//!
//! impl Default for EulerParams {
//!     fn default() -> Self {
//!         Self { fraction: 0.1 }
//!     }
//! }
//!
//! impl SolverParams for EulerParams {
//!     fn check(&self, c: &mut ParamCheck) {
//!         c.positive("fraction", Some(self.fraction), "0.1 is safe");
//!     }
//! }
//!
//! /// The integrator; its history (here only its parameter) is what `save` keeps.
//! #[derive(Clone, Serialize, Deserialize)]
//! pub struct Euler {
//!     fraction: Real,
//! }
//!
//! impl DdaMethod for Euler {
//!     const NAME: &'static str = "euler";
//!     const DESCRIPTION: &'static str = "semi-implicit Euler (a sketch)";
//!     type Params = EulerParams;
//!
//!     fn integrator(params: &EulerParams, _scene: &Scene) -> Box<dyn Integrator> {
//!         Box::new(Euler { fraction: params.fraction })
//!     }
//! }
//!
//! impl Integrator for Euler {
//!     fn name(&self) -> &'static str {
//!         <Self as DdaMethod>::NAME
//!     }
//!
//!     fn init(&mut self, world: &mut World) {
//!         // Contacts are detected at t = 0; their forces are the scheme's to evaluate.
//!         world.update_contact_forces();
//!     }
//!
//!     fn advance(
//!         &mut self,
//!         world: &mut World,
//!         dt: Real,
//!         energy: &mut EnergyMonitor,
//!     ) -> Result<StepReport, SolverError> {
//!         let mut work = 0.0;
//!         for &i in &world.free {
//!             let b = &mut world.blocks[i];
//!             let force = b.mass * world.gravity + world.load_force[i] + world.contact_force[i];
//!             b.velocity += force * (dt / b.mass);
//!             let d = b.velocity * dt;
//!             work += world.load_force[i].dot(&d);
//!             b.remember_pose();
//!             b.displace(&d, &Vector::zeros());
//!             b.update_world_geometry();
//!         }
//!         world.time += dt;
//!         energy.add_work(work);
//!         world.check_state(self.name())?;
//!         world.detect(world.penalty.margin);
//!         world.update_contact_forces();
//!         energy.check(world, self.name(), || 0.0, || "reduce [solid.euler] fraction".into())?;
//!         Ok(StepReport::default())
//!     }
//!
//!     fn dt_proposal(&self, world: &World) -> Real {
//!         self.fraction * world.dt_max
//!     }
//!
//!     fn save(&self) -> Result<Vec<u8>, String> {
//!         shared::checkpoint::encode(self)
//!     }
//!
//!     fn restore(&mut self, state: &[u8]) -> Result<(), String> {
//!         *self = shared::checkpoint::decode(state, "euler integrator")?;
//!         Ok(())
//!     }
//!
//!     // `begin_trial` has a default (nothing skipped during the look-ahead's trials).
//!
//!     fn duplicate(&self) -> Box<dyn Integrator> {
//!         Box::new(self.clone())
//!     }
//! }
//!
//! // The registry line, in `REGISTRY.entries` (lib.rs): `entry::<integrators::euler::Euler>(),`
//! let entry = solid_node::entry::<Euler>();
//! assert_eq!(entry.name, "euler");
//! ```

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

/// What a time integration scheme does with the block system, built by its [`DdaMethod`]
/// (module doc: how to add one).
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
