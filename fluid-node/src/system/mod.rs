//! What every SPH solver here shares: the particles and their grid, the wall particles, the
//! Eq. 22 coupling with the blocks, the instruments, the stability checks and the frame output.
//! A method ([`crate::methods::SphMethod`]) adds its own force evaluation and integrator;
//! [`crate::sph::Sph`] joins the two into a solver. The folder: this file is the system and its
//! step (`prepare_bodies`, `apply_coupling_forces`, `end_step`), `setup.rs` what it is built
//! from and its parts built along their seams, `checkpoint.rs` its saved state.

use crate::boundary::Boundary;
use crate::boundary::penalty::Penalty;
use crate::boundary::terrain::TerrainPenalty;
use crate::core::grid::CellGrid;
use crate::core::neighbors::NeighborLists;
use crate::core::particles::{Carried, Particles};
use crate::core::phases::{Phase, PhaseClock};
use crate::instruments::gauges::{FluidView, Recorder};
use crate::instruments::survey::{Rules, Survey};
use crate::instruments::wall_load::WallLoads;
use crate::kernels::Kernel;
use crate::ranks::comm::Comm;
use crate::ranks::share::Share;
use rayon::prelude::*;
use shared::math::{Real, Vector};
use shared::protocol::{BlockLoad, BlockState};
use shared::scene::VtkFormat;
use shared::solver::{SetupContext, SolverError};
use std::path::PathBuf;
use std::sync::Arc;

// A child module: a checkpoint saves and restores the system's private state.
pub(crate) mod checkpoint;
mod setup;

use setup::Eq22;
pub use setup::{Initial, Layout};

/// A frame's positions and velocities, and its densities and pressures.
type FrameColumns<'a> = (Vec<[f64; 3]>, Vec<[f64; 3]>, &'a [Real], &'a [Real]);

/// Per-step state shared by the solvers.
pub struct FluidSystem {
    pub solver: &'static str,
    pub particles: Particles,
    pub grid: CellGrid,
    /// Fluid neighbours of each fluid particle (itself excluded): rebuilt at every sort.
    pub fluid_lists: NeighborLists,
    /// The blocks' boundary particles and the fluid's neighbours among them (fixed part listed at
    /// every sort, moving part after every sort and every new pose).
    pub boundary: Boundary,
    pub penalty: Penalty,
    /// Eq. 22 against the terrain's triangles (the backstop of its boundary particles).
    pub terrain: TerrainPenalty,
    recorder: Recorder,
    /// The probes whose face reads the wall: their boundary particles and last readings.
    wall_loads: WallLoads,
    pub dx: Real,
    pub mass: Real,
    pub rest_density: Real,
    pub gravity: Vector,
    pub density_bound: Real,
    domain: (Vector, Vector),
    /// `[domain] open_top`: water above the top flies on (see [`Self::end_step`]).
    open_top: bool,
    /// Particles above the domain's top at the end of the last step.
    aloft: usize,
    /// A warning of the last step for the step's report ([`Self::take_warning`]).
    warning: Option<String>,
    run_dir: PathBuf,
    /// Encoding of the particle frames (`output.vtk_format`).
    vtk_format: VtkFormat,
    pub time: Real,
    pub steps: u64,
    grid_valid: bool,
    bodies_valid: bool,
    /// How far beyond the kernel support the grid and the lists reach [m].
    skin: Real,
    /// Positions at the last sort: the lists are those of these positions.
    sorted_at: Vec<Vector>,
    /// The particle arrays the scheme reads across a sort.
    carried: Carried,
    /// Sorts (list rebuilds) so far.
    pub sorts: u64,
    /// Whether the coming step's coupling forces are computed ([`Self::apply_coupling_forces`]):
    /// false after a new pose, a step or a restore.
    prepared: bool,
    /// The Eq. 22 load on each moving block for the step under way (what a scheme that moves
    /// the blocks within its step adds to their motion).
    pub penalty_loads: Vec<BlockLoad>,
    /// Whether the loads may be those of the step just taken (the parallel scheme: the
    /// runtime can send them after the step, and the solid then waits for them). In the serial
    /// scheme the fluid's step starts from the solid's next pose: a scheme cannot move the
    /// blocks within it.
    pub loads_may_follow_step: bool,
    /// Wall time per phase of the steps, off unless a caller turns it on (`fluid-bench
    /// --phases`); the scheme times its own phases on it too.
    pub phases: PhaseClock,
    /// This rank's share of the water when the fluid runs on several ranks (`crate::ranks`).
    pub share: Option<Share>,
}

impl FluidSystem {
    /// Builds the system from the filled scene as the scheme's `layout` asks: its support is
    /// the neighbour radius, its sound speed sets the default Eq. 22 stiffness, its skin ratio
    /// the Verlet skin of the lists over the support.
    /// The particles are not sorted yet: [`Self::prepare`] does it, once every rank has come
    /// this far.
    ///
    /// With `ranks` (more than one), this rank keeps its slab and halo of the water, and only
    /// rank 0 writes files.
    pub fn new(
        ctx: &SetupContext,
        solver: &'static str,
        init: &Initial,
        layout: Layout,
        ranks: Option<Arc<dyn Comm>>,
    ) -> Result<Self, SolverError> {
        let Layout {
            density,
            support: cell,
            sound_speed,
            skin_ratio,
            poly6_sums,
            carried,
        } = layout;
        assert!(
            !poly6_sums || skin_ratio == 0.0,
            "poly6 sums need lists rebuilt every step"
        );
        let scene = ctx.scene;
        let fluid = &init.fluid;
        let dx = fluid.dx;
        let mass = fluid.density * dx.powi(3);
        let lo = Vector::from(scene.domain.min);
        let hi = Vector::from(scene.domain.max);
        // Verlet lists: the grid and the lists reach one skin beyond the kernel support, so
        // they stay valid until a particle has moved half the skin (see `end_step`).
        let skin = skin_ratio * cell;
        let mut grid = CellGrid::new(lo, hi, cell + skin).map_err(SolverError::Failed)?;
        grid.set_stale_reach(0.5 * skin);
        let eq22 = Eq22::of(scene, fluid, sound_speed, mass);
        let penalty = eq22.penalty(scene, init);
        let bodies = setup::body_particles(scene, init, cell, &grid);
        let fixed = setup::wall_particles(scene, init, cell, (lo, hi), &grid);
        let terrain = eq22.terrain(init);
        let lead = ranks.as_ref().is_none_or(|c| c.rank() == 0);
        let recorder = setup::recorder(ctx, init, lead)?;
        let wall_loads =
            setup::wall_loads(scene, init, fixed.as_ref(), cell, (ranks.is_none(), lead))?;
        // The outer halo column holds the cells next to the fixed walls, or all of it when
        // blocks move (their particles move between sorts).
        let walls = match (&bodies, &fixed) {
            (Some(_), _) => None,
            (None, Some(w)) => Some(&w.position[..]),
            (None, None) => Some(&[][..]),
        };
        let mut share = ranks
            .map(|c| Share::new(c, &grid, init.fill.positions.len(), walls))
            .transpose()
            .map_err(SolverError::Failed)?;
        // On several ranks, only this rank's slab and halo of the filled water become particles.
        let (positions, density) = match &mut share {
            None => (init.fill.positions.clone(), density),
            Some(s) => {
                let all = &init.fill.positions;
                let keep = s.first_cut(&grid, all).map_err(SolverError::Failed)?;
                (
                    keep.iter().map(|&i| all[i]).collect(),
                    keep.iter().map(|&i| density[i]).collect(),
                )
            }
        };
        let sys = Self {
            solver,
            particles: Particles::new(positions, density),
            grid,
            fluid_lists: {
                let mut lists = NeighborLists::default();
                if poly6_sums {
                    lists.sum_poly6(cell);
                }
                lists
            },
            boundary: Boundary::new(fixed, bodies),
            penalty,
            terrain,
            recorder,
            wall_loads,
            dx,
            mass,
            rest_density: fluid.density,
            gravity: init.gravity,
            density_bound: fluid.density_ratio_bound,
            domain: (lo, hi),
            open_top: scene.domain.open_top,
            aloft: 0,
            warning: None,
            run_dir: ctx.run_dir.to_path_buf(),
            vtk_format: scene.output.vtk_format,
            time: 0.0,
            steps: 0,
            grid_valid: false,
            bodies_valid: false,
            skin,
            sorted_at: Vec::new(),
            carried,
            sorts: 0,
            prepared: false,
            penalty_loads: Vec::new(),
            loads_may_follow_step: ctx.scheme == shared::scene::CouplingScheme::Parallel,
            phases: PhaseClock::default(),
            share,
        };
        sys.check_domain()?;
        if lead {
            sys.write_counts()?;
        }
        Ok(sys)
    }

    /// Particles this rank holds (its own and its halo on several ranks).
    pub fn len(&self) -> usize {
        self.particles.len()
    }

    /// Particles on all ranks.
    pub fn global_len(&self) -> usize {
        self.share
            .as_ref()
            .map_or(self.particles.len(), |s| s.global_len)
    }

    /// Every particle's position, velocity, density and pressure as bits, in one-rank order,
    /// on rank 0 (None on the others; every rank must call it): what the rank tests compare.
    pub fn gathered_bits(&self) -> Option<Vec<[u64; 8]>> {
        let p = &self.particles;
        let values = |i: usize| {
            let (x, v) = (p.position[i], p.velocity[i]);
            [x.x, x.y, x.z, v.x, v.y, v.z, p.density[i], p.pressure[i]]
        };
        let all: Vec<[Real; 8]> = match &self.share {
            None => (0..p.len()).map(values).collect(),
            Some(share) => share.gather(values)?,
        };
        Some(all.iter().map(|a| a.map(f64::to_bits)).collect())
    }

    /// Which particles this rank computes the rates of: None on one rank (all of them).
    pub fn owned(&self) -> Option<&[bool]> {
        self.share.as_ref().map(|s| &s.owned[..])
    }

    /// After an evaluation of the rates on several ranks: the halo's rates from their owners
    /// (nothing on one rank).
    pub fn share_rates(&mut self) {
        if let Some(s) = &mut self.share {
            let t = self.phases.start();
            let p = &mut self.particles;
            s.share_rates(&mut p.acceleration, &mut p.density_rate);
            self.phases.stop(Phase::Halo, t);
        }
    }

    /// Writes `fluid.json` in the run directory: the particle counts the coupler puts in
    /// `summary.json` (they are fixed for the run: particles carry fixed masses).
    fn write_counts(&self) -> std::io::Result<()> {
        let (fixed, moving) = self.boundary.counts();
        let text = format!(
            "{{\n  \"solver\": \"{}\",\n  \"particles\": {},\n  \"boundary_particles_fixed\": {fixed},\n  \"boundary_particles_moving\": {moving},\n  \"dx\": {}\n}}\n",
            self.solver,
            self.global_len(),
            self.dx
        );
        std::fs::write(self.run_dir.join("fluid.json"), text)
    }

    pub fn is_empty(&self) -> bool {
        self.particles.is_empty()
    }

    /// Pairs in the neighbour lists: (fluid–fluid, fluid–boundary). Every pair a force pass
    /// visits is one of them (benchmarks report them per particle).
    pub fn listed_pairs(&self) -> (usize, usize) {
        (self.fluid_lists.pairs(), self.boundary.listed_pairs())
    }

    /// On several ranks: the start of this rank's work on a step (its time, outside messages,
    /// is what the cuts balance); false if a step is begun already or there is one rank.
    pub fn begin_busy(&mut self) -> bool {
        self.share.as_mut().is_some_and(Share::begin_busy)
    }

    /// The end of the work [`Self::begin_busy`] began.
    pub fn end_busy(&mut self) {
        if let Some(s) = &mut self.share {
            s.end_busy();
        }
    }

    /// Sorts the particles by cell and lists their neighbours, if they moved since the last sort.
    pub fn prepare(&mut self) {
        if !self.grid_valid {
            let t = self.phases.start();
            if let Some(s) = &mut self.share {
                // The cuts were checked at set-up: a failure here is a broken invariant.
                s.redistribute(&mut self.particles, &self.grid, &self.sorted_at)
                    .expect("the slabs fit the grid");
            }
            let t = self.phases.lap(Phase::Halo, t);
            let order = self.grid.sort(&self.particles.position);
            let t = self.phases.lap(Phase::Sort, t);
            self.particles
                .permute(order, self.carried, &mut self.sorted_at);
            let t = self.phases.lap(Phase::Permutation, t);
            self.sorts += 1;
            self.list_sorted(t);
            // The first cuts followed the particle counts: cut again by the work at once (the
            // particles have not moved: the one-rank order and every bit stay; not counted as
            // a sort of the run).
            if self.share.as_mut().is_some_and(Share::recut_at_start) {
                self.grid_valid = false;
                self.sorts -= 1;
                self.prepare();
            }
        }
    }

    /// The grid and lists of the last sort, rebuilt from the positions then (after a restart:
    /// the particles are in that sort's order, so sorting those positions is the identity).
    fn relist_as_sorted(&mut self) -> Result<(), SolverError> {
        let order = self.grid.sort(&self.sorted_at);
        if order.iter().enumerate().any(|(k, &i)| k != i as usize) {
            return Err(SolverError::Failed(
                "the checkpoint's particles are not in the order of their last sort: the file is damaged or from another build".into(),
            ));
        }
        self.list_sorted(self.phases.start());
        Ok(())
    }

    /// After a sort (the grid's ranges and `sorted_at` are those of the sorted particles): on
    /// several ranks the keys, ownership and halo links, then the fluid and wall lists of the
    /// positions at the sort, and the ranks' work. `t`: the phase clock's lap start.
    fn list_sorted(&mut self, t: Option<std::time::Instant>) {
        if let Some(s) = &mut self.share {
            s.after_sort(self.grid.last_order(), &self.grid, &self.sorted_at);
        }
        let (pos, radius) = (&self.sorted_at, self.grid.radius());
        let owned = self.share.as_ref().map(|s| &s.owned[..]);
        self.fluid_lists
            .build_for(pos, pos, &self.grid, radius, true, owned);
        let t = self.phases.lap(Phase::FluidLists, t);
        self.boundary.list_fixed(pos, &self.grid, radius, owned);
        self.phases.stop(Phase::WallLists, t);
        if let Some(s) = &mut self.share {
            s.measure_work(&self.fluid_lists, &self.boundary, &self.grid, pos)
                .expect("the slabs fit the grid");
        }
        self.grid_valid = true;
        self.bodies_valid = false;
    }

    /// [`Self::prepare`], then the fluid's neighbours among the moving blocks' boundary
    /// particles, if the fluid or the blocks moved since they were listed.
    pub fn prepare_bodies(&mut self) {
        self.prepare();
        if !self.bodies_valid {
            let t = self.phases.start();
            let (pos, radius) = (&self.particles.position, self.grid.radius());
            self.boundary.list_moving(pos, &self.grid, radius);
            self.phases.stop(Phase::WallLists, t);
            self.bodies_valid = true;
        }
    }

    /// Takes the moving blocks' poses and velocities, and carries their boundary particles.
    pub fn read_geometry(&mut self, blocks: &[BlockState]) {
        self.penalty.set_moving(blocks);
        self.boundary.place(blocks);
        self.penalty_loads
            .resize(blocks.len(), BlockLoad::default());
        self.bodies_valid = false;
        self.prepared = false;
    }

    /// The coupling forces of the coming step at the current particles and poses: the grid and
    /// lists made current ([`Self::prepare_bodies`]), paper Eq. 22 on the particles with its
    /// reaction on each moving block (into [`Self::penalty_loads`]), and Eq. 22 against the
    /// terrain. Called once per step, after the method's [`crate::methods::SphMethod::react`]
    /// when the loads are those of the state the step starts from ([`crate::sph::Sph`]).
    pub fn apply_coupling_forces(&mut self) {
        self.prepare_bodies();
        let t = self.phases.start();
        let loads = Some(&mut self.penalty_loads[..]).filter(|l| !l.is_empty());
        let split = self.share.as_ref();
        self.penalty
            .apply(&mut self.particles, &self.grid, loads, split);
        self.terrain.apply(&mut self.particles, &self.grid);
        self.phases.stop(Phase::Penalty, t);
        self.prepared = true;
    }

    /// Whether [`Self::apply_coupling_forces`] ran since the last pose, step or restore.
    pub fn is_prepared(&self) -> bool {
        self.prepared
    }

    /// The loads on the moving blocks of the coming step, from [`Self::apply_coupling_forces`]
    /// and the method's [`crate::methods::SphMethod::react`] before it: the Eq. 22 reaction plus
    /// the water's pressure on the blocks' boundary particles.
    pub fn write_loads(&mut self, loads: &mut [BlockLoad]) {
        let t = self.phases.start();
        loads.clone_from_slice(&self.penalty_loads);
        self.boundary.add_loads(loads);
        self.phases.stop(Phase::BlockLoads, t);
    }

    /// Reads the probes whose face reads the wall, before [`Self::end_step`] samples them:
    /// `forces(sys, i, visit)` is the method's wall term on fluid particle i
    /// ([`crate::methods::SphMethod::fixed_wall_forces`]).
    pub fn read_wall_loads(
        &mut self,
        forces: impl Fn(&FluidSystem, usize, &mut dyn FnMut(usize, Vector)),
    ) {
        let Some(walls) = self.boundary.fixed() else {
            return;
        };
        if self.wall_loads.is_empty() {
            return;
        }
        let t = self.phases.start();
        let mut loads = std::mem::take(&mut self.wall_loads);
        let p = &self.particles;
        loads.read(
            walls,
            &self.grid,
            self.share.as_ref(),
            &p.position,
            &p.penalty,
            |i, visit| forces(self, i, visit),
        );
        self.wall_loads = loads;
        self.phases.stop(Phase::Gauges, t);
    }

    /// After the particles moved by `dt`: checks stability, re-sorts and samples the
    /// instruments; returns the largest speed and acceleration (for the next step's proposal).
    /// `check_low_density` is false for summed densities, which are low at a free surface by
    /// construction: there only compression is an instability.
    pub fn end_step<K: Kernel>(
        &mut self,
        dt: Real,
        kernel: &K,
        check_low_density: bool,
        reference_density: Real,
    ) -> Result<(Real, Real), SolverError> {
        self.time += dt;
        self.steps += 1;
        self.prepared = false;
        // Keep the lists while every pair within the support at the next evaluation is surely
        // in them: a listed pair was closer than support + skin at the sort, so it suffices
        // that no particle moves half the skin from its sorted position before then. The next
        // step's move is bounded by twice this step's (|v|·dt, doubled for the speed-up and a
        // longer step).
        let t = self.phases.start();
        let p = &self.particles;
        let mut survey = Survey::of(
            &p.position,
            &p.velocity,
            &p.acceleration,
            &p.density,
            &self.sorted_at,
            self.share.as_ref().map(|s| &s.owned[..]),
            &Rules {
                domain: self.domain,
                open_top: self.open_top,
                density_bound: self.density_bound,
                reference_density,
                check_low_density,
                reach: 0.5 * self.skin,
                dt,
            },
        );
        self.phases.stop(Phase::Survey, t);
        let failure = self.failure(&survey, reference_density);
        if let Some(s) = &self.share {
            // In one message: whether a rank failed, the maxima and the sort over all ranks
            // (exact: maxima do not round), whether water is aloft anywhere.
            let flag = |b: bool| b as u8 as Real;
            let mut m = [
                flag(failure.is_some()),
                survey.v_max,
                survey.a_max,
                flag(survey.moved),
                flag(survey.aloft > 0),
            ];
            s.comm().max(&mut m);
            if m[0] > 0.0 {
                return Err(self.agree(failure).expect("a rank failed"));
            }
            (survey.v_max, survey.a_max, survey.moved) = (m[1], m[2], m[3] > 0.0);
            survey.aloft = 0;
            if m[4] > 0.0 {
                // The water aloft counted by its owners.
                let top = self.domain.1.z;
                let mut aloft = [p
                    .position
                    .iter()
                    .zip(&s.owned)
                    .filter(|(x, o)| **o && x.z > top)
                    .count() as u64];
                s.comm().sum(&mut aloft);
                survey.aloft = aloft[0] as usize;
            }
        } else if let Some(failure) = failure {
            return Err(failure);
        }
        // Water above an open top is a splash's spray: it stays SPH water (the grid keeps it in
        // its top layer of cells, where the pair loops measure true distances), meets no wall
        // (validation refuses blocks and terrain above an open top), and falls back. Said when
        // water rises there after none was.
        if survey.aloft > 0 && self.aloft == 0 {
            self.warning = Some(format!(
                "{}: {} particle(s) ({:.3} % of the water) thrown above the open domain top z = {} m at t = {:.4} s: spray that meets no wall up there until it falls back",
                self.solver,
                survey.aloft,
                100.0 * survey.aloft as Real / self.global_len() as Real,
                self.domain.1.z,
                self.time
            ));
        }
        self.aloft = survey.aloft;
        if survey.moved || self.skin == 0.0 {
            self.grid_valid = false;
        }
        self.bodies_valid = false;
        if let Some(s) = &mut self.share {
            s.step_done();
        }
        self.prepare();
        let t = self.phases.start();
        let view = FluidView {
            particles: &self.particles,
            grid: &self.grid,
            kernel,
            mass: self.mass,
            rest_density: self.rest_density,
            dx: self.dx,
            wall_loads: &self.wall_loads.loads,
        };
        self.recorder
            .sample(self.time, &view, self.share.as_ref())?;
        self.phases.stop(Phase::Gauges, t);
        Ok((survey.v_max, survey.a_max))
    }

    /// The instability the survey of a step found on this rank, if any: a non-finite value
    /// first, then a particle outside the domain, then a density past the bound.
    fn failure(&self, survey: &Survey, reference_density: Real) -> Option<SolverError> {
        let p = &self.particles;
        if let Some(i) = survey.not_finite {
            return Some(SolverError::Unstable(format!(
                "{}: NaN/inf limit exceeded: particle {i} has position {:?}, velocity {:?}, density {}",
                self.solver,
                p.position[i].as_slice(),
                p.velocity[i].as_slice(),
                p.density[i]
            )));
        }
        if let Some(i) = survey.outside {
            return Some(self.outside_domain(i));
        }
        let i = survey.density?;
        let (q, b) = (p.density[i] / reference_density, self.density_bound);
        let (what, bound) = if q > b {
            ("exceeds", b)
        } else {
            ("is below", 1.0 / b)
        };
        Some(SolverError::Unstable(format!(
            "{}: density ratio limit exceeded: ρ/ρ0 = {q:.4} {what} the bound {bound:.4} at particle {i}",
            self.solver
        )))
    }

    /// On several ranks, once some rank failed: the instability rank 0 names (the lowest
    /// failing rank's), every rank calling it; on one, `failure`.
    fn agree(&self, failure: Option<SolverError>) -> Option<SolverError> {
        let Some(s) = &self.share else {
            return failure;
        };
        let message = failure.map(|e| match e {
            SolverError::Unstable(m) | SolverError::Failed(m) => m,
        });
        Some(SolverError::Unstable(s.name_failure(message)))
    }

    /// The last step's warning, if any (taken: said once).
    pub fn take_warning(&mut self) -> Option<String> {
        self.warning.take()
    }

    /// Particles above the domain's top now.
    pub fn count_aloft(&self) -> usize {
        let top = self.domain.1.z;
        self.particles
            .position
            .par_iter()
            .filter(|x| x.z > top)
            .count()
    }

    /// The instability a particle outside the domain is (checked at set-up too).
    fn check_domain(&self) -> Result<(), SolverError> {
        let (lo, hi) = self.domain;
        match self
            .particles
            .position
            .par_iter()
            .position_first(|x| (0..3).any(|k| x[k] < lo[k] || x[k] > hi[k]))
        {
            Some(i) => Err(self.outside_domain(i)),
            None => Ok(()),
        }
    }

    fn outside_domain(&self, i: usize) -> SolverError {
        let (lo, hi) = self.domain;
        let x = self.particles.position[i];
        SolverError::Unstable(format!(
            "{}: domain limit exceeded: particle {i} at ({:.4}, {:.4}, {:.4}) m left the domain [{:?}, {:?}]",
            self.solver,
            x.x,
            x.y,
            x.z,
            lo.as_slice(),
            hi.as_slice()
        ))
    }

    /// `particles_{frame:05}.vtp` with density, pressure and velocity. On several ranks rank
    /// 0 gathers the particles in one-rank order and writes the one file.
    pub fn write_frame(&mut self, frame: u32) -> Result<(), SolverError> {
        self.recorder.flush()?;
        let p = &self.particles;
        let three = |x: &Vector| [x.x, x.y, x.z];
        let gathered;
        let (pos, vel, density, pressure): FrameColumns<'_> = match &self.share {
            None => (
                p.position.iter().map(three).collect(),
                p.velocity.iter().map(three).collect(),
                &p.density,
                &p.pressure,
            ),
            Some(s) => {
                let Some(all) = s.gather(|i| {
                    let (x, v) = (p.position[i], p.velocity[i]);
                    [x.x, x.y, x.z, v.x, v.y, v.z, p.density[i], p.pressure[i]]
                }) else {
                    return Ok(());
                };
                gathered = (
                    all.iter().map(|a| a[6]).collect::<Vec<_>>(),
                    all.iter().map(|a| a[7]).collect::<Vec<_>>(),
                );
                (
                    all.iter().map(|a| [a[0], a[1], a[2]]).collect(),
                    all.iter().map(|a| [a[3], a[4], a[5]]).collect(),
                    &gathered.0,
                    &gathered.1,
                )
            }
        };
        let path = self.run_dir.join(format!("particles_{frame:05}.vtp"));
        shared::vtk::write_particles(
            &path,
            &pos,
            &[("density", density), ("pressure", pressure)],
            &[("velocity", &vel)],
            self.vtk_format,
        )?;
        Ok(())
    }

    pub fn finish(&mut self) -> Result<(), SolverError> {
        self.recorder.flush()?;
        Ok(())
    }
}
