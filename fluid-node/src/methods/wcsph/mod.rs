//! Weakly compressible SPH in the DualSPHysics standard (Crespo et al. 2015; Domínguez et al.
//! 2022): Tait's equation of state p = B((ρ/ρ0)^γ − 1), B = ρ0c0²/γ (Monaghan 1994); the
//! Wendland C2 kernel (Wendland 1995); density from the continuity equation with δ-SPH diffusion
//! (Molteni & Colagrossi 2009) in Fourtakas et al. (2019)'s form, which subtracts the hydrostatic
//! density difference so the diffusion does not flatten a column at rest; Monaghan (1992)'s
//! artificial viscosity; the symplectic position-Verlet scheme (Leimkuhler 1996, as DualSPHysics),
//! by default with one force evaluation per step (its corrector alone, [`Integrator::Leapfrog`]),
//! or Verlet (Verlet 1967) with an Euler step every 40; adaptive dt.

pub mod pairs;
pub mod riemann;
pub mod sound_speed;
pub mod wall_term;

use crate::core::dt::StepLimits;
use crate::core::lanes::Packed;
use crate::core::phases::Phase;
use crate::core::tasks;
use crate::kernels::Kernel;
use crate::kernels::WendlandC2;
use crate::methods::SphMethod;
use crate::system::{FluidSystem, Initial, Layout};
use crate::validation::Check;
use pairs::{PairConstants, boundary_record, boundary_sums, fluid_record, fluid_sums};
use rayon::prelude::*;
use serde::Deserialize;
use shared::math::{Real, Vector};
use shared::registry::{ParamCheck, SolverParams, Variant, study};
use shared::scene::{FieldError, Scene};
use shared::solver::{SolverError, StepReport};
use wall_term::WallTerm;

/// `[fluid.wcsph]`: parameters of the weakly compressible solver. Unset values are derived.
#[derive(Debug, Clone, Default, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct WcsphParams {
    /// Numerical speed of sound c0 [m/s]; default 10·sqrt(2 g H) for the deepest water H; below
    /// 2·sqrt(2 g H) refused ([`sound_speed`]).
    pub sound_speed: Option<f64>,
    /// Tait exponent γ; default 7.
    pub gamma: Option<f64>,
    /// Artificial viscosity α (Monaghan 1992); default 0.01.
    pub alpha: Option<f64>,
    /// δ-SPH density diffusion coefficient (Molteni & Colagrossi 2009); default 0.1, 0 disables.
    pub delta: Option<f64>,
    /// Smoothing length h over dx (Wendland C2 support is 2h); default 1.3.
    pub smoothing_ratio: Option<f64>,
    /// `leapfrog` (default: one force evaluation per step), `symplectic` (predictor and
    /// corrector: two) or `verlet` (one).
    #[serde(default)]
    pub integrator: Integrator,
    /// CFL number; default 0.2.
    pub cfl: Option<f64>,
    /// Verlet skin of the neighbour lists, as a fraction of the kernel support; default 0.1
    /// ([`WCSPH_SKIN`]); 0 rebuilds the lists at every step.
    pub skin: Option<f64>,
    /// `riemann` only: η of the dissipation limiter of the fluid–wall pairs, along each fluid
    /// particle's wall normal (Zhang, Hu & Adams 2017, §3.3; [`riemann::WALL_ETA`]); default
    /// [`riemann::WALL_ETA`], 0 disables the wall's dissipation.
    pub wall_limiter: Option<f64>,
}

/// How a pair exchanges momentum and mass: the method `wcsph` (artificial viscosity and
/// δ-SPH) or `riemann` ([`crate::methods::riemann`]: a low-dissipation Riemann solver).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Deserialize, serde::Serialize)]
pub enum Flux {
    /// Monaghan (1992)'s artificial viscosity with δ-SPH density diffusion.
    #[default]
    Artificial,
    /// The low-dissipation Riemann solver of Zhang, Hu & Adams (2017) ([`riemann`]).
    Riemann,
}

impl SolverParams for WcsphParams {
    fn check(&self, c: &mut ParamCheck) {
        self.check_shared(c);
        if let Some(v) = self.wall_limiter {
            c.fail(
                "wall_limiter",
                v,
                "is a parameter of riemann only (the wall dissipation of its Riemann solver)",
                "remove it, or use solver = \"riemann\"",
            );
        }
    }
}

impl WcsphParams {
    /// The checks of the parameters `wcsph` and `riemann` share.
    pub fn check_shared(&self, c: &mut ParamCheck) {
        c.positive(
            "sound_speed",
            self.sound_speed,
            "give c0 in m/s (≥ 10 × the largest flow speed), or leave it out",
        );
        if let Some(g) = self.gamma
            && !(g.is_finite() && g >= 1.0)
        {
            c.fail(
                "gamma",
                g,
                "must be a finite number >= 1",
                "water is gamma = 7",
            );
        }
        c.non_negative("alpha", self.alpha, "e.g. alpha = 0.01");
        c.non_negative("delta", self.delta, "e.g. delta = 0.1; 0 disables δ-SPH");
        if let Some(r) = self.smoothing_ratio
            && !(r.is_finite() && r >= 0.5)
        {
            c.fail(
                "smoothing_ratio",
                r,
                "must be a finite number >= 0.5 (the support 2h must reach the nearest neighbours)",
                "e.g. smoothing_ratio = 1.3",
            );
        }
        c.positive("cfl", self.cfl, "e.g. cfl = 0.2");
        if let Some(k) = self.skin
            && !(k.is_finite() && (0.0..=1.0).contains(&k))
        {
            c.fail(
                "skin",
                k,
                "must be a fraction of the kernel support in [0, 1]",
                "e.g. skin = 0.1, or 0 to rebuild the neighbour lists every step",
            );
        }
    }
}

/// Time integration scheme.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Deserialize, serde::Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Integrator {
    /// Predictor at t + dt/2, corrector to t + dt: two force evaluations, second order.
    Symplectic,
    /// The symplectic scheme's corrector alone (drift–kick–drift leapfrog, Leimkuhler 1996):
    /// positions drift half a step on v^n alone, so the one force evaluation per step is at
    /// t + dt/2; the half-step velocity and density it reads are predicted with the previous
    /// step's rates, which differ from the predictor's by O(dt): second order still, at half
    /// the pair work.
    #[default]
    Leapfrog,
    /// Leapfrog over two steps, one evaluation per step, an Euler step every [`VERLET_EULER_EVERY`].
    Verlet,
}

impl Integrator {
    /// As written in the scene (`integrator = "leapfrog"`).
    pub fn name(self) -> &'static str {
        match self {
            Integrator::Symplectic => "symplectic",
            Integrator::Leapfrog => "leapfrog",
            Integrator::Verlet => "verlet",
        }
    }
}

/// The default Courant number of the CFL and force limits (`[fluid.wcsph] cfl`).
pub const DEFAULT_CFL: Real = 0.2;

/// The smallest Courant number at which each integrator went unstable (the density bound) on
/// the Lobovský dam break (`scenes/validation/lobovsky_impact.toml` at dx = 30 mm, `dt_max`
/// out of the way), WCSPH's artificial flux: leapfrog ran at 0.4 and blew up from 0.45
/// (at dx = 20 mm it ran at 0.45), verlet ran at 0.2 and blew up from 0.25, symplectic ran at
/// 0.6 and blew up at 0.8; the Riemann flux with leapfrog ran at 0.3 and blew up at 0.45
/// (docs/journal/2026-11-30-inputs.md, "Courant numbers"). For the message of an
/// instability in a run with a raised `cfl` ([`SphMethod::unstable_hint`]).
pub const CFL_MEASURED_UNSTABLE: [(Integrator, Real); 3] = [
    (Integrator::Verlet, 0.25),
    (Integrator::Leapfrog, 0.45),
    (Integrator::Symplectic, 0.8),
];

/// Verlet's two-step recurrence decouples odd and even steps; an Euler step every 40 re-couples
/// them (Monaghan 1989; DualSPHysics' default).
pub const VERLET_EULER_EVERY: u64 = 40;

/// Default Verlet skin of WCSPH's neighbour lists over the support: lists reach 1.1 supports
/// and are kept until a particle may have moved half the skin (0.13 h: a few steps at the
/// acoustic step in a developed dam-break flow), chosen against 0, 0.05 and 0.2 on the 3D dam
/// break (docs/journal/2026-11-performance.md).
pub const WCSPH_SKIN: Real = 0.1;

/// The scheme's constants, resolved from `[fluid.wcsph]` and the scene.
#[derive(Debug, Clone, Copy, serde::Serialize, serde::Deserialize)]
pub struct WcsphConstants {
    pub sound_speed: Real,
    pub gamma: Real,
    /// B = ρ0 c0²/γ [Pa].
    pub b: Real,
    pub alpha: Real,
    pub delta: Real,
    pub h: Real,
    pub integrator: Integrator,
    pub flux: Flux,
    /// η of the Riemann flux's wall dissipation (0: none; always 0 for the artificial flux).
    pub wall_limiter: Real,
}

#[derive(serde::Serialize, serde::Deserialize)]
pub struct Wcsph {
    kernel: WendlandC2,
    pub constants: WcsphConstants,
    rest_density: Real,
    limits: StepLimits,
    /// Step of the Verlet cycle (0 = Euler).
    verlet_step: u64,
    /// What the pair loop reads of a neighbour, packed into one cache line per particle
    /// (scratch, recomputed before every evaluation): p/ρ² and 1/ρ are computed once per
    /// particle, so the loop divides once per pair rather than five times, and a neighbour
    /// costs one line fetch rather than five. Not checkpointed: scratch.
    #[serde(skip)]
    near: Vec<Packed>,
    /// Each fluid particle's unit normal to the moving blocks in [`SphMethod::react`] (the
    /// Riemann flux's wall dissipation): scratch, kept so that the step does not allocate.
    #[serde(skip)]
    wall_normals: Vec<Vector>,
}

impl Wcsph {
    /// WCSPH with the pair exchange `flux`: the method `wcsph` ([`Flux::Artificial`]) or
    /// `riemann` ([`Flux::Riemann`], [`crate::methods::riemann`]).
    pub fn with_flux(
        spec: WcsphParams,
        flux: Flux,
        init: &Initial,
    ) -> Result<(Self, Layout), SolverError> {
        let dx = init.fluid.dx;
        let rho0 = init.fluid.density;
        let h = spec.smoothing_ratio.unwrap_or(1.3) * dx;
        let c0 = spec
            .sound_speed
            .unwrap_or_else(|| init.default_sound_speed());
        let gamma = spec.gamma.unwrap_or(7.0);
        let constants = WcsphConstants {
            sound_speed: c0,
            gamma,
            b: rho0 * c0 * c0 / gamma,
            alpha: spec.alpha.unwrap_or(0.01),
            delta: spec.delta.unwrap_or(0.1),
            h,
            integrator: spec.integrator,
            flux,
            wall_limiter: match flux {
                Flux::Artificial => 0.0,
                Flux::Riemann => spec.wall_limiter.unwrap_or(riemann::WALL_ETA),
            },
        };
        let g = init.gravity.norm();
        // Hydrostatic start: the Tait density of the pressure ρ0·g·depth.
        let density = init
            .fill
            .depth
            .iter()
            .map(|d| rho0 * (1.0 + rho0 * g * d / constants.b).powf(1.0 / gamma))
            .collect();
        let kernel = WendlandC2::new(h);
        let limits = StepLimits {
            h,
            sound_speed: c0,
            // The fluid's viscosity plus, for the artificial flux, the artificial viscosity's
            // equivalent ν = α h c0/(2(d + 2)) = α h c0/10 in 3D (Monaghan 2005, §5.1; the
            // pairs' Π_ij = −α c̄ μ_ij/ρ̄): binds past α ≈ 6 at the default Courant number.
            viscosity: init.fluid.kinematic_viscosity
                + match flux {
                    Flux::Artificial => constants.alpha * h * c0 / 10.0,
                    Flux::Riemann => 0.0,
                },
            // δ-SPH's density diffusion (the artificial flux only: the Riemann flux has none).
            diffusivity: match flux {
                Flux::Artificial => constants.delta * h * c0,
                Flux::Riemann => 0.0,
            },
            // Set in `start`, once the system has chosen the Eq. 22 spring.
            penalty_stiffness: 0.0,
            mass: rho0 * dx.powi(3),
            cfl: spec.cfl.unwrap_or(DEFAULT_CFL),
        };
        let layout = Layout {
            density,
            support: kernel.support(),
            sound_speed: c0,
            skin_ratio: spec.skin.unwrap_or(WCSPH_SKIN),
            poly6_sums: false,
            carried: crate::core::particles::Carried::ALL,
        };
        let scheme = Self {
            kernel,
            constants,
            rest_density: rho0,
            limits,
            verlet_step: 0,
            near: Vec::new(),
            wall_normals: Vec::new(),
        };
        Ok((scheme, layout))
    }

    /// The Tait density of a boundary particle's pressure: ρ0(1 + p/B)^(1/γ).
    fn density_of(&self, pw: Real) -> Real {
        let prm = &self.constants;
        self.rest_density * (1.0 + pw / prm.b).powf(1.0 / prm.gamma)
    }

    /// Pressure of every fluid particle from its density (and the pair loop's f32 copy of its
    /// state, with p/ρ²), then the boundary pressures (Adami).
    fn pressures(&mut self, sys: &mut FluidSystem) {
        let t = sys.phases.start();
        let (prm, rho0) = (self.constants, self.rest_density);
        let origin = sys.grid.centre();
        let p = &mut sys.particles;
        let n = p.len();
        self.near.resize(n, Packed::default());
        let (pos, vel) = (&p.position, &p.velocity);
        p.pressure
            .par_iter_mut()
            .zip(self.near.par_iter_mut())
            .zip(p.density.par_iter())
            .enumerate()
            .for_each(|(i, ((pr, near), &r))| {
                *pr = tait(&prm, rho0, r);
                *near = match prm.flux {
                    Flux::Artificial => fluid_record(&pos[i], &origin, &vel[i], r, rho0, *pr),
                    Flux::Riemann => riemann::record(&pos[i], &origin, &vel[i], r, rho0, *pr),
                };
            });
        let t = sys.phases.lap(Phase::Density, t);
        let this = &*self;
        sys.boundary
            .update(&this.kernel, &sys.particles, &sys.gravity, rho0, |pw| {
                this.density_of(pw)
            });
        match prm.flux {
            Flux::Artificial => sys
                .boundary
                .pack(|x, v, pw, rw| boundary_record(x, &origin, v, pw, rw)),
            Flux::Riemann => sys
                .boundary
                .pack(|x, v, pw, rw| riemann::record(x, &origin, v, rw, rho0, pw)),
        }
        sys.phases.stop(Phase::WallPressures, t);
    }

    /// Momentum and continuity: acceleration and dρ/dt of every particle at the current state.
    fn rates(&mut self, sys: &mut FluidSystem) {
        self.pressures(sys);
        let t = sys.phases.start();
        let prm = self.constants;
        let (g, rho0) = (sys.gravity, sys.rest_density);
        let kernel = &self.kernel;
        let near = &self.near;
        match prm.flux {
            Flux::Artificial => {
                let delta_coef = prm.delta * prm.h * prm.sound_speed;
                let inv_c2 = 1.0 / (prm.sound_speed * prm.sound_speed);
                let pc = PairConstants::new(
                    kernel,
                    sys.grid.centre(),
                    rho0,
                    0.01 * prm.h * prm.h,
                    -2.0 * prm.alpha * prm.sound_speed * prm.h,
                    g * (rho0 * inv_c2),
                );
                // Fluid neighbours (pairs.rs): symmetric pressure gradient and artificial
                // viscosity (Monaghan 1992), continuity, δ-SPH diffusion (Molteni & Colagrossi
                // 2009) minus its hydrostatic part (Fourtakas et al. 2019), linearised:
                // ρ0((1 + ρ0 g·r_ji/B)^(1/γ) − 1) ≈ ρ0 g·r_ji/c0², exact to O((ρ0gΔz/B)²).
                // Boundary particles, fixed and moving: the same pressure term (a moving block
                // takes its reverse, see `react`) and continuity with the wall's velocity, zero
                // on a fixed block (Adami 2012: free slip, the wall velocity enters through
                // v_i − v_w only).
                pair_rates(
                    sys,
                    near,
                    |me, list| {
                        let (a, d, diffusion) = fluid_sums(me, list, near, &pc);
                        (a, d + 2.0 * delta_coef * diffusion)
                    },
                    |me, list, walls| boundary_sums(me, list, walls, &pc),
                );
            }
            Flux::Riemann => {
                let rc = riemann::RiemannConstants::new(
                    kernel,
                    rho0,
                    prm.sound_speed,
                    prm.wall_limiter,
                    g,
                );
                pair_rates(
                    sys,
                    near,
                    |me, list| riemann::fluid_sums(me, list, near, &rc),
                    |me, list, walls| riemann::boundary_sums(me, list, walls, &rc),
                );
            }
        }
        sys.phases.stop(Phase::Forces, t);
        sys.share_rates();
    }

    /// Predictor: keeps (r, v, ρ)^n and moves half a step with the rates in `acceleration`
    /// and `density_rate`. One parallel pass, the copies included (serial copies before it kept
    /// the second thread idle long enough to fall asleep: docs/journal/2026-11-performance.md,
    /// "Inner loops, fifth round").
    fn predict_half_step(sys: &mut FluidSystem, dt: Real) {
        let p = &mut sys.particles;
        let half = 0.5 * dt;
        let start = p
            .position0
            .par_iter_mut()
            .zip(p.velocity0.par_iter_mut())
            .zip(p.density0.par_iter_mut());
        let rates = p.acceleration.par_iter().zip(p.density_rate.par_iter());
        p.position
            .par_iter_mut()
            .zip(p.velocity.par_iter_mut())
            .zip(p.density.par_iter_mut())
            .zip(start)
            .zip(rates)
            .for_each(|((((x, v), r), ((x0, v0), r0)), (a, d))| {
                (*x0, *v0, *r0) = (*x, *v, *r);
                *x += *v * half;
                *v += a * half;
                *r += d * half;
            });
    }

    /// Corrector: from (r, v, ρ)^n to n + 1 with the rates at n + 1/2 (evaluated on the
    /// neighbour lists of the last sort; the lists' skin covers the move). One parallel pass.
    fn correct(sys: &mut FluidSystem, dt: Real) {
        let p = &mut sys.particles;
        let half = 0.5 * dt;
        let start = p
            .velocity0
            .par_iter()
            .zip(p.position0.par_iter())
            .zip(p.density0.par_iter());
        let rates = p.acceleration.par_iter().zip(p.density_rate.par_iter());
        p.velocity
            .par_iter_mut()
            .zip(p.position.par_iter_mut())
            .zip(p.density.par_iter_mut())
            .zip(start)
            .zip(rates)
            .for_each(|((((v, x), r), ((v0, x0), r0)), (a, d))| {
                *v = v0 + a * dt;
                *x = x0 + (*v + v0) * half;
                let eps = -d / *r * dt;
                *r = r0 * (2.0 - eps) / (2.0 + eps);
            });
    }

    /// Symplectic position Verlet: the predictor with the rates at n, the corrector with those
    /// at n + 1/2.
    fn symplectic(&mut self, sys: &mut FluidSystem, dt: Real) {
        self.rates(sys);
        let t = sys.phases.start();
        Self::predict_half_step(sys, dt);
        sys.phases.stop(Phase::Predictor, t);
        self.rates(sys);
        let t = sys.phases.start();
        Self::correct(sys, dt);
        sys.phases.stop(Phase::Integration, t);
    }

    /// Drift–kick–drift with one evaluation (see [`Integrator::Leapfrog`]): the predictor with
    /// the last step's rates (positions drift on v^n alone, exact; velocity and density enter
    /// only viscosity, continuity and the EOS), the corrector unchanged. The first step
    /// evaluates the rates once.
    fn leapfrog(&mut self, sys: &mut FluidSystem, dt: Real) {
        if sys.steps == 0 {
            self.rates(sys);
        }
        let t = sys.phases.start();
        Self::predict_half_step(sys, dt);
        sys.phases.stop(Phase::Predictor, t);
        self.rates(sys);
        let t = sys.phases.start();
        Self::correct(sys, dt);
        sys.phases.stop(Phase::Integration, t);
    }

    fn verlet(&mut self, sys: &mut FluidSystem, dt: Real) {
        self.rates(sys);
        let t = sys.phases.start();
        let euler = self.verlet_step.is_multiple_of(VERLET_EULER_EVERY);
        self.verlet_step += 1;
        let p = &mut sys.particles;
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
        sys.phases.stop(Phase::Integration, t);
    }
}

/// Every (owned) particle's acceleration and dρ/dt from its pair sums over fluid neighbours
/// (`fluid`) and over each set of boundary neighbours (`wall`), both without the factor m.
fn pair_rates(
    sys: &mut FluidSystem,
    near: &[Packed],
    fluid: impl Fn(&Packed, &[u32]) -> (Vector, Real) + Sync,
    wall: impl Fn(&Packed, &[u32], &[Packed]) -> (Vector, Real) + Sync,
) {
    let (m, g) = (sys.mass, sys.gravity);
    let (lists, boundary) = (&sys.fluid_lists, &sys.boundary);
    // On several ranks, a rank's own particles only: the halo's rates come from their owners
    // (`share_rates`).
    let owned = sys.share.as_ref().map(|s| &s.owned[..]);
    let p = &mut sys.particles;
    let pen = &p.penalty;
    p.acceleration
        .par_iter_mut()
        .zip(p.density_rate.par_iter_mut())
        .enumerate()
        .with_max_len(tasks::PARTICLES)
        .for_each(|(i, (a, d))| {
            if owned.is_some_and(|o| !o[i]) {
                return;
            }
            let me = &near[i];
            let (mut ai, mut di) = fluid(me, lists.of(i));
            boundary.for_each_list(i, |list, walls| {
                let (ab, db) = wall(me, list, walls);
                ai += ab;
                di += db;
            });
            *a = ai * m + g + pen[i] / m;
            *d = di * m;
        });
}

/// Tait's equation of state.
#[inline]
pub fn tait(p: &WcsphConstants, rho0: Real, rho: Real) -> Real {
    let x = rho / rho0;
    // Water's γ = 7 by multiplications: `powf` was a visible share of the step.
    let xg = if p.gamma == 7.0 {
        let x2 = x * x;
        x2 * x2 * x2 * x
    } else {
        x.powf(p.gamma)
    };
    p.b * (xg - 1.0)
}

impl SphMethod for Wcsph {
    const NAME: &'static str = "wcsph";
    const DESCRIPTION: &'static str = "weakly compressible SPH (DualSPHysics standard): Tait EOS, Wendland C2, δ-SPH, artificial viscosity";
    const PARTICLE_STEPS_PER_SECOND: Option<f64> = Some(4.61e6);
    const SPLITS: bool = true;
    type Params = WcsphParams;
    type Kernel = WendlandC2;

    fn new(spec: WcsphParams, init: &Initial) -> Result<(Self, Layout), SolverError> {
        Self::with_flux(spec, Flux::Artificial, init)
    }

    fn start(&mut self, sys: &mut FluidSystem) {
        let (prm, rho0) = (self.constants, self.rest_density);
        let p = &mut sys.particles;
        p.pressure
            .par_iter_mut()
            .zip(p.density.par_iter())
            .for_each(|(pr, r)| *pr = tait(&prm, rho0, *r));
        self.limits.penalty_stiffness = sys.penalty.stiffness;
        self.limits.mass = sys.mass;
    }

    fn step(&mut self, sys: &mut FluidSystem, dt: Real) -> Result<StepReport, SolverError> {
        match self.constants.integrator {
            Integrator::Symplectic => self.symplectic(sys, dt),
            Integrator::Leapfrog => self.leapfrog(sys, dt),
            Integrator::Verlet => self.verlet(sys, dt),
        }
        // The pressures of the new densities, for the frames and probes: integration's tail.
        let t = sys.phases.start();
        let (prm, rho0) = (self.constants, self.rest_density);
        let p = &mut sys.particles;
        p.pressure
            .par_iter_mut()
            .zip(p.density.par_iter())
            .for_each(|(pr, r)| *pr = tait(&prm, rho0, *r));
        sys.phases.stop(Phase::Integration, t);
        Ok(StepReport::default())
    }

    fn react(&mut self, sys: &mut FluidSystem) {
        // Exactly the reverse of what the coming predictor applies to the fluid.
        sys.boundary.update_moving(
            &self.kernel,
            &sys.particles,
            &sys.gravity,
            self.rest_density,
            |pw| self.density_of(pw),
        );
        let mut normals = std::mem::take(&mut self.wall_normals);
        let term = WallTerm::new(self, sys.mass, sys.gravity);
        let p = &sys.particles;
        let split = sys.share.as_ref().map(|s| (s, &sys.grid));
        // The wall's dissipation along each fluid particle's normal to the moving blocks
        // (riemann::boundary_sums, which takes it over the particle's moving neighbours
        // alone, as here).
        if term.needs_normal() {
            let boundary = &sys.boundary;
            normals.resize(p.len(), Vector::zeros());
            normals.par_iter_mut().enumerate().for_each(|(i, normal)| {
                let mut s = Vector::zeros();
                boundary.for_each_moving_neighbor(i, |b| {
                    s += term.normal_part(&(p.position[i] - b.position()));
                });
                *normal = wall_term::unit(s);
            });
        }
        let none = Vector::zeros();
        sys.boundary.react_moving(
            &p.position,
            self.kernel.support(),
            |i, vw, pw, rw, r, len| {
                let n = normals.get(i).unwrap_or(&none);
                term.force(p, i, vw, pw, rw, r, len, n)
            },
            split,
        );
        self.wall_normals = normals;
    }

    fn fixed_wall_forces(&self, sys: &FluidSystem, i: usize, visit: &mut dyn FnMut(usize, Vector)) {
        let term = WallTerm::new(self, sys.mass, sys.gravity);
        let (p, support) = (&sys.particles, self.kernel.support());
        let x = p.position[i];
        let mut s = Vector::zeros();
        if term.needs_normal() {
            sys.boundary
                .for_each_fixed_neighbor(i, |b| s += term.normal_part(&(x - b.position())));
        }
        let n = wall_term::unit(s);
        sys.boundary
            .for_each_fixed_within(i, &x, support, |b, r, len| {
                let f = term.force(p, i, &b.velocity(), b.pressure(), b.density(), r, len, &n);
                visit(b.index(), f);
            });
    }

    fn kernel(&self) -> &WendlandC2 {
        &self.kernel
    }

    fn density_check(&self) -> (bool, Real) {
        (true, self.rest_density)
    }

    fn dt_proposal(&self, v_max: Real, a_max: Real) -> Real {
        self.limits.propose(v_max, a_max).0
    }

    /// A Courant number above the default ([`DEFAULT_CFL`]) is named: the system's message
    /// says what blew up (a density past its bound), not that the step outran the scheme, and
    /// where that happens depends on the integrator ([`CFL_MEASURED_UNSTABLE`]).
    fn unstable_hint(&self) -> Option<String> {
        let cfl = self.limits.cfl;
        (cfl > DEFAULT_CFL).then(|| {
            let name = match self.constants.flux {
                Flux::Artificial => "wcsph",
                Flux::Riemann => "riemann",
            };
            let measured = CFL_MEASURED_UNSTABLE
                .iter()
                .map(|(i, c)| format!("{c} with {}", i.name()))
                .collect::<Vec<_>>()
                .join(", ");
            format!(
                "this run's Courant number is cfl = {} (the default is {DEFAULT_CFL}), and a step past its integrator's stable range blows up this way (on the Lobovský dam break at dx = 30 mm WCSPH went unstable from cfl = {measured}, the Riemann flux alike where measured; this run's integrator is {}); fix: lower [fluid.{name}] cfl, e.g. to the default",
                shared::math::readable(cfl),
                self.constants.integrator.name()
            )
        })
    }

    /// A speed of sound too low for the water's depth ([`sound_speed`]).
    fn check_against(params: &WcsphParams, scene: &Scene) -> Vec<FieldError> {
        sound_speed::check(Self::NAME, params.sound_speed, params.gamma, scene)
            .into_iter()
            .collect()
    }

    /// In the stability maps WCSPH runs with its defaults: in the dt map with the solid
    /// registry's first solver, under both schemes and sub-cycled (its own step binds, so
    /// sub-cycling changes nothing: the row says so); in the density map with every solid
    /// solver under both schemes.
    fn study_variants(study: &str) -> &'static [Variant] {
        use shared::registry::StudyCoupling as C;
        use shared::scene::CouplingScheme::{Parallel, Serial};
        const DT: &[Variant] = &[Variant {
            couplings: &[C::plain(Parallel), C::plain(Serial), C::subcycled(Parallel)],
            ..Variant::DEFAULTS
        }];
        const DENSITY: &[Variant] = &[Variant {
            every_partner: true,
            couplings: &[C::plain(Parallel), C::plain(Serial)],
            ..Variant::DEFAULTS
        }];
        match study {
            study::STABILITY_DT => DT,
            study::STABILITY_DENSITY => DENSITY,
            _ => &[],
        }
    }

    /// The weakly compressible impact peak is a crest of the wall's ringing, which does not
    /// converge with resolution and whose height depends on c0 though its period does not
    /// (the lattice's rows striking the wall in step; docs/VALIDATION.md "Impact pressure"): above the experiment's band at every resolution of the study in
    /// the tank's width (only a slab 4 layers wide smears it into the band at H/dx = 15).
    /// The wall's load behind the sensor is above the band too (253.5 → 177.3 → 208.7
    /// mbar), while its impulse at H = 600 mm is within ±10 % of the median from H/dx = 30 on
    /// (−3.4, −2.0 %) and 29 % short at 15, where the wall's lowest cell is 40 mm ("What a
    /// sensor reads").
    fn known_limitation(check: &str, per_h: usize) -> Option<&'static str> {
        let peak = check == Check::ImpactPeak { per_h }.name()
            || check == Check::WallPeak { per_h }.name();
        let growth =
            check == Check::ImpactPeakGrowth.name() || check == Check::WallPeakGrowth.name();
        if peak || growth {
            return Some(
                "WCSPH impact peak is a crest of the wall's ringing, which does not converge with resolution; the impulse is the check",
            );
        }
        (per_h == 15 && check == Check::WallImpulse { per_h }.name()).then_some(
            "the wall's lowest cell at H = 600 mm, H/dx = 15 is 40 mm tall, over which even the finest run's impulse averages 10–13 % below the sensor's point: its load reads 29 % short of the median impulse",
        )
    }
}
