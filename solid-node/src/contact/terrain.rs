//! Contacts of convex blocks with the fixed terrain (`[[terrain]]`, [`shared::terrain`]): a
//! non-convex triangle mesh, possibly of millions of triangles, as one fixed body.
//!
//! The terrain enters the block system as one fixed [`Block`] whose shape is its bounding box:
//! the broad phase pairs it with the free blocks over it like any fixed block, and everything
//! downstream of the narrow phase (springs, Mohr–Coulomb, every integrator, the stability
//! bound) sees ordinary contacts whose face owner is a fixed block. Only the narrow phase
//! differs (here), with DDA's feature pairs kept so the shear history follows them:
//!
//! - a block vertex against the terrain (`VertexOfA`, the block is `a`): the nearest surface
//!   point by parry's BVH projection (O(log n) in the triangle count), its outward normal and
//!   signed distance from the pseudo-normals (exact at the mesh's edges and corners); pressed
//!   in at a convex crease, the plane of the triangle it entered by while it lies over it
//!   ([`reference_triangle`], DDA's reference face as between blocks);
//! - a terrain vertex against a block face (`VertexOfB`): the terrain vertices of the triangles
//!   under the block's box, tested against the block's face planes (the face entered by kept
//!   while the vertex lies over it, as between blocks). Only vertices where the
//!   surface bends away (peaks and ridges, [`TerrainBody::peaks`], found in a BVH of their
//!   own) are used: a vertex
//!   of a flat or hollow patch is never the feature that touches, and counting it would add a
//!   spring each time a block slid over one.
//! - a block edge across a terrain edge (`EdgeEdge`, the block edge is `i`, the terrain ridge
//!   `j`): only the mesh edges where the surface bends away (*ridges*, [`TerrainBody::ridges`],
//!   in a BVH of their own) can be crossed by a block resting on the terrain, as only peaks can
//!   touch a face. The crossing test is the one between two blocks
//!   ([`crate::contact::narrow_phase::crossing`]); its locality check measures the block edge's point
//!   against the ridge's two triangle planes (locally, the terrain is the wedge under them),
//!   and a crossing pressed past the margin is kept by the block's depth in that wedge
//!   ([`wedge_depth`]), as two blocks' crossings are by their separating-axis depth.
//!   Without these, a block lying across a ridge with no vertex on either side (a slab bridging
//!   a crest, a block rocking over the brink of a cliff) would sink through it.

use crate::blocks::block::Block;
use crate::contact::friction::Joint;
use crate::contact::narrow_phase::{self, Edge, NarrowParams};
use crate::contact::{self, Contact, ContactKey, Feature};
use parry3d_f64::bounding_volume::Aabb;
use parry3d_f64::partitioning::{Bvh, BvhBuildStrategy};
use shared::math::{Point, Real, Vector};
use shared::scene::{BlockKind, BlockSpec, ShapeSpec};
use shared::solver::SolverError;
use shared::terrain::Terrain;

/// Faces of a block within this angle of the contact normal share their area with a vertex
/// contact (cohesion acts on face–face contacts): cos 10°, as between blocks.
const FACE_ALIGNMENT: Real = 0.984_807_753;

/// A neighbour this far below a vertex's tangent plane (sine of the angle) makes it a peak.
const PEAK_SINE: Real = 1e-3;

/// A terrain with what its contacts need beyond the mesh.
pub struct TerrainBody {
    pub terrain: Terrain,
    /// The mesh vertices where some neighbour lies below the tangent plane (the surface bends
    /// away from a body resting on it there), ascending.
    pub peaks: Vec<u32>,
    /// A BVH over the peaks (leaf k is `peaks[k]`): the peaks under a block are found in
    /// O(log n + found), however many flat or hollow vertices the terrain has.
    peak_bvh: Bvh,
    /// The mesh edges between two triangles where the surface bends away by more than
    /// [`PEAK_SINE`] (convex creases), in the order of their vertex pairs.
    pub ridges: Vec<Ridge>,
    /// A BVH over the ridges (leaf k is `ridges[k]`): O(log n + found) per block, as the peaks.
    ridge_bvh: Bvh,
}

impl TerrainBody {
    pub fn new(terrain: Terrain) -> Self {
        let mesh = &terrain.mesh;
        let v = mesh.vertices();
        let normals: Vec<Vector> = match mesh.pseudo_normals() {
            Some(p) => p
                .vertices_pseudo_normal
                .iter()
                .map(|n| n.try_normalize(1e-300).unwrap_or_else(Vector::z))
                .collect(),
            None => vec![Vector::z(); v.len()],
        };
        let mut peak = vec![false; v.len()];
        for t in mesh.indices() {
            for k in 0..3 {
                let (w, u) = (t[k] as usize, t[(k + 1) % 3] as usize);
                let e = v[u] - v[w];
                if e.dot(&normals[w]) < -PEAK_SINE * e.norm() {
                    peak[w] = true;
                }
                if (-e).dot(&normals[u]) < -PEAK_SINE * e.norm() {
                    peak[u] = true;
                }
            }
        }
        let peaks: Vec<u32> = (0..v.len() as u32).filter(|&w| peak[w as usize]).collect();
        let leaves: Vec<Aabb> = peaks
            .iter()
            .map(|&w| Aabb::new(v[w as usize], v[w as usize]))
            .collect();
        let peak_bvh = Bvh::from_leaves(BvhBuildStrategy::Binned, &leaves);
        let ridges = ridges(mesh);
        let v = mesh.vertices();
        let leaves: Vec<Aabb> = ridges
            .iter()
            .map(|r| Aabb::from_points([v[r.vertices[0] as usize], v[r.vertices[1] as usize]]))
            .collect();
        let ridge_bvh = Bvh::from_leaves(BvhBuildStrategy::Binned, &leaves);
        Self {
            terrain,
            peaks,
            peak_bvh,
            ridges,
            ridge_bvh,
        }
    }

    /// The fixed block standing for the terrain in the block list: its bounding box (a flat
    /// terrain gets a thickness of 10⁻³ of its size), the terrain's friction and cohesion.
    pub fn block(&self, scene_index: usize) -> Result<Block, SolverError> {
        let (lo, hi) = self.terrain.bounds();
        let size = (hi - lo).norm().max(1e-6);
        let mut min = [lo.x, lo.y, lo.z];
        let mut max = [hi.x, hi.y, hi.z];
        for k in 0..3 {
            if max[k] - min[k] < 1e-3 * size {
                min[k] -= 0.5e-3 * size;
                max[k] += 0.5e-3 * size;
            }
        }
        let spec = BlockSpec {
            friction_angle: self.terrain.friction_angle,
            cohesion: self.terrain.cohesion,
            ..BlockSpec::plain(
                self.terrain.name.clone(),
                BlockKind::Fixed,
                ShapeSpec::Box { min, max },
                2500.0,
            )
        };
        Block::from_spec(scene_index, &spec)
    }
}

/// The contacts of block `a` (index, block) with terrain block `b`, in key order, inheriting
/// from `old` (the previous step's contacts of the pair, sorted by key).
#[allow(clippy::too_many_arguments)]
pub fn collide(
    a: u32,
    ba: &Block,
    b: u32,
    body: &TerrainBody,
    joint: Joint,
    params: NarrowParams,
    old: &[Contact],
    out: &mut Vec<Contact>,
) {
    let m = params.margin;
    let t = &body.terrain;
    // Block vertices: how far a vertex may be sunk and still be found (a quarter of the
    // block: deeper is a block through the ground, which the springs could not push back
    // anyway). The BVH box test skips the vertices clear of the ground at once.
    let reach = (0.25 * ba.size()).max(m);
    for (vi, v) in ba.world_vertices.iter().enumerate() {
        if !t.may_be_within(v, reach) {
            continue;
        }
        let Some(mut s) = t.nearest(v, reach) else {
            continue;
        };
        if s.distance > m {
            continue;
        }
        let key = ContactKey {
            a,
            b,
            feature: Feature::VertexOfA,
            i: vi as u32,
            j: 0,
        };
        let prev = contact::find(old, &key);
        // DDA's reference face, as between blocks (`narrow_phase::reference_face`): a vertex
        // pressed into the ground keeps the triangle it entered by while it lies over it,
        // instead of the nearest surface point's, which at a rim jumps to the flank.
        if let Some(o) = prev
            && o.face != s.triangle
            && let Some(r) = reference_triangle(&t.mesh, o.face, v, &s, m)
        {
            s = r;
        }
        let mut area = 0.0;
        for &pf in &ba.vertex_faces[vi] {
            if -ba.world_normals[pf as usize].dot(&s.normal) >= FACE_ALIGNMENT {
                area +=
                    ba.face_area[pf as usize] / ba.shape.faces[pf as usize].vertices.len() as Real;
            }
        }
        let mut c = Contact::new(key, a, b);
        c.face = s.triangle;
        c.point = *v;
        c.normal = s.normal;
        c.gap = s.distance;
        c.area = area;
        c.tan_phi = joint.tan_phi;
        c.cohesion = joint.cohesion;
        if let Some(o) = prev {
            c.inherit(o);
        }
        out.push(c);
    }
    // Terrain peaks inside the block's faces (or within the margin of them).
    let grow = Vector::repeat(m);
    let lo = Point::from(ba.aabb_min.coords - grow);
    let hi = Point::from(ba.aabb_max.coords + grow);
    let aabb = Aabb::new(lo, hi);
    let vertices = t.mesh.vertices();
    // The peaks in the block's box, in ascending vertex order (the contacts' key order): a
    // short sort of the few found, in a per-thread buffer (no allocation once warm).
    PEAKS.with_borrow_mut(|found| {
        found.clear();
        found.extend(
            body.peak_bvh
                .intersect_aabb(&aabb)
                .map(|k| body.peaks[k as usize]),
        );
        found.sort_unstable();
        for &w in found.iter() {
            peak_contact(
                a,
                ba,
                b,
                w,
                vertices[w as usize],
                &lo,
                &hi,
                joint,
                m,
                old,
                out,
            );
        }
    });
    ridge_contacts(a, ba, b, body, &aabb, joint, m, old, out);
}

thread_local! {
    static PEAKS: std::cell::RefCell<Vec<u32>> = const { std::cell::RefCell::new(Vec::new()) };
    /// The ridges near a block with their geometry (per thread, reused: no allocation once warm).
    static RIDGES: std::cell::RefCell<Vec<(u32, Edge)>> = const { std::cell::RefCell::new(Vec::new()) };
}

/// A convex crease of the terrain: a mesh edge (its two vertices) and the two triangles that
/// meet there. 16 bytes, so a rough 10⁶-triangle DEM (about 1.5·10⁶ edges, many of them
/// ridges) keeps its ridges in tens of MB; the geometry is read from the mesh when a block
/// is near.
#[derive(Debug, Clone, Copy)]
pub struct Ridge {
    pub vertices: [u32; 2],
    pub triangles: [u32; 2],
}

impl Ridge {
    /// The ridge with its two triangles' outward normals.
    fn edge(&self, mesh: &parry3d_f64::shape::TriMesh) -> Edge {
        let v = mesh.vertices();
        let normal = |t: u32| {
            mesh.triangle(t)
                .normal()
                .map_or(Vector::z(), |n| n.into_inner())
        };
        Edge {
            p0: v[self.vertices[0] as usize],
            p1: v[self.vertices[1] as usize],
            n1: normal(self.triangles[0]),
            n2: normal(self.triangles[1]),
        }
    }
}

/// The convex creases of a triangle mesh: each edge shared by two triangles whose far vertex
/// lies below the other's plane by more than [`PEAK_SINE`] of its distance (degenerate
/// triangles left out). Edges of one triangle only (the mesh's rim) are left out: a
/// block there is leaving the terrain. Sorted by vertex pair, so the order is the mesh's.
fn ridges(mesh: &parry3d_f64::shape::TriMesh) -> Vec<Ridge> {
    let v = mesh.vertices();
    let tris = mesh.indices();
    // (low vertex, high vertex, triangle) of every triangle edge; equal pairs are neighbours.
    let mut edges: Vec<(u32, u32, u32)> = Vec::with_capacity(3 * tris.len());
    for (ti, t) in tris.iter().enumerate() {
        for k in 0..3 {
            let (p, q) = (t[k], t[(k + 1) % 3]);
            edges.push((p.min(q), p.max(q), ti as u32));
        }
    }
    edges.sort_unstable();
    let far = |t: &[u32; 3], p: u32, q: u32| *t.iter().find(|&&w| w != p && w != q).unwrap();
    let mut out = Vec::new();
    for w in edges.windows(2) {
        let ((p, q, t1), (p2, q2, t2)) = (w[0], w[1]);
        if (p, q) != (p2, q2) {
            continue;
        }
        let tri2 = &tris[t2 as usize];
        let (Some(n1), Some(_)) = (mesh.triangle(t1).normal(), mesh.triangle(t2).normal()) else {
            continue;
        };
        let o2 = v[far(tri2, p, q) as usize] - v[p as usize];
        if o2.dot(&n1) < -PEAK_SINE * o2.norm() {
            out.push(Ridge {
                vertices: [p, q],
                triangles: [t1, t2],
            });
        }
    }
    out
}

/// Edges of block `a` crossing the terrain's ridges in `aabb` (the block's, grown by the
/// margin), in key order (block edge, then ridge).
#[allow(clippy::too_many_arguments)]
fn ridge_contacts(
    a: u32,
    ba: &Block,
    b: u32,
    body: &TerrainBody,
    aabb: &Aabb,
    joint: Joint,
    m: Real,
    old: &[Contact],
    out: &mut Vec<Contact>,
) {
    RIDGES.with_borrow_mut(|found| {
        found.clear();
        let mesh = &body.terrain.mesh;
        found.extend(
            body.ridge_bvh
                .intersect_aabb(aabb)
                .map(|j| (j, body.ridges[j as usize].edge(mesh))),
        );
        if found.is_empty() {
            return;
        }
        found.sort_unstable_by_key(|f| f.0);
        // A block edge pressed into the terrain lies under the ridge it crosses: its box is
        // grown by how far a vertex may be sunk and still be found (as in [`collide`]), not by
        // the margin, or a crossing past the margin would never be tested.
        let grow = Vector::repeat((0.25 * ba.size()).max(m));
        for ia in 0..ba.shape.edges.len() {
            let ea = narrow_phase::block_edge(ba, ia);
            let lo = ea.p0.coords.inf(&ea.p1.coords) - grow;
            let hi = ea.p0.coords.sup(&ea.p1.coords) + grow;
            for (j, eb) in found.iter() {
                let j = *j;
                let (rlo, rhi) = (
                    eb.p0.coords.inf(&eb.p1.coords),
                    eb.p0.coords.sup(&eb.p1.coords),
                );
                if (0..3).any(|k| rhi[k] < lo[k] || rlo[k] > hi[k]) {
                    continue;
                }
                let Some(x) = narrow_phase::crossing(&ea, eb, m) else {
                    continue;
                };
                // The block edge's point under the terrain: locally the wedge below the
                // ridge's two triangles. The ridge's point in the block: its face planes.
                let da = (x.pa - eb.p0).dot(&eb.n1).max((x.pa - eb.p0).dot(&eb.n2));
                let db = ba.plane_distance(&x.pb).0;
                // A block face pressed onto the ridge past the margin: the ridge's point lies
                // in the block's side face (depth ≈ 0), so the points' depths understate the
                // crossing's; the block's depth in the ridge's wedge says it is real, as the
                // separating-axis depth does between two blocks.
                let real = narrow_phase::local_depths(&x, da, db, m)
                    || (da <= m
                        && db <= m
                        && -x.gap
                            <= narrow_phase::EDGE_DEPTH_RATIO * wedge_depth(ba, eb, &x.normal) + m);
                if !real {
                    continue;
                }
                let key = ContactKey {
                    a,
                    b,
                    feature: Feature::EdgeEdge,
                    i: ia as u32,
                    j,
                };
                out.push(x.contact(key, &joint, old).0);
            }
        }
    });
}

/// How deep block `ba` lies in the terrain's wedge under ridge `e` (locally the terrain is
/// the wedge below its two triangles' planes): the least overlap of their projections on the
/// triangles' normals and on the crossing's normal `n`, the separating axes normal to the
/// ridge, on which the wedge's extent ends at the ridge line (Gottschalk, Lin & Manocha 1996,
/// as [`narrow_phase::penetration_depth`] between two blocks). A block sunk a little into one
/// triangle has a small overlap on that triangle's normal, so a crossing far deeper than that
/// (an edge of the block's plane, not a contact) is still refused.
fn wedge_depth(ba: &Block, e: &Edge, n: &Vector) -> Real {
    [e.n1, e.n2, *n]
        .iter()
        .map(|axis| {
            let lowest = ba
                .world_vertices
                .iter()
                .map(|v| axis.dot(&v.coords))
                .fold(Real::INFINITY, Real::min);
            axis.dot(&e.p0.coords) - lowest
        })
        .fold(Real::INFINITY, Real::min)
}

/// The surface as seen from triangle `tri`, the reference of a block vertex `v` pressed into
/// the ground (`near` its nearest surface point now, on another triangle): `tri`'s plane, its
/// normal and `v`'s signed distance from it, when `v` is in the ground by that plane too and
/// lies over `tri` (its projection inside the triangle, within `margin`) and the surface
/// bends away there (`near`'s triangle on or under `tri`'s plane: a convex crease, where the
/// ground is the intersection of the two half-spaces). Otherwise `None`, and the nearest
/// point stands: above the ground it is exact, and in a hollow (a concave crease, the ground
/// the union of the half-spaces) the entrance plane would let the vertex sink into the other
/// side unresisted.
fn reference_triangle(
    mesh: &parry3d_f64::shape::TriMesh,
    tri: u32,
    v: &Point,
    near: &shared::terrain::Surface,
    margin: Real,
) -> Option<shared::terrain::Surface> {
    if near.distance >= 0.0 || tri as usize >= mesh.indices().len() {
        return None;
    }
    let t = mesh.triangle(tri);
    let n = t.normal()?.into_inner();
    let d = n.dot(&(v - t.a));
    if d >= 0.0 {
        return None;
    }
    // Inside the triangle: on the inner side of each edge's in-plane outward normal. The
    // winding is counter-clockwise about n, so (b − a) × n points out of the triangle.
    let on_plane = v - n * d;
    let corners = [t.a, t.b, t.c];
    for k in 0..3 {
        let (p0, p1) = (corners[k], corners[(k + 1) % 3]);
        let out = (p1 - p0).cross(&n);
        let len = out.norm();
        if len > 0.0 && out.dot(&(on_plane - p0)) > margin * len {
            return None;
        }
    }
    let other = mesh.triangle(near.triangle);
    let tol = 1e-9 * (t.b - t.a).norm().max((t.c - t.a).norm());
    if [other.a, other.b, other.c]
        .iter()
        .any(|w| n.dot(&(w - t.a)) > tol)
    {
        return None;
    }
    Some(shared::terrain::Surface {
        distance: d,
        point: on_plane,
        normal: n,
        triangle: tri,
    })
}

/// Terrain peak `w` at `p` against the faces of block `a`.
#[allow(clippy::too_many_arguments)]
#[inline]
fn peak_contact(
    a: u32,
    ba: &Block,
    b: u32,
    w: u32,
    p: Point,
    lo: &Point,
    hi: &Point,
    joint: Joint,
    m: Real,
    old: &[Contact],
    out: &mut Vec<Contact>,
) {
    if (0..3).any(|k| p[k] < lo[k] || p[k] > hi[k]) {
        return;
    }
    let (d, f) = ba.plane_distance(&p);
    if d > m {
        return;
    }
    let key = ContactKey {
        a,
        b,
        feature: Feature::VertexOfB,
        i: w,
        j: 0,
    };
    let prev = contact::find(old, &key);
    // The block's face the peak entered by, kept while the peak lies over it (the rule
    // between blocks): the least deep face flips at the block's edge.
    let (d, f) = narrow_phase::reference_face(ba, prev, &p, (d, f), m);
    // The terrain vertex is the vertex owner (p), the block the face owner (q).
    let mut c = Contact::new(key, b, a);
    c.face = f as u32;
    c.point = p;
    c.normal = ba.world_normals[f];
    c.gap = d;
    c.tan_phi = joint.tan_phi;
    c.cohesion = joint.cohesion;
    if let Some(o) = prev {
        c.inherit(o);
    }
    out.push(c);
}

#[cfg(test)]
mod tests {
    use super::*;
    use shared::scene::{DomainSpec, TerrainSpec};
    use shared::terrain::dem::Grid;

    fn body(grid: &Grid) -> TerrainBody {
        let tmp = tempfile::tempdir().unwrap();
        let file = tmp.path().join("dem.asc");
        std::fs::write(&file, grid.to_asc()).unwrap();
        let spec: TerrainSpec =
            toml::from_str(&format!("file = {:?}", file.display().to_string())).unwrap();
        let domain = DomainSpec {
            min: [-2.0, -2.0, -2.0],
            max: [2.0, 2.0, 2.0],
            open_top: false,
        };
        TerrainBody::new(Terrain::load(&spec, &domain).unwrap())
    }

    /// A roof (z = −|x|) has its ridges along its crest and nowhere else; a flat ground and a
    /// valley (z = |x|) have none.
    #[test]
    fn ridges_are_the_convex_creases() {
        let grid = |f: fn(f64) -> f64| Grid::from_fn(11, 11, -2.5, -2.5, 0.5, move |x, _| f(x));
        let roof = body(&grid(|x| -x.abs()));
        assert_eq!(roof.ridges.len(), 10, "one per cell along the crest");
        let v = roof.terrain.mesh.vertices();
        for r in &roof.ridges {
            let e = r.edge(&roof.terrain.mesh);
            assert!(e.p0.x.abs() < 1e-12 && e.p1.x.abs() < 1e-12, "{e:?}");
            assert!(e.n1.z > 0.0 && e.n2.z > 0.0 && e.n1.x * e.n2.x < 0.0);
            assert!(r.vertices.iter().all(|&w| v[w as usize].z.abs() < 1e-12));
        }
        assert!(body(&grid(|_| 0.0)).ridges.is_empty());
        assert!(body(&grid(|x| x.abs())).ridges.is_empty());
    }

    /// The mesa of the rim tests: one 0.4 m DEM cell of flat top at z = 0.4, 45° flanks.
    const MESA: (Real, Real) = (0.4, 0.2);

    fn mesa() -> TerrainBody {
        let (height, half) = MESA;
        body(&Grid::from_fn(12, 12, -2.2, -2.2, 0.4, |x, y| {
            if x.abs() <= half + 1e-9 && y.abs() <= half + 1e-9 {
                height
            } else {
                0.0
            }
        }))
    }

    const JOINT: Joint = Joint {
        tan_phi: 0.7,
        cohesion: 0.0,
        tensile: 0.0,
        bonded: false,
    };

    const PARAMS: NarrowParams = NarrowParams {
        margin: 4e-4,
        at_start: false,
    };

    /// A 0.1 m tall box over the mesa's top, x and y from `lo` to `hi`, pressed `depth` in.
    fn pressed_box(lo: [Real; 2], hi: [Real; 2], depth: Real) -> Block {
        let z = MESA.0 - depth;
        free_block(crate::verification::box_corners(
            [lo[0], lo[1], z],
            [hi[0], hi[1], z + 0.1],
        ))
    }

    /// The contacts of `block` with `mesa`, inheriting from `old`.
    fn contacts(block: &Block, mesa: &TerrainBody, old: &[Contact]) -> Vec<Contact> {
        let mut out = Vec::new();
        collide(0, block, 1, mesa, JOINT, PARAMS, old, &mut out);
        out
    }

    fn free_block(vertices: Vec<[Real; 3]>) -> Block {
        let spec = BlockSpec::plain(
            "rock",
            BlockKind::Free,
            ShapeSpec::Convex { vertices },
            2500.0,
        );
        Block::from_spec(0, &spec).unwrap()
    }

    /// A cube as wide as a mesa's flat top, turned 45° about z and pressed `depth` into the
    /// top: no vertex of either lies in the other, and the cube's four bottom edges cross the
    /// rim's four ridges at eight points, each a contact with the full depth along +z.
    fn mesa_crossings(depth: Real) -> Vec<Contact> {
        let (height, half) = MESA;
        let (s, c) = std::f64::consts::FRAC_PI_4.sin_cos();
        let mut vertices = Vec::new();
        for &(x, y) in &[(-half, -half), (half, -half), (half, half), (-half, half)] {
            for z in [height - depth, height + 2.0 * half - depth] {
                vertices.push([c * x - s * y, s * x + c * y, z]);
            }
        }
        let out = contacts(&free_block(vertices), &mesa(), &[]);
        contact::assert_contacts(&out, Feature::EdgeEdge, 8, Vector::z(), depth, 1e-9);
        out
    }

    /// Touching (within the margin): the rim's crossings carry the cube.
    #[test]
    fn mesa_rim_holds_a_touching_cube_by_edge_crossings() {
        mesa_crossings(1e-4);
    }

    /// Pressed in five margins (a landing, or a load on top), the crossings stay. Their rim
    /// points lie in the cube's side faces (depth ≈ 0 below them), so the points' depths alone
    /// dropped them past the margin and the cube sank into the mesa unresisted until its
    /// corners reached the flanks; the cube's own depth in the rim's wedge keeps them.
    #[test]
    fn mesa_rim_keeps_a_pressed_in_cube() {
        mesa_crossings(5.0 * 4e-4);
    }

    /// A slab on the mesa's top with its two corners at x = 0.1995 m, 0.5 mm inside the rim,
    /// found touching and then pressed 1.7 mm in (4 margins: soft springs under its weight).
    /// Pressed in, the nearest surface point of those corners is on the flank (1.56 mm away,
    /// against 1.7 mm to the top), whose 45° normal pushed the slab off the mesa; the corners
    /// keep the top's triangle they entered by, its normal and its depth.
    #[test]
    fn a_corner_pressed_in_near_the_rim_keeps_the_top() {
        let half = MESA.1;
        let slab = |depth| pressed_box([-0.1, -0.15], [half - 5e-4, 0.15], depth);
        let mesa = mesa();
        let touching = contacts(&slab(1e-4), &mesa, &[]);
        contact::assert_contacts(&touching, Feature::VertexOfA, 4, Vector::z(), 1e-4, 1e-12);
        let fresh = contacts(&slab(1.7e-3), &mesa, &[]);
        let tilted = fresh.iter().filter(|c| c.normal.x > 0.7).count();
        assert_eq!(
            tilted, 2,
            "found afresh, the rim corners take the flank: {fresh:#?}"
        );
        let kept = contacts(&slab(1.7e-3), &mesa, &touching);
        contact::assert_contacts(&kept, Feature::VertexOfA, 4, Vector::z(), 1.7e-3, 1e-12);
    }

    /// In a hollow the entrance triangle is not kept: a vertex under the plane of one side of a
    /// valley (z = |x|) and over it, whose nearest point is on the other side, is on the wrong
    /// side of a concave crease to be held by the first plane alone.
    #[test]
    fn no_reference_triangle_in_a_valley() {
        let valley = body(&Grid::from_fn(11, 11, -2.5, -2.5, 0.5, |x, _| x.abs()));
        let t = &valley.terrain;
        let left = t.nearest(&Point::new(-0.02, 0.1, 0.03), 1.0).unwrap();
        let right = t.nearest(&Point::new(0.3, 0.1, 0.3), 1.0).unwrap();
        let v = Point::new(-0.05, 0.1, -0.01);
        let near = shared::terrain::Surface {
            distance: -1e-3,
            ..right
        };
        assert!(reference_triangle(&t.mesh, left.triangle, &v, &near, 4e-4).is_none());
        // The same point with the nearest point on a coplanar triangle of the left side: kept.
        let beside = t.nearest(&Point::new(-0.3, 0.6, 0.3), 1.0).unwrap();
        assert_ne!(beside.triangle, left.triangle);
        let near = shared::terrain::Surface {
            distance: -1e-3,
            ..beside
        };
        let r = reference_triangle(&t.mesh, left.triangle, &v, &near, 4e-4).unwrap();
        let n = Vector::new(1.0, 0.0, 1.0).normalize();
        assert!((r.normal - n).norm() < 1e-12 && (r.distance - n.dot(&v.coords)).abs() < 1e-12);
    }

    /// The mirror case: the mesa's corner (a peak) under a block whose side face is 0.5 mm
    /// past it, found touching the block's bottom and then pressed 1.7 mm in. The least deep
    /// face is then the side, whose normal pushed the block sideways off the corner; the peak
    /// keeps the bottom face it entered by.
    #[test]
    fn a_peak_pressed_in_near_a_side_face_keeps_the_bottom() {
        let half = MESA.1;
        let mesa = mesa();
        let peak = |old: &[Contact], depth| {
            let block = pressed_box([half - 5e-4, 0.1], [0.7, 0.7], depth);
            let mut out = contacts(&block, &mesa, old);
            out.retain(|c| c.key.feature == Feature::VertexOfB);
            out
        };
        let touching = peak(&[], 1e-4);
        contact::assert_contacts(&touching, Feature::VertexOfB, 1, -Vector::z(), 1e-4, 1e-12);
        let fresh = peak(&[], 1.7e-3);
        contact::assert_contacts(&fresh, Feature::VertexOfB, 1, -Vector::x(), 5e-4, 1e-12);
        let kept = peak(&touching, 1.7e-3);
        contact::assert_contacts(&kept, Feature::VertexOfB, 1, -Vector::z(), 1.7e-3, 1e-12);
    }
}
