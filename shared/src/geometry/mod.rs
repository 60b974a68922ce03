//! Convex polyhedra built from scene shapes: the one description of a block that both nodes use.
//!
//! parry3d-f64 computes the hull (with coplanar triangles merged into polygonal faces, which DDA's
//! vertex–face and edge–edge contacts need) and the mass properties. Vertices are stored in the
//! block's local frame with the centroid at the origin, so a pose (centroid, rotation) places them.
//!
//! Beside the polyhedra: [`cutting`], Shi's cutting of a convex region into blocks by joint
//! planes (`[[slide]]`), and [`strain`], the constant strain of a deformable (12-DOF) block.

pub mod cutting;
pub mod strain;

use crate::math::{Matrix, Point, Real, Vector};
use crate::scene::{Axis, ShapeSpec};
use parry3d_f64::mass_properties::MassProperties;
use parry3d_f64::shape::ConvexPolyhedron;

/// A planar face of a polyhedron, in the local frame.
#[derive(Debug, Clone)]
pub struct Face {
    /// Vertex indices, counter-clockwise seen from outside.
    pub vertices: Vec<u32>,
    /// Outward unit normal.
    pub normal: Vector,
    /// Plane offset: n·x = offset on the face; n·x < offset inside.
    pub offset: Real,
}

/// A convex block shape with its mass properties (per unit density).
#[derive(Debug, Clone)]
pub struct Polyhedron {
    /// Corners in the local frame (centroid at the origin).
    pub vertices: Vec<Point>,
    pub faces: Vec<Face>,
    /// Each edge once, as a pair of vertex indices.
    pub edges: Vec<[u32; 2]>,
    /// Centroid in the scene's (world) frame at t = 0.
    pub centroid: Point,
    pub volume: Real,
    /// Inertia tensor about the centroid for unit density [m⁵]; multiply by density.
    pub unit_inertia: Matrix,
    /// Largest distance from the centroid to a corner: the radius of the bounding sphere.
    pub radius: Real,
}

/// Why a shape cannot be a block: what is wrong and what to do.
#[derive(Debug, Clone, thiserror::Error)]
#[error("{problem}; fix: {fix}")]
pub struct GeometryError {
    pub problem: String,
    pub fix: String,
}

fn err(problem: impl Into<String>, fix: impl Into<String>) -> GeometryError {
    GeometryError {
        problem: problem.into(),
        fix: fix.into(),
    }
}

/// The corner points of a scene shape, in world coordinates.
pub fn shape_points(shape: &ShapeSpec) -> Result<Vec<Point>, GeometryError> {
    match shape {
        ShapeSpec::Box { min, max } => {
            if (0..3).any(|k| max[k].partial_cmp(&min[k]) != Some(std::cmp::Ordering::Greater)) {
                return Err(err(
                    format!("box max {max:?} is not above min {min:?} on every axis"),
                    "make max[k] > min[k] for x, y and z",
                ));
            }
            let mut p = Vec::with_capacity(8);
            for &x in &[min[0], max[0]] {
                for &y in &[min[1], max[1]] {
                    for &z in &[min[2], max[2]] {
                        p.push(Point::new(x, y, z));
                    }
                }
            }
            Ok(p)
        }
        ShapeSpec::Prism {
            axis,
            profile,
            extent,
        } => {
            if profile.len() < 3 {
                return Err(err(
                    format!(
                        "a prism profile needs at least 3 points, got {}",
                        profile.len()
                    ),
                    "give the cross-section as 3 or more [a, b] points",
                ));
            }
            if extent[1].partial_cmp(&extent[0]) != Some(std::cmp::Ordering::Greater) {
                return Err(err(
                    format!("prism extent {extent:?} is empty"),
                    "give extent = [from, to] with to > from",
                ));
            }
            check_profile(profile)?;
            let place = |a: f64, b: f64, c: f64| match axis {
                Axis::X => Point::new(c, a, b),
                Axis::Y => Point::new(a, c, b),
                Axis::Z => Point::new(a, b, c),
            };
            Ok(extent
                .iter()
                .flat_map(|&c| profile.iter().map(move |q| place(q[0], q[1], c)))
                .collect())
        }
        ShapeSpec::Convex { vertices } => Ok(vertices.iter().map(|v| Point::from(*v)).collect()),
    }
}

/// Largest coordinate magnitude a shape may have [m]: far beyond any scene, and small enough
/// that products of coordinates (areas, volumes, inertia) stay finite.
pub const MAX_COORDINATE: Real = 1e9;

/// A prism profile must be a simple convex polygon with its points in order around it: every
/// turn the same way (all cross products of consecutive edges of one sign) and one turn in
/// all (the exterior angles sum to ±2π; a star polygon turns the same way but twice or more).
fn check_profile(profile: &[[f64; 2]]) -> Result<(), GeometryError> {
    if let Some(q) = profile
        .iter()
        .find(|q| !(q[0].is_finite() && q[1].is_finite()))
    {
        return Err(err(
            format!("profile point {q:?} is not finite"),
            "give finite coordinates",
        ));
    }
    let n = profile.len();
    let edge = |i: usize| {
        let (a, b) = (profile[i % n], profile[(i + 1) % n]);
        [b[0] - a[0], b[1] - a[1]]
    };
    let (mut sign, mut turning) = (0.0_f64, 0.0_f64);
    for i in 0..n {
        let (e, f) = (edge(i), edge(i + 1));
        let cross = e[0] * f[1] - e[1] * f[0];
        let dot = e[0] * f[0] + e[1] * f[1];
        let limit = 1e-12 * (e[0].hypot(e[1]) * f[0].hypot(f[1]));
        let straight = cross.abs() <= limit;
        if straight || (sign != 0.0 && cross.signum() != sign) {
            return Err(err(
                format!(
                    "the prism profile is not a convex polygon in order: at point {} the outline {} \
                     (a self-intersecting or concave outline is not a block)",
                    (i + 1) % n,
                    if straight {
                        "does not turn (repeated or collinear points)"
                    } else {
                        "turns back the other way"
                    }
                ),
                "list the profile points in order around a convex polygon, without repeats; split a concave shape into convex blocks",
            ));
        }
        sign = cross.signum();
        turning += cross.atan2(dot);
    }
    if (turning.abs() - std::f64::consts::TAU).abs() > 1e-6 {
        return Err(err(
            format!(
                "the prism profile winds {:.0} times around its centre: its edges cross (a star, not a convex polygon)",
                turning.abs() / std::f64::consts::TAU
            ),
            "list the profile points in order around a convex polygon",
        ));
    }
    Ok(())
}

/// The thickness of the thinnest slab holding all `points`, as the distance of the farthest
/// point from the plane through three well-spread ones (a, the farthest from a, the farthest
/// from that line); `None` for fewer than 4 points. Zero means flat (coplanar or collinear).
fn thickness(points: &[Point]) -> Option<(Real, Real)> {
    let a = *points.first()?;
    let far = |f: &dyn Fn(&Point) -> Real| {
        points
            .iter()
            .copied()
            .max_by(|p, q| f(p).total_cmp(&f(q)))
            .unwrap_or(a)
    };
    let b = far(&|p| (p - a).norm());
    let ab = b - a;
    let line = |p: &Point| ab.cross(&(p - a)).norm();
    let c = far(&line);
    let span = line(&c) / ab.norm().max(Real::MIN_POSITIVE);
    let n = ab.cross(&(c - a));
    if n.norm() == 0.0 {
        return Some((0.0, 0.0));
    }
    let n = n.normalize();
    let d = far(&|p| n.dot(&(p - a)).abs());
    Some((span, n.dot(&(d - a)).abs()))
}

impl Polyhedron {
    /// Builds the polyhedron of a scene shape, rejecting non-convex or degenerate input.
    pub fn from_shape(shape: &ShapeSpec) -> Result<Polyhedron, GeometryError> {
        Polyhedron::from_points(&shape_points(shape)?)
    }

    /// Builds the convex polyhedron whose corners are exactly `points` (world frame).
    pub fn from_points(points: &[Point]) -> Result<Polyhedron, GeometryError> {
        if points.len() < 4 {
            return Err(err(
                format!("{} vertices cannot enclose a volume", points.len()),
                "give at least 4 corners",
            ));
        }
        if let Some(p) = points
            .iter()
            .find(|p| !p.coords.iter().all(|x| x.is_finite()))
        {
            return Err(err(
                format!("vertex {p} is not finite"),
                "give finite coordinates",
            ));
        }
        if let Some(p) = points
            .iter()
            .find(|p| p.coords.iter().any(|x| x.abs() > MAX_COORDINATE))
        {
            return Err(err(
                format!("vertex {p} lies beyond ±{MAX_COORDINATE:e} m"),
                "give coordinates in metres within the scene's domain",
            ));
        }
        let (lo, hi) = aabb(points);
        let scale = (hi - lo).norm();
        // A flat set (all points in one plane, or on one line) has zero volume, whatever the
        // hull makes of it: say so rather than "not convex".
        if let Some((span, thick)) = thickness(points)
            && (span <= 1e-9 * scale || thick <= 1e-9 * scale)
        {
            return Err(err(
                format!(
                    "the vertices are degenerate/flat: they lie {} (thickness {thick:.3e} m across a {scale:.3e} m shape): zero volume",
                    if span <= 1e-9 * scale {
                        "on one line"
                    } else {
                        "in one plane"
                    }
                ),
                "give corners that span 3D",
            ));
        }
        let tol = 1e-9 * scale;
        for (i, a) in points.iter().enumerate() {
            if let Some(j) = points[..i].iter().position(|b| (a - b).norm() <= tol) {
                return Err(err(
                    format!("vertices {j} and {i} coincide at {a}"),
                    "remove the duplicate vertex",
                ));
            }
        }
        let hull = ConvexPolyhedron::from_convex_hull(points).ok_or_else(|| {
            err(
                "the vertices are degenerate (coplanar or collinear): they enclose no volume",
                "give corners that span 3D",
            )
        })?;
        // Every given vertex must be a corner of the hull: a vertex inside the hull (or on a face)
        // means the shape the user meant is not convex.
        for (i, p) in points.iter().enumerate() {
            if !hull.points().iter().any(|q| (p - q).norm() <= tol * 10.0) {
                return Err(err(
                    format!(
                        "vertex {i} at {p} is not a corner of the convex hull: the shape is not convex"
                    ),
                    "blocks are convex polyhedra; split a concave shape into convex blocks",
                ));
            }
        }

        let (tri_points, tris) = hull.to_trimesh();
        let mp = MassProperties::from_convex_polyhedron(1.0, &tri_points, &tris);
        let volume = mp.mass();
        if volume.is_nan() || volume <= 1e-12 * scale.powi(3) {
            return Err(err(
                format!("the shape has no volume ({volume:e} m³)"),
                "give corners that span 3D",
            ));
        }
        let centroid = mp.local_com;
        let vertices: Vec<Point> = hull
            .points()
            .iter()
            .map(|p| Point::from(p - centroid))
            .collect();

        let adj = hull.vertices_adj_to_face();
        let faces: Vec<Face> = hull
            .faces()
            .iter()
            .map(|f| {
                let first = f.first_vertex_or_edge as usize;
                let ids: Vec<u32> = adj[first..first + f.num_vertices_or_edges as usize].to_vec();
                let normal = f.normal.into_inner();
                let offset = normal.dot(&vertices[ids[0] as usize].coords);
                Face {
                    vertices: ids,
                    normal,
                    offset,
                }
            })
            .collect();
        // Edges from the merged polygonal faces (parry keeps the diagonals of merged triangles
        // in its edge list, marked deleted; DDA edge–edge contacts must not see them).
        let mut edges: Vec<[u32; 2]> = Vec::new();
        for f in &faces {
            let n = f.vertices.len();
            for k in 0..n {
                let (a, b) = (f.vertices[k], f.vertices[(k + 1) % n]);
                let e = [a.min(b), a.max(b)];
                if !edges.contains(&e) {
                    edges.push(e);
                }
            }
        }
        let radius = vertices
            .iter()
            .map(|v| v.coords.norm())
            .fold(0.0, Real::max);
        Ok(Polyhedron {
            vertices,
            faces,
            edges,
            centroid,
            volume,
            unit_inertia: mp.reconstruct_inertia_matrix(),
            radius,
        })
    }

    /// Axis-aligned bounds at the scene (t = 0) pose.
    pub fn world_aabb(&self) -> (Point, Point) {
        let world: Vec<Point> = self
            .vertices
            .iter()
            .map(|v| v + self.centroid.coords)
            .collect();
        aabb(&world)
    }

    /// Largest plane distance max_f (n_f·p − offset_f) of a local point: negative inside (minus
    /// the depth to the nearest face), positive outside (a lower bound of the true distance,
    /// exact in front of a face).
    pub fn plane_distance(&self, local: &Point) -> (Real, usize) {
        let mut best = (Real::NEG_INFINITY, 0);
        for (i, f) in self.faces.iter().enumerate() {
            let d = f.normal.dot(&local.coords) - f.offset;
            if d > best.0 {
                best = (d, i);
            }
        }
        best
    }
}

/// How deep the interiors of `a` and `b` (at their scene poses) overlap [m]: the smallest
/// overlap of their projections over the separating axes of two convex polyhedra (the face
/// normals of each and the cross products of their edges). Zero or less: they are apart or
/// only touch.
pub fn overlap_depth(a: &Polyhedron, b: &Polyhedron) -> Real {
    swept_overlap_depth(a, Vector::zeros(), Vector::zeros(), b)
}

/// [`overlap_depth`] of the volume `a` sweeps when translated from `d0` to `d1` (from its scene
/// pose) and `b`: the swept hull's separating axes are `a`'s and `b`'s face normals, the cross
/// products of their edges, and of the sweep with their edges (a zero sweep adds none).
pub fn swept_overlap_depth(a: &Polyhedron, d0: Vector, d1: Vector, b: &Polyhedron) -> Real {
    let world = |p: &Polyhedron| -> Vec<Point> {
        p.vertices.iter().map(|v| v + p.centroid.coords).collect()
    };
    let (va, vb) = (world(a), world(b));
    let dirs = |p: &Polyhedron, v: &[Point]| -> Vec<Vector> {
        p.edges
            .iter()
            .map(|e| v[e[1] as usize] - v[e[0] as usize])
            .collect()
    };
    let sweep = d1 - d0;
    let (mut ea, eb) = (dirs(a, &va), dirs(b, &vb));
    ea.push(sweep);
    let mut axes: Vec<Vector> = a.faces.iter().chain(&b.faces).map(|f| f.normal).collect();
    for u in &ea {
        for w in eb.iter().chain([&sweep]) {
            let n = u.cross(w);
            if n.norm() > 1e-12 * u.norm() * w.norm() {
                axes.push(n.normalize());
            }
        }
    }
    let range = |v: &[Point], n: &Vector| {
        v.iter()
            .fold((Real::INFINITY, Real::NEG_INFINITY), |(lo, hi), p| {
                let d = n.dot(&p.coords);
                (lo.min(d), hi.max(d))
            })
    };
    axes.iter()
        .map(|n| {
            let ((alo, ahi), (blo, bhi)) = (range(&va, n), range(&vb, n));
            let (s0, s1) = (n.dot(&d0), n.dot(&d1));
            let (alo, ahi) = (alo + s0.min(s1), ahi + s0.max(s1));
            ahi.min(bhi) - alo.max(blo)
        })
        .fold(Real::INFINITY, Real::min)
}

impl Polyhedron {
    /// Top of the block (scene pose) on the vertical line through (x, y): the highest z with
    /// (x, y, z) inside, or None when the line misses the block. A convex block is the
    /// intersection of its face half-spaces n·p ≤ offset, so on the line the faces with n_z > 0
    /// bound z from above, those with n_z < 0 from below, and a vertical face either contains
    /// the whole line or none of it.
    pub fn top_at(&self, x: Real, y: Real) -> Option<Real> {
        const EPS: Real = 1e-12;
        let (lx, ly) = (x - self.centroid.x, y - self.centroid.y);
        let (mut lo, mut hi) = (Real::NEG_INFINITY, Real::INFINITY);
        for f in &self.faces {
            let rest = f.offset - f.normal.x * lx - f.normal.y * ly;
            if f.normal.z > EPS {
                hi = hi.min(rest / f.normal.z);
            } else if f.normal.z < -EPS {
                lo = lo.max(rest / f.normal.z);
            } else if rest < -1e-9 {
                return None;
            }
        }
        (hi.is_finite() && hi >= lo).then_some(hi + self.centroid.z)
    }
}

fn aabb(points: &[Point]) -> (Point, Point) {
    let mut lo = Point::from([Real::INFINITY; 3]);
    let mut hi = Point::from([Real::NEG_INFINITY; 3]);
    for p in points {
        lo = lo.inf(p);
        hi = hi.sup(p);
    }
    (lo, hi)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn box_mass_properties() {
        let b = Polyhedron::from_shape(&ShapeSpec::Box {
            min: [0.0, 0.0, 0.0],
            max: [2.0, 1.0, 0.5],
        })
        .unwrap();
        assert!((b.volume - 1.0).abs() < 1e-12);
        assert!((b.centroid - Point::new(1.0, 0.5, 0.25)).norm() < 1e-12);
        // I_xx = m (b² + c²)/12 for a box of sides a, b, c.
        let i = b.unit_inertia;
        assert!((i[(0, 0)] - (1.0 + 0.25) / 12.0).abs() < 1e-12);
        assert!((i[(1, 1)] - (4.0 + 0.25) / 12.0).abs() < 1e-12);
        assert!((i[(2, 2)] - (4.0 + 1.0) / 12.0).abs() < 1e-12);
        assert!(i[(0, 1)].abs() < 1e-12);
        assert_eq!(b.faces.len(), 6);
        assert_eq!(b.edges.len(), 12);
        assert!(
            b.faces
                .iter()
                .all(|f| f.vertices.len() == 4 && f.offset > 0.0)
        );
    }

    #[test]
    fn top_at_follows_a_slope_and_misses_outside() {
        // A ramp rising from z = 0 at x = 0 to z = 1 at x = 2 over a 1 m thick base.
        let ramp = Polyhedron::from_shape(&ShapeSpec::Prism {
            axis: Axis::Y,
            profile: vec![[0.0, -1.0], [2.0, -1.0], [2.0, 1.0], [0.0, 0.0]],
            extent: [0.0, 1.0],
        })
        .unwrap();
        for x in [0.1, 0.5, 1.0, 1.9] {
            let top = ramp.top_at(x, 0.5).unwrap();
            assert!((top - 0.5 * x).abs() < 1e-9, "top at x = {x}: {top}");
        }
        assert!(ramp.top_at(2.5, 0.5).is_none());
        assert!(ramp.top_at(1.0, 1.5).is_none());
    }

    #[test]
    fn wedge_prism() {
        let shape = ShapeSpec::Prism {
            axis: Axis::Y,
            profile: vec![[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]],
            extent: [0.0, 2.0],
        };
        let w = Polyhedron::from_shape(&shape).unwrap();
        assert!((w.volume - 1.0).abs() < 1e-12);
        assert!((w.centroid - Point::new(1.0 / 3.0, 1.0, 1.0 / 3.0)).norm() < 1e-12);
        assert_eq!(w.faces.len(), 5);
        assert_eq!(w.edges.len(), 9);
    }

    #[test]
    fn rejects_non_convex_and_degenerate() {
        let mut v: Vec<[f64; 3]> = vec![[0., 0., 0.], [1., 0., 0.], [0., 1., 0.], [0., 0., 1.]];
        v.push([0.1, 0.1, 0.1]); // inside the tetrahedron
        let e = Polyhedron::from_shape(&ShapeSpec::Convex { vertices: v }).unwrap_err();
        assert!(e.problem.contains("not convex"), "{e}");
        let flat = vec![[0., 0., 0.], [1., 0., 0.], [0., 1., 0.], [1., 1., 0.]];
        let e = Polyhedron::from_shape(&ShapeSpec::Convex { vertices: flat }).unwrap_err();
        assert!(
            e.problem.contains("degenerate") || e.problem.contains("volume"),
            "{e}"
        );
        let e = Polyhedron::from_shape(&ShapeSpec::Box {
            min: [0.0; 3],
            max: [1.0, 0.0, 1.0],
        })
        .unwrap_err();
        assert!(e.problem.contains("not above"), "{e}");
    }

    #[test]
    fn self_intersecting_or_star_profiles_are_refused() {
        let prism = |profile: Vec<[f64; 2]>| ShapeSpec::Prism {
            axis: Axis::Y,
            profile,
            extent: [0.0, 1.0],
        };
        let bowtie = prism(vec![[0., 0.], [1., 1.], [1., 0.], [0., 1.]]);
        let e = Polyhedron::from_shape(&bowtie).unwrap_err();
        assert!(e.problem.contains("not a convex polygon in order"), "{e}");
        let star: Vec<[f64; 2]> = (0..5)
            .map(|k| {
                let a = k as f64 * 4.0 * std::f64::consts::PI / 5.0;
                [a.cos(), a.sin()]
            })
            .collect();
        let e = Polyhedron::from_shape(&prism(star)).unwrap_err();
        assert!(e.problem.contains("winds 2 times"), "{e}");
        // Either orientation of a convex outline is fine.
        let ccw = prism(vec![[0., 0.], [1., 0.], [0., 1.]]);
        let cw = prism(vec![[0., 0.], [0., 1.], [1., 0.]]);
        assert!(Polyhedron::from_shape(&ccw).is_ok() && Polyhedron::from_shape(&cw).is_ok());
    }

    #[test]
    fn flat_and_huge_vertices_are_named_as_such() {
        let flat = vec![[0., 0., 0.], [1., 0., 0.], [0., 1., 0.], [0.3, 0.3, 1e-13]];
        let e = Polyhedron::from_shape(&ShapeSpec::Convex { vertices: flat }).unwrap_err();
        assert!(
            e.problem.contains("flat") && e.problem.contains("zero volume"),
            "{e}"
        );
        let line = vec![[0., 0., 0.], [1., 0., 0.], [2., 0., 0.], [3., 0., 0.]];
        let e = Polyhedron::from_shape(&ShapeSpec::Convex { vertices: line }).unwrap_err();
        assert!(e.problem.contains("one line"), "{e}");
        let huge = vec![
            [0., 0., 0.],
            [1e200, 0., 0.],
            [0., 1e200, 0.],
            [0., 0., 1e200],
        ];
        let e = Polyhedron::from_shape(&ShapeSpec::Convex { vertices: huge }).unwrap_err();
        assert!(e.problem.contains("beyond"), "{e}");
    }

    #[test]
    fn overlap_depth_of_boxes() {
        let cube = |x: f64| {
            Polyhedron::from_shape(&ShapeSpec::Box {
                min: [x, 0.0, 0.0],
                max: [x + 1.0, 1.0, 1.0],
            })
            .unwrap()
        };
        assert!((overlap_depth(&cube(0.0), &cube(0.0)) - 1.0).abs() < 1e-12);
        assert!((overlap_depth(&cube(0.0), &cube(0.75)) - 0.25).abs() < 1e-12);
        assert!(overlap_depth(&cube(0.0), &cube(1.0)).abs() < 1e-12);
        assert!(overlap_depth(&cube(0.0), &cube(2.0)) < 0.0);
    }

    #[test]
    fn plane_distance_signs() {
        let b = Polyhedron::from_shape(&ShapeSpec::Box {
            min: [-1.0; 3],
            max: [1.0; 3],
        })
        .unwrap();
        let (d, _) = b.plane_distance(&Point::new(0.0, 0.0, 0.5));
        assert!((d + 0.5).abs() < 1e-12);
        let (d, f) = b.plane_distance(&Point::new(0.0, 0.0, 1.25));
        assert!((d - 0.25).abs() < 1e-12);
        assert!((b.faces[f].normal - Vector::z()).norm() < 1e-12);
    }
}
