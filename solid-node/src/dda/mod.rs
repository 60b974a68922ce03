//! The solid node's solver: a block system advanced by one of the integrators, behind the
//! coupling interface ([`SolidSolver`]): loads in, geometry out, outputs on request.

mod look_ahead;

use crate::checkpoint;
use crate::integrators::Integrator;
use crate::integrators::energy::EnergyMonitor;
use crate::output::{self, KinematicsCsv};
use crate::world::World;
use shared::geometry::strain::Strain;
use shared::math::{Real, Vector};
use shared::protocol::{BlockLoad, BlockState};
use shared::solver::{SetupContext, SolidSolver, Solver, SolverError, StepReport};
use std::path::{Path, PathBuf};

pub struct DdaSolver {
    pub world: World,
    integrator: Box<dyn Integrator>,
    pub energy: EnergyMonitor,
    run_dir: PathBuf,
    csv: KinematicsCsv,
    vtk: bool,
    vtk_format: shared::scene::VtkFormat,
    /// How the slides settled under gravity before t = 0 ([`crate::settle`]); `None` without
    /// bonded joints.
    pub settled: Option<crate::settle::Settled>,
    /// Each block's response over the coming coupling step, if measured for a fluid that moves
    /// the blocks in its step (per block in scene order; empty: every block on its own).
    response: Vec<Option<look_ahead::Response>>,
}

/// A scheme whose first proposal is already below `time.dt_min` is refused at set-up, naming
/// the stiffness behind it: the coupler would stop at step 0 on "proposed dt = 1.5e-150 s,
/// below dt_min", naming the node but not the field (`[solid.contact] normal_stiffness =
/// 1e300` under the explicit scheme).
fn collapsed_at_start(integrator: &dyn Integrator, world: &World) -> Result<(), SolverError> {
    let first = integrator.dt_proposal(world);
    if first >= world.dt_min {
        return Ok(());
    }
    let elastic = if world.deformable.is_empty() {
        ""
    } else {
        ", or a deformable block's elastic mode (its Young's modulus)"
    };
    Err(SolverError::Failed(format!(
        "{}: its first step, {first:.3e} s, is below time.dt_min = {:e} s before anything moves: \
         the contact springs' normal stiffness is {:.3e} N/m ({}){elastic}; fix: leave \
         [solid.contact] normal_stiffness out to derive it from the lightest free block, or \
         lower it",
        integrator.name(),
        world.dt_min,
        world.penalty.normal,
        world.penalty.origin
    )))
}

impl DdaSolver {
    pub fn new(
        ctx: &SetupContext,
        mut integrator: Box<dyn Integrator>,
    ) -> Result<DdaSolver, SolverError> {
        let mut world = World::new(ctx.scene)?;
        world.detect(world.penalty.margin);
        integrator.init(&mut world);
        collapsed_at_start(integrator.as_ref(), &world)?;
        let settled = if world.joints.bond_count() > 0 {
            let s = crate::settle::settle(&mut world, integrator.as_mut())?;
            eprintln!(
                "solid-node: {} bonded joint(s); the slides settled under gravity in {} static step(s), largest settlement {:.3e} m{}",
                world.joints.bond_count(),
                s.steps,
                s.max_settlement,
                if s.converged {
                    String::new()
                } else {
                    format!(
                        " — NOT in equilibrium after {} steps: the run starts from there",
                        crate::settle::MAX_STEPS
                    )
                }
            );
            Some(s)
        } else {
            None
        };
        let energy = EnergyMonitor::new(&world);
        let mut csv = KinematicsCsv::create(
            ctx.run_dir,
            ctx.scene.output.interval,
            !world.deformable.is_empty(),
        )?;
        csv.sample(&world, true)?;
        Ok(DdaSolver {
            world,
            integrator,
            energy,
            run_dir: ctx.run_dir.to_path_buf(),
            csv,
            vtk: ctx.scene.output.vtk,
            vtk_format: ctx.scene.output.vtk_format,
            settled,
            response: Vec::new(),
        })
    }

    /// Block `name`'s index in the scene.
    pub fn block_index(&self, name: &str) -> Option<usize> {
        self.world.blocks.iter().position(|b| b.name == name)
    }

    /// Number of unknowns of the block system (6 per free rigid block, 12 per deformable one).
    pub fn unknowns(&self) -> usize {
        self.world.unknowns()
    }

    /// Gives deformable block `block` an initial strain and strain rate (a scene starts
    /// unstrained; verification starts free vibrations this way). Only before the first step:
    /// the contacts, the integrator's state and the energy reference are set up again.
    pub fn set_initial_strain(
        &mut self,
        block: usize,
        strain: Strain,
        rate: Strain,
    ) -> Result<(), SolverError> {
        let b = &mut self.world.blocks[block];
        let name = b.name.clone();
        let Some(el) = b.elastic.as_mut() else {
            return Err(SolverError::Failed(format!(
                "block '{name}' is rigid: it has no strain to set"
            )));
        };
        if self.world.time != 0.0 {
            return Err(SolverError::Failed(
                "an initial strain can only be set before the first step".into(),
            ));
        }
        el.strain = strain;
        el.prev_strain = strain;
        el.rate = rate;
        el.update_stretch();
        b.update_world_geometry();
        self.world.detect(self.world.penalty.margin);
        self.integrator.init(&mut self.world);
        self.energy = EnergyMonitor::new(&self.world);
        Ok(())
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
                "{} solver: cannot advance by dt = {}",
                self.name(),
                shared::math::readable(dt)
            )));
        }
        for &i in &self.world.moving {
            let (f, t) = (self.world.load_force[i], self.world.load_torque[i]);
            let g = self.world.load_strain[i];
            if !(f
                .iter()
                .chain(t.iter())
                .chain(g.iter())
                .all(|x| x.is_finite()))
            {
                return Err(SolverError::Unstable(format!(
                    "{} solver: the fluid load on block '{}' is non-finite (force {:?}, torque {:?}, strain load {:?}) at t = {:.6} s",
                    self.name(),
                    self.world.blocks[i].name,
                    f.as_slice(),
                    t.as_slice(),
                    g.as_slice(),
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
            output::write_blocks_vtp(
                &self.world,
                &output::frame_path(&self.run_dir, frame),
                self.vtk_format,
            )?;
        }
        Ok(())
    }

    fn finish(&mut self) -> Result<(), SolverError> {
        self.csv.flush()?;
        Ok(())
    }

    fn save_state(&mut self) -> Result<Vec<u8>, SolverError> {
        self.csv.flush()?;
        // The response measured for the geometry sent last: a resumed run sends it again.
        let response = self.response.clone();
        self.encode_state(&response)
    }

    fn restore_state(&mut self, state: &[u8], run_dir: &Path) -> Result<(), SolverError> {
        let (response, mark) = self.decode_state(state, "solid checkpoint")?;
        self.response = response;
        self.run_dir = run_dir.to_path_buf();
        self.csv.resume(run_dir, mark)?;
        Ok(())
    }
}

impl DdaSolver {
    /// The block system, its integrator and its outputs' marks as a checkpoint has them
    /// ([`checkpoint::encode`]), with `extra` after them.
    fn encode_state<T: serde::Serialize>(&mut self, extra: &T) -> Result<Vec<u8>, SolverError> {
        checkpoint::encode(
            &mut self.world,
            self.integrator.as_ref(),
            &self.energy,
            self.csv.mark(),
            extra,
        )
    }

    /// Restores [`Self::encode_state`]; returns its `extra` and `blocks.csv`'s mark.
    fn decode_state<T: serde::de::DeserializeOwned>(
        &mut self,
        bytes: &[u8],
        what: &str,
    ) -> Result<(T, (Option<Real>, usize)), SolverError> {
        checkpoint::decode(
            &mut self.world,
            self.integrator.as_mut(),
            &mut self.energy,
            bytes,
            what,
        )
    }
}

impl SolidSolver for DdaSolver {
    fn look_ahead(&mut self, step: Option<(Real, u32)>) -> Result<(), SolverError> {
        // Cleared first: a look-ahead that fails leaves the blocks on their own.
        self.response.clear();
        self.response = look_ahead::measure(
            &mut self.world,
            self.integrator.as_mut(),
            &mut self.energy,
            self.csv.mark(),
            step,
        )?;
        Ok(())
    }

    fn read_loads(&mut self, loads: &[BlockLoad]) {
        // Loads arrive per moving block in `Scene::moving_blocks` order; a non-finite load is
        // kept and the next advance reports it as an instability.
        for (l, &i) in loads.iter().zip(&self.world.moving) {
            self.world.load_force[i] = Vector::from(l.force);
            self.world.load_torque[i] = Vector::from(l.torque);
            // The generalised load on the strains is only used by deformable blocks (a rigid
            // block has no strain unknowns for it to act on).
            if self.world.blocks[i].is_deformable() {
                self.world.load_strain[i] = Strain::from(l.strain_load);
            }
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
            // World corners are the deformed ones (c + R (I + E) X) for a deformable block.
            let (flags, strain, strain_rate) = match &b.elastic {
                Some(el) => (BlockState::DEFORMABLE, el.strain.into(), el.rate.into()),
                None => (0, [0.0; 6], [0.0; 6]),
            };
            *state = BlockState {
                block: b.scene_index as u32,
                first_vertex: first as u32,
                vertex_count: n as u32,
                flags,
                centroid: b.position.coords.into(),
                orientation: b.rotation.coords.into(),
                velocity: b.velocity.into(),
                angular_velocity: b.angular_velocity.into(),
                strain,
                strain_rate,
                ..BlockState::default()
            };
            // The block's inertia and its forces besides the water's (weight, contacts,
            // joints) as the last evaluation has them, and its response over the coming step
            // if measured: for a fluid that moves it inside its pressure solve.
            if b.is_free() {
                state.inverse_mass = 1.0 / b.mass;
                state.inverse_inertia = BlockState::pack_symmetric(&b.world_inv_inertia());
                state.other_force =
                    (b.mass * self.world.gravity + self.world.contact_force[i]).into();
                state.other_torque = self.world.contact_torque[i].into();
                if let Some(r) = self.response.get(i).copied().flatten() {
                    state.set_response(&r.free_acceleration, &r.mobility);
                }
            }
            for (dst, v) in vertices[first..first + n].iter_mut().zip(&b.world_vertices) {
                *dst = [v.x, v.y, v.z];
            }
            first += n;
        }
    }
}
