//! Looking ahead for a fluid that moves the blocks inside its own step: each free block's
//! response over the coming coupling step, (Δv, Δω) = Δt (a0 + M (F, τ)) in the water's force
//! and torque held over it ([`shared::protocol::BlockState::free_acceleration`]), measured by
//! trial steps.
//!
//! Why: DFSPH moves a block inside its pressure solve (Gissler et al. 2019) by the block's
//! inertia and the rest of its forces. Taken on their own, at their last value, those say
//! nothing of a contact: a block resting on the floor answers the water as if free, while the
//! solid's contact spring, sub-cycled within the coupling step, answers the same force within
//! it. The water then cancels the last contact force and the contact re-closes inside the step,
//! so a resting block's contact opens and closes from step to step (docs/journal/
//! 2026-11-performance.md "The solid looks ahead"). The solid's own step, linearised in the
//! water's load, is what a fluid needs instead: the interface Jacobian of quasi-Newton
//! partitioned coupling (Degroote, Bathe & Vierendeels 2009), here of a rigid block's six
//! degrees of freedom, by finite differences.
//!
//! How: after its step the solid saves its state (the checkpoint's bytes), advances over the
//! last step's dt in the same substeps with the water's loads held, once as they are and once
//! with each of the six load components raised by a thousandth of the block's weight (times
//! its radius of gyration for a torque), and restores the state after each trial: seven trial
//! steps, nothing of them kept. The fluid waits for the response, so its core is free: trials
//! 1, 3 and 5 run on a copy of the block system on the second thread (`rayon::join`), beside
//! 0, 2, 4 and 6; each starts from the same state, so the split changes no bit. Trial steps
//! may skip what only sizes and reports the kept steps
//! ([`crate::integrators::Integrator::begin_trial`]): in a cut rock mass, where every block touches its
//! neighbours face to face, the trials are most of the solid's work. All free rigid blocks are perturbed together (a block's response to its neighbours' loads
//! is left out). The mean velocities over a trial (displacement over Δt) give a0 and M. A
//! trial that fails (a contact past its limit) leaves the blocks on their own for that step;
//! deformable blocks always are (their strains are not in a fluid's rigid motion).

use crate::blocks::block::Block;
use crate::checkpoint;
use crate::integrators::Integrator;
use crate::integrators::energy::EnergyMonitor;
use crate::world::World;
use shared::math::{Matrix6, Point, Real, Rotation, Vector6};
use shared::solver::SolverError;

/// Relative size of the trial loads: a thousandth of the block's weight moves it by ½ 10⁻³ g Δt²
/// over a step, far above rounding and far below a contact's penetration.
const PERTURBATION: Real = 1e-3;

/// A free block's response over the coming step (module doc).
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Response {
    pub free_acceleration: Vector6,
    pub mobility: Matrix6,
}

/// A free block's pose and velocities at the start of the trials.
struct Start {
    block: usize,
    position: Point,
    rotation: Rotation,
    velocity: Vector6,
}

impl Start {
    /// The block's mean velocities over `dt` since the start, less those at the start.
    fn mean_change(&self, b: &Block, dt: Real) -> Vector6 {
        let v = (b.position - self.position) / dt;
        let w = (b.rotation * self.rotation.inverse()).scaled_axis() / dt;
        Vector6::new(v.x, v.y, v.z, w.x, w.y, w.z) - self.velocity
    }
}

/// Measures each free rigid block's [`Response`] over a step of `dt` in `substeps` with the
/// loads held (module doc), from the solver's block system, its integrator and energy monitor
/// and `blocks.csv`'s mark `csv` (all as they were when it returns); empty for `None` or when a
/// trial fails (the blocks on their own), else one entry per block of the world.
pub(super) fn measure(
    world: &mut World,
    integrator: &mut dyn Integrator,
    energy: &mut EnergyMonitor,
    csv: (Option<Real>, usize),
    step: Option<(Real, u32)>,
) -> Result<Vec<Option<Response>>, SolverError> {
    let Some((dt, substeps)) = step else {
        return Ok(Vec::new());
    };
    let starts: Vec<Start> = world
        .free
        .iter()
        .filter(|&&i| !world.blocks[i].is_deformable())
        .map(|&i| {
            let b = &world.blocks[i];
            let (v, w) = (b.velocity, b.angular_velocity);
            Start {
                block: i,
                position: b.position,
                rotation: b.rotation,
                velocity: Vector6::new(v.x, v.y, v.z, w.x, w.y, w.z),
            }
        })
        .collect();
    if starts.is_empty() {
        return Ok(Vec::new());
    }
    let g = match world.gravity.norm() {
        g if g > 0.0 => g,
        _ => shared::math::STANDARD_GRAVITY,
    };
    // The trial loads: a thousandth of the weight, times the radius of gyration
    // r² = 3/(m tr I⁻¹) for a torque.
    let sizes: Vec<(Real, Real)> = starts
        .iter()
        .map(|s| {
            let b = &world.blocks[s.block];
            let f = PERTURBATION * b.mass * g;
            let r2 = 3.0 / (b.mass * b.world_inv_inertia().trace());
            (f, f * r2.sqrt())
        })
        .collect();
    let saved = checkpoint::encode(world, integrator, energy, csv, &())?;
    let plan = Plan {
        starts: &starts,
        sizes: &sizes,
        saved: &saved,
        dt,
        substeps,
    };
    // The fluid waits for this response (it moves the blocks with it), so the second core
    // is free: trials 1, 3, 5 run on a copy of the block system beside 0, 2, 4, 6 here.
    // Each starts from the same state, so the split changes no bit.
    let mut copy = (world.clone(), integrator.duplicate(), energy.clone());
    let (here, there) = rayon::join(
        || plan.run(world, integrator, energy, 0),
        || plan.run(&mut copy.0, copy.1.as_mut(), &mut copy.2, 1),
    );
    let (mut here, mut there) = (here?.into_iter(), there?.into_iter());
    let mut trials: Vec<Vec<Vector6>> = Vec::with_capacity(7);
    for k in 0..7 {
        let side = if k % 2 == 0 { &mut here } else { &mut there };
        // A trial that failed (a contact past its limit) leaves the blocks on their own.
        match side.next().flatten() {
            Some(changes) => trials.push(changes),
            None => return Ok(Vec::new()),
        }
    }
    let mut response = vec![None; world.blocks.len()];
    for (k, (s, &(f, t))) in starts.iter().zip(&sizes).enumerate() {
        let mut mobility = Matrix6::zeros();
        for j in 0..6 {
            let size = if j < 3 { f } else { t };
            let column = (trials[j + 1][k] - trials[0][k]) / (size * dt);
            mobility.set_column(j, &column);
        }
        let (lf, lt) = (world.load_force[s.block], world.load_torque[s.block]);
        let load = Vector6::new(lf.x, lf.y, lf.z, lt.x, lt.y, lt.z);
        // Trial 0 is the response to the loads held: a0 is what is left without them.
        let free_acceleration = trials[0][k] / dt - mobility * load;
        response[s.block] = Some(Response {
            free_acceleration,
            mobility,
        });
    }
    Ok(response)
}

/// The trial steps of one look-ahead: trial 0 with the loads as they are, trial 1 + j with
/// load component j of every block raised by its size, each from the state `saved`.
struct Plan<'a> {
    starts: &'a [Start],
    sizes: &'a [(Real, Real)],
    saved: &'a [u8],
    dt: Real,
    substeps: u32,
}

impl Plan<'_> {
    /// Runs trials `first`, `first + 2`, … below 7 on `world` (which holds the saved state),
    /// restoring it after each: each trial's velocity changes, `None` where a trial failed.
    fn run(
        &self,
        world: &mut World,
        integrator: &mut dyn Integrator,
        energy: &mut EnergyMonitor,
        first: usize,
    ) -> Result<Vec<Option<Vec<Vector6>>>, SolverError> {
        let h = self.dt / self.substeps as Real;
        let mut out = Vec::new();
        for trial in (first..7).step_by(2) {
            if trial > 0 {
                let j = trial - 1;
                for (s, &(f, t)) in self.starts.iter().zip(self.sizes) {
                    if j < 3 {
                        world.load_force[s.block][j] += f;
                    } else {
                        world.load_torque[s.block][j - 3] += t;
                    }
                }
            }
            // Each trial is thrown away (the restore below also ends the trial mode).
            integrator.begin_trial();
            let ok = (0..self.substeps).all(|_| integrator.advance(world, h, energy).is_ok());
            out.push(ok.then(|| {
                self.starts
                    .iter()
                    .map(|s| s.mean_change(&world.blocks[s.block], self.dt))
                    .collect()
            }));
            checkpoint::decode::<()>(
                world,
                integrator,
                energy,
                self.saved,
                "the look-ahead's snapshot",
            )?;
        }
        Ok(out)
    }
}
