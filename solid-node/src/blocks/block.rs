//! A block: its convex shape, mass properties, kind, pose and velocity, and the world-frame
//! copy of its geometry the contact search reads each step.
//!
//! Blocks are rigid (6 unknowns) unless the scene gives them `elastic = { ... }`: then they
//! carry Shi's six constant strains as well ([`crate::blocks::elastic`]), and a material point at X
//! (block frame, undeformed) is at x = c + R (I + E) X. Every geometric query below (world
//! vertices, face planes, point velocity and step displacement, the lever arm of a load on the
//! strains) takes the strain into account; for rigid blocks E = 0 is not even stored.

use crate::blocks::elastic::Elastic;
use crate::blocks::rotation;
use shared::geometry::Polyhedron;
use shared::geometry::strain::{self, Strain};
use shared::math::{Isometry, Matrix, Point, Real, Rotation, Vector};
use shared::scene::{BlockKind, BlockSpec, MotionSpec};
use shared::solver::SolverError;

/// One block of the scene.
#[derive(Debug, Clone)]
pub struct Block {
    /// Index in the scene's `[[block]]` list.
    pub scene_index: usize,
    pub name: String,
    pub kind: BlockKind,
    /// Shape in the local frame (centroid at the origin).
    pub shape: Polyhedron,
    /// Faces adjacent to each edge of `shape.edges` (for the edge normal cone).
    pub edge_faces: Vec<[u32; 2]>,
    /// For each vertex, the faces that contain it.
    pub vertex_faces: Vec<Vec<u32>>,
    /// Area of each face [m²].
    pub face_area: Vec<Real>,
    /// Mass [kg] (free blocks; kinematic and fixed blocks get their geometric mass too).
    pub mass: Real,
    /// Inertia tensor about the centroid in the body frame [kg·m²].
    pub inertia: Matrix,
    pub inv_inertia: Matrix,
    /// I^(-1/2) in the body frame, for the mass-normalised stiffness of the stability bound.
    pub inv_sqrt_inertia: Matrix,
    pub friction_angle: Option<Real>,
    pub cohesion: Option<Real>,
    /// The `[[slide]]` (index) the block was cut from, if any.
    pub slide: Option<usize>,
    pub motion: Option<MotionSpec>,
    /// Centroid at t = 0.
    pub origin: Point,

    // State at the current time.
    pub position: Point,
    pub rotation: Rotation,
    pub velocity: Vector,
    pub angular_velocity: Vector,
    /// Pose at the start of the last step (for the material displacement of contact points).
    pub prev_position: Point,
    pub prev_rotation: Rotation,
    /// Strain state and matrices of a deformable block; `None` for a rigid one (boxed: rigid
    /// blocks stay small in the contact search's cache).
    pub elastic: Option<Box<Elastic>>,

    // World-frame geometry at the current pose.
    pub world_vertices: Vec<Point>,
    /// Outward unit normal of each face.
    pub world_normals: Vec<Vector>,
    /// Plane offsets: n·x = offset on the face.
    pub world_offsets: Vec<Real>,
    pub aabb_min: Point,
    pub aabb_max: Point,
}

impl Block {
    /// Builds a block from its scene entry; the error names the block.
    pub fn from_spec(scene_index: usize, spec: &BlockSpec) -> Result<Block, SolverError> {
        let shape = Polyhedron::from_shape(&spec.shape)
            .map_err(|e| SolverError::Failed(format!("block '{}': {e}", spec.name)))?;
        let mass = spec.density * shape.volume;
        let inertia = shape.unit_inertia * spec.density;
        if spec.kind == BlockKind::Free && !(mass > 0.0 && mass.is_finite()) {
            return Err(SolverError::Failed(format!(
                "block '{}': free block has mass {} kg; fix: give a positive density",
                spec.name,
                shared::math::readable(mass)
            )));
        }
        let inv_inertia = inertia.try_inverse().unwrap_or_else(Matrix::zeros);
        let eig = inertia.symmetric_eigen();
        let inv_sqrt = eig
            .eigenvalues
            .map(|l| if l > 0.0 { 1.0 / l.sqrt() } else { 0.0 });
        let inv_sqrt_inertia =
            eig.eigenvectors * Matrix::from_diagonal(&inv_sqrt) * eig.eigenvectors.transpose();

        let edge_faces = shape
            .edges
            .iter()
            .map(|&[a, b]| {
                let mut found = [u32::MAX; 2];
                let mut n = 0;
                for (fi, f) in shape.faces.iter().enumerate() {
                    let k = f.vertices.len();
                    let has = (0..k).any(|i| {
                        let (p, q) = (f.vertices[i], f.vertices[(i + 1) % k]);
                        (p == a && q == b) || (p == b && q == a)
                    });
                    if has && n < 2 {
                        found[n] = fi as u32;
                        n += 1;
                    }
                }
                found
            })
            .collect();
        let mut vertex_faces = vec![Vec::new(); shape.vertices.len()];
        for (fi, f) in shape.faces.iter().enumerate() {
            for &v in &f.vertices {
                vertex_faces[v as usize].push(fi as u32);
            }
        }
        let face_area = shape
            .faces
            .iter()
            .map(|f| {
                // Fan triangulation of the planar convex polygon.
                let p0 = shape.vertices[f.vertices[0] as usize];
                let mut s = Vector::zeros();
                for w in f.vertices[1..].windows(2) {
                    s += (shape.vertices[w[0] as usize] - p0)
                        .cross(&(shape.vertices[w[1] as usize] - p0));
                }
                0.5 * s.norm()
            })
            .collect();
        let origin = shape.centroid;
        let nv = shape.vertices.len();
        let nf = shape.faces.len();
        let mut block = Block {
            scene_index,
            name: spec.name.clone(),
            kind: spec.kind,
            edge_faces,
            vertex_faces,
            face_area,
            mass,
            inertia,
            inv_inertia,
            inv_sqrt_inertia,
            friction_angle: spec.friction_angle,
            cohesion: spec.cohesion,
            slide: spec.slide.map(|m| m.slide),
            motion: spec.motion.clone(),
            origin,
            position: origin,
            rotation: Rotation::identity(),
            velocity: Vector::from(spec.velocity),
            angular_velocity: Vector::from(spec.angular_velocity),
            prev_position: origin,
            prev_rotation: Rotation::identity(),
            elastic: spec
                .elastic
                .as_ref()
                .filter(|_| spec.kind == BlockKind::Free)
                .map(|el| {
                    Box::new(Elastic::new(
                        el,
                        shape.volume,
                        spec.density,
                        &shape.unit_inertia,
                    ))
                }),
            world_vertices: vec![Point::origin(); nv],
            world_normals: vec![Vector::zeros(); nf],
            world_offsets: vec![0.0; nf],
            aabb_min: origin,
            aabb_max: origin,
            shape,
        };
        if block.kind == BlockKind::Kinematic {
            block.set_kinematic_pose(0.0);
        }
        if block.kind == BlockKind::Fixed {
            block.velocity = Vector::zeros();
            block.angular_velocity = Vector::zeros();
        }
        block.update_world_geometry();
        Ok(block)
    }

    #[inline]
    pub fn is_free(&self) -> bool {
        self.kind == BlockKind::Free
    }

    /// True for a 12-DOF deformable block.
    #[inline]
    pub fn is_deformable(&self) -> bool {
        self.elastic.is_some()
    }

    /// Number of unknowns: 6 for a free rigid block, 12 for a deformable one, 0 otherwise.
    pub fn unknowns(&self) -> usize {
        match (self.is_free(), self.is_deformable()) {
            (false, _) => 0,
            (true, false) => 6,
            (true, true) => 12,
        }
    }

    /// Strain (zero for a rigid block).
    #[inline]
    pub fn strain(&self) -> Strain {
        self.elastic
            .as_ref()
            .map_or_else(Strain::zeros, |e| e.strain)
    }

    /// Strain rate (zero for a rigid block).
    #[inline]
    pub fn strain_rate(&self) -> Strain {
        self.elastic.as_ref().map_or_else(Strain::zeros, |e| e.rate)
    }

    /// The linear part of the block-frame → world map, F = R (I + E) (R for a rigid block).
    pub fn deformation(&self) -> Matrix {
        let r = self.rotation.to_rotation_matrix().into_inner();
        match &self.elastic {
            None => r,
            Some(el) => r * el.stretch(),
        }
    }

    /// The undeformed block-frame position X of the material point now at world `p`:
    /// X = (I + E)⁻¹ Rᵀ (p − c).
    #[inline]
    pub fn material_point(&self, p: &Point) -> Vector {
        let local = self.rotation.inverse_transform_vector(&(p - self.position));
        match &self.elastic {
            None => local,
            Some(el) => el.stretch_inv * local,
        }
    }

    /// Generalised load on the strain unknowns of a world force `f` acting on the material
    /// point now at `p`: T_e(X)ᵀ Rᵀ f (zero for a rigid block).
    #[inline]
    pub fn strain_load(&self, p: &Point, f: &Vector) -> Strain {
        if self.elastic.is_none() {
            return Strain::zeros();
        }
        strain::generalised_force(
            &self.material_point(p),
            &self.rotation.inverse_transform_vector(f),
        )
    }

    /// Diameter of the bounding sphere [m]: the block's size in the displacement limit.
    #[inline]
    pub fn size(&self) -> Real {
        2.0 * self.shape.radius
    }

    pub fn isometry(&self) -> Isometry {
        Isometry::from_parts(self.position.coords.into(), self.rotation)
    }

    /// Prescribed pose and velocity of a kinematic block at time `t` (translation only: the
    /// scene's motions translate the block).
    pub fn set_kinematic_pose(&mut self, t: Real) {
        if let Some(m) = &self.motion {
            self.position = self.origin + m.displacement(t);
            self.velocity = m.velocity(t);
            self.angular_velocity = Vector::zeros();
        }
    }

    /// World inertia tensor R·I·Rᵀ.
    pub fn world_inertia(&self) -> Matrix {
        let r = self.rotation.to_rotation_matrix();
        r.matrix() * self.inertia * r.matrix().transpose()
    }

    pub fn world_inv_inertia(&self) -> Matrix {
        let r = self.rotation.to_rotation_matrix();
        r.matrix() * self.inv_inertia * r.matrix().transpose()
    }

    /// Velocity of the material point at world position `p`: v + ω × r, plus R Ė X for a
    /// deformable block (d/dt of c + R (I + E) X with Ṙ = [ω]× R).
    #[inline]
    pub fn point_velocity(&self, p: &Point) -> Vector {
        let rigid = self.velocity + self.angular_velocity.cross(&(p - self.position));
        match &self.elastic {
            None => rigid,
            Some(el) => rigid + self.strain_velocity(el, p),
        }
    }

    /// R Ė X (kept out of line: the rigid blocks' hot path stays as small as it was).
    #[inline(never)]
    fn strain_velocity(&self, el: &Elastic, p: &Point) -> Vector {
        let x = self.material_point(p);
        self.rotation * (strain::tensor(&el.rate) * x)
    }

    /// Displacement over the last step of the material point now at `p`: exact for the
    /// finite rotation and the strain change (p minus where that point was at the previous
    /// pose and strain).
    #[inline]
    pub fn point_step_displacement(&self, p: &Point) -> Vector {
        if let Some(el) = &self.elastic {
            return self.deformed_step_displacement(el, p);
        }
        let local = self.rotation.inverse_transform_vector(&(p - self.position));
        p - (self.prev_position + self.prev_rotation * local)
    }

    #[inline(never)]
    fn deformed_step_displacement(&self, el: &Elastic, p: &Point) -> Vector {
        let x = self.material_point(p);
        let before = x + strain::tensor(&el.prev_strain) * x;
        p - (self.prev_position + self.prev_rotation * before)
    }

    /// Records the pose (and strain) at the start of a step.
    pub fn remember_pose(&mut self) {
        self.prev_position = self.position;
        self.prev_rotation = self.rotation;
        if let Some(el) = &mut self.elastic {
            el.prev_strain = el.strain;
        }
    }

    /// Changes the strain by `de` (after [`Block::remember_pose`]); the caller updates the
    /// world geometry.
    #[inline]
    pub fn strain_by(&mut self, de: &Strain) {
        if let Some(el) = &mut self.elastic {
            el.strain += de;
            el.update_stretch();
        }
    }

    /// Moves by `d` and turns by the rotation vector `theta` (exactly, see [`rotation`]).
    pub fn displace(&mut self, d: &Vector, theta: &Vector) {
        self.position += d;
        self.rotation = rotation::integrate(&self.rotation, theta);
    }

    /// Recomputes world vertices, face planes and the bounding box from the pose.
    pub fn update_world_geometry(&mut self) {
        if self.elastic.is_some() {
            return self.update_deformed_geometry();
        }
        let iso = self.isometry();
        let mut lo = Point::from([Real::INFINITY; 3]);
        let mut hi = Point::from([Real::NEG_INFINITY; 3]);
        for (w, l) in self.world_vertices.iter_mut().zip(&self.shape.vertices) {
            *w = iso * l;
            lo = lo.inf(w);
            hi = hi.sup(w);
        }
        for ((n, o), f) in self
            .world_normals
            .iter_mut()
            .zip(self.world_offsets.iter_mut())
            .zip(&self.shape.faces)
        {
            *n = self.rotation * f.normal;
            *o = f.offset + n.dot(&self.position.coords);
        }
        self.aabb_min = lo;
        self.aabb_max = hi;
    }

    /// World geometry of a deformable block under the affine map x = c + F X, F = R (I + E):
    /// a plane n·X = o of the block frame maps to m·(x − c) = o with m = F⁻ᵀ n = R (I + E)⁻¹ n
    /// ((I + E) is symmetric), renormalised: normal m/|m|, offset o/|m| + n_w·c.
    #[inline(never)]
    fn update_deformed_geometry(&mut self) {
        let Some(el) = &self.elastic else { return };
        let rot = self.rotation.to_rotation_matrix().into_inner();
        let f = rot * el.stretch();
        let normal_map = rot * el.stretch_inv;
        let c = self.position;
        let mut lo = Point::from([Real::INFINITY; 3]);
        let mut hi = Point::from([Real::NEG_INFINITY; 3]);
        for (w, l) in self.world_vertices.iter_mut().zip(&self.shape.vertices) {
            *w = c + f * l.coords;
            lo = lo.inf(w);
            hi = hi.sup(w);
        }
        for ((n, o), face) in self
            .world_normals
            .iter_mut()
            .zip(self.world_offsets.iter_mut())
            .zip(&self.shape.faces)
        {
            let m = normal_map * face.normal;
            let len = m.norm();
            *n = m / len;
            *o = face.offset / len + n.dot(&c.coords);
        }
        self.aabb_min = lo;
        self.aabb_max = hi;
    }

    /// Largest signed plane distance of a world point: negative inside (minus the depth below
    /// the nearest face), and the face it belongs to.
    #[inline]
    pub fn plane_distance(&self, p: &Point) -> (Real, usize) {
        let mut best = (Real::NEG_INFINITY, 0);
        for (i, (n, o)) in self
            .world_normals
            .iter()
            .zip(&self.world_offsets)
            .enumerate()
        {
            let d = n.dot(&p.coords) - o;
            if d > best.0 {
                best = (d, i);
            }
        }
        best
    }

    /// Kinetic energy [J] (with ½ ėᵀ M_e ė for a deformable block).
    pub fn kinetic_energy(&self) -> Real {
        let w = self
            .rotation
            .inverse_transform_vector(&self.angular_velocity);
        let rigid =
            0.5 * self.mass * self.velocity.norm_squared() + 0.5 * w.dot(&(self.inertia * w));
        rigid + self.elastic.as_ref().map_or(0.0, |e| e.kinetic_energy())
    }

    /// Elastic strain energy ½ V eᵀ D e [J] (0 for a rigid block).
    pub fn strain_energy(&self) -> Real {
        self.elastic.as_ref().map_or(0.0, |e| e.strain_energy())
    }

    /// True when position, orientation and velocities are all finite.
    pub fn is_finite(&self) -> bool {
        self.position.coords.iter().all(|x| x.is_finite())
            && self.rotation.coords.iter().all(|x| x.is_finite())
            && self.velocity.iter().all(|x| x.is_finite())
            && self.angular_velocity.iter().all(|x| x.is_finite())
            && self.elastic.as_ref().is_none_or(|e| e.is_finite())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use shared::scene::ShapeSpec;

    fn spec(kind: BlockKind) -> BlockSpec {
        let shape = ShapeSpec::Box {
            min: [0.0, 0.0, 0.0],
            max: [2.0, 1.0, 0.5],
        };
        BlockSpec::plain("b", kind, shape, 2000.0)
    }

    #[test]
    fn mass_properties_and_topology() {
        let b = Block::from_spec(0, &spec(BlockKind::Free)).unwrap();
        assert!((b.mass - 2000.0).abs() < 1e-9);
        assert!((b.inertia[(2, 2)] - 2000.0 * (4.0 + 1.0) / 12.0).abs() < 1e-9);
        assert!(
            b.edge_faces
                .iter()
                .all(|f| f[0] != u32::MAX && f[1] != u32::MAX && f[0] != f[1])
        );
        assert!(b.vertex_faces.iter().all(|f| f.len() == 3));
        let total: Real = b.face_area.iter().sum();
        assert!(
            (total - 2.0 * (2.0 + 1.0 + 0.5)).abs() < 1e-12,
            "surface {total}"
        );
        assert!((b.aabb_min - Point::new(0.0, 0.0, 0.0)).norm() < 1e-12);
        assert!((b.aabb_max - Point::new(2.0, 1.0, 0.5)).norm() < 1e-12);
    }

    #[test]
    fn plane_distance_follows_pose() {
        let mut b = Block::from_spec(0, &spec(BlockKind::Free)).unwrap();
        b.displace(
            &Vector::new(10.0, 0.0, 0.0),
            &Vector::new(0.0, 0.0, std::f64::consts::FRAC_PI_2),
        );
        b.update_world_geometry();
        // After a quarter turn about z the 2 m side lies along y.
        let ext = b.aabb_max - b.aabb_min;
        assert!((ext - Vector::new(1.0, 2.0, 0.5)).norm() < 1e-12, "{ext}");
        let (d, _) = b.plane_distance(&b.position);
        assert!((d + 0.25).abs() < 1e-12);
    }

    #[test]
    fn rejects_massless_free_block() {
        let mut s = spec(BlockKind::Free);
        s.density = 0.0;
        assert!(Block::from_spec(0, &s).is_err());
    }
}
