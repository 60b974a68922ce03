//! Boundary particles on the moving (kinematic and free) blocks (Adami, Hu & Adams 2012, §2.3),
//! the same wall as [`crate::boundary::walls`] carried with the block: with the
//! Eq. 22 springs alone the particles under a floating block see no water above them, their
//! pressure is a truncated-kernel estimate and the block floats too deep (43 % at dx = 0.04,
//! 10 % at 0.02; docs/speed-accuracy.md). The block's boundary particles are sampled once in its
//! local frame and carried, as the material points they are, with the pose (and the strain, for a
//! deformable block) the solid node sends; the force the water exerts
//! on them (the reverse of their pressure force on each fluid neighbour) is summed into the
//! block's load, so action and reaction balance pair by pair.

use crate::boundary::walls::WallParticles;
use crate::core::grid::CellGrid;
use crate::ranks::share::Share;
use rayon::prelude::*;
use shared::geometry::Polyhedron;
use shared::geometry::strain::{MaterialMap, Strain};
use shared::math::{Matrix, Matrix6, Point, Real, Vector, Vector6};
use shared::protocol::{BlockLoad, BlockState};

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
    /// Each block's inertia and the rest of its forces, as the solid node sent them.
    pub rigid: Vec<Rigid>,
    /// `velocity` as the pose set it (a solver that moves the blocks within its step changes
    /// `velocity` and puts this back after it: [`Self::nudge`], [`Self::settle`]).
    placed_velocity: Vec<Vector>,
}

/// What a moving block's motion within a fluid step follows from. Taken on its own:
/// m Δv = Δt (F + R) and I Δω = Δt (τ + T) with F, τ the water's and R, T the rest
/// ([`shared::protocol::BlockState::other_force`]). With a response the solid measured over the
/// step (it looked ahead, [`shared::protocol::BlockState::free_acceleration`]):
/// (Δv, Δω) = Δt (a0 + M (F, τ)), the block's contacts' answer within the step included.
#[derive(Debug, Clone, Copy)]
pub struct Rigid {
    /// 1/m; zero for a kinematic block.
    pub inverse_mass: Real,
    /// World inverse inertia about the centroid.
    pub inverse_inertia: Matrix,
    pub other_force: Vector,
    pub other_torque: Vector,
    /// (a0, M), if the solid measured them.
    pub response: Option<(Vector6, Matrix6)>,
}

impl Rigid {
    /// (Δv, Δω) of the water's force `f` and torque `t` over `dt`; with `rest`, also of
    /// everything else on the block (R, T or a0).
    pub fn response(&self, f: &Vector, t: &Vector, dt: Real, rest: bool) -> (Vector, Vector) {
        match &self.response {
            None => {
                let (f, t) = if rest {
                    (f + self.other_force, t + self.other_torque)
                } else {
                    (*f, *t)
                };
                (f * (self.inverse_mass * dt), self.inverse_inertia * t * dt)
            }
            Some((a0, m)) => {
                let mut x = m * Vector6::new(f.x, f.y, f.z, t.x, t.y, t.z);
                if rest {
                    x += a0;
                }
                x *= dt;
                (x.fixed_rows::<3>(0).into(), x.fixed_rows::<3>(3).into())
            }
        }
    }

    /// uᵀ M u for u = (a, c) (M = diag(1/m, I⁻¹) on its own): how far a load along u moves
    /// the block along it (the symmetric part of a measured M; at least 0).
    pub fn mobility_along(&self, a: &Vector, c: &Vector) -> Real {
        match &self.response {
            None => self.inverse_mass * a.norm_squared() + c.dot(&(self.inverse_inertia * c)),
            Some((_, m)) => {
                let u = Vector6::new(a.x, a.y, a.z, c.x, c.y, c.z);
                u.dot(&(m * u)).max(0.0)
            }
        }
    }
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
            rigid: vec![
                Rigid {
                    inverse_mass: 0.0,
                    inverse_inertia: Matrix::zeros(),
                    other_force: Vector::zeros(),
                    other_torque: Vector::zeros(),
                    response: None,
                };
                moving.len()
            ],
            placed_velocity: vec![Vector::zeros(); n],
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
            .zip(self.placed_velocity.par_iter_mut())
            .enumerate()
            .for_each(|(i, (v, placed))| {
                *v = maps[owner[i] as usize].velocity(&local[i]);
                *placed = *v;
            });
        for (r, s) in self.rigid.iter_mut().zip(states) {
            *r = Rigid {
                inverse_mass: s.inverse_mass,
                inverse_inertia: s.inverse_inertia(),
                other_force: Vector::from(s.other_force),
                other_torque: Vector::from(s.other_torque),
                response: s.response(),
            };
        }
    }

    /// Block `k`'s centroid at its current pose.
    pub fn centroid(&self, k: usize) -> Vector {
        self.maps[k].centroid
    }

    /// Whether any block can be moved by forces (a free block: nonzero inverse mass).
    pub fn any_free(&self) -> bool {
        self.rigid.iter().any(|r| r.inverse_mass > 0.0)
    }

    /// Sets every particle's velocity to the placed one plus its block's rigid change
    /// (Δv, Δω) from `change` (loads order): v = v_placed + Δv + Δω × (x − c).
    pub fn nudge(&mut self, change: &[(Vector, Vector)]) {
        let (owner, maps, pos) = (&self.owner_sorted, &self.maps, &self.set.position);
        self.velocity
            .par_iter_mut()
            .zip(self.placed_velocity.par_iter())
            .enumerate()
            .for_each(|(i, (v, placed))| {
                let k = owner[i] as usize;
                let (dv, dw) = &change[k];
                *v = placed + dv + dw.cross(&(pos[i] - maps[k].centroid));
            });
    }

    /// Puts the placed velocities back (after a step that nudged them).
    pub fn settle(&mut self) {
        self.velocity.copy_from_slice(&self.placed_velocity);
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
    /// Parallel over the active particles, then a short sequential sum per block. On several
    /// ranks (`split`, with the fluid's `grid`) each boundary particle's force is its owner's,
    /// and rank 0 sums them in one-rank order (the other ranks' loads are not meaningful).
    pub fn react(
        &mut self,
        fluid: &[Vector],
        support: Real,
        pair: impl Fn(usize, Real, Real, &Vector, Real) -> Vector + Sync,
        split: Option<(&Share, &CellGrid)>,
    ) {
        self.react_moving(
            fluid,
            support,
            |i, _, pw, rw, r, len| pair(i, pw, rw, r, len),
            split,
        );
    }

    /// [`Self::react`] with the wall particle's velocity: `pair(f, v_w, p_w, ρ_w, r_fw, r)`
    /// (for a force that depends on the pair's relative velocity).
    pub fn react_moving(
        &mut self,
        fluid: &[Vector],
        support: Real,
        pair: impl Fn(usize, &Vector, Real, Real, &Vector, Real) -> Vector + Sync,
        split: Option<(&Share, &CellGrid)>,
    ) {
        let s2 = support * support;
        let velocity = &self.velocity;
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
                        f -= pair(i, &velocity[w], pw, rw, &r, r2.sqrt());
                    }
                }
                *out = f;
            });
        self.loads
            .iter_mut()
            .for_each(|l| *l = (Vector::zeros(), Vector::zeros(), Strain::zeros()));
        let terms: Vec<(u32, Vector)> = match split {
            None => set
                .active
                .iter()
                .copied()
                .zip(self.reaction.iter().copied())
                .collect(),
            Some((share, grid)) => {
                let mine: Vec<(u64, [Real; 3])> = set
                    .active
                    .iter()
                    .zip(&self.reaction)
                    .filter(|(w, _)| share.owns(grid, &set.position[**w as usize]))
                    .map(|(&w, f)| (w as u64, [f.x, f.y, f.z]))
                    .collect();
                // The owned particles' terms in the order of their indices: the order of the
                // active list on one rank (a particle active there and not here has no
                // water near enough to push it: its term is zero and changes no sum).
                share.gather_items(&mine).map_or_else(Vec::new, |all| {
                    all.iter()
                        .map(|(w, f)| (*w as u32, Vector::new(f[0], f[1], f[2])))
                        .collect()
                })
            }
        };
        for (w, f) in terms.iter().map(|(w, f)| (*w, f)) {
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

    /// A 0.4 m cube sampled at dx = 0.05 m, 0.1 m deep.
    fn cube_body() -> BodyParticles {
        let cube = Polyhedron::from_shape(&ShapeSpec::Box {
            min: [0.0; 3],
            max: [0.4; 3],
        })
        .unwrap();
        let grid = CellGrid::new(Vector::repeat(-1.0), Vector::repeat(2.0), 0.1).unwrap();
        BodyParticles::new(
            std::slice::from_ref(&cube),
            &Vector::repeat(0.025),
            0.05,
            0.1,
            grid,
        )
    }

    /// Boundary particles of a deformable block follow x = c + R(I + E)X with the material
    /// velocity; with the rigid flag the same pose puts them where the rotation alone does.
    #[test]
    fn body_particles_follow_the_strain_of_a_deformable_block() {
        let mut body = cube_body();
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
                    r * (Matrix::identity() + shared::geometry::strain::tensor(&state.strain())),
                    r * shared::geometry::strain::tensor(&Strain::from(state.strain_rate)),
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

    /// A block moved within a fluid step: its particles take v_placed + Δv + Δω × (x − c), the
    /// response of a force and torque is Δt F/m and Δt I⁻¹τ, and `settle` puts the placed
    /// velocities back.
    #[test]
    fn a_block_nudged_within_a_step_moves_its_particles_rigidly() {
        let mut body = cube_body();
        let state = BlockState {
            centroid: [0.2, 0.2, 0.2],
            orientation: [0.0, 0.0, 0.0, 1.0],
            velocity: [0.1, 0.0, -0.2],
            angular_velocity: [0.0, 0.3, 0.0],
            inverse_mass: 0.5,
            inverse_inertia: [0.25, 0.5, 1.0, 0.0, 0.0, 0.0],
            other_force: [0.0, 0.0, -19.62],
            ..Default::default()
        };
        body.place(std::slice::from_ref(&state));
        assert!(body.any_free());
        let placed = body.velocity.clone();
        let rigid = body.rigid[0];
        assert!(rigid.response.is_none());
        let (f, t) = (Vector::new(2.0, 0.0, 4.0), Vector::new(4.0, 2.0, 1.0));
        // With the rest of its forces: the weight 2 · 9.81 N.
        let (v0, w0) = rigid.response(&f, &t, 0.1, true);
        assert!((v0 - Vector::new(0.1, 0.0, 0.2 - 0.981)).norm() < 1e-15);
        assert!((w0 - Vector::new(0.1, 0.1, 0.1)).norm() < 1e-15);
        let (dv, dw) = rigid.response(&f, &t, 0.1, false);
        assert!((dv - Vector::new(0.1, 0.0, 0.2)).norm() < 1e-15);
        assert!((dw - Vector::new(0.1, 0.1, 0.1)).norm() < 1e-15);
        // A measured response takes the place of the mass and the rest of the forces: a block
        // held along z (a contact) and free along x.
        let mut measured = state;
        let mut m = shared::math::Matrix6::zeros();
        m[(0, 0)] = 0.5;
        m[(4, 4)] = 0.5;
        m[(2, 0)] = 0.01;
        measured.set_response(&Vector6::new(1.0, 0.0, 0.0, 0.0, 0.0, 0.0), &m);
        body.place(std::slice::from_ref(&measured));
        let r = body.rigid[0];
        let (mv, mw) = r.response(&f, &t, 0.1, true);
        assert!((mv - Vector::new(0.2, 0.0, 0.002)).norm() < 1e-15, "{mv}");
        assert!((mw - Vector::new(0.0, 0.1, 0.0)).norm() < 1e-15, "{mw}");
        assert!(
            (r.mobility_along(&Vector::new(1.0, 0.0, 1.0), &Vector::zeros()) - 0.51).abs() < 1e-15
        );
        body.place(std::slice::from_ref(&state));
        body.nudge(&[(dv, dw)]);
        let c = Vector::from(state.centroid);
        for ((v, p), x) in body.velocity.iter().zip(&placed).zip(&body.set.position) {
            assert!((v - (p + dv + dw.cross(&(x - c)))).norm() < 1e-14);
        }
        body.settle();
        assert_eq!(body.velocity, placed);
        // A kinematic block (inverse mass 0) is not free.
        body.place(&[BlockState {
            inverse_mass: 0.0,
            ..state
        }]);
        assert!(!body.any_free());
    }
}
