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

use crate::contact::Feature;
use crate::world::World;
use shared::math::Real;
use shared::solver::SolverError;

/// Ratio of (kinetic + contact) energy to the energy available above which a run is unstable.
pub const GROWTH_LIMIT: Real = 4.0;

/// Share of the free blocks' energy one contact must hold for the message to name it.
const DOMINANT_SHARE: Real = 0.5;

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
                 against {:.4e} J available) at t = {:.6} s, ω_max·dt = {omega_dt:.3} ({hint}){}",
                self.ratio,
                if world.deformable.is_empty() {
                    ""
                } else {
                    " + strain"
                },
                available.max(self.floor),
                world.time,
                dominant_contact(world, dynamic, omega_dt),
            )));
        }
        Ok(())
    }
}

/// The contact holding most of the free blocks' `dynamic` energy, as a clause of the energy
/// watch's message ("" when none holds [`DOMINANT_SHARE`]). With ω_max·dt inside the central
/// difference's bound (< 2), a single contact holding kilojoules is not the step's doing: the
/// blocks moved into each other while no contact was found there, and the spring, found
/// late, holds the whole depth. That is how two holes in the contact detection showed
/// themselves (a corner flush with a neighbour's side face, edges crossing between faces
/// pressed into each other; docs/ARCHITECTURE.md), so the message says which contact.
fn dominant_contact(world: &World, dynamic: Real, omega_dt: Real) -> String {
    let Some((c, e)) = world
        .contacts
        .iter()
        .map(|c| (c, world.penalty.energy(c)))
        .max_by(|x, y| x.1.total_cmp(&y.1))
    else {
        return String::new();
    };
    // A NaN state (the watch's other trigger) names no contact.
    if e.is_nan() || dynamic.is_nan() || e < DOMINANT_SHARE * dynamic {
        return String::new();
    }
    let (p, q) = (
        &world.blocks[c.p as usize].name,
        &world.blocks[c.q as usize].name,
    );
    let what = match c.key.feature {
        Feature::EdgeEdge => format!("an edge of '{p}' crossing an edge of '{q}'"),
        Feature::VertexOfA | Feature::VertexOfB => {
            format!("a vertex of '{p}' in face {} of '{q}'", c.face)
        }
    };
    let cause = if omega_dt < 2.0 {
        "; with ω_max·dt inside the scheme's bound of 2, a contact this deep was most likely \
         found late, after the blocks had moved into each other undetected (a fault of the \
         contact detection for this geometry, not of the step: please report the scene)"
    } else {
        ""
    };
    format!(
        "; {:.0} % of it in one contact, {what}, {:.3e} m deep at ({:.4}, {:.4}, {:.4}) m, \
         holding {e:.4e} J{cause}",
        100.0 * e / dynamic,
        -c.gap,
        c.point.x,
        c.point.y,
        c.point.z,
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use shared::math::Vector;
    use shared::scene::Scene;

    /// A free tetrahedron standing on its apex 1 mm over a fixed floor, then moved 5 cm into
    /// it (as a contact detection that missed the apex would leave it): the watch stops the
    /// run, and its message names the one contact that holds the energy and what that means
    /// at a step inside the scheme's bound.
    #[test]
    fn a_deep_contact_found_late_is_named() {
        let text = r#"
            name = "late"
            [time]
            end = 1.0
            [domain]
            min = [-5.0, -5.0, -5.0]
            max = [5.0, 5.0, 5.0]
            [solid.contact]
            normal_stiffness = 1e7
            [[block]]
            name = "floor"
            kind = "fixed"
            shape = { type = "box", min = [-1.0, -1.0, -0.5], max = [1.0, 1.0, 0.0] }
            density = 2500.0
            [[block]]
            name = "spike"
            shape = { type = "convex", vertices = [[0.0, 0.0, 0.001], [-0.2, -0.2, 0.3], [0.2, -0.2, 0.3], [0.0, 0.25, 0.3]] }
            density = 2500.0
        "#;
        let scene = Scene::parse(text, "t").unwrap();
        let mut world = World::new(&scene).unwrap();
        let margin = world.penalty.margin;
        world.detect(margin);
        let mut watch = EnergyMonitor::new(&world);
        assert!(watch.check(&world, "explicit", || 0.5, String::new).is_ok());
        let spike = world.free[0];
        world.blocks[spike].displace(&Vector::new(0.0, 0.0, -0.051), &Vector::zeros());
        world.blocks[spike].update_world_geometry();
        world.detect(margin);
        let named = |omega_dt: Real| {
            let mut w = watch.clone();
            // The explicit solver's own hint, so the message is as long as a run's.
            let hint = || {
                "central difference is stable only below 2, paper Eq. 8; reduce dt or \
                 [solid.explicit] safety_factor"
                    .to_string()
            };
            match w.check(&world, "explicit", || omega_dt, hint) {
                Err(SolverError::Unstable(m)) => m,
                other => panic!("{other:?}"),
            }
        };
        let inside = named(0.5);
        for part in [
            "100 % of it in one contact",
            "a vertex of 'spike' in face",
            "of 'floor'",
            "5.000e-2 m deep",
            "found late",
        ] {
            assert!(inside.contains(part), "{part:?} not in: {inside}");
        }
        // The node's status carries it to the coupler whole (it held 512 bytes, and the
        // jointed slide's stop lost everything from "found late" on).
        use shared::protocol::{MESSAGE_BYTES, Text};
        assert_eq!(Text::<MESSAGE_BYTES>::new(&inside).as_str(), inside);
        assert!(inside.len() > 512, "{} bytes", inside.len());
        // Past the bound the step is the cause: the contact is named, the detection is not
        // blamed.
        let past = named(2.5);
        assert!(
            past.contains("one contact") && !past.contains("found late"),
            "{past}"
        );
    }
}
