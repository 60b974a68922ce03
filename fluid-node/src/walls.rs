//! Boundary particles on the fixed blocks (Adami, Hu & Adams 2012): a better wall than the
//! paper's Eq. 22 alone, where the validation needs one.
//!
//! With penalty forces only, a particle next to a wall misses the part of its kernel support
//! that lies inside the wall: its summed density (Müller) is low and its pressure gradient is
//! one-sided, so water sticks to walls and hydrostatic pressure is wrong within ~h of the bed.
//! Here the fixed blocks are filled, on the water's own lattice, to a depth of one kernel support
//! with static particles. Each step their pressure is extrapolated from the fluid around them,
//! p_w = (Σ_f p_f W_wf + g·Σ_f ρ_f r_wf W_wf) / Σ_f W_wf (Adami 2012, Eq. 27 for a wall at rest),
//! so the fluid near a wall feels the hydrostatic pressure it would feel in open water. Walls are
//! free-slip (boundary particles take no part in the viscous terms).
//!
//! Moving (kinematic and free) blocks get the same treatment through [`BodyParticles`]: with the
//! Eq. 22 springs alone the particles under a floating block see no water above them, their
//! pressure is a truncated-kernel estimate and the block floats too deep (43 % at dx = 0.04,
//! 10 % at 0.02; docs/speed-accuracy.md). The block's boundary particles are sampled once in its
//! local frame and carried, as the material points they are, with the pose (and the strain, for a
//! deformable block) the solid node sends; the force the water exerts
//! on them (the reverse of their pressure force on each fluid neighbour) is summed into the
//! block's load, so action and reaction balance pair by pair.

use crate::kernel::Kernel;
use crate::neighbors::{CellGrid, NeighborLists};
use crate::particles::Particles;
use rayon::prelude::*;
use shared::geometry::Polyhedron;
use shared::math::{Matrix, Point, Real, Vector};
use shared::protocol::{BlockLoad, BlockState};
use shared::strain::{MaterialMap, Strain};

/// Static boundary particles with their extrapolated pressure and the density it implies.
#[derive(Debug, Clone)]
pub struct WallParticles {
    pub position: Vec<Vector>,
    pub pressure: Vec<Real>,
    pub density: Vec<Real>,
    pub grid: CellGrid,
    /// Wall particles with a fluid neighbour this step, and their positions: only these need a
    /// pressure (a tall side wall holds many particles no water reaches).
    pub active: Vec<u32>,
    active_position: Vec<Vector>,
    mark: Vec<bool>,
    active_position_out: Vec<(Real, Real)>,
    /// Fluid neighbours of each active wall particle.
    pub lists: NeighborLists,
}

impl WallParticles {
    /// Lattice points (`anchor + k·dx`) inside the fixed blocks, at most `depth` below the
    /// surface of the block they are in and within `[lo, hi]`.
    pub fn sample(
        fixed: &[Polyhedron],
        anchor: &Vector,
        dx: Real,
        depth: Real,
        lo: &Vector,
        hi: &Vector,
    ) -> Vec<Vector> {
        let kmin: Vec<i64> = (0..3)
            .map(|k| ((lo[k] - anchor[k]) / dx).floor() as i64)
            .collect();
        let kmax: Vec<i64> = (0..3)
            .map(|k| ((hi[k] - anchor[k]) / dx).ceil() as i64)
            .collect();
        let zs: Vec<i64> = (kmin[2]..=kmax[2]).collect();
        zs.par_iter()
            .flat_map_iter(|&kz| {
                let mut out = Vec::new();
                for ky in kmin[1]..=kmax[1] {
                    for kx in kmin[0]..=kmax[0] {
                        let p = anchor + Vector::new(kx as Real, ky as Real, kz as Real) * dx;
                        if (0..3).any(|k| p[k] < lo[k] || p[k] > hi[k]) {
                            continue;
                        }
                        // Depth into the union of blocks, bounded below by the deepest single block.
                        let inside = fixed
                            .iter()
                            .map(|b| -b.plane_distance(&Point::from(p - b.centroid.coords)).0)
                            .filter(|&d| d > 0.0)
                            .fold(None, |m: Option<Real>, d| Some(m.map_or(d, |m| m.max(d))));
                        if inside.is_some_and(|d| d <= depth) {
                            out.push(p);
                        }
                    }
                }
                out
            })
            .collect()
    }

    /// Sorts `position` into a grid of the fluid grid's geometry, once: the walls never move.
    pub fn new(mut position: Vec<Vector>, mut grid: CellGrid) -> Self {
        let order = grid.sort(&position).to_vec();
        position = order.iter().map(|&i| position[i as usize]).collect();
        let n = position.len();
        Self {
            position,
            pressure: vec![0.0; n],
            density: vec![0.0; n],
            grid,
            active: Vec::new(),
            active_position: Vec::new(),
            mark: vec![false; n],
            active_position_out: Vec::new(),
            lists: NeighborLists::default(),
        }
    }

    pub fn len(&self) -> usize {
        self.position.len()
    }

    pub fn is_empty(&self) -> bool {
        self.position.is_empty()
    }

    /// Finds the wall particles near water from the fluid's wall lists and lists their fluid
    /// neighbours. Called at every sort.
    pub fn activate(
        &mut self,
        fluid_to_wall: &NeighborLists,
        fluid: &[Vector],
        fluid_grid: &CellGrid,
        radius: Real,
    ) {
        self.mark.iter_mut().for_each(|m| *m = false);
        for i in 0..fluid.len() {
            for &w in fluid_to_wall.of(i) {
                self.mark[w as usize] = true;
            }
        }
        self.active.clear();
        self.active_position.clear();
        for (w, &m) in self.mark.iter().enumerate() {
            if m {
                self.active.push(w as u32);
                self.active_position.push(self.position[w]);
            }
        }
        self.lists
            .build(&self.active_position, fluid, fluid_grid, radius, false);
    }

    /// Adami's pressure extrapolation, then ρ_w from the solver's inverse equation of state.
    /// Negative wall pressure is clipped to zero so walls never pull water (no sticking).
    pub fn update<K: Kernel>(
        &mut self,
        kernel: &K,
        fluid: &Particles,
        gravity: &Vector,
        rest_density: Real,
        density_of: impl Fn(Real) -> Real + Sync,
    ) {
        let s2 = kernel.support() * kernel.support();
        let (pos, lists) = (&self.active_position, &self.lists);
        // Computed per active particle, then scattered (the active list is short).
        let mut out = std::mem::take(&mut self.active_position_out);
        out.resize(self.active.len(), (0.0, 0.0));
        out.par_iter_mut().enumerate().for_each(|(w, (pw, rw))| {
            let xw = pos[w];
            let (mut sum_w, mut sum_p, mut sum_rho_r) = (0.0, 0.0, Vector::zeros());
            for &f in lists.of(w) {
                let f = f as usize;
                let r = xw - fluid.position[f];
                let r2 = r.norm_squared();
                if r2 < s2 {
                    let wv = kernel.value(r2.sqrt());
                    sum_w += wv;
                    sum_p += fluid.pressure[f] * wv;
                    sum_rho_r += r * (fluid.density[f] * wv);
                }
            }
            *pw = if sum_w > 0.0 {
                ((sum_p + gravity.dot(&sum_rho_r)) / sum_w).max(0.0)
            } else {
                0.0
            };
            *rw = if sum_w > 0.0 {
                density_of(*pw)
            } else {
                rest_density
            };
        });
        for (&w, &(p, r)) in self.active.iter().zip(&out) {
            self.pressure[w as usize] = p;
            self.density[w as usize] = r;
        }
        self.active_position_out = out;
    }
}

/// Boundary particles of the moving blocks (Adami, Hu & Adams 2012, §2.3 for moving walls).
///
/// `local` and `owner` keep the set-up order; `set` holds the same particles at their current
/// world positions, sorted by cell (re-sorted at every pose), with `velocity` and `owner_sorted`
/// in that sorted order. Everything is sized once: moving the blocks allocates nothing.
#[derive(Debug, Clone)]
pub struct BodyParticles {
    /// Position in the block's frame (centroid at the origin, scene orientation).
    local: Vec<Vector>,
    /// Index of the block among the moving blocks (loads order).
    owner: Vec<u32>,
    /// World positions in set-up order (scratch for the sort).
    world: Vec<Vector>,
    /// The particles as walls: sorted positions, extrapolated pressure and density, active lists.
    pub set: WallParticles,
    /// Material velocity v + ω × (x − c) (+ R Ė X for a deformable block) of each sorted
    /// particle: the wall velocity of the continuity equation (free slip, as the fixed walls).
    pub velocity: Vec<Vector>,
    pub owner_sorted: Vec<u32>,
    /// `local` in sorted order (the material point each sorted particle is).
    local_sorted: Vec<Vector>,
    /// Set-up index of each sorted particle.
    source: Vec<u32>,
    /// The point of the block's surface each particle stands for (block frame, set-up order):
    /// its projection on the nearest face. A boundary particle carries the pressure of the
    /// wall it lies under, so the first moment of that pressure, the strain load, is taken at
    /// the wall, not a particle depth inside it (which would shorten every lever arm by it).
    surface: Vec<Vector>,
    /// Where each moving block's material points are now (centroid: the torque reference).
    maps: Vec<MaterialMap>,
    /// Force of the water on each active particle (scratch) and the sums per block: force,
    /// torque about the centroid, and the strain load of a deformable block.
    reaction: Vec<Vector>,
    pub loads: Vec<(Vector, Vector, Strain)>,
}

impl BodyParticles {
    /// Samples each moving block, at its scene pose, on the water's lattice to `depth` (one
    /// kernel support) below its surface, as [`WallParticles::sample`] does for fixed blocks.
    /// `moving[k]` is the polyhedron (local faces, scene centroid) of moving block k.
    pub fn new(
        moving: &[Polyhedron],
        anchor: &Vector,
        dx: Real,
        depth: Real,
        grid: CellGrid,
    ) -> Self {
        let (mut local, mut owner, mut world) = (Vec::new(), Vec::new(), Vec::new());
        let mut surface = Vec::new();
        let mut maps = Vec::with_capacity(moving.len());
        for (k, b) in moving.iter().enumerate() {
            let c = b.centroid.coords;
            let (mut lo, mut hi) = (
                Vector::repeat(Real::INFINITY),
                Vector::repeat(Real::NEG_INFINITY),
            );
            for v in &b.vertices {
                lo = lo.inf(&(v.coords + c));
                hi = hi.sup(&(v.coords + c));
            }
            for p in WallParticles::sample(std::slice::from_ref(b), anchor, dx, depth, &lo, &hi) {
                let x = Point::from(p - c);
                let (d, f) = b.plane_distance(&x);
                surface.push(x.coords - b.faces[f].normal * d);
                local.push(x.coords);
                owner.push(k as u32);
                world.push(p);
            }
            maps.push(MaterialMap::new(
                c,
                Matrix::identity(),
                Vector::zeros(),
                Vector::zeros(),
                None,
            ));
        }
        let n = local.len();
        let set = WallParticles::new(world.clone(), grid);
        let mut body = Self {
            local,
            owner,
            world,
            set,
            velocity: vec![Vector::zeros(); n],
            owner_sorted: vec![0; n],
            local_sorted: vec![Vector::zeros(); n],
            source: vec![0; n],
            surface,
            maps,
            reaction: Vec::new(),
            loads: vec![(Vector::zeros(), Vector::zeros(), Strain::zeros()); moving.len()],
        };
        body.sort();
        body
    }

    pub fn len(&self) -> usize {
        self.local.len()
    }

    pub fn is_empty(&self) -> bool {
        self.local.is_empty()
    }

    /// Carries every particle with its block as the material point it is: x = c + F·X with
    /// F = R (rigid) or R(I + E) (deformable), v = v_c + ω × (x − c) (+ R Ė X).
    /// `states` are the moving blocks in loads order.
    pub fn place(&mut self, states: &[BlockState]) {
        for (m, s) in self.maps.iter_mut().zip(states) {
            *m = s.material_map();
        }
        let (local, owner, maps) = (&self.local, &self.owner, &self.maps);
        self.world.par_iter_mut().enumerate().for_each(|(i, x)| {
            *x = maps[owner[i] as usize].position(&local[i]);
        });
        self.sort();
        let (owner, local, maps) = (&self.owner_sorted, &self.local_sorted, &self.maps);
        self.velocity
            .par_iter_mut()
            .enumerate()
            .for_each(|(i, v)| *v = maps[owner[i] as usize].velocity(&local[i]));
    }

    /// Counting sort of the world positions into the set's grid.
    fn sort(&mut self) {
        let order = self.set.grid.sort(&self.world);
        let (world, owner, local) = (&self.world, &self.owner, &self.local);
        self.set
            .position
            .par_iter_mut()
            .zip(self.owner_sorted.par_iter_mut())
            .zip(self.local_sorted.par_iter_mut())
            .zip(self.source.par_iter_mut())
            .zip(order.par_iter())
            .for_each(|((((x, o), l), src), &k)| {
                *x = world[k as usize];
                *o = owner[k as usize];
                *l = local[k as usize];
                *src = k;
            });
    }

    /// The force and torque (about the centroid) the water exerts on each block through its
    /// boundary particles, into `self.loads`. `pair(f, w, r_fw, r)` is the solver's pressure
    /// force of wall particle `w` on fluid particle `f` (r_fw = x_f − x_w, r = |r_fw|); the block
    /// takes its reverse (Newton's third law pair by pair, so the exchange conserves momentum).
    /// Parallel over the active particles, then a short sequential sum per block.
    pub fn react(
        &mut self,
        fluid: &[Vector],
        support: Real,
        pair: impl Fn(usize, Real, Real, &Vector, Real) -> Vector + Sync,
    ) {
        let s2 = support * support;
        let set = &self.set;
        self.reaction.resize(set.active.len(), Vector::zeros());
        self.reaction
            .par_iter_mut()
            .enumerate()
            .for_each(|(a, out)| {
                let w = set.active[a] as usize;
                let (xw, pw, rw) = (set.position[w], set.pressure[w], set.density[w]);
                let mut f = Vector::zeros();
                for &i in set.lists.of(a) {
                    let i = i as usize;
                    let r = fluid[i] - xw;
                    let r2 = r.norm_squared();
                    if r2 < s2 {
                        f -= pair(i, pw, rw, &r, r2.sqrt());
                    }
                }
                *out = f;
            });
        self.loads
            .iter_mut()
            .for_each(|l| *l = (Vector::zeros(), Vector::zeros(), Strain::zeros()));
        for (&w, f) in set.active.iter().zip(&self.reaction) {
            let w = w as usize;
            let k = self.owner_sorted[w] as usize;
            let map = &self.maps[k];
            let arm = set.position[w] - map.centroid;
            self.loads[k].0 += f;
            self.loads[k].1 += arm.cross(f);
            if map.deformable {
                let at = &self.surface[self.source[w] as usize];
                self.loads[k].2 += map.strain_load(at, f);
            }
        }
    }

    /// Adds the last [`Self::react`] to the moving blocks' loads.
    pub fn add_loads(&self, loads: &mut [BlockLoad]) {
        for (slot, (f, t, e)) in loads.iter_mut().zip(&self.loads) {
            slot.force = (Vector::from(slot.force) + f).into();
            slot.torque = (Vector::from(slot.torque) + t).into();
            slot.strain_load = (Strain::from(slot.strain_load) + e).into();
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use shared::scene::ShapeSpec;

    #[test]
    fn samples_fill_the_floor_to_the_requested_depth() {
        let floor = Polyhedron::from_shape(&ShapeSpec::Box {
            min: [-1.0, -1.0, -1.0],
            max: [2.0, 2.0, 0.0],
        })
        .unwrap();
        let anchor = Vector::repeat(0.05);
        let lo = Vector::new(0.0, 0.0, -0.5);
        let hi = Vector::new(1.0, 1.0, 1.0);
        let pts = WallParticles::sample(&[floor], &anchor, 0.1, 0.26, &lo, &hi);
        // Three layers (z = -0.05, -0.15, -0.25) of 10 × 10.
        assert_eq!(pts.len(), 300);
        assert!(pts.iter().all(|p| p.z < 0.0 && p.z > -0.3));
    }

    /// Boundary particles of a deformable block follow x = c + R(I + E)X with the material
    /// velocity; with the rigid flag the same pose puts them where the rotation alone does.
    #[test]
    fn body_particles_follow_the_strain_of_a_deformable_block() {
        let cube = Polyhedron::from_shape(&ShapeSpec::Box {
            min: [0.0; 3],
            max: [0.4; 3],
        })
        .unwrap();
        let grid = CellGrid::new(Vector::repeat(-1.0), Vector::repeat(2.0), 0.1).unwrap();
        let mut body = BodyParticles::new(
            std::slice::from_ref(&cube),
            &Vector::repeat(0.025),
            0.05,
            0.1,
            grid,
        );
        assert!(!body.is_empty());
        let rot = shared::math::Rotation::from_euler_angles(0.2, -0.1, 0.4);
        let mut state = BlockState {
            centroid: [0.3, 0.25, 0.2],
            orientation: [rot.i, rot.j, rot.k, rot.w],
            velocity: [0.1, 0.0, -0.2],
            angular_velocity: [0.0, 0.3, 0.0],
            strain: [0.02, -0.01, 0.03, 0.01, 0.0, -0.02],
            strain_rate: [0.5, 0.0, -0.3, 0.2, 0.1, 0.0],
            ..Default::default()
        };
        let r = rot.to_rotation_matrix().into_inner();
        for deformable in [true, false] {
            state.flags = if deformable {
                BlockState::DEFORMABLE
            } else {
                0
            };
            body.place(std::slice::from_ref(&state));
            let (f, rate) = if deformable {
                (
                    r * (Matrix::identity() + shared::strain::tensor(&state.strain())),
                    r * shared::strain::tensor(&Strain::from(state.strain_rate)),
                )
            } else {
                (r, Matrix::zeros())
            };
            let (c, v0, w) = (
                Vector::from(state.centroid),
                Vector::from(state.velocity),
                Vector::from(state.angular_velocity),
            );
            for ((x, v), local) in body
                .set
                .position
                .iter()
                .zip(&body.velocity)
                .zip(&body.local_sorted)
            {
                assert!((x - (c + f * local)).norm() < 1e-12);
                assert!((v - (v0 + w.cross(&(x - c)) + rate * local)).norm() < 1e-12);
            }
            let key = |a: &Vector, b: &Vector| a.as_slice().partial_cmp(b.as_slice()).unwrap();
            let (mut sorted, mut all) = (body.local_sorted.clone(), body.local.clone());
            sorted.sort_by(key);
            all.sort_by(key);
            assert_eq!(sorted, all, "every particle once");
        }
    }
}
