//! DFSPH as a [`SphMethod`] of the SPH core: construction from `[fluid.dfsph]`, the step (2017
//! Algorithm 1, rotated: densities and factors, divergence solve, non-pressure forces, density
//! solve, positions), the loads on the blocks and the stable step.

use super::SMOOTHING_RATIO;
use super::stall::STALLED_STEPS;
use super::{
    ABSURD_DENSITY_ERROR, BLOCKS_IN_SOLVE, CONTINUED_SURFACE, DEFAULT_CFL, DEFICIENT_FRACTION,
    Dfsph, DfsphConstants, DfsphParams, PRESSURE_STUDY, RELAXATION, SURFACE_FRACTION, SolveStats,
    WALL_CLEARANCE, WALL_PRESSURE, blocks_in_solve, density_stiffness, divergence_stiffness, halo,
    hydrostatic, lattice_neighbours, stiffnesses,
};
use crate::core::neighbors::PairValues;
use crate::core::particles::Particles;
use crate::core::phases::Phase;
use crate::kernels::WendlandC2;
use crate::kernels::{Kernel, lattice_density};
use crate::methods::SphMethod;
use crate::system::{FluidSystem, Initial, Layout};
use crate::validation::Check;
use rayon::prelude::*;
use shared::math::{Real, Vector};
use shared::protocol::BlockLoad;
use shared::registry::{Variant, study};
use shared::scene::{CouplingScheme, Scene};
use shared::solver::{SolverError, StepReport};

impl SphMethod for Dfsph {
    const NAME: &'static str = "dfsph";
    const DESCRIPTION: &'static str = "divergence-free SPH (Bender & Koschier 2015/2017): summed density, implicit constant-density and divergence-free solves, CFL step on the flow speed";
    const PARTICLE_STEPS_PER_SECOND: Option<f64> = Some(6.24e5);
    const SPLITS: bool = true;
    type Params = DfsphParams;
    type Kernel = WendlandC2;

    fn new(spec: DfsphParams, init: &Initial) -> Result<(Self, Layout), SolverError> {
        let dx = init.fluid.dx;
        let rho0 = init.fluid.density;
        let h = spec.smoothing_ratio.unwrap_or(SMOOTHING_RATIO) * dx;
        let kernel = WendlandC2::new(h);
        let mass = rho0 * dx.powi(3);
        let rest_density = lattice_density(&kernel, dx, mass);
        let deficient_below = (spec.deficient_fraction.unwrap_or(DEFICIENT_FRACTION)
            * lattice_neighbours(kernel.support(), dx) as Real)
            .round() as usize;
        let surface_below = if spec.continued_surface.unwrap_or(CONTINUED_SURFACE) {
            (SURFACE_FRACTION * lattice_neighbours(kernel.support(), dx) as Real).round() as usize
        } else {
            0
        };
        let constants = DfsphConstants {
            cfl: spec.cfl.unwrap_or(DEFAULT_CFL),
            density_tolerance: 0.01 * spec.density_tolerance.unwrap_or(0.05),
            divergence_tolerance: 0.01 * spec.divergence_tolerance.unwrap_or(0.1),
            // Off unless asked for (module doc, "Known limits").
            pressure_tolerance: spec.pressure_tolerance.map_or(Real::INFINITY, |t| 0.01 * t),
            max_iterations: spec.max_iterations.unwrap_or(100).max(1) as usize,
            relaxation: spec.relaxation.unwrap_or(RELAXATION),
            viscosity: spec.viscosity.unwrap_or(0.01),
            h,
        };
        // No sound speed limits the step; it only sets the default Eq. 22 spring, the backstop
        // behind the boundary particles. A fifth of WCSPH's (2·sqrt(2 g H), twice the largest
        // free-fall speed) keeps the spring's own limit sqrt(m/K_S) = √2·dx/c above the CFL step.
        let penalty_speed = 0.2 * init.default_sound_speed();
        // Initial hydrostatic pressure, carried to `start` through the density (as Müller does):
        // ρ = ρ0 + ρ_w g d/c².
        let g = init.gravity.norm();
        let density = init
            .fill
            .depth
            .iter()
            .map(|d| rest_density + rho0 * g * d / (penalty_speed * penalty_speed))
            .collect();
        let layout = Layout {
            density,
            support: kernel.support(),
            sound_speed: penalty_speed,
            // particles move ~0.4 dx per step: the lists could not be kept.
            skin_ratio: 0.0,
            poly6_sums: false,
            carried: crate::core::particles::Carried::ALL,
        };
        let scheme = Self {
            kernel,
            constants,
            rest_density,
            penalty_speed,
            dx,
            mass,
            penalty_stiffness: 0.0,
            beta: Vec::new(),
            grad: Vec::new(),
            wall_flux: Vec::new(),
            deficient: Vec::new(),
            deficient_below,
            surface_below,
            error: Vec::new(),
            predicted: Vec::new(),
            dk: Vec::new(),
            v_old: Vec::new(),
            pairs: PairValues::default(),
            block_loads: Vec::new(),
            stats: SolveStats::default(),
            blocks_in_solve: spec.blocks_in_solve.unwrap_or(BLOCKS_IN_SOLVE),
            mirrored: spec.wall_pressure.as_deref().unwrap_or(WALL_PRESSURE[0]) == "mirrored",
            wall_grad: Vec::new(),
            kbar: Vec::new(),
            k_last: Vec::new(),
            motion: Vec::new(),
            loads: Vec::new(),
            damping: Vec::new(),
            near: Vec::new(),
            mobility: Vec::new(),
            k_best: Vec::new(),
            motion_best: Vec::new(),
            loads_best: Vec::new(),
            stalls: Default::default(),
        };
        Ok((scheme, layout))
    }

    fn start(&mut self, sys: &mut FluidSystem) {
        // The particles were sorted: decode the hydrostatic pressure from their own densities,
        // and warm-start the first density solve from it (k = p/ρ0²).
        let (rho0, c2) = (self.rest_density, self.penalty_speed * self.penalty_speed);
        let Particles {
            pressure,
            density,
            density0: density_stiffness,
            density_rate: divergence_stiffness,
            ..
        } = &mut sys.particles;
        pressure
            .par_iter_mut()
            .zip(density.par_iter_mut())
            .zip(
                density_stiffness
                    .par_iter_mut()
                    .zip(divergence_stiffness.par_iter_mut()),
            )
            .for_each(|((pr, r), (kd, kv))| {
                *pr = (*r - rho0) * c2;
                *kd = *pr / (rho0 * rho0);
                *kv = 0.0;
                *r = rho0;
            });
        self.penalty_stiffness = sys.penalty.stiffness;
        self.mass = sys.mass;
    }

    fn step(&mut self, sys: &mut FluidSystem, dt: Real) -> Result<StepReport, SolverError> {
        let c = self.constants;
        // Algorithm 1's "update ρ and α" (rotated to the start): ρ_i and α_i at the current
        // positions; what the walls hold over the step (module doc): mirrored, the last
        // step's stiffness that bounds H_ib; extrapolated, their pressure from the last step's
        // (Adami 2012, Eq. 27 at rest).
        let t = sys.phases.start();
        self.densities_and_factors(sys);
        let t = sys.phases.lap(Phase::Density, t);
        let rho0 = self.rest_density;
        if self.mirrored {
            let p = &sys.particles;
            let (kd, kv) = stiffnesses(p);
            self.k_last.resize(p.len(), 0.0);
            self.k_last
                .par_iter_mut()
                .zip(kd.par_iter().zip(kv.par_iter()))
                .for_each(|(k, (a, b))| *k = a + b);
        } else {
            sys.boundary
                .update(&self.kernel, &sys.particles, &sys.gravity, rho0, |_| rho0);
        }
        let t = sys.phases.lap(Phase::WallPressures, t);
        let blocks = self.moves_blocks(sys);
        self.motion.fill((Vector::zeros(), Vector::zeros()));
        self.loads.fill(BlockLoad::default());
        if blocks {
            self.block_damping(sys);
        }
        let t = sys.phases.lap(Phase::Blocks, t);
        // Algorithm 1's divergence solve (Algorithm 2), rotated to the start on the current velocities.
        let kv = std::mem::take(divergence_stiffness(&mut sys.particles));
        let (div_it, div_err, kv, div_kept) = self.solve(sys, dt, false, kv);
        *divergence_stiffness(&mut sys.particles) = kv;
        let t = sys.phases.lap(Phase::DivergenceSolve, t);
        // Non-pressure forces and predicted velocities.
        self.non_pressure(sys, dt);
        let t = sys.phases.lap(Phase::Forces, t);
        if blocks {
            // The blocks' non-pressure part: the walls' held pressure, Eq. 22 and the rest of
            // their forces.
            if self.mirrored {
                let (g, rho0) = (sys.gravity, self.rest_density);
                let k_last = std::mem::take(&mut self.k_last);
                self.move_blocks(sys, dt, true, |i, _, _, r| {
                    hydrostatic(&g, r, rho0, k_last[i])
                });
                self.k_last = k_last;
            } else {
                self.move_blocks(sys, dt, true, |_, pw, rw, _| pw / (rw * rw));
            }
        }
        let t = sys.phases.lap(Phase::Blocks, t);
        // The constant-density solve (Algorithm 3) on v*.
        let kd = std::mem::take(density_stiffness(&mut sys.particles));
        let (it, err, kd, kept) = self.solve(sys, dt, true, kd);
        *density_stiffness(&mut sys.particles) = kd;
        let t = sys.phases.lap(Phase::DensitySolve, t);
        // Positions. The pressure the step applied, p = (k_ρ + k_v)ρ², for output and
        // probes; the density the constant-density solve predicts at the new positions.
        if blocks && let Some(bodies) = sys.boundary.bodies_mut() {
            // The solid node moves the blocks; the next pose brings their velocities.
            bodies.settle();
        }
        let Particles {
            position,
            velocity,
            pressure,
            density,
            density0: density_stiffness,
            density_rate: divergence_stiffness,
            ..
        } = &mut sys.particles;
        position
            .par_iter_mut()
            .zip(velocity.par_iter())
            .for_each(|(x, v)| *x += v * dt);
        pressure
            .par_iter_mut()
            .zip(density.par_iter_mut())
            .zip(
                density_stiffness
                    .par_iter()
                    .zip(divergence_stiffness.par_iter()),
            )
            .zip(self.predicted.par_iter())
            .for_each(|(((pr, r), (kd, kv)), pred)| {
                *pr = (kd + kv) * *r * *r;
                *r = *pred;
            });
        // The halo's ρ* (the step's survey reads every particle held).
        let predicted = &self.predicted;
        for (i, [r]) in halo(&mut sys.share, |i| [predicted[i]]) {
            density[i as usize] = r;
        }
        // No particle through a fixed wall (module doc, "Walls that cannot be crossed").
        sys.penalty
            .keep_out(&mut sys.particles, &sys.grid, WALL_CLEARANCE * self.dx);
        sys.phases.stop(Phase::Integration, t);
        self.stats = SolveStats {
            density_iterations: it,
            density_error: err,
            divergence_iterations: div_it,
            divergence_error: div_err,
        };
        let mut warnings = Vec::new();
        if err > c.density_tolerance {
            warnings.push(format!(
                "dfsph: density solve did not converge: mean error {:.3} % after {it} iterations (tolerance {:.3} %)",
                100.0 * err,
                100.0 * c.density_tolerance
            ));
        }
        if err > ABSURD_DENSITY_ERROR {
            return Err(SolverError::Unstable(format!(
                "dfsph: mean compression limit exceeded: {:.1} % after {it} iterations (limit {:.0} %): the constant-density solve cannot hold this step; lower [fluid.dfsph] cfl or [time] dt_max",
                100.0 * err,
                100.0 * ABSURD_DENSITY_ERROR
            )));
        }
        if div_err > c.divergence_tolerance {
            warnings.push(format!(
                "dfsph: divergence solve did not converge: mean error {:.3} % after {div_it} iterations (tolerance {:.3} %)",
                100.0 * div_err,
                100.0 * c.divergence_tolerance
            ));
        }
        // A solve that began to diverge went back to its iterate of smallest error (module
        // doc, "Stopping"), which may be within the tolerance: said either way.
        for (what, kept, n, error) in [
            ("divergence", div_kept, div_it, div_err),
            ("density", kept, it, err),
        ] {
            if let Some(i) = kept {
                warnings.push(format!(
                    "dfsph: {what} solve diverging: its iterate of smallest error kept (iteration {i} of {n}, mean error {:.3} %)",
                    100.0 * error
                ));
            }
        }
        // A solve that did nothing, step after step, is not holding the water (`stall.rs`).
        for ((stall, what), (kept, error, tolerance)) in self
            .stalls
            .iter_mut()
            .zip(["divergence-free", "constant-density"])
            .zip([
                (div_kept, div_err, c.divergence_tolerance),
                (kept, err, c.density_tolerance),
            ])
        {
            let n = stall.note(kept, error, tolerance);
            if n >= STALLED_STEPS {
                return Err(SolverError::Unstable(format!(
                    "dfsph: the {what} solve has done nothing for {n} steps in a row (each went back to its starting iterate, mean error now {:.3} %, tolerance {:.3} %): its Jacobi iteration diverges from the first iteration on this particle arrangement, so the water is no longer held and compresses step after step; use [fluid.dfsph] relaxation = {RELAXATION} (the default; this run has {}) or a narrower kernel, smoothing_ratio = {SMOOTHING_RATIO} (the default; this run has {:.2})",
                    100.0 * error,
                    100.0 * tolerance,
                    c.relaxation,
                    c.h / self.dx
                )));
            }
        }
        Ok(StepReport {
            warning: (!warnings.is_empty()).then(|| warnings.join("; ")),
        })
    }

    fn react(&mut self, sys: &mut FluidSystem) {
        // The reverse of the pressure force the fluid takes from each moving boundary particle,
        // m·(−m (k_i + k_b) ∇W_ib) with k_i = k_ρ + k_v of the last step and k_b the wall's
        // at the new pose (module doc): mirrored, k_i + H_ib (k_i for k̄_i: summed over a
        // block's pairs the two differ by the noise of single stiffnesses); extrapolated,
        // p_b/ρ_b².
        let rho0 = self.rest_density;
        if !self.mirrored {
            sys.boundary
                .update_moving(&self.kernel, &sys.particles, &sys.gravity, rho0, |_| rho0);
        }
        let (p, this) = (&sys.particles, &*self);
        let state = (p, sys.mass, &sys.gravity);
        let split = sys.share.as_ref().map(|s| (s, &sys.grid));
        sys.boundary.react(
            &p.position,
            self.kernel.support(),
            |i, pw, rw, r, len| this.wall_force(state, i, pw, rw, r, len),
            split,
        );
    }

    fn fixed_wall_forces(&self, sys: &FluidSystem, i: usize, visit: &mut dyn FnMut(usize, Vector)) {
        let p = &sys.particles;
        let state = (p, sys.mass, &sys.gravity);
        sys.boundary.for_each_fixed_within(
            i,
            &p.position[i],
            self.kernel.support(),
            |b, r, len| {
                visit(
                    b.index(),
                    self.wall_force(state, i, b.pressure(), b.density(), r, len),
                );
            },
        );
    }

    fn loads_follow_step(&self, sys: &FluidSystem) -> bool {
        self.moves_blocks(sys)
    }

    fn step_loads(&self, sys: &FluidSystem, loads: &mut [BlockLoad]) {
        for ((out, load), penalty) in loads.iter_mut().zip(&self.loads).zip(&sys.penalty_loads) {
            *out = BlockLoad {
                block: penalty.block,
                ..*load
            };
        }
    }

    fn kernel(&self) -> &WendlandC2 {
        &self.kernel
    }

    fn density_check(&self) -> (bool, Real) {
        (false, self.rest_density)
    }

    fn dt_proposal(&self, v_max: Real, a_max: Real) -> Real {
        let c = &self.constants;
        let mut dt: Real = 1.0;
        if v_max > 0.0 {
            dt = dt.min(c.cfl * self.dx / v_max);
        }
        if a_max > 0.0 {
            dt = dt.min(c.cfl * (self.dx / a_max).sqrt());
        }
        if self.penalty_stiffness > 0.0 {
            dt = dt.min((self.mass / self.penalty_stiffness).sqrt());
        }
        dt
    }

    /// The CFL step on the flow speed: [`DEFAULT_CFL`]·dx over the speed sqrt(g H) of a shallow
    /// water wave of the water's depth (no speed of sound).
    fn estimate_dt(scene: &Scene, dx: Real, depth: Real) -> Option<Real> {
        let g = scene.gravity.iter().map(|x| x * x).sum::<f64>().sqrt();
        Some(DEFAULT_CFL * dx / (g * depth).sqrt().max(1e-6))
    }

    fn warnings(scene: &Scene, scheme: CouplingScheme) -> Vec<String> {
        let mut out = Vec::new();
        if scheme == CouplingScheme::Parallel
            && scene.coupling.added_mass > 0.0
            && blocks_in_solve(scene)
        {
            out.push(format!(
                "[coupling] added_mass = {} relaxes the loads of blocks that DFSPH already moves inside its pressure solve (its default in the parallel scheme): the solid then moves them otherwise than the water predicted (docs/REFERENCES.md §4.1b). Fix: drop --added-mass, or set [fluid.dfsph] blocks_in_solve = false to relax lagged loads instead",
                shared::math::readable(scene.coupling.added_mass)
            ));
        }
        out
    }

    /// The still-water case is a pressure study against fixed walls: there DFSPH runs with its
    /// pressure-change stop, [`PRESSURE_STUDY`] (module doc).
    fn study_table(study: &str) -> Option<&'static str> {
        (study == "still_water").then_some(PRESSURE_STUDY)
    }

    /// In the stability maps DFSPH runs with the explicit-coupling partner (the solid
    /// registry's first), single-rate and sub-cycled under the parallel scheme: first with the
    /// blocks held over its step (`blocks_in_solve = false`, the added-mass lag; in the density
    /// map also with those loads relaxed by ρ_w V), then moved inside its solve (its default).
    fn study_variants(study: &str) -> &'static [Variant] {
        use shared::registry::StudyCoupling as C;
        const P: CouplingScheme = CouplingScheme::Parallel;
        const HELD: &str = "blocks_in_solve = false";
        const IN_SOLVE: &str = "blocks_in_solve = true";
        // The held rows keep the label they had before blocks could move in the solve.
        const DT: &[Variant] = &[
            Variant {
                label: "",
                table: HELD,
                every_partner: false,
                couplings: &[C::plain(P), C::subcycled(P)],
            },
            Variant {
                label: " (blocks in solve)",
                table: IN_SOLVE,
                every_partner: false,
                couplings: &[C::plain(P), C::subcycled(P)],
            },
        ];
        const DENSITY: &[Variant] = &[
            Variant {
                label: "",
                table: HELD,
                every_partner: false,
                couplings: &[
                    C::plain(P),
                    C::subcycled(P),
                    C::plain(P).relaxed(1.0),
                    C::subcycled(P).relaxed(1.0),
                ],
            },
            Variant {
                label: " (blocks in solve)",
                table: IN_SOLVE,
                every_partner: false,
                couplings: &[C::plain(P), C::subcycled(P)],
            },
        ];
        match study {
            study::STABILITY_DT => DT,
            study::STABILITY_DENSITY => DENSITY,
            _ => &[],
        }
    }

    /// Its wall pressure fluctuates through the whole impact (in the tank's width a standard
    /// deviation of 24–33 mbar about a 111 ms mean of 41–73 mbar, most of it the divergence
    /// solve's share of p = (k_ρ + k_v)ρ²; not the step length, the solves' tolerances or
    /// Eq. 22), and the peak is the largest fluctuation: above the experiment's band at every
    /// resolution of the study and growing (135.7 → 144.2 → 252.1 mbar; docs/VALIDATION.md,
    /// "Impact pressure: resolution study"), while the mean over the impact settles.
    /// The wall's load behind the sensor fluctuates with it (157.9 → 276.3 → 181.9 mbar), while
    /// its impulse at H = 600 mm is within ±10 % of the median at every resolution (+0.1, +2.5,
    /// +8.3 %; "What a sensor reads").
    fn known_limitation(check: &str, per_h: usize) -> Option<&'static str> {
        let peak = check == Check::ImpactPeak { per_h }.name()
            || check == Check::WallPeak { per_h }.name();
        let growth =
            check == Check::ImpactPeakGrowth.name() || check == Check::WallPeakGrowth.name();
        (peak || growth).then_some(
            "DFSPH's wall pressure fluctuates through the impact and its peak is the largest fluctuation; the impulse of the wall's load is the check",
        )
    }
}
