//! The block system every integrator advances: blocks, contacts, loads and the checks that end a
//! run when the method has gone wrong.

use crate::blocks::block::Block;
use crate::contact::broad_phase::BroadPhase;
use crate::contact::friction::Joint;
use crate::contact::joints::SlideJoints;
use crate::contact::narrow_phase::{self, NarrowParams};
use crate::contact::springs::PenaltyModel;
use crate::contact::terrain::{self as terrain_contact, TerrainBody};
use crate::contact::{self, Contact};
use rayon::prelude::*;
use shared::geometry::strain::Strain;
use shared::math::{Point, Real, Vector};
use shared::scene::{ContactSpec, Scene};
use shared::solver::SolverError;
use shared::terrain::Terrain;
use std::sync::Arc;

/// Below this many pairs (or contacts) the narrow phase runs on one thread: rayon's fork costs
/// more than the work.
const PARALLEL_MIN: usize = 64;

/// Blocks, their contacts and the loads on them. (Clone: the look-ahead runs half its trial
/// steps on a copy, `dda/look_ahead.rs`.)
#[derive(Clone)]
pub struct World {
    /// All blocks in scene order (fixed ones too: they are contact partners), then one fixed
    /// block per terrain (from `first_terrain` on).
    pub blocks: Vec<Block>,
    /// Index of the first terrain block: the scene's own blocks are `blocks[..first_terrain]`.
    pub first_terrain: usize,
    /// The scene's `[[terrain]]`, in order: block `first_terrain + k` is terrain k.
    pub terrain: Arc<Vec<TerrainBody>>,
    /// Indices of the kinematic and free blocks, in `Scene::moving_blocks` order.
    pub moving: Vec<usize>,
    /// Indices of the free blocks.
    pub free: Vec<usize>,
    /// Indices of the deformable (12-DOF) free blocks; empty in a scene of rigid blocks, and
    /// then no strain work is done anywhere.
    pub deformable: Vec<usize>,
    pub gravity: Vector,
    pub penalty: PenaltyModel,
    pub contact_spec: ContactSpec,
    pub domain_min: Point,
    pub domain_max: Point,
    /// Simulated time [s].
    pub time: Real,
    /// The scene's `[time].dt_max`: the proposal when nothing limits the step.
    pub dt_max: Real,
    /// The scene's `[time].dt_min`: an integrator that cuts its step gives up below it.
    pub dt_min: Real,
    pub broad: BroadPhase,
    /// The bonded joints between blocks cut from one slide.
    pub joints: SlideJoints,
    /// True once the contacts were detected (the first detection makes the slides' bonds).
    pub detected: bool,
    /// Current contacts, sorted by key.
    pub contacts: Vec<Contact>,
    pub(crate) previous: Vec<Contact>,
    pub(crate) slots: Vec<Vec<Contact>>,
    /// Fluid loads per block (force, torque about the centroid), for the coming step.
    pub load_force: Vec<Vector>,
    pub load_torque: Vec<Vector>,
    /// Contact force and torque on each block from the last force evaluation.
    pub contact_force: Vec<Vector>,
    pub contact_torque: Vec<Vector>,
    /// Fluid load on the strain unknowns (the protocol's `strain_load`), deformable blocks.
    pub load_strain: Vec<Strain>,
    /// Contact load on the strain unknowns, Σ T_e(X)ᵀ Rᵀ f, deformable blocks only.
    pub contact_strain: Vec<Strain>,
}

impl World {
    pub fn new(scene: &Scene) -> Result<World, SolverError> {
        let mut blocks = scene
            .blocks
            .iter()
            .enumerate()
            .map(|(i, spec)| Block::from_spec(i, spec))
            .collect::<Result<Vec<_>, _>>()?;
        // The terrain: one fixed block each, after the scene's blocks (read again from the
        // scene's files on a resume: it never changes, so it is not checkpointed).
        let terrain: Vec<TerrainBody> = Terrain::load_all(scene)
            .map_err(SolverError::Failed)?
            .into_iter()
            .map(TerrainBody::new)
            .collect();
        let first_terrain = blocks.len();
        for (k, t) in terrain.iter().enumerate() {
            blocks.push(t.block(first_terrain + k)?);
        }
        let gravity = Vector::from(scene.gravity);
        let penalty = PenaltyModel::new(&scene.solid.contact, &blocks, &gravity);
        let n = blocks.len();
        let joints = SlideJoints::new(scene, &blocks);
        Ok(World {
            moving: scene.moving_blocks(),
            free: (0..n).filter(|&i| blocks[i].is_free()).collect(),
            deformable: (0..n)
                .filter(|&i| blocks[i].is_free() && blocks[i].is_deformable())
                .collect(),
            blocks,
            first_terrain,
            terrain: Arc::new(terrain),
            gravity,
            penalty,
            contact_spec: scene.solid.contact.clone(),
            domain_min: Point::from(scene.domain.min),
            domain_max: Point::from(scene.domain.max),
            time: 0.0,
            dt_max: scene.time.dt_max,
            dt_min: scene.time.dt_min,
            broad: BroadPhase::default(),
            joints,
            detected: false,
            contacts: Vec::new(),
            previous: Vec::new(),
            slots: Vec::new(),
            load_force: vec![Vector::zeros(); n],
            load_torque: vec![Vector::zeros(); n],
            contact_force: vec![Vector::zeros(); n],
            contact_torque: vec![Vector::zeros(); n],
            load_strain: vec![Strain::zeros(); n],
            contact_strain: vec![Strain::zeros(); n],
        })
    }

    /// Number of unknowns of the block system: 6 per free rigid block, 12 per deformable one
    /// (fixed and kinematic blocks have none).
    pub fn unknowns(&self) -> usize {
        self.free.iter().map(|&i| self.blocks[i].unknowns()).sum()
    }

    /// Total mass of the free blocks [kg].
    pub fn free_mass(&self) -> Real {
        self.free.iter().map(|&i| self.blocks[i].mass).sum()
    }

    /// Size of the smallest free block [m].
    pub fn smallest_free_size(&self) -> Real {
        self.free
            .iter()
            .map(|&i| self.blocks[i].size())
            .fold(Real::INFINITY, Real::min)
    }

    /// Finds the contacts at the current poses (broad phase, then vertex–face and edge–edge
    /// tests per pair, in parallel), carrying each contact's history over from the previous
    /// call. Contacts closer than `margin` are kept.
    pub fn detect(&mut self, margin: Real) {
        std::mem::swap(&mut self.contacts, &mut self.previous);
        self.broad.update(&self.blocks, margin);
        let pairs = &self.broad.pairs;
        if self.slots.len() < pairs.len() {
            self.slots.resize_with(pairs.len(), Vec::new);
        }
        let blocks = &self.blocks;
        let previous = &self.previous;
        let spec = &self.contact_spec;
        let at_start = !self.detected;
        let params = NarrowParams { margin, at_start };
        let joints = &self.joints;
        let (terrain, first_terrain) = (&self.terrain, self.first_terrain);
        let work = |(slot, &(a, b)): (&mut Vec<Contact>, &(u32, u32))| {
            slot.clear();
            let (ba, bb) = (&blocks[a as usize], &blocks[b as usize]);
            let joint = joints.joint(a, b, ba, bb).unwrap_or_else(|| {
                Joint::of_pair(
                    spec,
                    (ba.friction_angle, bb.friction_angle),
                    (ba.cohesion, bb.cohesion),
                )
            });
            let old = contact::pair_range(previous, a, b);
            // Terrain blocks come last, so a terrain is always b of its pairs.
            if let Some(body) = (b as usize).checked_sub(first_terrain).map(|k| &terrain[k]) {
                terrain_contact::collide(a, ba, b, body, joint, params, old, slot);
                return;
            }
            narrow_phase::collide(
                &narrow_phase::Pair {
                    a,
                    b,
                    ba,
                    bb,
                    joint,
                },
                params,
                old,
                slot,
            );
            // The bonds are made now: the pair's bonded contacts share the joint's area.
            if at_start && let Some(bond) = joints.bond(a, b) {
                let n = slot.iter().filter(|c| c.bonded).count();
                for c in slot.iter_mut().filter(|c| c.bonded) {
                    c.bond_area = bond.area / n as Real;
                    c.area = c.bond_area;
                }
            }
        };
        let slots = &mut self.slots[..pairs.len()];
        if pairs.len() >= PARALLEL_MIN {
            slots
                .par_iter_mut()
                .zip(pairs.par_iter())
                .with_min_len(16)
                .for_each(work);
        } else {
            slots.iter_mut().zip(pairs.iter()).for_each(work);
        }
        self.contacts.clear();
        for s in slots.iter() {
            self.contacts.extend_from_slice(s);
        }
        self.detected = true;
    }

    /// The forces of all contacts at the current configuration (see [`PenaltyModel::update`]), summed
    /// into [`World::contact_force`] / [`World::contact_torque`].
    pub fn update_contact_forces(&mut self) {
        let blocks = &self.blocks;
        let penalty = &self.penalty;
        let work =
            |c: &mut Contact| penalty.update(c, &blocks[c.p as usize], &blocks[c.q as usize]);
        if self.contacts.len() >= PARALLEL_MIN {
            self.contacts.par_iter_mut().with_min_len(64).for_each(work);
        } else {
            self.contacts.iter_mut().for_each(work);
        }
        self.sum_contact_forces();
    }

    /// Sums the committed contact forces into per-block force and torque.
    pub fn sum_contact_forces(&mut self) {
        self.contact_force
            .iter_mut()
            .for_each(|f| *f = Vector::zeros());
        self.contact_torque
            .iter_mut()
            .for_each(|t| *t = Vector::zeros());
        for c in &self.contacts {
            if c.force == Vector::zeros() {
                continue;
            }
            let (p, q) = (c.p as usize, c.q as usize);
            self.contact_force[p] += c.force;
            self.contact_torque[p] += (c.point - self.blocks[p].position).cross(&c.force);
            self.contact_force[q] -= c.force;
            self.contact_torque[q] -= (c.point - self.blocks[q].position).cross(&c.force);
        }
        if !self.deformable.is_empty() {
            self.sum_contact_strain_loads();
        }
    }

    /// The contact forces' loads on the strain unknowns of the deformable blocks: the force f
    /// at the contact point loads the block with T_e(X)ᵀ Rᵀ f (X the point's undeformed
    /// block-frame position, [`Block::strain_load`]).
    fn sum_contact_strain_loads(&mut self) {
        for &i in &self.deformable {
            self.contact_strain[i] = Strain::zeros();
        }
        for c in &self.contacts {
            if c.force == Vector::zeros() {
                continue;
            }
            let (p, q) = (c.p as usize, c.q as usize);
            if self.blocks[p].is_deformable() {
                self.contact_strain[p] += self.blocks[p].strain_load(&c.point, &c.force);
            }
            if self.blocks[q].is_deformable() {
                self.contact_strain[q] += self.blocks[q].strain_load(&c.point, &-c.force);
            }
        }
    }

    /// Kinetic energy of the free blocks [J].
    pub fn kinetic_energy(&self) -> Real {
        self.free
            .iter()
            .map(|&i| self.blocks[i].kinetic_energy())
            .sum()
    }

    /// Elastic strain energy of the deformable blocks [J].
    pub fn strain_energy(&self) -> Real {
        self.deformable
            .iter()
            .map(|&i| self.blocks[i].strain_energy())
            .sum()
    }

    /// Gravitational potential energy of the free blocks [J] (zero at the origin).
    pub fn potential_energy(&self) -> Real {
        self.free
            .iter()
            .map(|&i| -self.blocks[i].mass * self.gravity.dot(&self.blocks[i].position.coords))
            .sum()
    }

    /// Energy stored in the contact springs [J].
    pub fn contact_energy(&self) -> Real {
        self.contacts.iter().map(|c| self.penalty.energy(c)).sum()
    }

    /// NaN and domain checks on the free blocks: either is an instability.
    pub fn check_state(&self, solver: &str) -> Result<(), SolverError> {
        for &i in &self.free {
            let b = &self.blocks[i];
            if !b.is_finite() {
                return Err(SolverError::Unstable(format!(
                    "{solver} solver: block '{}' has a non-finite state (position {:?}, velocity {:?}) at t = {:.6} s",
                    b.name,
                    b.position.coords.as_slice(),
                    b.velocity.as_slice(),
                    self.time
                )));
            }
            let p = &b.position;
            if (0..3).any(|k| p[k] < self.domain_min[k] || p[k] > self.domain_max[k]) {
                return Err(SolverError::Unstable(format!(
                    "{solver} solver: block '{}' left the domain: centroid ({:.4}, {:.4}, {:.4}) m outside [{:?}, {:?}] at t = {:.6} s, speed {:.4e} m/s",
                    b.name,
                    p.x,
                    p.y,
                    p.z,
                    self.domain_min.coords.as_slice(),
                    self.domain_max.coords.as_slice(),
                    self.time,
                    b.velocity.norm()
                )));
            }
        }
        Ok(())
    }
}
