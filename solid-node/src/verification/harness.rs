//! Driving one solver alone, as the coupler would, in a temporary run directory.

use crate::dda::DdaSolver;
use crate::world::World;
use shared::coupling::step::{StepRule, grant};
use shared::math::Real;
use shared::scene::{CouplingScheme, Scene};
use shared::solver::{SetupContext, Solver, SolverError};

/// The central difference scheme's registry name: the cases whose reference is that scheme's
/// own (its limit 2/ω_max, paper Eq. 8; its restitution and period) choose by it.
pub const EXPLICIT: &str =
    <crate::integrators::explicit::CentralDifference as crate::integrators::DdaMethod>::NAME;

/// Shi's implicit scheme's registry name: for the studies of its own numerical damping (its
/// restitution against [`super::newmark_restitution`], paper Eq. 4), as [`EXPLICIT`] is for
/// the central difference's.
pub const IMPLICIT: &str =
    <crate::integrators::implicit::Implicit as crate::integrators::DdaMethod>::NAME;

/// A solver with its own temporary run directory (removed on drop).
pub struct Harness {
    pub solver: DdaSolver,
    /// The scene's step limits, as the coupler applies them.
    pub rule: StepRule,
    /// Removed on drop, also when the solver could not be built.
    dir: tempfile::TempDir,
}

impl Harness {
    pub fn new(scene: &Scene, solver: &str) -> Result<Harness, SolverError> {
        let dir = tempfile::Builder::new()
            .prefix("rockwave-solid-")
            .tempdir()?;
        let ctx = SetupContext {
            scene,
            run_dir: dir.path(),
            scheme: CouplingScheme::Parallel,
            peer_present: false,
        };
        let solver = *crate::REGISTRY.build(solver, &ctx)?;
        let rule = StepRule::new(scene.time.dt_max, scene.time.dt_min);
        Ok(Harness { solver, rule, dir })
    }

    pub fn world(&self) -> &World {
        &self.solver.world
    }

    pub fn time(&self) -> Real {
        self.solver.world.time
    }

    pub fn run_dir(&self) -> &std::path::Path {
        self.dir.path()
    }

    /// One step towards `target`, granted by the coupler's rule ([`shared::coupling::step::grant`]: the
    /// proposal within `rule`'s limits, times its `dt_factor`, landing on `target`); returns the
    /// step taken. A collapsed proposal is an instability.
    pub fn step(&mut self, rule: &StepRule, target: Real) -> Result<Real, SolverError> {
        let proposal = [(self.solver.name(), self.solver.dt_proposal())];
        let dt = grant(proposal, rule, self.time(), target)
            .map(|g| g.dt)
            .map_err(|c| SolverError::Unstable(format!("step collapsed: {c}")))?;
        self.solver.advance(dt)?;
        Ok(dt)
    }

    /// Advances to `t_end` the way the coupler does ([`Self::step`] with the scene's limits),
    /// or with a fixed `dt`; calls `each` after every step.
    pub fn run_until(
        &mut self,
        t_end: Real,
        dt: Option<Real>,
        mut each: impl FnMut(&World),
    ) -> Result<(), SolverError> {
        let rule = self.rule;
        while self.time() < t_end - 1e-12 {
            match dt {
                Some(dt) => {
                    self.solver.advance(dt.min(t_end - self.time()))?;
                }
                None => {
                    self.step(&rule, t_end)?;
                }
            }
            each(&self.solver.world);
        }
        Ok(())
    }

    pub fn block(&self, name: &str) -> &crate::blocks::block::Block {
        let i = self.solver.block_index(name).expect("block exists");
        &self.solver.world.blocks[i]
    }
}
