//! A solid solver's checkpoint: what the block system, its integrator and its outputs need to
//! continue exactly.
//!
//! Saved per block: pose, velocity, the previous pose, the strain state of a deformable block,
//! and its world geometry (corners, face planes, bounding box), copied rather than recomputed
//! so that it is the same to the bit. Saved for the system: time, the contacts with their
//! history (shear spring, open–close state, normal force) and the previous step's contacts they
//! carry over from, the broad phase's sort order (sweep and prune starts from it), the loads
//! read for the coming step and the last contact forces. Then the integrator's own history
//! ([`crate::integrators::Integrator::save`]), the energy monitor and where `blocks.csv` is in
//! its sampling. Not saved: what never changes after set-up (shapes, masses, materials,
//! prescribed motions), built again from the scene.

use crate::blocks::block::Block;
use crate::blocks::elastic::Elastic;
use crate::contact::Contact;
use crate::contact::broad_phase::BroadPhase;
use crate::integrators::Integrator;
use crate::integrators::energy::EnergyMonitor;
use crate::world::World;
use shared::geometry::strain::Strain;
use shared::math::{Point, Real, Rotation, Vector};
use shared::solver::SolverError;

/// The parts of a block that move.
#[derive(serde::Serialize, serde::Deserialize)]
struct BlockState {
    position: Point,
    rotation: Rotation,
    velocity: Vector,
    angular_velocity: Vector,
    prev_position: Point,
    prev_rotation: Rotation,
    elastic: Option<Box<Elastic>>,
    world_vertices: Vec<Point>,
    world_normals: Vec<Vector>,
    world_offsets: Vec<Real>,
    aabb_min: Point,
    aabb_max: Point,
}

impl BlockState {
    fn of(b: &Block) -> BlockState {
        BlockState {
            position: b.position,
            rotation: b.rotation,
            velocity: b.velocity,
            angular_velocity: b.angular_velocity,
            prev_position: b.prev_position,
            prev_rotation: b.prev_rotation,
            elastic: b.elastic.clone(),
            world_vertices: b.world_vertices.clone(),
            world_normals: b.world_normals.clone(),
            world_offsets: b.world_offsets.clone(),
            aabb_min: b.aabb_min,
            aabb_max: b.aabb_max,
        }
    }

    fn apply(self, b: &mut Block) {
        b.position = self.position;
        b.rotation = self.rotation;
        b.velocity = self.velocity;
        b.angular_velocity = self.angular_velocity;
        b.prev_position = self.prev_position;
        b.prev_rotation = self.prev_rotation;
        b.elastic = self.elastic;
        b.world_vertices = self.world_vertices;
        b.world_normals = self.world_normals;
        b.world_offsets = self.world_offsets;
        b.aabb_min = self.aabb_min;
        b.aabb_max = self.aabb_max;
    }
}

/// What a restored world hands back to the solver: the integrator's state, the energy monitor
/// and `blocks.csv`'s mark.
pub(crate) type SolverParts = (Vec<u8>, EnergyMonitor, (Option<Real>, usize));

/// The solid solver's checkpoint.
#[derive(serde::Serialize, serde::Deserialize)]
pub(crate) struct SolidState {
    time: Real,
    blocks: Vec<BlockState>,
    contacts: Vec<Contact>,
    previous: Vec<Contact>,
    broad: BroadPhase,
    load_force: Vec<Vector>,
    load_torque: Vec<Vector>,
    load_strain: Vec<Strain>,
    contact_force: Vec<Vector>,
    contact_torque: Vec<Vector>,
    contact_strain: Vec<Strain>,
    integrator: Vec<u8>,
    energy: EnergyMonitor,
    /// `blocks.csv`'s last sample time and row count.
    csv: (Option<Real>, usize),
}

impl SolidState {
    pub(crate) fn save(
        world: &mut World,
        integrator: Vec<u8>,
        energy: &EnergyMonitor,
        csv: (Option<Real>, usize),
    ) -> SolidState {
        SolidState {
            time: world.time,
            blocks: world.blocks.iter().map(BlockState::of).collect(),
            contacts: world.contacts.clone(),
            previous: world.previous.clone(),
            broad: std::mem::take(&mut world.broad),
            load_force: world.load_force.clone(),
            load_torque: world.load_torque.clone(),
            load_strain: world.load_strain.clone(),
            contact_force: world.contact_force.clone(),
            contact_torque: world.contact_torque.clone(),
            contact_strain: world.contact_strain.clone(),
            integrator,
            energy: energy.clone(),
            csv,
        }
    }

    /// Gives the broad phase back after encoding (it was moved out to avoid a copy).
    pub(crate) fn give_back(self, world: &mut World) {
        world.broad = self.broad;
    }

    /// Restores the world; returns the integrator's state, the energy monitor and the csv mark.
    pub(crate) fn restore(self, world: &mut World) -> Result<SolverParts, String> {
        if self.blocks.len() != world.blocks.len() {
            return Err(format!(
                "the checkpoint holds {} blocks, the scene {}: it was written for another scene",
                self.blocks.len(),
                world.blocks.len()
            ));
        }
        world.time = self.time;
        for (s, b) in self.blocks.into_iter().zip(world.blocks.iter_mut()) {
            s.apply(b);
        }
        world.contacts = self.contacts;
        world.previous = self.previous;
        world.broad = self.broad;
        world.load_force = self.load_force;
        world.load_torque = self.load_torque;
        world.load_strain = self.load_strain;
        world.contact_force = self.contact_force;
        world.contact_torque = self.contact_torque;
        world.contact_strain = self.contact_strain;
        Ok((self.integrator, self.energy, self.csv))
    }
}

/// The block system, its integrator and `blocks.csv`'s mark `csv` as a checkpoint has them
/// ([`SolidState`]), with `extra` after them.
pub(crate) fn encode<T: serde::Serialize>(
    world: &mut World,
    integrator: &dyn Integrator,
    energy: &EnergyMonitor,
    csv: (Option<Real>, usize),
    extra: &T,
) -> Result<Vec<u8>, SolverError> {
    let integrator = integrator.save().map_err(SolverError::Failed)?;
    let state = SolidState::save(world, integrator, energy, csv);
    let bytes = shared::checkpoint::encode(&(&state, extra)).map_err(SolverError::Failed);
    state.give_back(world);
    bytes
}

/// Restores [`encode`] into any block system of the scene (the solver's, or the look-ahead's
/// copy); returns its `extra` and `blocks.csv`'s mark.
pub(crate) fn decode<T: serde::de::DeserializeOwned>(
    world: &mut World,
    integrator: &mut dyn Integrator,
    energy: &mut EnergyMonitor,
    bytes: &[u8],
    what: &str,
) -> Result<(T, (Option<Real>, usize)), SolverError> {
    let (state, extra): (SolidState, T) =
        shared::checkpoint::decode(bytes, what).map_err(SolverError::Failed)?;
    let (saved, monitor, mark) = state.restore(world).map_err(SolverError::Failed)?;
    integrator.restore(&saved).map_err(SolverError::Failed)?;
    *energy = monitor;
    Ok((extra, mark))
}
