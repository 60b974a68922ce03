//! `--solver euler`: semi-implicit (symplectic) Euler for rigid blocks, as an example of a DDA
//! time integrator added through the public API (one file; one registry line in
//! `extended-solid-node`).
//!
//! ```text
//! v_{n+1} = v_n + Δt (m g + F_water + F_contact) / m
//! L_{n+1} = L_n + Δt (T_water + T_contact),  ω_{n+1} = I(q_n)⁻¹ L_{n+1}
//! x_{n+1} = x_n + Δt v_{n+1},  q_{n+1} = exp(Δt ω_{n+1}) q_n
//! ```
//!
//! Stable, like central differences, for Δt ω_max < 2 on the contact springs: the step
//! proposed is `safety_factor` · 2/ω_max from the contacts present (paper Eq. 8).

use serde::{Deserialize, Serialize};
use shared::math::Real;
use shared::registry::{ParamCheck, SolverParams};
use shared::scene::Scene;
use shared::solver::{SolverError, StepReport};
use solid_node::integrators::energy::EnergyMonitor;
use solid_node::integrators::stability::{self, Estimate, Scratch};
use solid_node::integrators::{DdaMethod, Integrator};
use solid_node::world::World;

/// `[solid.euler]`.
#[derive(Debug, Clone, Deserialize, PartialEq)]
#[serde(deny_unknown_fields, default)]
pub struct EulerParams {
    /// Fraction of 2/ω_max taken as the step (default 0.5).
    pub safety_factor: f64,
}

impl Default for EulerParams {
    fn default() -> Self {
        Self { safety_factor: 0.5 }
    }
}

impl SolverParams for EulerParams {
    fn check(&self, c: &mut ParamCheck) {
        if !(self.safety_factor.is_finite()
            && self.safety_factor > 0.0
            && self.safety_factor <= 1.0)
        {
            c.fail(
                "safety_factor",
                self.safety_factor,
                "must be in (0, 1]",
                "0.5 is safe",
            );
        }
    }
}

#[derive(Clone, Serialize, Deserialize)]
pub struct Euler {
    safety: Real,
    /// ω² of the resting-block floor (set-up) and of the contacts present.
    floor: Estimate,
    now: Estimate,
    #[serde(skip)]
    scratch: Scratch,
}

impl DdaMethod for Euler {
    const NAME: &'static str = "euler";
    const DESCRIPTION: &'static str =
        "semi-implicit Euler for rigid blocks; an example of an integrator added from outside";
    type Params = EulerParams;

    fn integrator(params: &EulerParams, _scene: &Scene) -> Box<dyn Integrator> {
        Box::new(Euler {
            safety: params.safety_factor,
            floor: Estimate::default(),
            now: Estimate::default(),
            scratch: Scratch::default(),
        })
    }
}

impl Integrator for Euler {
    fn name(&self) -> &'static str {
        <Self as DdaMethod>::NAME
    }

    fn init(&mut self, world: &mut World) {
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
        if let Some(&i) = world.deformable.first() {
            return Err(SolverError::Failed(format!(
                "euler integrates rigid blocks only, and block '{}' is deformable. Fix: choose another [solid] solver, or drop its elastic table",
                world.blocks[i].name
            )));
        }
        let mut work = 0.0;
        for &i in &world.free {
            let b = &mut world.blocks[i];
            let force = b.mass * world.gravity + world.load_force[i] + world.contact_force[i];
            let torque = world.load_torque[i] + world.contact_torque[i];
            b.velocity += force * (dt / b.mass);
            let momentum = b.world_inertia() * b.angular_velocity + torque * dt;
            b.angular_velocity = b.world_inv_inertia() * momentum;
            let (d, theta) = (b.velocity * dt, b.angular_velocity * dt);
            work += world.load_force[i].dot(&d) + world.load_torque[i].dot(&theta);
            b.remember_pose();
            b.displace(&d, &theta);
            b.update_world_geometry();
        }
        let t1 = world.time + dt;
        for &i in &world.moving {
            let b = &mut world.blocks[i];
            if !b.is_free() {
                b.remember_pose();
                b.set_kinematic_pose(t1);
                b.update_world_geometry();
            }
        }
        world.time = t1;
        energy.add_work(work);
        world.check_state(self.name())?;
        world.detect(world.penalty.margin);
        world.update_contact_forces();
        self.now = stability::current(world, &mut self.scratch);
        let omega_dt = self.floor.max(self.now).omega2.sqrt() * dt;
        energy.check(world, self.name(), || omega_dt, || {
            "symplectic Euler is stable only below 2 (paper Eq. 8); reduce dt or [solid.euler] safety_factor".into()
        })?;
        Ok(StepReport::default())
    }

    fn dt_proposal(&self, world: &World) -> Real {
        let w = self.floor.max(self.now).omega2.sqrt();
        if w > 0.0 {
            self.safety * 2.0 / w
        } else {
            world.dt_max
        }
    }

    fn save(&self) -> Result<Vec<u8>, String> {
        shared::checkpoint::encode(self)
    }

    fn restore(&mut self, state: &[u8]) -> Result<(), String> {
        *self = shared::checkpoint::decode(state, "euler integrator")?;
        Ok(())
    }

    fn duplicate(&self) -> Box<dyn Integrator> {
        Box::new(self.clone())
    }
}
