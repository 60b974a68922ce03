//! Energy bookkeeping that detects a method going unstable.
//!
//! Without the method's error, the kinetic plus contact-spring (plus elastic strain, for
//! deformable blocks) energy of the free blocks can
//! never exceed what they started with, plus the potential energy they have lost, plus the work
//! of the fluid loads and of kinematic blocks pushing them; friction and dashpots only take
//! energy away. The central difference scheme run past 2/ω_max multiplies a contact mode's
//! amplitude every step (paper Eq. 8), so that ratio explodes: it is the measured "energy
//! growth" reported. Stable runs stay near or below 1 (the explicit scheme's bounded energy
//! error near ω·dt = 2 is well below [`GROWTH_LIMIT`]).

use crate::world::World;
use shared::math::Real;
use shared::solver::SolverError;

/// Ratio of (kinetic + contact) energy to the energy available above which a run is unstable.
pub const GROWTH_LIMIT: Real = 4.0;

#[derive(Debug, Clone, serde::Serialize, serde::Deserialize)]
pub struct EnergyMonitor {
    /// Kinetic + contact + potential energy at the start [J].
    initial: Real,
    /// Work done on the free blocks by loads and kinematic blocks [J].
    work: Real,
    /// Energy scale under which ratios are noise [J].
    floor: Real,
    /// Last measured ratio.
    pub ratio: Real,
}

impl EnergyMonitor {
    pub fn new(world: &World) -> EnergyMonitor {
        let g = world.gravity.norm().max(1.0);
        let size = world.smallest_free_size();
        let size = if size.is_finite() { size } else { 1.0 };
        EnergyMonitor {
            initial: world.kinetic_energy()
                + world.contact_energy()
                + world.strain_energy()
                + world.potential_energy(),
            work: 0.0,
            floor: 1e-3 * world.free_mass() * g * size,
            ratio: 0.0,
        }
    }

    /// Adds work done on the free blocks from outside (loads, kinematic blocks) [J].
    pub fn add_work(&mut self, w: Real) {
        if w.is_finite() {
            self.work += w;
        }
    }

    /// Measures the energy ratio; `Unstable` naming the solver, the growth and ω·dt when it
    /// exceeds [`GROWTH_LIMIT`].
    /// `omega_dt` gives ω_max·dt for the message; `hint` says what bounds the method (e.g.
    /// "central difference is stable only below 2", or which elastic mode binds); both are
    /// only evaluated when the check fails.
    pub fn check(
        &mut self,
        world: &World,
        solver: &str,
        omega_dt: impl FnOnce() -> Real,
        hint: impl FnOnce() -> String,
    ) -> Result<(), SolverError> {
        // A scene whose only moving blocks are kinematic (a wave-maker piston) has no free
        // block whose energy could grow: nothing to check, and 0/0 must not read as growth.
        if world.free_mass() <= 0.0 {
            self.ratio = 0.0;
            return Ok(());
        }
        let dynamic = world.kinetic_energy() + world.contact_energy() + world.strain_energy();
        let available = self.initial - world.potential_energy() + self.work;
        self.ratio = dynamic / available.max(self.floor);
        if self.ratio > GROWTH_LIMIT || !self.ratio.is_finite() {
            let omega_dt = omega_dt();
            let hint = hint();
            return Err(SolverError::Unstable(format!(
                "{solver} solver: energy grew {:.3e}-fold beyond what the loads supplied ({dynamic:.4e} J kinetic + contact{} \
                 against {:.4e} J available) at t = {:.6} s, ω_max·dt = {omega_dt:.3} ({hint})",
                self.ratio,
                if world.deformable.is_empty() {
                    ""
                } else {
                    " + strain"
                },
                available.max(self.floor),
                world.time
            )));
        }
        Ok(())
    }
}
