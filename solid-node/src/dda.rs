//! The solid node's solver: a block system advanced by one of the integrators, behind the
//! coupling interface ([`SolidSolver`]): loads in, geometry out, outputs on request.

use crate::energy::EnergyMonitor;
use crate::integrator::Integrator;
use crate::output::{self, KinematicsCsv};
use crate::world::World;
use shared::math::{Real, Vector};
use shared::protocol::{BlockLoad, BlockState};
use shared::solver::{SetupContext, SolidSolver, Solver, SolverError, StepReport};
use std::path::PathBuf;

pub struct DdaSolver {
    pub world: World,
    integrator: Box<dyn Integrator>,
    pub energy: EnergyMonitor,
    run_dir: PathBuf,
    csv: KinematicsCsv,
    vtk: bool,
}

impl DdaSolver {
    pub fn new(
        ctx: &SetupContext,
        mut integrator: Box<dyn Integrator>,
    ) -> Result<DdaSolver, SolverError> {
        let mut world = World::new(ctx.scene)?;
        world.detect(world.penalty.margin);
        integrator.init(&mut world);
        let energy = EnergyMonitor::new(&world);
        let mut csv = KinematicsCsv::create(ctx.run_dir, ctx.scene.output.interval)?;
        csv.sample(&world, true)?;
        Ok(DdaSolver {
            world,
            integrator,
            energy,
            run_dir: ctx.run_dir.to_path_buf(),
            csv,
            vtk: ctx.scene.output.vtk,
        })
    }

    /// Block `name`'s index in the scene.
    pub fn block_index(&self, name: &str) -> Option<usize> {
        self.world.blocks.iter().position(|b| b.name == name)
    }
}

impl Solver for DdaSolver {
    fn name(&self) -> &str {
        self.integrator.name()
    }

    fn dt_proposal(&self) -> Real {
        self.integrator.dt_proposal(&self.world)
    }

    fn advance(&mut self, dt: Real) -> Result<StepReport, SolverError> {
        if !(dt > 0.0 && dt.is_finite()) {
            return Err(SolverError::Failed(format!(
                "{} solver: cannot advance by dt = {dt}",
                self.name()
            )));
        }
        for &i in &self.world.moving {
            let (f, t) = (self.world.load_force[i], self.world.load_torque[i]);
            if !(f.iter().chain(t.iter()).all(|x| x.is_finite())) {
                return Err(SolverError::Unstable(format!(
                    "{} solver: the fluid load on block '{}' is non-finite (force {:?}, torque {:?}) at t = {:.6} s",
                    self.name(),
                    self.world.blocks[i].name,
                    f.as_slice(),
                    t.as_slice(),
                    self.world.time
                )));
            }
        }
        let report = self
            .integrator
            .advance(&mut self.world, dt, &mut self.energy)?;
        self.csv.sample(&self.world, false)?;
        Ok(report)
    }

    fn write_frame(&mut self, frame: u32, _time: Real) -> Result<(), SolverError> {
        self.csv.sample(&self.world, true)?;
        self.csv.flush()?;
        if self.vtk {
            output::write_blocks_vtp(&self.world, &output::frame_path(&self.run_dir, frame))?;
        }
        Ok(())
    }

    fn finish(&mut self) -> Result<(), SolverError> {
        self.csv.flush()?;
        Ok(())
    }
}

impl SolidSolver for DdaSolver {
    fn read_loads(&mut self, loads: &[BlockLoad]) {
        // Loads arrive per moving block in `Scene::moving_blocks` order; a non-finite load is
        // kept and the next advance reports it as an instability.
        for (l, &i) in loads.iter().zip(&self.world.moving) {
            self.world.load_force[i] = Vector::from(l.force);
            self.world.load_torque[i] = Vector::from(l.torque);
        }
    }

    fn vertex_count(&self) -> usize {
        self.world
            .moving
            .iter()
            .map(|&i| self.world.blocks[i].world_vertices.len())
            .sum()
    }

    fn write_geometry(&self, blocks: &mut [BlockState], vertices: &mut [[f64; 3]]) {
        let mut first = 0usize;
        for (state, &i) in blocks.iter_mut().zip(&self.world.moving) {
            let b = &self.world.blocks[i];
            let n = b.world_vertices.len();
            *state = BlockState {
                block: b.scene_index as u32,
                first_vertex: first as u32,
                vertex_count: n as u32,
                flags: 0,
                centroid: b.position.coords.into(),
                orientation: b.rotation.coords.into(),
                velocity: b.velocity.into(),
                angular_velocity: b.angular_velocity.into(),
                strain: [0.0; 6],
                strain_rate: [0.0; 6],
            };
            for (dst, v) in vertices[first..first + n].iter_mut().zip(&b.world_vertices) {
                *dst = [v.x, v.y, v.z];
            }
            first += n;
        }
    }
}
