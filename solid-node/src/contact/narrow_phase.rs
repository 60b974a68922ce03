//! Narrow phase: the vertex–face and edge–edge contacts of two convex blocks (3D-DDA's contact
//! types, Shi 2001; Doolin & Sitar 2004 list the same for their 3D code).
//!
//! Why our own and not parry's contact manifolds: DDA puts one normal and one shear penalty
//! spring on each *feature pair* (a vertex against a face, two crossing edges) and keeps that
//! spring from step to step, because the shear spring's elongation is the history Mohr–Coulomb
//! friction needs. parry's manifolds are rebuilt from clipped polygons whose points are not
//! tied to features of the blocks, so the shear history could not follow them. Both blocks
//! being convex, the feature tests below are exact and cheap (plane distances, segment
//! clipping).

use crate::blocks::block::Block;
use crate::contact::friction::Joint;
use crate::contact::{self, Contact, ContactKey, Feature};
use shared::math::{Point, Real, Vector};

/// How the narrow phase treats history.
#[derive(Debug, Clone, Copy)]
pub struct NarrowParams {
    /// Feature pairs closer than this [m] are contacts (open when the gap is positive).
    pub margin: Real,
    /// The first detection of the run: contacts found now across a slide's joint are bonded.
    pub at_start: bool,
}

/// Faces whose normal is within this angle of the contact normal share their area with the
/// contact (cohesion acts on face–face contacts only): cos 10°.
const FACE_ALIGNMENT: Real = 0.984_807_753;

/// Edges closer to parallel than this (sine of the angle) have no edge–edge contact: their
/// touching is carried by vertex–face contacts.
const PARALLEL_SINE: Real = 1e-3;

/// Largest ratio of an edge–edge penetration to the depth of its points below the nearest face
/// (1/cos 75°).
pub(crate) const EDGE_DEPTH_RATIO: Real = 3.9;

/// Appends the contacts of blocks `a` < `b` to `out` in key order, inheriting state from `old`
/// (the previous step's contacts of this pair, sorted by key).
pub fn collide(pair: &Pair, params: NarrowParams, old: &[Contact], out: &mut Vec<Contact>) {
    vertex_face(pair, Feature::VertexOfA, params, old, out);
    vertex_face(pair, Feature::VertexOfB, params, old, out);
    edge_edge(pair, params, old, out);
}

/// Two blocks a < b (indices and blocks) and their joint.
#[derive(Clone, Copy)]
pub struct Pair<'a> {
    pub a: u32,
    pub b: u32,
    pub ba: &'a Block,
    pub bb: &'a Block,
    pub joint: Joint,
}

fn inflated_contains(blk: &Block, p: &Point, margin: Real) -> bool {
    (0..3).all(|k| p[k] >= blk.aabb_min[k] - margin && p[k] <= blk.aabb_max[k] + margin)
}

/// Vertices of one block of the pair (the vertex owner, P) against the faces of the other (Q).
fn vertex_face(
    pair: &Pair,
    feature: Feature,
    params: NarrowParams,
    old: &[Contact],
    out: &mut Vec<Contact>,
) {
    let Pair { a, b, joint, .. } = *pair;
    let (p, q, pb, qb) = if feature == Feature::VertexOfA {
        (a, b, pair.ba, pair.bb)
    } else {
        (b, a, pair.bb, pair.ba)
    };
    for (vi, v) in pb.world_vertices.iter().enumerate() {
        if !inflated_contains(qb, v, params.margin) {
            continue;
        }
        let (mut d, mut f) = qb.plane_distance(v);
        if d > params.margin {
            continue;
        }
        let key = ContactKey {
            a,
            b,
            feature,
            i: vi as u32,
            j: 0,
        };
        let prev = contact::find(old, &key);
        if prev.is_none() {
            f = entrance_face(pb, vi, qb, d, f, params.margin);
            d = qb.world_normals[f].dot(&v.coords) - qb.world_offsets[f];
        }
        (d, f) = reference_face(qb, prev, v, (d, f), params.margin);
        let normal = qb.world_normals[f];
        // Tributary area: the faces of P at this vertex lying flat on Q's face share their
        // area among their corners.
        let mut area = 0.0;
        for &pf in &pb.vertex_faces[vi] {
            if -pb.world_normals[pf as usize].dot(&normal) >= FACE_ALIGNMENT {
                area +=
                    pb.face_area[pf as usize] / pb.shape.faces[pf as usize].vertices.len() as Real;
            }
        }
        let mut c = Contact::new(key, p, q);
        c.face = f as u32;
        c.point = *v;
        c.normal = normal;
        c.gap = d;
        c.area = area;
        c.tan_phi = joint.tan_phi;
        c.cohesion = joint.cohesion;
        if let Some(o) = prev {
            c.inherit(o);
        }
        c.apply_joint(&joint, prev.is_none(), params.at_start);
        out.push(c);
    }
}

/// DDA's reference face: the face of `prev` (the same contact at the previous step), with
/// `v`'s signed distance from it, while the vertex still lies over it (its projection on the
/// face's plane inside the face, [`over_face`]), however deep it has been pressed in, so that
/// the normal neither flips between the two faces at an edge when the vertex sits near it nor
/// jumps to a face the vertex did not enter by. Otherwise `nearest` (distance, face).
pub(crate) fn reference_face(
    qb: &Block,
    prev: Option<&Contact>,
    v: &Point,
    nearest: (Real, usize),
    margin: Real,
) -> (Real, usize) {
    if let Some(o) = prev
        && (o.face as usize) < qb.world_normals.len()
        && o.face as usize != nearest.1
    {
        let fo = o.face as usize;
        let dold = qb.world_normals[fo].dot(&v.coords) - qb.world_offsets[fo];
        if over_face(qb, fo, v, dold, margin) {
            return (dold, fo);
        }
    }
    nearest
}

/// Whether point `v`, at signed distance `d` from the plane of face `f` of `qb`, lies over
/// that face: its projection on the plane is inside the face polygon, within `margin` (`qb`
/// being convex, inside every other face's plane).
///
/// Why the reference face is kept on this test and not on depth: the least deep face of a
/// pressed-in vertex is not always the face it entered by. Blocks cut from one rock mass by a
/// joint set share that joint's planes, so a corner of one block sits flush with a side face of
/// its neighbour (depth ≈ 0 there) while it is pressed into the neighbour's front face; once
/// the contact force passed what the margin allows (about the lightest block's weight), a test
/// on depth moved the contact to the flush face, where it has no depth and no force, and the
/// corner sank freely into the neighbour until an edge–edge contact far past the margin and
/// the energy watch stopped the run (scenes/jointed_slide.toml under DFSPH).
fn over_face(qb: &Block, f: usize, v: &Point, d: Real, margin: Real) -> bool {
    let on_plane = v - qb.world_normals[f] * d;
    qb.world_normals
        .iter()
        .zip(&qb.world_offsets)
        .enumerate()
        .all(|(g, (n, o))| g == f || n.dot(&on_plane.coords) - o <= margin)
}

/// The face of `qb` a new vertex–face contact of vertex `vi` of `pb` takes. The nearest face
/// `f` (distance `d`) is ambiguous when the vertex sits at an edge or corner of `qb` (within
/// `margin` of several faces), as every vertex of blocks cut from one rock mass does at the
/// start, where their corners coincide: then the face that a face of `pb` at the vertex lies
/// flat against is the contact (Shi's entrance rule for vertex-to-vertex contacts picks the
/// face the vertex slides along). A wrong pick pins the vertex to a face across its path.
fn entrance_face(pb: &Block, vi: usize, qb: &Block, d: Real, f: usize, margin: Real) -> usize {
    let v = &pb.world_vertices[vi];
    let alignment = |g: usize| {
        pb.vertex_faces[vi]
            .iter()
            .map(|&pf| -pb.world_normals[pf as usize].dot(&qb.world_normals[g]))
            .fold(Real::NEG_INFINITY, Real::max)
    };
    if alignment(f) >= FACE_ALIGNMENT {
        return f;
    }
    let mut best = (f, alignment(f));
    for g in 0..qb.world_normals.len() {
        let dg = qb.world_normals[g].dot(&v.coords) - qb.world_offsets[g];
        if g != f && dg >= d - margin {
            let a = alignment(g);
            if a >= FACE_ALIGNMENT && a > best.1 {
                best = (g, a);
            }
        }
    }
    best.0
}

/// Parameter range [t0, t1] ⊂ [0, 1] of segment p0 + t (p1 − p0) inside `blk` inflated by
/// `margin` (Cyrus–Beck clipping against the face planes), if any.
fn clip_segment(blk: &Block, p0: &Point, p1: &Point, margin: Real) -> Option<(Real, Real)> {
    let d = p1 - p0;
    let (mut t0, mut t1) = (0.0, 1.0);
    for (n, o) in blk.world_normals.iter().zip(&blk.world_offsets) {
        let num = o + margin - n.dot(&p0.coords);
        let den = n.dot(&d);
        if den.abs() < 1e-300 {
            if num < 0.0 {
                return None;
            }
        } else if den > 0.0 {
            t1 = Real::min(t1, num / den);
        } else {
            t0 = Real::max(t0, num / den);
        }
        if t0 > t1 {
            return None;
        }
    }
    Some((t0, t1))
}

/// Closest points of segments p0 + s·u and q0 + t·w (non-parallel): the parameters.
fn closest_parameters(p0: &Point, u: &Vector, q0: &Point, w: &Vector) -> (Real, Real) {
    let r = p0 - q0;
    let (a, b, c) = (u.dot(u), u.dot(w), w.dot(w));
    let (d, e) = (u.dot(&r), w.dot(&r));
    let den = a * c - b * b;
    let s = (b * e - c * d) / den;
    let t = (a * e - b * d) / den;
    (s, t)
}

/// Slack of the normal-cone test (in cosine, about 3° at a right-angled edge). Two nearly
/// parallel faces (a block resting on another) touch where their edges cross, with n at the
/// very border of both cones; without slack, every tiny rocking tilt would drop and re-add
/// those contacts at full penetration, and the force jumps pump a rocking limit cycle.
const CONE_SLACK: Real = 0.05;

/// True when unit `n` (normal to the edge) lies in the wedge spanned by the edge's face
/// normals `n1`, `n2`: the edge's normal cone, where it can touch.
#[inline]
fn in_normal_cone(n: &Vector, n1: &Vector, n2: &Vector) -> bool {
    let c12 = n1.dot(n2) - CONE_SLACK;
    n.dot(n1) >= c12 && n.dot(n2) >= c12
}

/// An edge with the outward normals of its two faces: the feature of an edge–edge contact.
#[derive(Debug, Clone, Copy)]
pub struct Edge {
    pub p0: Point,
    pub p1: Point,
    pub n1: Vector,
    pub n2: Vector,
}

/// Where edge `ea` (of the vertex side, P) crosses edge `eb` (of the face side, Q).
pub(crate) struct Crossing {
    /// The closest points on `ea` and on `eb`.
    pub pa: Point,
    pub pb: Point,
    /// Unit normal, out of Q's edge (within its normal cone).
    pub normal: Vector,
    /// (pa − pb)·normal: negative when the edges interpenetrate.
    pub gap: Real,
}

/// The crossing of two edges within `margin`, if they can touch there: not parallel, closest
/// points inside both (a crossing at an end point is a vertex, carried by vertex–face), the
/// normal inside both edges' normal cones. The caller checks that the points lie in (or at the
/// margin of) the other body ([`local_depths`]).
#[inline]
pub(crate) fn crossing(ea: &Edge, eb: &Edge, m: Real) -> Option<Crossing> {
    let (a0, b0) = (ea.p0, eb.p0);
    let u = ea.p1 - a0;
    let w = eb.p1 - b0;
    let cross = u.cross(&w);
    let cn = cross.norm();
    if cn <= PARALLEL_SINE * u.norm() * w.norm() {
        return None;
    }
    let (s, t) = closest_parameters(&a0, &u, &b0, &w);
    // End points are vertices: vertex–face contacts carry them, also a crossing within the
    // margin of one (corners that coincide, as in a cut rock mass, would otherwise cross at
    // every corner with a normal across the joint).
    let (lu, lw) = (u.norm(), w.norm());
    let (su, tw) = (m.max(1e-9 * lu), m.max(1e-9 * lw));
    if !(s * lu > su && (1.0 - s) * lu > su && t * lw > tw && (1.0 - t) * lw > tw) {
        return None;
    }
    let pa = a0 + u * s;
    let pb = b0 + w * t;
    let mut n = cross / cn;
    if n.dot(&(eb.n1 + eb.n2)) < 0.0 {
        n = -n;
    }
    if !in_normal_cone(&n, &eb.n1, &eb.n2) || !in_normal_cone(&-n, &ea.n1, &ea.n2) {
        return None;
    }
    let gap = (pa - pb).dot(&n);
    if gap > m {
        return None;
    }
    Some(Crossing {
        pa,
        pb,
        normal: n,
        gap,
    })
}

impl Crossing {
    /// The contact of this crossing between P = `key.a`'s feature and Q = `key.b`'s, at the
    /// midpoint of the closest points, with the pair's joint, its history taken from `old`.
    /// Returns whether it is new (no contact of that key before).
    #[inline]
    pub(crate) fn contact(
        &self,
        key: ContactKey,
        joint: &Joint,
        old: &[Contact],
    ) -> (Contact, bool) {
        let mut c = Contact::new(key, key.a, key.b);
        c.point = Point::from((self.pa.coords + self.pb.coords) * 0.5);
        c.normal = self.normal;
        c.gap = self.gap;
        c.tan_phi = joint.tan_phi;
        c.cohesion = joint.cohesion;
        let prev = contact::find(old, &key);
        if let Some(o) = prev {
            c.inherit(o);
        }
        (c, prev.is_none())
    }
}

/// True when a crossing whose points lie `da` (pa under Q's surface) and `db` (pb under P's)
/// from the other body is a contact: both within the margin of the other body (the crossing
/// is local, not two far edges whose infinite lines happen to cross), and the depth along n
/// of the order of the points' depth below the nearest face. An edge sunk a little into a
/// face is "crossed" by every edge of that face's plane at the distance between them, which
/// is no contact (the face carries it as vertex–face); a true crossing is at most 1/cos of
/// the angle between n and the nearest face normal deeper.
#[inline]
pub(crate) fn local_depths(c: &Crossing, da: Real, db: Real, m: Real) -> bool {
    da <= m
        && db <= m
        && -c.gap <= EDGE_DEPTH_RATIO * (-da).max(0.0) + m
        && -c.gap <= EDGE_DEPTH_RATIO * (-db).max(0.0) + m
}

/// How deep two convex blocks interpenetrate (0 or less when apart): the least overlap of
/// their projections over the separating-axis candidates, the face normals of both and the
/// directions normal to an edge of each (Gottschalk, Lin & Manocha 1996's separating-axis
/// theorem; for convex polyhedra the least overlap is the depth, the shortest translation
/// that parts them).
///
/// Why [`local_depths`] alone is not enough: it measures a crossing's points against the
/// other block's nearest face, which for two faces pressed into each other with their edges
/// crossing is the side face at the crossing, at depth ≈ 0. Past the margin such crossings
/// were dropped, and two blocks of a cut rock mass that met face to face, twisted (no vertex
/// of either inside the other), sank into each other far past the margin before the points'
/// depth caught up (scenes/jointed_slide.toml; the energy watch then stopped the run).
pub(crate) fn penetration_depth(ba: &Block, bb: &Block) -> Real {
    let extent = |b: &Block, n: &Vector| {
        b.world_vertices
            .iter()
            .map(|v| n.dot(&v.coords))
            .fold((Real::INFINITY, Real::NEG_INFINITY), |(lo, hi), x| {
                (lo.min(x), hi.max(x))
            })
    };
    let overlap = |n: &Vector| {
        let ((alo, ahi), (blo, bhi)) = (extent(ba, n), extent(bb, n));
        (ahi - blo).min(bhi - alo)
    };
    let mut depth = Real::INFINITY;
    for n in ba.world_normals.iter().chain(&bb.world_normals) {
        depth = depth.min(overlap(n));
    }
    for ia in 0..ba.shape.edges.len() {
        let ea = block_edge(ba, ia);
        let u = ea.p1 - ea.p0;
        for ib in 0..bb.shape.edges.len() {
            let eb = block_edge(bb, ib);
            let w = eb.p1 - eb.p0;
            let c = u.cross(&w);
            let cn = c.norm();
            if cn > PARALLEL_SINE * u.norm() * w.norm() {
                depth = depth.min(overlap(&(c / cn)));
            }
        }
    }
    depth
}

/// The edge `e` of block `b` in the world, with its faces' normals.
#[inline]
pub(crate) fn block_edge(b: &Block, e: usize) -> Edge {
    let [v0, v1] = b.shape.edges[e];
    let [f1, f2] = b.edge_faces[e];
    Edge {
        p0: b.world_vertices[v0 as usize],
        p1: b.world_vertices[v1 as usize],
        n1: b.world_normals[f1 as usize],
        n2: b.world_normals[f2 as usize],
    }
}

fn edge_edge(pair: &Pair, params: NarrowParams, old: &[Contact], out: &mut Vec<Contact>) {
    let Pair {
        a,
        b,
        ba,
        bb,
        joint,
    } = *pair;
    let m = params.margin;
    // The pair's depth of interpenetration, computed once and only if a crossing needs it.
    let mut depth = None;
    for ia in 0..ba.shape.edges.len() {
        let ea = block_edge(ba, ia);
        if clip_segment(bb, &ea.p0, &ea.p1, m).is_none() {
            continue;
        }
        for ib in 0..bb.shape.edges.len() {
            let Some(x) = crossing(&ea, &block_edge(bb, ib), m) else {
                continue;
            };
            let (da, db) = (bb.plane_distance(&x.pa).0, ba.plane_distance(&x.pb).0);
            // Two faces pressed into each other deeper than the margin, their edges crossing:
            // the crossing points lie at the other block's edges, hardly below its side
            // faces, so the points' depths understate the crossing's; the blocks' own depth
            // of interpenetration says it is real ([`penetration_depth`]). And two corners
            // overlapping: a crossing point may lie outside the other block, past the corner
            // one of its faces cuts off, by up to the overlap itself; within the margin plus
            // the pair's depth it is still local to the overlap (scenes/jointed_slide.toml
            // under DFSPH: refused, the pair had no contact while it sank into itself).
            let real = local_depths(&x, da, db, m)
                || (da.max(db) <= m + (-x.gap).max(0.0) && {
                    let d = *depth.get_or_insert_with(|| penetration_depth(ba, bb));
                    da.max(db) <= m + d.max(0.0) && -x.gap <= EDGE_DEPTH_RATIO * d + m
                });
            if !real {
                continue;
            }
            let key = ContactKey {
                a,
                b,
                feature: Feature::EdgeEdge,
                i: ia as u32,
                j: ib as u32,
            };
            let (mut c, fresh) = x.contact(key, &joint, old);
            c.apply_joint(&joint, fresh, params.at_start);
            out.push(c);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use shared::scene::{BlockKind, BlockSpec, ShapeSpec};

    fn block(kind: BlockKind, vertices: Vec<[f64; 3]>) -> Block {
        let spec = BlockSpec::plain("t", kind, ShapeSpec::Convex { vertices }, 1000.0);
        Block::from_spec(0, &spec).unwrap()
    }

    fn cube(c: [f64; 3], h: f64, turn: f64) -> Block {
        let mut v = Vec::new();
        for &x in &[-h, h] {
            for &y in &[-h, h] {
                for &z in &[-h, h] {
                    let (s, co) = turn.sin_cos();
                    v.push([c[0] + co * x - s * y, c[1] + s * x + co * y, c[2] + z]);
                }
            }
        }
        block(BlockKind::Free, v)
    }

    const JOINT: Joint = Joint {
        tan_phi: 0.5,
        cohesion: 0.0,
        tensile: 0.0,
        bonded: false,
    };

    fn pair<'a>(ba: &'a Block, bb: &'a Block) -> Pair<'a> {
        Pair {
            a: 0,
            b: 1,
            ba,
            bb,
            joint: JOINT,
        }
    }
    const P: NarrowParams = NarrowParams {
        margin: 1e-3,
        at_start: false,
    };

    #[test]
    fn resting_cube_has_four_vertex_face_contacts() {
        let floor = cube([0.0, 0.0, -1.0], 1.0, 0.0);
        let top = cube([0.2, 0.1, 0.25 - 1e-4], 0.25, 0.3);
        let mut out = Vec::new();
        collide(&pair(&floor, &top), P, &[], &mut out);
        let vf: Vec<_> = out
            .iter()
            .filter(|c| c.key.feature == Feature::VertexOfB)
            .collect();
        assert_eq!(vf.len(), 4, "{out:#?}");
        for c in &vf {
            assert!((c.gap + 1e-4).abs() < 1e-12);
            assert!((c.normal - Vector::z()).norm() < 1e-12);
            assert_eq!((c.p, c.q), (1, 0));
            assert!((c.area - 0.25 * 0.25).abs() < 1e-12, "area {}", c.area);
        }
        assert!(out.iter().all(|c| c.key.feature != Feature::VertexOfA));
    }

    /// Two equal cubes stacked flush, as one joint set cuts them: the upper one's corners lie
    /// in the planes of the lower one's side faces. Pressed in three margins, its corner
    /// contacts keep the lower one's top face (normal +z, the full depth), where the least
    /// deep face is a side face at depth 0, which carried no force: the corners sank freely.
    #[test]
    fn flush_corner_pressed_in_keeps_its_face() {
        let low = cube([0.0, 0.0, 0.0], 0.5, 0.0);
        let touching = cube([0.0, 0.0, 1.0 - 1e-4], 0.5, 0.0);
        let mut first = Vec::new();
        collide(&pair(&low, &touching), P, &[], &mut first);
        let corners = |out: &[Contact]| -> Vec<Contact> {
            out.iter()
                .filter(|c| c.key.feature == Feature::VertexOfB)
                .cloned()
                .collect()
        };
        assert_eq!(corners(&first).len(), 4, "{first:#?}");
        for c in corners(&first) {
            assert!((c.normal - Vector::z()).norm() < 1e-12, "{c:?}");
        }
        let depth = 3.0 * P.margin;
        let pressed = cube([0.0, 0.0, 1.0 - depth], 0.5, 0.0);
        let mut out = Vec::new();
        collide(&pair(&low, &pressed), P, &first, &mut out);
        let cs = corners(&out);
        contact::assert_contacts(&cs, Feature::VertexOfB, 4, Vector::z(), depth, 1e-12);
    }

    /// The edge–edge contacts of two equal cubes stacked with a 45° twist, the upper one
    /// pressed `depth` into the lower: eight (the octagon of the overlap), each with the full
    /// depth along −z; no vertex inside the other cube.
    fn twisted_stack_crossings(depth: Real) -> Vec<Contact> {
        let low = cube([0.0, 0.0, 0.0], 0.5, 0.0);
        let high = cube([0.0, 0.0, 1.0 - depth], 0.5, std::f64::consts::FRAC_PI_4);
        assert!((penetration_depth(&low, &high) - depth).abs() < 1e-12);
        let mut out = Vec::new();
        collide(&pair(&low, &high), P, &[], &mut out);
        contact::assert_contacts(&out, Feature::EdgeEdge, 8, -Vector::z(), depth, 1e-9);
        for c in &out {
            assert!((c.point.z - 0.5).abs() < depth);
        }
        out
    }

    /// Touching (within the margin): the crossings carry the contact.
    #[test]
    fn twisted_stack_touches_by_edge_crossings() {
        twisted_stack_crossings(2e-4);
    }

    /// Pressed in five margins, the crossings stay. Their points lie at the other cube's side
    /// faces (depth ≈ 0 below them), so the points' depths alone dropped them past the margin
    /// and the cubes sank into each other unresisted; the cubes' own depth of
    /// interpenetration keeps them.
    #[test]
    fn twisted_stack_pressed_in_keeps_its_crossings() {
        twisted_stack_crossings(5.0 * P.margin);
        let low = cube([0.0, 0.0, 0.0], 0.5, 0.0);
        // Apart, the depth is the gap between them, negated.
        let apart = cube([0.0, 0.0, 1.0 + 0.01], 0.5, 0.3);
        assert!((penetration_depth(&low, &apart) + 0.01).abs() < 1e-12);
    }

    /// Two bars crossing at right angles, edge on edge: one edge–edge contact with the normal
    /// along the common perpendicular.
    #[test]
    fn crossed_edges() {
        // A bar along x with a vertical diamond cross-section (edge on top), another along y
        // with its edge pointing down onto it.
        let r = 0.1;
        let mut lo = Vec::new();
        let mut hi = Vec::new();
        for &s in &[-1.0, 1.0] {
            for &(y, z) in &[(0.0, r), (r, 0.0), (0.0, -r), (-r, 0.0)] {
                lo.push([s, y, z]);
                hi.push([y, s, z + 2.0 * r - 1e-4]);
            }
        }
        let (bl, bh) = (block(BlockKind::Fixed, lo), block(BlockKind::Free, hi));
        let mut out = Vec::new();
        collide(&pair(&bl, &bh), P, &[], &mut out);
        assert_eq!(out.len(), 1, "{out:#?}");
        let c = &out[0];
        assert_eq!(c.key.feature, Feature::EdgeEdge);
        assert!((c.gap + 1e-4).abs() < 1e-12);
        // Normal outward from b (the upper bar, q), i.e. pointing down onto a.
        assert!((c.normal + Vector::z()).norm() < 1e-12);
        assert!((c.point - Point::new(0.0, 0.0, r - 0.5e-4)).norm() < 1e-12);
    }

    /// Two blocks of `scenes/jointed_slide.toml` as they met corner to corner under DFSPH
    /// (`rock/17` below, `rock/26`, a triangular prism, above; their vertices at t = 1.3046 s,
    /// the run's margin): no vertex of either inside the other, the two overlapping 0.76 mm
    /// where an edge of each crosses the other's, and the crossing's point on the lower edge
    /// 0.7 mm outside the upper block, past the corner its face cuts off. Past the margin that
    /// crossing was dropped, so the pair had no contact at all while it sank into itself (the
    /// energy watch then stopped the run). It is kept, at the pair's depth.
    #[test]
    fn corner_to_corner_overlap_keeps_its_crossing() {
        let low = block(
            BlockKind::Free,
            vec![
                [1.615882602256422, 0.7056994157758114, 0.24620020333526454],
                [1.7996317021225383, 0.7065397274633812, 0.12010010210732486],
                [1.8035720374725883, 0.7062833556316358, 0.24003511797347224],
                [1.5997404755866924, 0.7059178253628743, 0.12666598299053772],
                [1.6034938786396322, 0.7056736159922306, 0.24091119684033752],
                [1.8041795752341088, 0.5062847789763968, 0.23958764311740774],
                [1.8002392398840588, 0.5065411508081423, 0.11965262725126037],
                [1.6164901400179426, 0.5057008391205724, 0.24575272847920004],
                [1.6003480133482129, 0.5059192487076354, 0.12621850813447322],
                [1.6041014164011527, 0.5056750393369914, 0.24046372198427304],
            ],
        );
        let high = block(
            BlockKind::Free,
            vec![
                [1.618091995660172, 0.7182066841138806, 0.24510506495977116],
                [1.8055011666720944, 0.7092554065177108, 0.33303468734988284],
                [1.805563564051409, 0.7072551060783777, 0.2454889119330763],
                [1.606422157834889, 0.518599344024612, 0.2496575003100765],
                [1.793893726226126, 0.5076477659891092, 0.2500413472833816],
                [1.7938313288468115, 0.5096480664284423, 0.3375871227001882],
            ],
        );
        let params = NarrowParams {
            margin: 2.7862005497146953e-4,
            at_start: false,
        };
        let depth = penetration_depth(&low, &high);
        assert!(depth > 2.0 * params.margin, "depth {depth}");
        for v in &low.world_vertices {
            assert!(high.plane_distance(v).0 > params.margin, "a vertex inside");
        }
        for v in &high.world_vertices {
            assert!(low.plane_distance(v).0 > params.margin, "a vertex inside");
        }
        let mut out = Vec::new();
        collide(&pair(&low, &high), params, &[], &mut out);
        let deepest = out.iter().map(|c| -c.gap).fold(0.0, Real::max);
        assert!(
            (deepest - depth).abs() < 0.05 * depth,
            "deepest contact {deepest} m against the pair's depth {depth} m: {out:#?}"
        );
    }

    #[test]
    fn separated_blocks_have_no_contact() {
        let a = cube([0.0, 0.0, 0.0], 0.5, 0.0);
        let b = cube([0.0, 0.0, 1.01], 0.5, 0.2);
        let mut out = Vec::new();
        collide(&pair(&a, &b), P, &[], &mut out);
        assert!(out.is_empty(), "{out:#?}");
    }
}
