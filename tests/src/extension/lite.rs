//! `--solver lite`: weakly compressible SPH in its plainest form, as an example of a method
//! added through the public API (one file; one registry line in `extended-fluid-node`).
//!
//! ```text
//! ρ_i = Σ_j m W_ij  (fluid and boundary particles)              (Monaghan 1992, Eq. 2.9)
//! p_i = c² (ρ_i − ρ_lattice), clamped at 0 (a free surface sums low)
//! a_i = −Σ_j m (p_i/ρ_i² + p_j/ρ_j² + Π_ij) ∇W_ij + g + f_Eq.22 / m   (Monaghan 1992, Eq. 3.2)
//! v += Δt a;  x += Δt v                                          (symplectic Euler)
//! ```
//!
//! Π_ij is Monaghan's artificial viscosity, −α c h (v_ij·r_ij) / (ρ̄ (r² + 0.01 h²)) for
//! approaching pairs. Boundary particles carry Adami's extrapolated pressure
//! (`Boundary::update`); a moving block takes the reverse of their pressure force
//! (`Boundary::react`), and paper Eq. 22 is the system's backstop, as for every method.

use fluid_node::core::particles::{Carried, Particles};
use fluid_node::kernels::{Kernel, WendlandC2, lattice_density};
use fluid_node::methods::SphMethod;
use fluid_node::system::{FluidSystem, Initial, Layout};
use serde::{Deserialize, Serialize};
use shared::math::{Real, Vector};
use shared::registry::{ParamCheck, SolverParams};
use shared::solver::{SolverError, StepReport};

/// `[fluid.lite]`: every field optional.
#[derive(Debug, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LiteParams {
    /// Monaghan's α (default 0.1).
    pub alpha: Option<f64>,
    /// Courant number of the acoustic step (default 0.2).
    pub cfl: Option<f64>,
}

impl SolverParams for LiteParams {
    fn check(&self, c: &mut ParamCheck) {
        c.non_negative("alpha", self.alpha, "0.1 is usual; 0 for none");
        c.positive("cfl", self.cfl, "0.2 is safe");
    }
}

/// The method's state: its constants (nothing carries over from step to step but the
/// particles, which the system keeps).
#[derive(Serialize, Deserialize)]
pub struct Lite {
    kernel: WendlandC2,
    /// c² [m²/s²] of the linear equation of state.
    c2: Real,
    /// The summed density of a full lattice: zero pressure.
    lattice: Real,
    alpha: Real,
    cfl: Real,
}

impl Lite {
    fn density_of(&self, p: Real) -> Real {
        self.lattice + p / self.c2
    }

    /// The pressure force of a boundary particle (p_w, ρ_w) at r = x_i − x_w on fluid
    /// particle i: what a moving block takes reversed, and a wall-reading probe reads.
    #[allow(clippy::too_many_arguments)]
    fn wall_force(
        &self,
        m: Real,
        p: &Particles,
        i: usize,
        pw: Real,
        rw: Real,
        r: &Vector,
        len: Real,
    ) -> Vector {
        let rho = p.density[i];
        self.kernel.gradient(r, len) * (-m * m * (p.pressure[i] / (rho * rho) + pw / (rw * rw)))
    }
}

impl SphMethod for Lite {
    const NAME: &'static str = "lite";
    const DESCRIPTION: &'static str = "plain WCSPH (Monaghan 1992): summed density, linear EOS, symplectic Euler; an example of a method added from outside";
    type Params = LiteParams;
    type Kernel = WendlandC2;

    fn new(params: LiteParams, init: &Initial) -> Result<(Self, Layout), SolverError> {
        let dx = init.fluid.dx;
        let kernel = WendlandC2::new(1.3 * dx);
        let c = init.default_sound_speed();
        let lattice = lattice_density(&kernel, dx, init.fluid.density * dx.powi(3));
        let method = Lite {
            kernel,
            c2: c * c,
            lattice,
            alpha: params.alpha.unwrap_or(0.1),
            cfl: params.cfl.unwrap_or(0.2),
        };
        // Hydrostatic densities, so that the first frame's pressures are the water's.
        let g = init.gravity.norm();
        let density = init
            .fill
            .depth
            .iter()
            .map(|d| method.density_of(init.fluid.density * g * d))
            .collect();
        let layout = Layout {
            density,
            support: method.kernel.support(),
            sound_speed: c,
            skin_ratio: 0.0,
            poly6_sums: false,
            carried: Carried::ALL,
        };
        Ok((method, layout))
    }

    fn start(&mut self, sys: &mut FluidSystem) {
        let p = &mut sys.particles;
        for (pr, rho) in p.pressure.iter_mut().zip(&p.density) {
            *pr = (self.c2 * (rho - self.lattice)).max(0.0);
        }
    }

    fn step(&mut self, sys: &mut FluidSystem, dt: Real) -> Result<StepReport, SolverError> {
        let (m, h, support) = (sys.mass, self.kernel.support() / 2.0, self.kernel.support());
        // Density and pressure.
        let n = sys.particles.len();
        for i in 0..n {
            let xi = sys.particles.position[i];
            let mut sum = self.kernel.value(0.0);
            for &j in sys.fluid_lists.of(i) {
                sum += self
                    .kernel
                    .value((xi - sys.particles.position[j as usize]).norm());
            }
            sys.boundary.for_each_neighbor(i, |b| {
                sum += self.kernel.value((xi - b.position()).norm());
            });
            sys.particles.density[i] = m * sum;
            sys.particles.pressure[i] = (self.c2 * (m * sum - self.lattice)).max(0.0);
        }
        // The boundary particles' pressures from the fluid's (Adami, Hu & Adams 2012).
        sys.boundary.update(
            &self.kernel,
            &sys.particles,
            &sys.gravity,
            self.lattice,
            |p| self.density_of(p),
        );
        // Forces, then symplectic Euler.
        let c = self.c2.sqrt();
        // All accelerations from the positions and velocities at the start of the step, into
        // the particles' own array (no allocation per step), then the update.
        let Particles {
            position,
            velocity,
            density,
            pressure,
            penalty,
            acceleration,
            ..
        } = &mut sys.particles;
        let (position, velocity, density, pressure) =
            (&*position, &*velocity, &*density, &*pressure);
        for (i, a) in acceleration.iter_mut().enumerate() {
            let (xi, vi) = (position[i], velocity[i]);
            let term_i = pressure[i] / (density[i] * density[i]);
            let mut sum = Vector::zeros();
            let mut pair = |xj: Vector, vj: Vector, pj: Real, rhoj: Real| {
                let r = xi - xj;
                let len = r.norm();
                if len <= 0.0 || len >= support {
                    return;
                }
                let vr = (vi - vj).dot(&r);
                let viscous = if vr < 0.0 {
                    -self.alpha * c * h * vr
                        / (0.5 * (density[i] + rhoj) * (len * len + 0.01 * h * h))
                } else {
                    0.0
                };
                sum -=
                    self.kernel.gradient(&r, len) * (m * (term_i + pj / (rhoj * rhoj) + viscous));
            };
            for &j in sys.fluid_lists.of(i) {
                let j = j as usize;
                pair(position[j], velocity[j], pressure[j], density[j]);
            }
            sys.boundary.for_each_neighbor(i, |b| {
                pair(b.position(), b.velocity(), b.pressure(), b.density())
            });
            *a = sum + sys.gravity + penalty[i] / m;
        }
        let p = &mut sys.particles;
        for ((x, v), a) in p
            .position
            .iter_mut()
            .zip(&mut p.velocity)
            .zip(&p.acceleration)
        {
            *v += a * dt;
            *x += *v * dt;
        }
        Ok(StepReport::default())
    }

    fn react(&mut self, sys: &mut FluidSystem) {
        // The wall pressures at the blocks' new pose, then each pair's pressure force with its
        // sign reversed onto the block (r = x_i − x_wall).
        sys.boundary.update_moving(
            &self.kernel,
            &sys.particles,
            &sys.gravity,
            self.lattice,
            |p| self.density_of(p),
        );
        let (m, p, this) = (sys.mass, &sys.particles, &*self);
        sys.boundary.react(
            &p.position,
            self.kernel.support(),
            |i, pw, rw, r, len| this.wall_force(m, p, i, pw, rw, r, len),
            None,
        );
    }

    fn fixed_wall_forces(&self, sys: &FluidSystem, i: usize, visit: &mut dyn FnMut(usize, Vector)) {
        let p = &sys.particles;
        let support = self.kernel.support();
        sys.boundary
            .for_each_fixed_within(i, &p.position[i], support, |b, r, len| {
                let f = self.wall_force(sys.mass, p, i, b.pressure(), b.density(), r, len);
                visit(b.index(), f);
            });
    }

    fn kernel(&self) -> &WendlandC2 {
        &self.kernel
    }

    fn density_check(&self) -> (bool, Real) {
        (false, self.lattice)
    }

    fn dt_proposal(&self, v_max: Real, a_max: Real) -> Real {
        let h = self.kernel.support() / 2.0;
        let acoustic = self.cfl * h / (self.c2.sqrt() + v_max);
        let force = if a_max > 0.0 {
            0.25 * (h / a_max).sqrt()
        } else {
            acoustic
        };
        acoustic.min(force)
    }
}
