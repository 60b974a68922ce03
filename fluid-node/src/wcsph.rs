//! Weakly compressible SPH in the DualSPHysics standard (Crespo et al. 2015; Domínguez et al.
//! 2022): Tait's equation of state p = B((ρ/ρ0)^γ − 1), B = ρ0c0²/γ (Monaghan 1994); the
//! Wendland C2 kernel (Wendland 1995); density from the continuity equation with δ-SPH diffusion
//! (Molteni & Colagrossi 2009) in Fourtakas et al. (2019)'s form, which subtracts the hydrostatic
//! density difference so the diffusion does not flatten a column at rest; Monaghan (1992)'s
//! artificial viscosity; the symplectic position-Verlet scheme (Leimkuhler 1996, as DualSPHysics)
//! or Verlet (Verlet 1967) with an Euler step every 40; adaptive dt.

use crate::dt::StepLimits;
use crate::kernel::Kernel;
use crate::kernels::WendlandC2;
use crate::system::{FluidSystem, Initial, WallMode};
use rayon::prelude::*;
use shared::math::{Real, Vector};
use shared::protocol::{BlockLoad, BlockState};
use shared::solver::{FluidSolver, SetupContext, Solver, SolverError, StepReport};

/// Time integration scheme.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Integrator {
    /// Predictor at t + dt/2, corrector to t + dt: two force evaluations, second order.
    Symplectic,
    /// Leapfrog over two steps, one evaluation per step, an Euler step every [`VERLET_EULER_EVERY`].
    Verlet,
}

/// Verlet's two-step recurrence decouples odd and even steps; an Euler step every 40 re-couples
/// them (Monaghan 1989; DualSPHysics' default).
pub const VERLET_EULER_EVERY: u64 = 40;

/// Parameters of the scheme, resolved from `[fluid.wcsph]` and the scene.
#[derive(Debug, Clone, Copy)]
pub struct WcsphParams {
    pub sound_speed: Real,
    pub gamma: Real,
    /// B = ρ0 c0²/γ [Pa].
    pub b: Real,
    pub alpha: Real,
    pub delta: Real,
    pub h: Real,
    pub integrator: Integrator,
}

pub struct Wcsph {
    pub sys: FluidSystem,
    kernel: WendlandC2,
    pub params: WcsphParams,
    limits: StepLimits,
    dt_next: Real,
    /// Step of the Verlet cycle (0 = Euler).
    verlet_step: u64,
}

impl Wcsph {
    pub fn new(ctx: &SetupContext) -> Result<Self, SolverError> {
        let init = Initial::from_scene(ctx.scene)?;
        let spec = &init.fluid.wcsph;
        let dx = init.fluid.dx;
        let rho0 = init.fluid.density;
        let h = spec.smoothing_ratio.unwrap_or(1.3) * dx;
        let c0 = spec
            .sound_speed
            .unwrap_or_else(|| init.default_sound_speed());
        let gamma = spec.gamma.unwrap_or(7.0);
        let integrator = match spec.integrator.as_deref() {
            None | Some("symplectic") => Integrator::Symplectic,
            Some("verlet") => Integrator::Verlet,
            Some(other) => {
                return Err(SolverError::Failed(format!(
                    "fluid.wcsph.integrator = \"{other}\": use symplectic or verlet"
                )));
            }
        };
        let params = WcsphParams {
            sound_speed: c0,
            gamma,
            b: rho0 * c0 * c0 / gamma,
            alpha: spec.alpha.unwrap_or(0.01),
            delta: spec.delta.unwrap_or(0.1),
            h,
            integrator,
        };
        let g = init.gravity.norm();
        // Hydrostatic start: the Tait density of the pressure ρ0·g·depth.
        let density = init
            .fill
            .depth
            .iter()
            .map(|d| rho0 * (1.0 + rho0 * g * d / params.b).powf(1.0 / gamma))
            .collect();
        let kernel = WendlandC2::new(h);
        let walls = WallMode::from_spec(&init.fluid)?;
        let mut sys = FluidSystem::new(ctx, "wcsph", &init, density, kernel.support(), walls, c0)?;
        let p = &mut sys.particles;
        p.pressure
            .par_iter_mut()
            .zip(p.density.par_iter())
            .for_each(|(pr, r)| *pr = tait(&params, rho0, *r));
        let limits = StepLimits {
            h,
            sound_speed: c0,
            viscosity: init.fluid.kinematic_viscosity,
            penalty_stiffness: sys.penalty.stiffness,
            mass: sys.mass,
            cfl: spec.cfl.unwrap_or(0.2),
        };
        let dt_next = limits.propose(0.0, g).0;
        Ok(Self {
            sys,
            kernel,
            params,
            limits,
            dt_next,
            verlet_step: 0,
        })
    }

    /// Pressure of every fluid particle from its density, then the wall pressures (Adami).
    fn pressures(&mut self) {
        let (prm, rho0) = (self.params, self.sys.rest_density);
        let p = &mut self.sys.particles;
        p.pressure
            .par_iter_mut()
            .zip(p.density.par_iter())
            .for_each(|(pr, r)| *pr = tait(&prm, rho0, *r));
        let sys = &mut self.sys;
        if let Some(w) = sys.walls.as_mut() {
            w.update(&self.kernel, &sys.particles, &sys.gravity, rho0, |pw| {
                rho0 * (1.0 + pw / prm.b).powf(1.0 / prm.gamma)
            });
        }
        self.body_pressures();
    }

    /// Adami's extrapolation on the moving blocks' boundary particles. The wall acceleration
    /// term of Adami's Eq. 27 (g − a_w) is left out: the solid node sends poses and velocities,
    /// not accelerations, and for a block near equilibrium a_w ≪ g.
    fn body_pressures(&mut self) {
        let (prm, rho0) = (self.params, self.sys.rest_density);
        let sys = &mut self.sys;
        if let Some(b) = sys.bodies.as_mut() {
            b.set
                .update(&self.kernel, &sys.particles, &sys.gravity, rho0, |pw| {
                    rho0 * (1.0 + pw / prm.b).powf(1.0 / prm.gamma)
                });
        }
    }

    /// Momentum and continuity: acceleration and dρ/dt of every particle at the current state.
    fn rates(&mut self) {
        self.pressures();
        let sys = &mut self.sys;
        let prm = self.params;
        let (m, g, rho0) = (sys.mass, sys.gravity, sys.rest_density);
        let kernel = &self.kernel;
        let s2 = kernel.support().powi(2);
        let eta2 = 0.01 * prm.h * prm.h;
        let delta_coef = prm.delta * prm.h * prm.sound_speed;
        let inv_c2 = 1.0 / (prm.sound_speed * prm.sound_speed);
        let (lists, wall_lists) = (&sys.fluid_lists, &sys.wall_lists);
        let p = &mut sys.particles;
        let (pos, vel, rho, pre, pen) = (
            &p.position,
            &p.velocity,
            &p.density,
            &p.pressure,
            &p.penalty,
        );
        let walls = sys.walls.as_ref();
        let (bodies, body_lists) = (sys.bodies.as_ref(), &sys.body_lists);
        p.acceleration
            .par_iter_mut()
            .zip(p.density_rate.par_iter_mut())
            .enumerate()
            .for_each(|(i, (a, d))| {
                let (xi, vi, ri) = (pos[i], vel[i], rho[i]);
                let pi_term = pre[i] / (ri * ri);
                let mut ai = Vector::zeros();
                let mut di = 0.0;
                for &j in lists.of(i) {
                    let j = j as usize;
                    let rij = xi - pos[j];
                    let r2 = rij.norm_squared();
                    if r2 >= s2 {
                        continue;
                    }
                    let f = kernel.gradient_factor(r2.sqrt());
                    let grad = rij * f;
                    let vij = vi - vel[j];
                    let rj = rho[j];
                    // Symmetric pressure gradient (Monaghan 1992), conserving momentum.
                    let mut coef = pi_term + pre[j] / (rj * rj);
                    // Artificial viscosity (Monaghan 1992), approaching pairs only.
                    let vr = vij.dot(&rij);
                    if vr < 0.0 {
                        let mu = prm.h * vr / (r2 + eta2);
                        coef += -prm.alpha * prm.sound_speed * mu / (0.5 * (ri + rj));
                    }
                    ai -= grad * (m * coef);
                    // Continuity equation.
                    di += m * vij.dot(&grad);
                    // δ-SPH diffusion (Molteni & Colagrossi 2009) minus the hydrostatic part
                    // ρ0((1 + ρ0 g·r_ji/B)^(1/γ) − 1) (Fourtakas et al. 2019).
                    if delta_coef > 0.0 {
                        // Linearised: ρ0·(ρ0 g·r_ji/B)/γ = ρ0 g·r_ji/c0², exact to O((ρ0gΔz/B)²).
                        let hydro = rho0 * g.dot(&(-rij)) * inv_c2;
                        let psi = 2.0 * (rj - ri - hydro) * (-f * r2) / (r2 + eta2);
                        di += delta_coef * psi * m / rj;
                    }
                }
                if let Some(w) = walls {
                    for &j in wall_lists.of(i) {
                        let j = j as usize;
                        let rij = xi - w.position[j];
                        let r2 = rij.norm_squared();
                        if r2 >= s2 {
                            continue;
                        }
                        let grad = rij * kernel.gradient_factor(r2.sqrt());
                        let rw = w.density[j];
                        ai -= grad * (m * (pi_term + w.pressure[j] / (rw * rw)));
                        // The wall is at rest: continuity with v_w = 0 (free slip: no viscosity).
                        di += m * vi.dot(&grad);
                    }
                }
                // Moving blocks' boundary particles: the same pressure term (its reverse is the
                // block's load, see `write_loads`) and continuity with the wall's rigid-body
                // velocity (Adami 2012: free slip, the wall velocity enters through v_i − v_w).
                if let Some(b) = bodies {
                    for &j in body_lists.of(i) {
                        let j = j as usize;
                        let rij = xi - b.set.position[j];
                        let r2 = rij.norm_squared();
                        if r2 >= s2 {
                            continue;
                        }
                        let grad = rij * kernel.gradient_factor(r2.sqrt());
                        let rw = b.set.density[j];
                        ai -= grad * (m * (pi_term + b.set.pressure[j] / (rw * rw)));
                        di += m * (vi - b.velocity[j]).dot(&grad);
                    }
                }
                *a = ai + g + pen[i] / m;
                *d = di;
            });
    }

    fn symplectic(&mut self, dt: Real) {
        // Predictor: half a step from (r, v, ρ)^n with the rates at n.
        self.rates();
        let p = &mut self.sys.particles;
        let half = 0.5 * dt;
        p.position0.copy_from_slice(&p.position);
        p.velocity0.copy_from_slice(&p.velocity);
        p.density0.copy_from_slice(&p.density);
        p.position
            .par_iter_mut()
            .zip(p.velocity.par_iter_mut())
            .zip(p.acceleration.par_iter())
            .for_each(|((x, v), a)| {
                *x += *v * half;
                *v += a * half;
            });
        p.density
            .par_iter_mut()
            .zip(p.density_rate.par_iter())
            .for_each(|(r, d)| *r += d * half);
        // Corrector from the rates at n + 1/2 (neighbour cells of t^n; particles moved < 0.1h).
        self.rates();
        let p = &mut self.sys.particles;
        p.velocity
            .par_iter_mut()
            .zip(p.position.par_iter_mut())
            .zip(p.velocity0.par_iter().zip(p.position0.par_iter()))
            .zip(p.acceleration.par_iter())
            .for_each(|(((v, x), (v0, x0)), a)| {
                *v = v0 + a * dt;
                *x = x0 + (*v + v0) * half;
            });
        p.density
            .par_iter_mut()
            .zip(p.density0.par_iter())
            .zip(p.density_rate.par_iter())
            .for_each(|((r, r0), d)| {
                let eps = -d / *r * dt;
                *r = r0 * (2.0 - eps) / (2.0 + eps);
            });
    }

    fn verlet(&mut self, dt: Real) {
        self.rates();
        let euler = self.verlet_step.is_multiple_of(VERLET_EULER_EVERY);
        self.verlet_step += 1;
        let p = &mut self.sys.particles;
        // velocity0/density0 hold the values one step back.
        p.position
            .par_iter_mut()
            .zip(p.velocity.par_iter_mut())
            .zip(p.velocity0.par_iter_mut())
            .zip(p.acceleration.par_iter())
            .for_each(|(((x, v), vprev), a)| {
                let vn = *v;
                *x += vn * dt + a * (0.5 * dt * dt);
                *v = if euler {
                    vn + a * dt
                } else {
                    *vprev + a * (2.0 * dt)
                };
                *vprev = vn;
            });
        p.density
            .par_iter_mut()
            .zip(p.density0.par_iter_mut())
            .zip(p.density_rate.par_iter())
            .for_each(|((r, rprev), d)| {
                let rn = *r;
                *r = if euler {
                    rn + d * dt
                } else {
                    *rprev + d * (2.0 * dt)
                };
                *rprev = rn;
            });
    }
}

/// Tait's equation of state.
#[inline]
pub fn tait(p: &WcsphParams, rho0: Real, rho: Real) -> Real {
    p.b * ((rho / rho0).powf(p.gamma) - 1.0)
}

impl Solver for Wcsph {
    fn name(&self) -> &str {
        "wcsph"
    }

    fn dt_proposal(&self) -> Real {
        self.dt_next
    }

    fn advance(&mut self, dt: Real) -> Result<StepReport, SolverError> {
        self.sys.begin_step();
        match self.params.integrator {
            Integrator::Symplectic => self.symplectic(dt),
            Integrator::Verlet => self.verlet(dt),
        }
        let (prm, rho0) = (self.params, self.sys.rest_density);
        let p = &mut self.sys.particles;
        p.pressure
            .par_iter_mut()
            .zip(p.density.par_iter())
            .for_each(|(pr, r)| *pr = tait(&prm, rho0, *r));
        let (v, a) = self.sys.extremes();
        self.sys.end_step(dt, &self.kernel, true, rho0)?;
        self.dt_next = self.limits.propose(v, a).0;
        Ok(StepReport::default())
    }

    fn write_frame(&mut self, frame: u32, _time: Real) -> Result<(), SolverError> {
        self.sys.write_frame(frame)
    }

    fn finish(&mut self) -> Result<(), SolverError> {
        self.sys.finish()
    }
}

impl FluidSolver for Wcsph {
    fn read_geometry(&mut self, blocks: &[BlockState], _vertices: &[[f64; 3]]) {
        self.sys.read_geometry(blocks);
    }

    fn write_loads(&mut self, loads: &mut [BlockLoad]) {
        // The water's pressure on the moving blocks' boundary particles at the current state
        // (the pressures are those of the last step's end, the wall pressures are extrapolated
        // at the new pose): exactly the reverse of what the coming predictor applies to the fluid.
        self.sys.prepare_bodies();
        self.body_pressures();
        let sys = &mut self.sys;
        if let Some(b) = sys.bodies.as_mut() {
            let (m, kernel, p) = (sys.mass, &self.kernel, &sys.particles);
            b.react(&p.position, kernel.support(), |i, pw, rw, r, len| {
                let ri = p.density[i];
                r * (kernel.gradient_factor(len)
                    * (-m * m * (p.pressure[i] / (ri * ri) + pw / (rw * rw))))
            });
        }
        self.sys.write_loads(loads);
    }
}
