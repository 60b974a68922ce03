//! Any [`SphMethod`] as a coupled solver: [`Sph`] implements the coupling interface
//! ([`Solver`], [`FluidSolver`]) once, for every method.
//!
//! One fluid step, in the order the runtime calls it (`shared::solver`):
//! 1. [`FluidSolver::read_geometry`]: the moving blocks' new poses (when a solid node runs);
//! 2. [`FluidSolver::prepare_step`]: the coupling forces of the coming step at the current
//!    particles and poses: the method's [`SphMethod::react`] (the water's pressure on the
//!    blocks' boundary particles, unless the method's loads follow its step), then paper
//!    Eq. 22 on the particles and its reaction on the blocks
//!    ([`FluidSystem::apply_coupling_forces`]);
//! 3. [`FluidSolver::write_loads`]: those loads, summed per block (nothing is computed there);
//! 4. [`Solver::advance`]: the method's step, then the system's checks, re-sort and
//!    instruments ([`FluidSystem::end_step`]);
//! 5. with [`FluidSolver::loads_follow_step`], [`FluidSolver::write_loads`] after the step
//!    instead of before: the forces the method moved the blocks with.
//!
//! A caller that drives the solver by [`Solver::advance`] alone (no loads to write) may skip
//! step 2: `advance` does it when it was not done since the last pose or step.

use crate::core::phases::{Phase, PhaseClock};
use crate::methods::SphMethod;
use crate::ranks::comm::Comm;
use crate::system::{FluidSystem, Initial};
use shared::math::Real;
use shared::protocol::{BlockLoad, BlockState};
use shared::registry::solver_params;
use shared::solver::{FluidSolver, SetupContext, Solver, SolverError, StepReport};
use std::sync::Arc;

/// An SPH solver: the shared system and one method.
pub struct Sph<S: SphMethod> {
    pub sys: FluidSystem,
    pub method: S,
    dt_next: Real,
}

/// A fluid solver whose particles the validation, benchmarks and sweeps can look at (`Send`:
/// their loops run on a rayon worker, [`crate::validation::run`]).
pub trait SphSolver: FluidSolver + Send {
    fn system(&self) -> &FluidSystem;
    /// The system's phase clock, to turn it on and reset it (`fluid-bench --phases`; it is read
    /// through [`Self::system`]).
    fn phases_mut(&mut self) -> &mut PhaseClock;
}

impl<S: SphMethod> Sph<S> {
    /// Fills the scene's water and builds the method from its table `[fluid.<S::NAME>]`, on the
    /// ranks this process is one of ([`crate::ranks::current`]), if several.
    pub fn new(ctx: &SetupContext) -> Result<Self, SolverError> {
        Self::on_ranks(ctx, crate::ranks::current())
    }

    /// [`Self::new`] as one of `ranks` (one rank when None).
    pub fn on_ranks(ctx: &SetupContext, ranks: Option<Arc<dyn Comm>>) -> Result<Self, SolverError> {
        if let Some(c) = &ranks
            && !S::SPLITS
        {
            return Err(SolverError::Failed(format!(
                "the fluid solver '{}' does not run on several ranks yet ({} ranks asked): use a solver that does (every built-in one), or one rank",
                S::NAME,
                c.size()
            )));
        }
        let built = (|| {
            let init = Initial::from_scene(ctx.scene)?;
            let params = solver_params::<S::Params>(&init.fluid.solvers, "fluid", S::NAME)?;
            let (method, layout) = S::new(params, &init)?;
            let sys = FluidSystem::new(ctx, S::NAME, &init, layout, ranks.clone())?;
            Ok::<_, SolverError>((init, method, sys))
        })();
        // On several ranks all fail if one did (a file one host cannot read, a run directory
        // rank 0 cannot write): the sort below is the ranks' first exchange.
        let failed = |c: &Arc<dyn Comm>, yes: bool| crate::ranks::any(&**c, yes);
        let (init, mut method, mut sys) = match (built, &ranks) {
            (Ok(b), Some(c)) if failed(c, false) => {
                drop(b);
                return Err(SolverError::Failed(
                    "another fluid rank failed to set up; its message is on its standard error"
                        .into(),
                ));
            }
            (Err(e), Some(c)) => {
                failed(c, true);
                return Err(e);
            }
            (b, _) => b?,
        };
        sys.prepare();
        method.start(&mut sys);
        let dt_next = method.dt_proposal(0.0, init.gravity.norm());
        Ok(Self {
            sys,
            method,
            dt_next,
        })
    }
}

impl<S: SphMethod> SphSolver for Sph<S> {
    fn system(&self) -> &FluidSystem {
        &self.sys
    }

    fn phases_mut(&mut self) -> &mut PhaseClock {
        &mut self.sys.phases
    }
}

impl<S: SphMethod> Solver for Sph<S> {
    fn name(&self) -> &str {
        S::NAME
    }

    fn dt_proposal(&self) -> Real {
        self.dt_next
    }

    fn advance(&mut self, dt: Real) -> Result<StepReport, SolverError> {
        let busy = self.sys.begin_busy();
        if !self.sys.is_prepared() {
            self.prepare_step();
        }
        let mut report = self.method.step(&mut self.sys, dt)?;
        let method = &self.method;
        self.sys
            .read_wall_loads(|sys, i, visit| method.fixed_wall_forces(sys, i, visit));
        let (low, reference) = self.method.density_check();
        let (v, a) = self
            .sys
            .end_step(dt, self.method.kernel(), low, reference)
            .map_err(|e| match (e, self.method.unstable_hint()) {
                (SolverError::Unstable(m), Some(hint)) => {
                    SolverError::Unstable(format!("{m}; {hint}"))
                }
                (e, _) => e,
            })?;
        self.dt_next = self.method.dt_proposal(v, a);
        if busy {
            self.sys.end_busy();
        }
        if let Some(w) = self.sys.take_warning() {
            report.warning = Some(match report.warning {
                Some(own) => format!("{own}; {w}"),
                None => w,
            });
        }
        Ok(report)
    }

    fn write_frame(&mut self, frame: u32, _time: Real) -> Result<(), SolverError> {
        self.sys.write_frame(frame)
    }

    fn finish(&mut self) -> Result<(), SolverError> {
        self.sys.finish()
    }

    fn save_state(&mut self) -> Result<Vec<u8>, SolverError> {
        crate::system::checkpoint::save(&mut self.sys, &self.method, self.dt_next)
    }

    fn restore_state(
        &mut self,
        state: &[u8],
        run_dir: &std::path::Path,
    ) -> Result<(), SolverError> {
        self.dt_next =
            crate::system::checkpoint::restore(&mut self.sys, &mut self.method, state, run_dir)?;
        Ok(())
    }
}

impl<S: SphMethod> FluidSolver for Sph<S> {
    fn read_geometry(&mut self, blocks: &[BlockState], _vertices: &[[f64; 3]]) {
        self.sys.read_geometry(blocks);
    }

    fn loads_follow_step(&self) -> bool {
        self.method.loads_follow_step(&self.sys)
    }

    fn prepare_step(&mut self) {
        let busy = self.sys.begin_busy();
        self.sys.prepare_bodies();
        if !self.method.loads_follow_step(&self.sys) {
            // The water's pressure on the moving blocks' boundary particles at the current
            // state: the fluid pressures of the last step's end, the wall pressures
            // extrapolated at the new pose.
            let t = self.sys.phases.start();
            self.method.react(&mut self.sys);
            self.sys.phases.stop(Phase::BlockLoads, t);
        }
        self.sys.apply_coupling_forces();
        if busy {
            self.sys.end_busy();
        }
    }

    fn write_loads(&mut self, loads: &mut [BlockLoad]) {
        if self.method.loads_follow_step(&self.sys) {
            // Called after the step: the forces the method moved the blocks with.
            let t = self.sys.phases.start();
            self.method.step_loads(&self.sys, loads);
            self.sys.phases.stop(Phase::BlockLoads, t);
            return;
        }
        debug_assert!(
            loads.is_empty() || self.sys.is_prepared(),
            "write_loads before prepare_step: the loads would be those of the last step"
        );
        self.sys.write_loads(loads);
    }
}
