//! What a time integration scheme does with the block system: the seam between the shared
//! DDA machinery (blocks, contacts, loads) and the explicit or implicit update.

use crate::energy::EnergyMonitor;
use crate::world::World;
use shared::math::Real;
use shared::solver::{SolverError, StepReport};

pub trait Integrator: Send {
    /// The `--solver` name.
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
}
