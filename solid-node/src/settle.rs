//! Gravity loading of a jointed rock mass before t = 0: the blocks cut from a `[[slide]]`
//! start exactly touching, with unloaded joints. Switched on at once, gravity would set their
//! contact springs ringing and the transient (up to twice the static load) would break joints
//! that hold the slope statically. A real slope carries its weight already, so the solid node
//! first brings the slides' blocks to static equilibrium with every contact held elastic (no
//! slip, bonds without strength limit: the rock mass in place before it is released), by
//! dynamic relaxation with kinetic damping: the integrator's steps run on, and whenever the
//! slides' kinetic energy falls (the motion has passed through the equilibrium it oscillates
//! about) their velocities are zeroed. This converges in about as many steps as the slowest
//! mode's period holds, where Shi's static analysis (velocities zeroed every step, Shi 1988)
//! needs its square. Then the joints' strength and the friction apply from t = 0: a slope past
//! its limit fails at the first step, one within it stands. Blocks that are not cut from a slide keep their scene state meanwhile (put back
//! after every settling step, so a block given an initial velocity starts with it).
//!
//! The settled poses differ from the scene's by the springs' elastic deflection (μm for the
//! default contact stiffness). Deterministic: a fixed sequence of steps from the scene.

use crate::blocks::block::Block;
use crate::integrators::Integrator;
use crate::integrators::energy::EnergyMonitor;
use crate::world::World;
use shared::math::{Real, Vector};
use shared::scene::BlockKind;
use shared::solver::SolverError;

/// Most static steps; a slide that has not settled by then starts from where it got to.
pub const MAX_STEPS: usize = 20_000;
/// Settled when the net force on every slide block is below this fraction of its weight (the
/// net torque below it times weight × size) and it moves less than this fraction of its size
/// per step.
const FORCE_TOLERANCE: Real = 1e-6;

/// How the settling went.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct Settled {
    pub steps: usize,
    /// Largest displacement of a block centroid from its scene position [m].
    pub max_settlement: Real,
    pub converged: bool,
}

/// Settles `world` (free blocks at rest, bonds elastic) and re-initialises `integrator` at the
/// settled state, time 0. Only called when the scene has bonded joints.
pub fn settle(world: &mut World, integrator: &mut dyn Integrator) -> Result<Settled, SolverError> {
    let origin: Vec<_> = world.blocks.iter().map(|b| b.position).collect();
    let others: Vec<(usize, Block)> = world
        .blocks
        .iter()
        .enumerate()
        .filter(|(_, b)| b.slide.is_none() && b.kind != BlockKind::Fixed)
        .map(|(i, b)| (i, b.clone()))
        .collect();
    world.penalty.bonds_hold = true;
    let mut report = Settled::default();
    let mut result = Ok(());
    // Kinetic energy of the slides' blocks at the previous step: when it falls, the motion
    // has passed the equilibrium it oscillates about, and the velocities are zeroed there.
    let mut previous_energy = 0.0;
    while report.steps < MAX_STEPS {
        let dt = integrator.dt_proposal(world);
        let mut energy = EnergyMonitor::new(world);
        if let Err(e) = integrator.advance(world, dt, &mut energy) {
            result = Err(e);
            break;
        }
        report.steps += 1;
        world.time = 0.0;
        for (i, b) in &others {
            world.blocks[*i] = b.clone();
        }
        let kinetic: Real = world
            .free
            .iter()
            .filter(|&&i| world.blocks[i].slide.is_some())
            .map(|&i| world.blocks[i].kinetic_energy())
            .sum();
        let peak = kinetic < previous_energy;
        previous_energy = if peak { 0.0 } else { kinetic };
        for &i in &world.free {
            let b = &mut world.blocks[i];
            if b.slide.is_none() {
                continue;
            }
            report.max_settlement = report.max_settlement.max((b.position - origin[i]).norm());
            if peak {
                b.velocity = Vector::zeros();
                b.angular_velocity = Vector::zeros();
            }
        }
        // (Restarting the central difference from v_{n+1} = v_{n+½} + ½Δt a_{n+1} takes the
        // same next step as carrying on: this only resets the other blocks.)
        rest(world, integrator);
        let g = world.gravity.norm().max(1.0);
        let balanced = world
            .free
            .iter()
            .filter(|&&i| world.blocks[i].slide.is_some())
            .all(|&i| {
                let b = &world.blocks[i];
                let w = b.mass * g;
                let f = b.mass * world.gravity + world.load_force[i] + world.contact_force[i];
                let t = world.load_torque[i] + world.contact_torque[i];
                let slow = b.velocity.norm() * dt <= FORCE_TOLERANCE * b.size();
                slow && f.norm() <= FORCE_TOLERANCE * w
                    && t.norm() <= FORCE_TOLERANCE * w * b.size()
            });
        if balanced {
            report.converged = true;
            break;
        }
    }
    world.penalty.bonds_hold = false;
    world.time = 0.0;
    result?;
    rest(world, integrator);
    Ok(report)
}

/// Blocks where they are: no step displacement pending (the shear springs are not stretched
/// again), the integrator's history restarted from the blocks' velocities (zero for the
/// slides').
fn rest(world: &mut World, integrator: &mut dyn Integrator) {
    for b in &mut world.blocks {
        b.remember_pose();
    }
    integrator.init(world);
}
