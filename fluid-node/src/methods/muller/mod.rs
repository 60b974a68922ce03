//! The paper's SPH (Geraili Mikola & Sitar 2014, Eqs. 11–21), which is Müller, Charypar & Gross
//! (2003): summed density with the poly6 kernel (Eqs. 12–13), the linear equation of state
//! p = k(ρ − ρ0) (Eq. 17), the symmetric spiky pressure force −Σ m_j (p_i + p_j)/(2ρ_j) ∇W
//! (Eqs. 14–15; the paper prints p_i − p_j, Müller's symmetric form is the sum), the viscosity
//! Laplacian μ Σ m_j (v_j − v_i)/ρ_j ∇²W (Eqs. 18–19; the paper's v_i − v_j would anti-damp), and
//! symplectic Euler (Eq. 21).

pub mod pairs;

use crate::core::dt::StepLimits;
use crate::core::lanes::Packed;
use crate::core::particles::Carried;
use crate::core::phases::Phase;
use crate::core::tasks;
use crate::kernels::{Kernel, lattice_density};
use crate::kernels::{Poly6, Spiky, ViscosityKernel};
use crate::methods::SphMethod;
use crate::system::{FluidSystem, Initial, Layout};
use crate::validation::Check;
use pairs::{PairConstants, boundary_forces, density_sum, fluid_forces, record};
use rayon::prelude::*;
use serde::Deserialize;
use shared::math::{Real, Vector};
use shared::registry::{ParamCheck, SolverParams, Variant, study};
use shared::solver::{SolverError, StepReport};

/// `[fluid.muller]`: parameters of the paper's SPH. Unset values are derived from the scene.
#[derive(Debug, Clone, Default, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct MullerParams {
    /// Gas constant k in p = k(ρ − ρ0) (paper Eq. 17) [m²/s²]; default c² with c = 10·sqrt(2 g H).
    pub stiffness: Option<f64>,
    /// Dynamic viscosity μ in paper Eq. 18 [Pa·s]; default ρ0·ν, raised to what the resolution needs.
    pub viscosity: Option<f64>,
    /// Kernel support h over dx (poly6 / spiky / viscosity kernels vanish at r = h); default 2.
    pub support_ratio: Option<f64>,
    /// Step limit factor on the CFL, force and viscous limits; default 0.25.
    pub cfl: Option<f64>,
    /// Clip negative pressure to zero (p = max(k(ρ − ρ0), 0)); default true. `false` is the
    /// paper's Eq. 17 as printed: summed densities are low at a free surface, so the printed
    /// form sucks surface particles inward hard enough to make still water boil.
    pub clamp_negative_pressure: Option<bool>,
}

impl SolverParams for MullerParams {
    fn check(&self, c: &mut ParamCheck) {
        c.positive(
            "stiffness",
            self.stiffness,
            "give k in m²/s², or leave it out for c² with c = 10·sqrt(2 g H)",
        );
        c.non_negative(
            "viscosity",
            self.viscosity,
            "give μ in Pa·s, or leave it out",
        );
        if let Some(r) = self.support_ratio
            && !(r.is_finite() && r >= 1.0)
        {
            c.fail(
                "support_ratio",
                r,
                "must be a finite number >= 1 (the support must reach the nearest neighbours)",
                "2.0 is the paper's h = 2 dx",
            );
        }
        c.positive("cfl", self.cfl, "e.g. cfl = 0.25");
    }
}

/// Mean compression above which a step carries a warning (the weakly compressible promise).
const COMPRESSION_WARNING: Real = 0.01;
/// Steps between two repeated compression warnings.
const WARNING_EVERY: u64 = 1000;

/// Units per unit of compression in the mean compression's integer sum: exact, so the mean is
/// the same whatever order the particles are added in, on any number of threads or ranks.
const COMPRESSION_UNITS: Real = (1u64 << 32) as Real;

/// A particle's compression max(ρ/ρ0 − 1, 0) in [`COMPRESSION_UNITS`], capped at 100 (far past
/// any run that has not stopped), so that 4·10⁷ particles sum below 2⁶⁴.
fn compression_count(relative: Real) -> u64 {
    (relative.clamp(0.0, 100.0) * COMPRESSION_UNITS).round() as u64
}

#[derive(serde::Serialize, serde::Deserialize)]
pub struct Muller {
    poly6: Poly6,
    spiky: Spiky,
    viscosity_kernel: ViscosityKernel,
    /// k of Eq. 17 [m²/s²].
    pub stiffness: Real,
    /// μ of Eq. 18 [Pa·s].
    pub viscosity: Real,
    /// ρ0 of Eq. 17: the poly6 sum of Eq. 12 on the filled lattice
    /// ([`crate::kernels::lattice_density`]), 1.0098·ρ0·(m/ρ0dx³) for h = 2 dx. The paper's ρ0
    /// is water at rest; the continuum value would start every particle 1 % compressed, with
    /// k·0.0098ρ0 of pressure pushing the surface up (more than the hydrostatic pressure of a
    /// 0.1 m column).
    pub rest_density: Real,
    clamp: bool,
    limits: StepLimits,
    last_warning: Option<u64>,
    /// What the pair loops read of each particle (scratch, rebuilt every evaluation; not
    /// checkpointed).
    #[serde(skip)]
    records: Vec<Packed>,
}

impl Muller {
    /// Eq. 14's pressure force of a boundary particle (p_w, ρ_w) at r = x_i − x_w on fluid
    /// particle i, as a force (m·f_pressure/ρ_i): the moving blocks take its reverse
    /// (`react`), the wall-reading probes read it (`fixed_wall_forces`).
    #[allow(clippy::too_many_arguments)]
    fn wall_force(
        &self,
        m: Real,
        p: &crate::core::particles::Particles,
        i: usize,
        pw: Real,
        rw: Real,
        r: &Vector,
        len: Real,
    ) -> Vector {
        self.spiky.gradient(r, len) * (-m * m * (p.pressure[i] + pw) / (2.0 * rw * p.density[i]))
    }

    /// ρ0 + p/k: the density Eq. 17 gives a pressure (the boundary particles' density).
    fn density_of(&self, p: Real) -> Real {
        self.rest_density + p / self.stiffness
    }

    /// Eq. 12 (fluid and boundary particles both carry mass), then Eq. 17, and in the same pass
    /// the records the force loop reads (muller_pairs.rs); returns the mean compression, the
    /// average of max(ρ/ρ0 − 1, 0) over all particles (a free surface's low summed densities do
    /// not hide compression elsewhere). On several ranks, the sums of the owned particles; the
    /// halo's density and pressure come from their owners.
    fn density_and_pressure(&mut self, sys: &mut FluidSystem) -> Real {
        let t = sys.phases.start();
        let (m, k, rho_ref, clamp) = (sys.mass, self.stiffness, self.rest_density, self.clamp);
        let origin = sys.grid.centre();
        let pc = self.pair_constants();
        let (c, self_weight) = (self.poly6.coefficient(), self.poly6.value_r2(0.0));
        // The boundary's positions at the blocks' current pose (the density reads nothing else).
        sys.boundary
            .pack(|x, v, _, _| record(x, &origin, v, 0.0, 1.0));
        let p = &mut sys.particles;
        let (pos, vel) = (&p.position, &p.velocity);
        let (lists, boundary) = (&sys.fluid_lists, &sys.boundary);
        let owned = sys.share.as_ref().map(|s| &s.owned[..]);
        self.records.resize(p.len(), Packed::default());
        let mut compressed: u64 = p
            .density
            .par_iter_mut()
            .zip(p.pressure.par_iter_mut())
            .zip(self.records.par_iter_mut())
            .enumerate()
            .with_max_len(tasks::PARTICLES)
            .map(|(i, ((rho, pr), rec))| {
                if owned.is_some_and(|o| !o[i]) {
                    return 0;
                }
                // The fluid neighbours' sum came with this step's lists (rebuilt every step at
                // these positions, `Layout::poly6_sums`); the boundary's is summed here.
                let mut sum = self_weight + c * lists.poly6_sum(i);
                let me = record(&pos[i], &origin, &vel[i], 0.0, 1.0);
                boundary.for_each_list(i, |list, walls| {
                    sum += density_sum(&me, list, walls, &pc);
                });
                *rho = m * sum;
                let pressure = k * (*rho - rho_ref);
                *pr = if clamp { pressure.max(0.0) } else { pressure };
                *rec = record(&pos[i], &origin, &vel[i], *pr, *rho);
                compression_count((*rho - rho_ref) / rho_ref)
            })
            .sum();
        let t = sys.phases.lap(Phase::Density, t);
        if let Some(s) = &mut sys.share {
            let halo = s.share(|i| [p.density[i], p.pressure[i]]);
            for (i, [rho, pr]) in halo {
                let i = i as usize;
                (p.density[i], p.pressure[i]) = (rho, pr);
                self.records[i] = record(&pos[i], &origin, &vel[i], pr, rho);
            }
            let mut total = [compressed];
            s.comm().sum(&mut total);
            compressed = total[0];
        }
        let t = sys.phases.lap(Phase::Halo, t);
        let this = &*self;
        sys.boundary
            .update(&this.poly6, &sys.particles, &sys.gravity, rho_ref, |p| {
                this.density_of(p)
            });
        sys.boundary
            .pack(|x, v, pw, rw| record(x, &origin, v, pw, rw));
        sys.phases.stop(Phase::WallPressures, t);
        compressed as Real / COMPRESSION_UNITS / sys.global_len().max(1) as Real
    }

    /// The f32 constants of the pair loops.
    fn pair_constants(&self) -> PairConstants {
        PairConstants::new(
            &self.poly6,
            &self.spiky,
            &self.viscosity_kernel,
            self.viscosity,
            self.poly6.support(),
        )
    }

    /// Eqs. 14, 18 and 20: acceleration from pressure, viscosity, gravity and Eq. 22, and with
    /// it Eq. 21's symplectic Euler, velocity first, then position with the new velocity. The
    /// force sums read the records of the density pass, never `position` or `velocity`, so a
    /// particle can move as soon as its acceleration is known: one pass over the particles.
    /// (An integration pass of its own gained nothing from a second thread:
    /// docs/journal/2026-11-performance.md, "Inner loops, fifth round".) On several ranks the
    /// owned particles move in that pass; the halo's accelerations come from their owners and
    /// the halo moves after, by the same two lines.
    fn accelerate_and_move(&self, sys: &mut FluidSystem, dt: Real) {
        let (m, g) = (sys.mass, sys.gravity);
        let pc = self.pair_constants();
        let (lists, boundary, records) = (&sys.fluid_lists, &sys.boundary, &self.records);
        let owned = sys.share.as_ref().map(|s| &s.owned[..]);
        let p = &mut sys.particles;
        let (rho, pen) = (&p.density, &p.penalty);
        p.acceleration
            .par_iter_mut()
            .zip(p.velocity.par_iter_mut())
            .zip(p.position.par_iter_mut())
            .enumerate()
            .with_max_len(tasks::PARTICLES)
            .for_each(|(i, ((a, v), x))| {
                if owned.is_some_and(|o| !o[i]) {
                    return;
                }
                let me = &records[i];
                // Fluid neighbours: Eq. 14 with Müller's symmetric (p_i + p_j)/2, Eq. 18 with
                // Müller's sign (it damps the velocity difference).
                let mut f = fluid_forces(me, lists.of(i), records, &pc);
                // Boundary particles, fixed and moving (free slip); a moving block takes the
                // reverse (`react`).
                boundary.for_each_list(i, |list, walls| {
                    f += boundary_forces(me, list, walls, &pc);
                });
                *a = f * (m / rho[i]) + g + pen[i] / m;
                *v += *a * dt;
                *x += *v * dt;
            });
        if let Some(s) = &mut sys.share {
            let t = sys.phases.start();
            let halo = s.share(|i| p.acceleration[i].into());
            for (i, a) in halo {
                let i = i as usize;
                p.acceleration[i] = a.into();
                p.velocity[i] += p.acceleration[i] * dt;
                p.position[i] += p.velocity[i] * dt;
            }
            sys.phases.stop(Phase::Halo, t);
        }
    }
}

impl SphMethod for Muller {
    const NAME: &'static str = "muller";
    const DESCRIPTION: &'static str = "the paper's SPH (Müller et al. 2003): summed density, linear EOS, spiky pressure, symplectic Euler";
    const PARTICLE_STEPS_PER_SECOND: Option<f64> = Some(5.33e6);
    const SPLITS: bool = true;
    type Params = MullerParams;
    type Kernel = Poly6;

    fn new(spec: MullerParams, init: &Initial) -> Result<(Self, Layout), SolverError> {
        let dx = init.fluid.dx;
        let rho0 = init.fluid.density;
        let h = spec.support_ratio.unwrap_or(2.0) * dx;
        let c = init.default_sound_speed();
        let stiffness = spec.stiffness.unwrap_or(c * c);
        let sound = stiffness.sqrt();
        // μ = ρ0·max(ν, ν_num): water's own viscosity is far below what a particle spacing can
        // resolve; ν_num = α·h·c/10 with α = 0.05 is the viscosity Monaghan's artificial term
        // with that α adds in 3D (Monaghan 2005, ν = αhc/(2(d+2))), enough to damp the
        // particle-scale noise of the explicit scheme.
        let viscosity = spec
            .viscosity
            .unwrap_or(rho0 * init.fluid.kinematic_viscosity.max(0.05 * h * sound / 10.0));
        let poly6 = Poly6::new(h);
        let mass = rho0 * dx.powi(3);
        let rest_density = lattice_density(&poly6, dx, mass);
        // Initial pressure for output and probes: hydrostatic where asked (Eq. 12 fixes density
        // from positions, so the lattice itself settles by ρ0gH/k, 0.5 % of H at the default k).
        let density = init
            .fill
            .depth
            .iter()
            .map(|d| rest_density + rho0 * init.gravity.norm() * d / stiffness)
            .collect();
        let limits = StepLimits {
            h,
            sound_speed: sound,
            viscosity: viscosity / rho0,
            // No density diffusion in this scheme.
            diffusivity: 0.0,
            // Set in `start`, once the system has chosen the Eq. 22 spring.
            penalty_stiffness: 0.0,
            mass,
            cfl: spec.cfl.unwrap_or(0.25),
        };
        let scheme = Self {
            poly6,
            spiky: Spiky::new(h),
            viscosity_kernel: ViscosityKernel::new(h),
            stiffness,
            viscosity,
            rest_density,
            clamp: spec.clamp_negative_pressure.unwrap_or(true),
            limits,
            last_warning: None,
            records: Vec::new(),
        };
        let layout = Layout {
            density,
            support: h,
            sound_speed: sound,
            // Lists rebuilt every step: Müller's step is long enough that a developed flow moves
            // a particle past half of any useful skin in one step.
            skin_ratio: 0.0,
            poly6_sums: true,
            // Eq. 12 rewrites the densities and pressures too, but the frames and probes read
            // them after the sort; accelerations are rewritten before they are read, and the
            // symplectic Euler of Eq. 21 keeps no history.
            carried: Carried {
                rates: false,
                history: false,
            },
        };
        Ok((scheme, layout))
    }

    fn start(&mut self, sys: &mut FluidSystem) {
        // The particles were sorted by cell: pressures from their own (permuted) densities.
        let (k, rest_density) = (self.stiffness, self.rest_density);
        sys.particles
            .pressure
            .par_iter_mut()
            .zip(sys.particles.density.par_iter())
            .for_each(|(p, r)| *p = k * (r - rest_density));
        self.limits.penalty_stiffness = sys.penalty.stiffness;
    }

    fn step(&mut self, sys: &mut FluidSystem, dt: Real) -> Result<StepReport, SolverError> {
        let compression = self.density_and_pressure(sys);
        let t = sys.phases.start();
        self.accelerate_and_move(sys, dt);
        sys.phases.stop(Phase::Forces, t);
        let mut report = StepReport::default();
        let steps = sys.steps + 1;
        if compression > COMPRESSION_WARNING
            && self.last_warning.is_none_or(|s| steps >= s + WARNING_EVERY)
        {
            self.last_warning = Some(steps);
            report.warning = Some(format!(
                "muller: mean compression {:.2} % exceeds {:.0} %: the Eq. 17 stiffness k = {:.4e} m²/s² is too soft for this flow; raise [fluid.muller] stiffness",
                100.0 * compression,
                100.0 * COMPRESSION_WARNING,
                self.stiffness
            ));
        }
        Ok(report)
    }

    fn react(&mut self, sys: &mut FluidSystem) {
        // The pressures of the last evaluation (Eq. 12 sums are recomputed at the start of the
        // step) and the wall pressures extrapolated at the new pose.
        sys.boundary.update_moving(
            &self.poly6,
            &sys.particles,
            &sys.gravity,
            self.rest_density,
            |p| self.density_of(p),
        );
        let (p, m, this) = (&sys.particles, sys.mass, &*self);
        sys.boundary.react(
            &p.position,
            self.spiky.support(),
            |i, pw, rw, r, len| this.wall_force(m, p, i, pw, rw, r, len),
            sys.share.as_ref().map(|s| (s, &sys.grid)),
        );
    }

    fn fixed_wall_forces(&self, sys: &FluidSystem, i: usize, visit: &mut dyn FnMut(usize, Vector)) {
        let p = &sys.particles;
        let support = self.spiky.support();
        sys.boundary
            .for_each_fixed_within(i, &p.position[i], support, |b, r, len| {
                let f = self.wall_force(sys.mass, p, i, b.pressure(), b.density(), r, len);
                visit(b.index(), f);
            });
    }

    fn kernel(&self) -> &Poly6 {
        &self.poly6
    }

    fn density_check(&self) -> (bool, Real) {
        (false, self.rest_density)
    }

    fn dt_proposal(&self, v_max: Real, a_max: Real) -> Real {
        self.limits.propose(v_max, a_max).0
    }

    /// `fluid-validate` runs the paper's method once more with its own walls (Eq. 22 only), to
    /// show what boundary particles buy.
    fn study_variants(study: &str) -> &'static [Variant] {
        match study {
            study::PENALTY_WALLS => &[Variant::DEFAULTS],
            _ => &[],
        }
    }

    /// Eq. 14's symmetric pressure force approximates ½∇p·(…) with summation density at the
    /// surface: about twice hydrostatic at depth, with either wall treatment.
    fn known_limitation(check: &str, _resolution: usize) -> Option<&'static str> {
        (check == Check::StillPressure.name())
            .then_some("Eq. 14 gives about 2× hydrostatic pressure")
    }
}
