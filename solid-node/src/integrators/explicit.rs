//! `--solver explicit`: the paper's central difference scheme (Eqs. 5–8).
//!
//! With velocities at half steps and a step that may change from one advance to the next:
//!
//! ```text
//! a_n       = M⁻¹ (F_n − I_n)                         (Eq. 7: contact springs in I_n)
//! v_{n+½}   = v_{n−½} + ½ (Δt_n + Δt_{n+1}) a_n       (Eq. 6)
//! x_{n+1}   = x_n + Δt_{n+1} v_{n+½}                  (Eq. 5)
//! ```
//!
//! Each block is updated on its own (no global matrix). Rotations: the angular momentum
//! L = I ω takes the torque kick, ω_{n+½} = I(q_n)⁻¹ L_{n+½}, and the orientation turns by the
//! exact rotation exp(Δt ω_{n+½}) (see [`crate::blocks::rotation`]). The scheme is stable for
//! Δt ≤ 2/ω_max (Eq. 8); the proposal is `safety_factor` · 2/ω_max. Past it nothing is
//! refused: the step is taken as the method would, and the energy growth that follows is
//! detected and reported (see [`crate::integrators::energy`]).
//!
//! Deformable blocks integrate their six strains the same way (Shi's strain unknowns, with
//! the block-diagonal mass of [`crate::blocks::elastic`]):
//!
//! ```text
//! ė_{n+½} = ė_{n−½} + ½ (Δt_n + Δt_{n+1}) M_e⁻¹ (g_contact + g_fluid − V D e_n)
//! e_{n+1} = e_n + Δt_{n+1} ė_{n+½}
//! ```
//!
//! and the limit Δt ≤ 2/ω_max then includes their elastic modes (see [`crate::integrators::stability`]).

use crate::integrators::energy::EnergyMonitor;
use crate::integrators::stability::{self, Estimate};
use crate::integrators::{DdaMethod, Integrator};
use crate::world::World;
use serde::Deserialize;
use shared::geometry::strain::Strain;
use shared::math::{Real, Vector};
use shared::registry::{ParamCheck, SolverParams};
use shared::scene::Scene;
use shared::solver::{SolverError, StepReport};

/// `[solid.explicit]`: parameters of the central difference scheme.
#[derive(Debug, Clone, Deserialize, PartialEq)]
#[serde(deny_unknown_fields, default)]
pub struct ExplicitParams {
    /// Fraction of the explicit limit 2/ω_max used as the step (paper Eq. 8); default 0.5.
    pub safety_factor: f64,
}

impl Default for ExplicitParams {
    fn default() -> Self {
        Self { safety_factor: 0.5 }
    }
}

impl SolverParams for ExplicitParams {
    fn check(&self, c: &mut ParamCheck) {
        let s = self.safety_factor;
        if !(s.is_finite() && s > 0.0 && s <= 10.0) {
            c.fail(
                "safety_factor",
                s,
                "must be a finite number in (0, 10]",
                "0.5 is safe; > 1 exceeds 2/ω_max (paper Eq. 8)",
            );
        }
    }
}

impl DdaMethod for CentralDifference {
    const NAME: &'static str = "explicit";
    const DESCRIPTION: &'static str = "the paper's central difference (Eqs. 5–8): no global matrix, step bounded by safety_factor · 2/ω_max";
    type Params = ExplicitParams;

    fn integrator(params: &ExplicitParams, _scene: &Scene) -> Box<dyn Integrator> {
        Box::new(CentralDifference::new(params.safety_factor))
    }
}

#[derive(Clone, serde::Serialize, serde::Deserialize)]
pub struct CentralDifference {
    /// v_{n−½} of each block (indexed like `World::blocks`).
    half_velocity: Vec<Vector>,
    /// Angular momentum L_{n−½} (world frame).
    half_momentum: Vec<Vector>,
    /// ė_{n−½} of each block (used for the deformable ones only).
    half_rate: Vec<Strain>,
    /// The previous step Δt_n (0 before the first step).
    dt_prev: Real,
    safety: Real,
    /// ω² of the resting-block floor (set-up) and of the current contacts (and elastic modes).
    floor: Estimate,
    now: Estimate,
    scratch: stability::Scratch,
    /// ω·dt of the first step that exceeded 2, and the estimate it came from (what an
    /// instability report names: by the time the energy has grown, the contact configuration
    /// is anything).
    first_excess: Option<(Real, Estimate)>,
    /// Trial steps ([`Integrator::begin_trial`]): the estimate of ω_max from the contacts (an
    /// eigenvalue problem per block in contact, a large part of a step in a cut rock mass) is
    /// not renewed after each; it only sizes the next kept step and names an excess, and a
    /// trial's state is thrown away. Not saved: a restore ends the trials.
    #[serde(skip)]
    trial: bool,
}

impl CentralDifference {
    pub fn new(safety: Real) -> CentralDifference {
        CentralDifference {
            half_velocity: Vec::new(),
            half_momentum: Vec::new(),
            half_rate: Vec::new(),
            dt_prev: 0.0,
            safety,
            floor: Estimate::default(),
            now: Estimate::default(),
            scratch: stability::Scratch::default(),
            first_excess: None,
            trial: false,
        }
    }

    /// Highest frequency ω_max [rad/s] the proposal is built on (contacts, elastic modes).
    pub fn omega_max(&self) -> Real {
        self.floor.omega2.max(self.now.omega2).sqrt()
    }

    /// The estimate behind [`CentralDifference::omega_max`].
    pub fn binding(&self) -> Estimate {
        self.floor.max(self.now)
    }
}

/// What an instability report says bounds the step.
fn limit_hint(world: &World, est: &Estimate) -> String {
    const BASE: &str = "central difference is stable only below 2, paper Eq. 8; reduce dt or [solid.explicit] safety_factor";
    match est.elastic {
        Some(i) => {
            let b = &world.blocks[i];
            let w = b.elastic.as_ref().map_or(0.0, |e| e.omega2.sqrt());
            format!(
                "the elastic mode of deformable block '{}' binds: ω_elastic = {w:.4e} rad/s, λ_max(M_e^-½ V D M_e^-½); \
                 {BASE}, or soften the block (ω_elastic ∝ sqrt(E))",
                b.name
            )
        }
        None => BASE.to_string(),
    }
}

impl Integrator for CentralDifference {
    fn name(&self) -> &'static str {
        <Self as DdaMethod>::NAME
    }

    fn save(&self) -> Result<Vec<u8>, String> {
        shared::checkpoint::encode(self)
    }

    fn restore(&mut self, state: &[u8]) -> Result<(), String> {
        *self = shared::checkpoint::decode(state, "explicit integrator")?;
        Ok(())
    }

    fn begin_trial(&mut self) {
        self.trial = true;
    }

    fn duplicate(&self) -> Box<dyn Integrator> {
        Box::new(self.clone())
    }

    fn init(&mut self, world: &mut World) {
        self.half_velocity = world.blocks.iter().map(|b| b.velocity).collect();
        self.half_momentum = world
            .blocks
            .iter()
            .map(|b| b.world_inertia() * b.angular_velocity)
            .collect();
        self.half_rate = world.blocks.iter().map(|b| b.strain_rate()).collect();
        self.dt_prev = 0.0;
        self.first_excess = None;
        world.update_contact_forces();
        self.floor = stability::resting_floor(world);
        self.now = stability::current(world, &mut self.scratch);
    }

    fn advance(
        &mut self,
        world: &mut World,
        dt: Real,
        energy: &mut EnergyMonitor,
    ) -> Result<StepReport, SolverError> {
        // ω·dt of the contacts present and of the elastic modes (the set-up floor only
        // anticipates contacts to come).
        let (omega_now, est_now) = if self.now.omega2 > 0.0 {
            (self.now.omega2.sqrt(), self.now)
        } else {
            (self.omega_max(), self.binding())
        };
        let omega_dt = omega_now * dt;
        if omega_dt > 2.0 && self.first_excess.is_none() {
            self.first_excess = Some((omega_dt, est_now));
        }
        let kick = 0.5 * (self.dt_prev + dt);
        let mut work = 0.0;
        for &i in &world.free {
            let b = &mut world.blocks[i];
            let force = b.mass * world.gravity + world.load_force[i] + world.contact_force[i];
            let torque = world.load_torque[i] + world.contact_torque[i];
            // Eq. 6 (and its rotational twin on the angular momentum).
            self.half_velocity[i] += force * (kick / b.mass);
            self.half_momentum[i] += torque * kick;
            let omega = b.world_inv_inertia() * self.half_momentum[i];
            let (d, theta) = (self.half_velocity[i] * dt, omega * dt);
            work += world.load_force[i].dot(&d) + world.load_torque[i].dot(&theta);
            b.remember_pose();
            // Eq. 5, with the exact rotation.
            b.displace(&d, &theta);
            // The dashpots of the next force evaluation see the half-step velocity (the
            // lagging velocity keeps damped central difference stable below
            // (2/ω)(sqrt(1 + ζ²) − ζ)); the velocity at t_{n+1} is set once a_{n+1} is known.
            b.velocity = self.half_velocity[i];
            b.angular_velocity = omega;
            if !b.is_deformable() {
                // (A deformable block's geometry follows its strain update below.)
                b.update_world_geometry();
            }
        }
        // The strain unknowns of the deformable blocks: the same central difference.
        // (`remember_pose` above kept e_n for the step displacement of contact points.)
        for &i in &world.deformable {
            let b = &mut world.blocks[i];
            let de = match b.elastic.as_mut() {
                Some(el) => {
                    let g = world.contact_strain[i] + world.load_strain[i] + el.elastic_force();
                    self.half_rate[i] += el.inv_mass * g * kick;
                    // As for v above: the dashpots of the next evaluation see ė_{n+½}.
                    el.rate = self.half_rate[i];
                    self.half_rate[i] * dt
                }
                None => continue,
            };
            work += world.load_strain[i].dot(&de);
            b.strain_by(&de);
            b.update_world_geometry();
        }
        let t1 = world.time + dt;
        for &i in &world.moving {
            let b = &mut world.blocks[i];
            if b.is_free() {
                continue;
            }
            b.remember_pose();
            b.set_kinematic_pose(t1);
            // Work of the prescribed motion on the blocks it pushes (first half of the
            // trapezoid; the second half once the forces at t_{n+1} are known).
            work -= 0.5 * world.contact_force[i].dot(&(b.position - b.prev_position));
            b.update_world_geometry();
        }
        world.time = t1;
        self.dt_prev = dt;
        energy.add_work(work);
        world.check_state(self.name())?;

        world.detect(world.penalty.margin);
        world.update_contact_forces();
        let mut work_end = 0.0;
        for &i in &world.moving {
            let b = &world.blocks[i];
            if !b.is_free() {
                work_end -= 0.5 * world.contact_force[i].dot(&(b.position - b.prev_position));
            }
        }
        energy.add_work(work_end);
        // Velocities at t_{n+1} for the outputs and the coupling: v_{n+½} + ½ Δt a_{n+1}, with
        // the loads of the step just taken standing in for the next ones.
        for &i in &world.free {
            let b = &mut world.blocks[i];
            let force = b.mass * world.gravity + world.load_force[i] + world.contact_force[i];
            let torque = world.load_torque[i] + world.contact_torque[i];
            b.velocity = self.half_velocity[i] + force * (0.5 * dt / b.mass);
            b.angular_velocity =
                b.world_inv_inertia() * (self.half_momentum[i] + torque * (0.5 * dt));
        }
        for &i in &world.deformable {
            if let Some(el) = world.blocks[i].elastic.as_mut() {
                let g = world.contact_strain[i] + world.load_strain[i] + el.elastic_force();
                el.rate = self.half_rate[i] + el.inv_mass * g * (0.5 * dt);
            }
        }
        if !self.trial {
            self.now = stability::current(world, &mut self.scratch);
        }
        let (reported, est) = self.first_excess.unwrap_or((omega_dt, est_now));
        energy.check(world, self.name(), || reported, || limit_hint(world, &est))?;
        let warning = (self.omega_max() * dt > 2.0).then(|| {
            let omega_dt = self.omega_max() * dt;
            let what = match self.binding().elastic {
                Some(i) => format!(
                    ", bound by the elastic mode of deformable block '{}'",
                    world.blocks[i].name
                ),
                None => String::new(),
            };
            format!("explicit step dt = {dt:.3e} s exceeds the stability limit 2/ω_max = {:.3e} s (ω_max·dt = {omega_dt:.2}{what})", 2.0 / self.omega_max())
        });
        Ok(StepReport { warning })
    }

    fn dt_proposal(&self, world: &World) -> Real {
        let w = self.omega_max();
        if w > 0.0 {
            self.safety * 2.0 / w
        } else {
            world.dt_max
        }
    }
}
