//! Paper Eq. 22, both ways: f = (K_S·d − (v·n)·K_D)·n on every particle within the margin of a
//! block face, and the opposite force with its moment about the centroid on the block.
//!
//! Broad phase: for each block only the grid cells overlapping its bounding box (grown by the
//! margin) are visited, and a cell is skipped whole when its centre is farther from the block's
//! planes than the margin plus half the cell diagonal. The fixed blocks' cells are found once
//! (neither the grid nor the blocks move), and all fixed blocks are applied in one parallel pass
//! over the particles, each reading the fixed blocks near its cell; the moving blocks, whose
//! reactions are summed, follow block by block. The narrow phase takes the face of largest
//! signed plane distance (the nearest face in front of it; exact in front of a face, a lower
//! bound near edges, which errs on the side of pushing).

use crate::core::grid::CellGrid;
use crate::core::particles::Particles;
use crate::core::tasks;
use crate::ranks::share::Share;
use rayon::prelude::*;
use shared::geometry::Polyhedron;
use shared::geometry::strain::{MaterialMap, Strain};
use shared::math::{Real, Vector};
use shared::protocol::{BlockLoad, BlockState};

/// One block as the fluid sees it.
#[derive(Debug, Clone)]
pub struct Obstacle {
    /// Faces in the block's local frame (centroid at the origin).
    pub shape: Polyhedron,
    /// Pose and velocities (zero for fixed blocks).
    pub state: BlockState,
    /// Index into the loads of moving blocks, `None` for fixed blocks.
    pub moving: Option<usize>,
    /// Margin used for this block [m].
    pub margin: Real,
    /// Material positions and velocities at the current state.
    map: MaterialMap,
    /// World planes (outward unit normal, offset n·x) of each face at the current state: the
    /// block frame's planes carried by F = R(I + E), whose normals turn with F⁻ᵀ.
    planes: Vec<(Vector, Real)>,
    /// World bounds of the corners.
    lo: Vector,
    hi: Vector,
}

impl Obstacle {
    pub fn new(shape: Polyhedron, state: BlockState, moving: Option<usize>, margin: Real) -> Self {
        let nf = shape.faces.len();
        let mut o = Self {
            shape,
            state,
            moving,
            margin,
            map: state.material_map(),
            planes: vec![(Vector::zeros(), 0.0); nf],
            lo: Vector::zeros(),
            hi: Vector::zeros(),
        };
        o.set_state(state);
        o
    }

    pub fn set_state(&mut self, state: BlockState) {
        self.state = state;
        self.map = state.material_map();
        let normal_map = self.map.inverse.transpose();
        for (plane, f) in self.planes.iter_mut().zip(&self.shape.faces) {
            let n = (normal_map * f.normal).normalize();
            let on_face = self
                .map
                .position(&self.shape.vertices[f.vertices[0] as usize].coords);
            *plane = (n, n.dot(&on_face));
        }
        self.lo = Vector::repeat(Real::INFINITY);
        self.hi = Vector::repeat(Real::NEG_INFINITY);
        for v in &self.shape.vertices {
            let w = self.map.position(&v.coords);
            self.lo = self.lo.inf(&w);
            self.hi = self.hi.sup(&w);
        }
    }

    /// World-frame bounds grown by the margin.
    fn bounds(&self) -> (Vector, Vector) {
        let m = Vector::repeat(self.margin);
        (self.lo - m, self.hi + m)
    }

    /// Signed distance of a world point to the block's planes (the largest: negative inside)
    /// and the world normal of that face.
    #[inline]
    fn distance(&self, x: &Vector) -> (Real, Vector) {
        let mut best = (Real::NEG_INFINITY, Vector::z());
        for (n, o) in &self.planes {
            let d = n.dot(x) - o;
            if d > best.0 {
                best = (d, *n);
            }
        }
        best
    }

    /// Eq. 22 force on a particle at `x` with velocity `v`; also the surface point it acts at.
    #[inline]
    fn force(&self, x: &Vector, v: &Vector, ks: Real, kd: Real) -> Option<(Vector, Vector)> {
        let (dist, n) = self.distance(x);
        if dist >= self.margin {
            return None;
        }
        let surface = x - n * dist;
        let vs = self.map.velocity(&self.map.material(&surface));
        let d = self.margin - dist;
        // A penalty contact pushes, never pulls: a particle leaving fast must not be held back.
        let magnitude = (ks * d - (v - vs).dot(&n) * kd).max(0.0);
        Some((n * magnitude, surface))
    }
}

/// A block at rest at its scene pose.
pub fn resting_state(block: u32, shape: &Polyhedron) -> BlockState {
    BlockState {
        block,
        centroid: shape.centroid.coords.into(),
        orientation: [0.0, 0.0, 0.0, 1.0],
        ..Default::default()
    }
}

/// Eq. 22 coupling between the particles and every block.
#[derive(Debug, Clone)]
pub struct Penalty {
    pub stiffness: Real,
    pub damping: Real,
    pub obstacles: Vec<Obstacle>,
    /// Candidate particles of the block being processed, and their forces (reused buffers).
    candidates: Vec<u32>,
    forces: Vec<(Vector, Vector)>,
    /// The fixed blocks near each grid cell, found once (the grid and the blocks never move):
    /// scanning every cell of a wall's bounding box at each step cost a third of a Müller step
    /// once the cells were halved.
    fixed_near: Option<NearBlocks>,
}

/// For each grid cell, the fixed blocks (obstacle indices, in obstacle order) whose margin a
/// particle in the cell may reach: compressed rows, `blocks[start[c]..start[c + 1]]` (a u32 per
/// cell, as the grid's own ranges take, and one per near pair).
#[derive(Debug, Clone)]
struct NearBlocks {
    start: Vec<u32>,
    blocks: Vec<u32>,
}

impl NearBlocks {
    /// A cell is near a block when its centre is within the margin plus half the cell diagonal
    /// of the block's planes: every point of the cell is within half the diagonal of its centre.
    fn new(obstacles: &[Obstacle], grid: &CellGrid) -> Self {
        let half_diag = 0.5 * 3f64.sqrt() * grid.cell_size();
        let mut pairs: Vec<(u32, u32)> = Vec::new();
        for (b, o) in obstacles.iter().enumerate() {
            if o.moving.is_some() {
                continue;
            }
            let (lo, hi) = o.bounds();
            grid.box_all_cells(&lo, &hi, |cell, centre| {
                if o.distance(centre).0 < o.margin + half_diag {
                    pairs.push((cell as u32, b as u32));
                }
            });
        }
        // By cell, and within a cell in obstacle order (the order the forces are summed in).
        pairs.sort_unstable();
        let mut start = vec![0u32; grid.cell_count() + 1];
        for &(cell, _) in &pairs {
            start[cell as usize + 1] += 1;
        }
        for c in 0..grid.cell_count() {
            start[c + 1] += start[c];
        }
        Self {
            start,
            blocks: pairs.into_iter().map(|(_, b)| b).collect(),
        }
    }

    #[inline]
    fn of(&self, cell: usize) -> &[u32] {
        &self.blocks[self.start[cell] as usize..self.start[cell + 1] as usize]
    }
}

impl Penalty {
    pub fn new(stiffness: Real, damping: Real, obstacles: Vec<Obstacle>) -> Self {
        Self {
            stiffness,
            damping,
            obstacles,
            candidates: Vec::new(),
            fixed_near: None,
            forces: Vec::new(),
        }
    }

    /// Takes the moving blocks' states (in loads order).
    pub fn set_moving(&mut self, states: &[BlockState]) {
        for o in &mut self.obstacles {
            if let Some(k) = o.moving
                && let Some(s) = states.get(k)
            {
                o.set_state(*s);
            }
        }
    }

    /// A fixed wall that cannot be crossed: every particle (`owned` or not: the same on every
    /// rank holding it) that the step has moved closer than `clearance` to a fixed block's face,
    /// or into the block, is put back at `clearance` in front of that face (the face of largest
    /// signed distance, as [`Obstacle::distance`]) and loses the velocity it had into it, v·n < 0
    /// (the no-penetration condition v·n = 0 of an incompressible fluid at a fixed wall,
    /// imposed directly: the position correction of Ihmsen, Akinci, Gissler & Teschner 2010,
    /// "Boundary handling and adaptive time-stepping for PCISPH", and the direct forcing of
    /// Becker, Tessendorf & Teschner 2009, both inelastic). Eq. 22 and the boundary particles
    /// hold water at rest half a spacing off the face; this is for what they cannot stop within
    /// a step. Returns how many particles it moved. The fixed blocks near each cell are those of
    /// [`Self::apply`].
    pub fn keep_out(
        &mut self,
        particles: &mut Particles,
        grid: &CellGrid,
        clearance: Real,
    ) -> usize {
        let near = self
            .fixed_near
            .get_or_insert_with(|| NearBlocks::new(&self.obstacles, grid));
        let obstacles = &self.obstacles;
        particles
            .position
            .par_iter_mut()
            .zip(particles.velocity.par_iter_mut())
            .with_max_len(tasks::PARTICLES)
            .map(|(x, v)| {
                let mut moved = 0;
                for &b in near.of(grid.cell_index(x)) {
                    let (d, n) = obstacles[b as usize].distance(x);
                    if d < clearance {
                        *x += n * (clearance - d);
                        let vn = v.dot(&n);
                        if vn < 0.0 {
                            *v -= n * vn;
                        }
                        moved = 1;
                    }
                }
                moved
            })
            .sum()
    }

    /// Writes the Eq. 22 force of all blocks on each particle into `particles.penalty`, and the
    /// opposite force and its torque about the centroid, summed per moving block, into `loads`.
    /// A particle's forces are summed the fixed blocks first, then the moving ones, each in
    /// scene order. On several ranks (`split`) each rank applies the forces to all it holds and
    /// rank 0 sums the loads from the owners' terms in one-rank order (its `loads`; the other
    /// ranks' are not meaningful).
    pub fn apply(
        &mut self,
        particles: &mut Particles,
        grid: &CellGrid,
        mut loads: Option<&mut [BlockLoad]>,
        split: Option<&Share>,
    ) {
        if let Some(l) = loads.as_deref_mut() {
            for (k, load) in l.iter_mut().enumerate() {
                let block = self
                    .obstacles
                    .iter()
                    .find(|o| o.moving == Some(k))
                    .map_or(0, |o| o.state.block);
                *load = BlockLoad {
                    block,
                    ..Default::default()
                };
            }
        }
        let (ks, kd) = (self.stiffness, self.damping);
        // The fixed blocks, in one pass that also clears every other particle's force. A
        // particle reads the blocks near the cell it is in now (not the cell it was sorted
        // into), so how far it moved since the sort does not matter.
        let near = self
            .fixed_near
            .get_or_insert_with(|| NearBlocks::new(&self.obstacles, grid));
        let obstacles = &self.obstacles;
        let (pos, vel) = (&particles.position, &particles.velocity);
        // On several ranks only the owned particles' forces are read (a halo particle's
        // acceleration comes from its owner).
        let owned = split.map(|s| &s.owned[..]);
        particles
            .penalty
            .par_iter_mut()
            .enumerate()
            .with_max_len(tasks::PARTICLES)
            .for_each(|(i, f)| {
                if owned.is_some_and(|o| !o[i]) {
                    return;
                }
                let mut sum = Vector::zeros();
                for &b in near.of(grid.cell_index(&pos[i])) {
                    if let Some((force, _)) = obstacles[b as usize].force(&pos[i], &vel[i], ks, kd)
                    {
                        sum += force;
                    }
                }
                *f = sum;
            });
        // A cell is near when its centre is within the margin plus half its diagonal, plus how
        // far its particles may have moved since they were sorted into it.
        let half_diag = 0.5 * 3f64.sqrt() * grid.cell_size() + grid.stale_reach();
        for o in self.obstacles.iter().filter(|o| o.moving.is_some()) {
            // Broad phase: cells near the block.
            self.candidates.clear();
            let (lo, hi) = o.bounds();
            grid.box_cells(&lo, &hi, |centre, range| {
                if o.distance(centre).0 < o.margin + half_diag {
                    self.candidates.extend(range.map(|i| i as u32));
                }
            });
            // Narrow phase in parallel, then a sequential scatter over the few candidates.
            self.forces
                .resize(self.candidates.len(), (Vector::zeros(), Vector::zeros()));
            let (pos, vel) = (&particles.position, &particles.velocity);
            self.forces
                .par_iter_mut()
                .zip(self.candidates.par_iter())
                .for_each(|(out, &i)| {
                    let i = i as usize;
                    *out = o
                        .force(&pos[i], &vel[i], ks, kd)
                        .unwrap_or((Vector::zeros(), pos[i]));
                });
            let (mut force, mut torque, mut strain) =
                (Vector::zeros(), Vector::zeros(), Strain::zeros());
            let c = o.map.centroid;
            let loaded = loads.is_some();
            let mut add = |f: &Vector, at: &Vector| {
                force -= f;
                torque -= (at - c).cross(f);
                if o.map.deformable {
                    strain -= o.map.strain_load(&o.map.material(at), f);
                }
            };
            let mut terms = Vec::new();
            for (&i, (f, at)) in self.candidates.iter().zip(&self.forces) {
                // Most candidates are beyond the margin; a zero force changes no sum (none
                // holds −0), so it is skipped.
                if *f == Vector::zeros() {
                    continue;
                }
                particles.penalty[i as usize] += f;
                if !loaded {
                    continue;
                }
                match split {
                    None => add(f, at),
                    // The candidates are in one-rank order (cell by cell), as the keys are.
                    Some(s) if s.owned[i as usize] => {
                        terms.push((s.key(i as usize), [f.x, f.y, f.z, at.x, at.y, at.z]))
                    }
                    Some(_) => {}
                }
            }
            if let Some(all) = split
                .filter(|_| loaded)
                .and_then(|s| s.gather_items(&terms))
            {
                for (_, t) in all {
                    add(
                        &Vector::new(t[0], t[1], t[2]),
                        &Vector::new(t[3], t[4], t[5]),
                    );
                }
            }
            if let (Some(k), Some(l)) = (o.moving, loads.as_deref_mut())
                && let Some(slot) = l.get_mut(k)
            {
                slot.force = (Vector::from(slot.force) + force).into();
                slot.torque = (Vector::from(slot.torque) + torque).into();
                slot.strain_load = (Strain::from(slot.strain_load) + strain).into();
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use shared::math::Rotation;
    use shared::scene::ShapeSpec;

    fn cube() -> Polyhedron {
        Polyhedron::from_shape(&ShapeSpec::Box {
            min: [0.0; 3],
            max: [1.0; 3],
        })
        .unwrap()
    }

    #[test]
    fn eq22_force_and_equal_opposite_load() {
        let shape = cube();
        let mut state = resting_state(3, &shape);
        // Block moving up at 1 m/s and spinning about z.
        state.velocity = [0.0, 0.0, 1.0];
        state.angular_velocity = [0.0, 0.0, 0.5];
        let margin = 0.05;
        let (ks, kd) = (1000.0, 10.0);
        let ob = Obstacle::new(shape, state, Some(0), margin);
        let mut pen = Penalty::new(ks, kd, vec![ob]);
        // Two particles above the top face (one inside the margin, one outside), one far away.
        let pos = vec![
            Vector::new(0.8, 0.5, 1.02),
            Vector::new(0.5, 0.5, 1.2),
            Vector::new(3.0, 3.0, 3.0),
        ];
        let mut p = Particles::new(pos, vec![1000.0; 3]);
        p.velocity[0] = Vector::new(0.0, 0.0, -2.0);
        let mut grid = CellGrid::new(Vector::repeat(-1.0), Vector::repeat(4.0), 0.1).unwrap();
        let order = grid.sort(&p.position).to_vec();
        p.permute(
            &order,
            crate::core::particles::Carried::ALL,
            &mut Vec::new(),
        );
        let mut loads = vec![BlockLoad::default()];
        pen.apply(&mut p, &grid, Some(&mut loads), None);
        let i = p
            .position
            .iter()
            .position(|x| (x.z - 1.02).abs() < 1e-12)
            .unwrap();
        // d = margin − 0.02; relative normal velocity −2 − 1 = −3 m/s.
        let expected = ks * 0.03 + 3.0 * kd;
        assert!(
            (p.penalty[i] - Vector::new(0.0, 0.0, expected)).norm() < 1e-9,
            "{}",
            p.penalty[i]
        );
        let others: Real = p
            .penalty
            .iter()
            .enumerate()
            .filter(|&(j, _)| j != i)
            .map(|(_, f)| f.norm())
            .sum();
        assert_eq!(others, 0.0);
        assert_eq!(loads[0].block, 3);
        assert!((Vector::from(loads[0].force) + p.penalty[i]).norm() < 1e-9);
        // Torque about the centroid (0.5, 0.5, 0.5) of −f applied at the surface point (0.8, 0.5, 1).
        let arm = Vector::new(0.3, 0.0, 0.5);
        let t = arm.cross(&(-p.penalty[i]));
        assert!((Vector::from(loads[0].torque) - t).norm() < 1e-9);
        assert!(t.norm() > 1.0);
    }

    #[test]
    fn rotated_block_pushes_along_its_rotated_normal() {
        let shape = cube();
        let mut state = resting_state(0, &shape);
        let rot = Rotation::from_axis_angle(&Vector::y_axis(), std::f64::consts::FRAC_PI_4);
        state.orientation = [rot.i, rot.j, rot.k, rot.w];
        let ob = Obstacle::new(shape, state, None, 0.05);
        // Just outside the rotated top face, whose normal is (sin 45°, 0, cos 45°).
        let n = rot * Vector::z();
        let x = Vector::new(0.5, 0.5, 0.5) + n * 0.51;
        let (f, _) = ob.force(&x, &Vector::zeros(), 100.0, 0.0).unwrap();
        assert!((f - n * (100.0 * 0.04)).norm() < 1e-9, "{f}");
    }

    /// A deformable cube stretched by εz = 0.1 and shearing (γzx rate): the particle feels the
    /// displaced top face with its material velocity, and the block's strain load is the
    /// virtual work of the reaction, f · (δE X).
    #[test]
    fn deformed_block_pushes_from_its_deformed_face_and_loads_its_strain() {
        let shape = cube();
        let mut state = resting_state(0, &shape);
        state.flags = BlockState::DEFORMABLE;
        state.strain = [0.0, 0.0, 0.1, 0.0, 0.0, 0.0];
        state.strain_rate = [0.0, 0.0, 2.0, 0.0, 0.0, 0.0];
        let (margin, ks, kd) = (0.05, 1000.0, 10.0);
        let mut pen = Penalty::new(ks, kd, vec![Obstacle::new(shape, state, Some(0), margin)]);
        // The top face is at z = 0.5 + 0.5 · 1.1 = 1.05, moving up at ε̇z · 0.5 = 1 m/s.
        let pos = vec![Vector::new(0.6, 0.5, 1.07), Vector::new(0.5, 0.5, 1.2)];
        let mut p = Particles::new(pos, vec![1000.0; 2]);
        let mut grid = CellGrid::new(Vector::repeat(-1.0), Vector::repeat(4.0), 0.1).unwrap();
        let order = grid.sort(&p.position).to_vec();
        p.permute(
            &order,
            crate::core::particles::Carried::ALL,
            &mut Vec::new(),
        );
        let mut loads = vec![BlockLoad::default()];
        pen.apply(&mut p, &grid, Some(&mut loads), None);
        let i = p.position.iter().position(|x| x.z < 1.1).unwrap();
        let expected = ks * (margin - 0.02) + 1.0 * kd;
        assert!(
            (p.penalty[i] - Vector::new(0.0, 0.0, expected)).norm() < 1e-9,
            "{}",
            p.penalty[i]
        );
        // −f at the material point X = (0.1, 0, 0.5) of the undeformed cube.
        let g = shared::geometry::strain::generalised_force(
            &Vector::new(0.1, 0.0, 0.5),
            &-p.penalty[i],
        );
        assert!((Strain::from(loads[0].strain_load) - g).norm() < 1e-9);
        assert!((loads[0].strain_load[2] + expected * 0.5).abs() < 1e-9);
        // A rigid block of the same pose loads no strain.
        let mut rigid = state;
        rigid.flags = 0;
        pen.obstacles[0].set_state(rigid);
        pen.apply(&mut p, &grid, Some(&mut loads), None);
        assert_eq!(loads[0].strain_load, [0.0; 6]);
        assert!(p.penalty.iter().all(|f| f.norm() == 0.0));
    }

    #[test]
    fn broad_phase_finds_what_brute_force_finds() {
        let shape = cube();
        let mut state = resting_state(0, &shape);
        let rot = Rotation::from_euler_angles(0.3, -0.5, 0.9);
        state.orientation = [rot.i, rot.j, rot.k, rot.w];
        state.centroid = [1.0, 1.0, 1.0];
        let ob = Obstacle::new(shape, state, Some(0), 0.04);
        let mut pen = Penalty::new(500.0, 1.0, vec![ob.clone()]);
        let mut rnd = crate::uniform(11);
        let pos: Vec<Vector> = (0..20_000)
            .map(|_| Vector::new(3.0 * rnd(), 3.0 * rnd(), 3.0 * rnd()))
            .collect();
        let mut p = Particles::new(pos, vec![1000.0; 20_000]);
        let mut grid = CellGrid::new(Vector::zeros(), Vector::repeat(3.0), 0.1).unwrap();
        let order = grid.sort(&p.position).to_vec();
        p.permute(
            &order,
            crate::core::particles::Carried::ALL,
            &mut Vec::new(),
        );
        let mut loads = vec![BlockLoad::default()];
        pen.apply(&mut p, &grid, Some(&mut loads), None);
        let mut touched = 0;
        let mut total = Vector::zeros();
        for i in 0..p.len() {
            let brute = ob
                .force(&p.position[i], &p.velocity[i], 500.0, 1.0)
                .map_or(Vector::zeros(), |f| f.0);
            assert!(
                (brute - p.penalty[i]).norm() < 1e-9,
                "particle {i}: {brute} vs {}",
                p.penalty[i]
            );
            touched += usize::from(brute.norm() > 0.0);
            total += brute;
        }
        // Inside the block or within the margin: a sizeable sample, and the load balances it.
        assert!(touched > 500, "{touched}");
        assert!((Vector::from(loads[0].force) + total).norm() < 1e-6 * total.norm().max(1.0));
    }

    #[test]
    fn fixed_blocks_in_one_pass_give_the_brute_force_sums_after_particles_moved() {
        let boxed = |min: [f64; 3], max: [f64; 3]| {
            Polyhedron::from_shape(&ShapeSpec::Box { min, max }).unwrap()
        };
        // A floor and two walls meeting in a corner, and a tilted moving cube over it; the
        // moving block comes first in scene order, its forces are still summed last.
        let mut moving_state = resting_state(0, &cube());
        let rot = Rotation::from_euler_angles(0.2, 0.1, -0.4);
        moving_state.orientation = [rot.i, rot.j, rot.k, rot.w];
        moving_state.centroid = [0.7, 0.7, 0.6];
        moving_state.velocity = [0.3, 0.0, -1.0];
        let margin = 0.06;
        let fixed = [
            boxed([-0.5, -0.5, -0.5], [2.5, 2.5, 0.0]),
            boxed([-0.5, -0.5, -0.5], [0.0, 2.5, 2.5]),
            boxed([-0.5, -0.5, -0.5], [2.5, 0.0, 2.5]),
        ];
        let mut obstacles = vec![Obstacle::new(cube(), moving_state, Some(0), margin)];
        for (k, f) in fixed.iter().enumerate() {
            obstacles.push(Obstacle::new(
                f.clone(),
                resting_state(k as u32 + 1, f),
                None,
                margin,
            ));
        }
        let (ks, kd) = (800.0, 3.0);
        let mut pen = Penalty::new(ks, kd, obstacles.clone());
        let mut rnd = crate::uniform(3);
        // Crowded near the corner, so that many particles are within the margin of 2–4 blocks.
        let n = 30_000;
        let pos: Vec<Vector> = (0..n)
            .map(|_| Vector::new(0.25 * rnd(), 1.5 * rnd(), 0.25 * rnd()))
            .collect();
        let mut p = Particles::new(pos, vec![1000.0; n]);
        let mut grid = CellGrid::new(Vector::zeros(), Vector::repeat(2.0), 0.1).unwrap();
        grid.set_stale_reach(0.03);
        let order = grid.sort(&p.position).to_vec();
        p.permute(
            &order,
            crate::core::particles::Carried::ALL,
            &mut Vec::new(),
        );
        // Moved since the sort by up to the stale reach, some across a cell face.
        for (i, x) in p.position.iter_mut().enumerate() {
            let a = i as f64 * 0.7;
            *x += Vector::new(a.sin(), a.cos(), (2.0 * a).sin()) * (0.03 / 3f64.sqrt());
            p.velocity[i] = Vector::new(0.0, 0.0, -a.cos());
        }
        let mut loads = vec![BlockLoad::default()];
        pen.apply(&mut p, &grid, Some(&mut loads), None);
        let (mut pushed, mut several) = (0, 0);
        for i in 0..n {
            let (x, v) = (&p.position[i], &p.velocity[i]);
            let mut expected = Vector::zeros();
            let mut count = 0;
            for o in obstacles[1..].iter().chain(&obstacles[..1]) {
                if let Some((f, _)) = o.force(x, v, ks, kd)
                    && f != Vector::zeros()
                {
                    expected += f;
                    count += 1;
                }
            }
            assert_eq!(p.penalty[i], expected, "particle {i} at {x}");
            pushed += usize::from(count > 0);
            several += usize::from(count > 1);
        }
        assert!(
            pushed > 2_000 && several > 200,
            "{pushed} pushed, {several} by several blocks"
        );
        // A second call (the near cells now kept) gives the same forces.
        let first = p.penalty.clone();
        pen.apply(&mut p, &grid, Some(&mut loads), None);
        assert_eq!(p.penalty, first);
    }
}
