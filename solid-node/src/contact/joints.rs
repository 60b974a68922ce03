//! The joints of a slide: blocks cut from one `[[slide]]` (`shared::scene::slide`) are bonded
//! where they share a face on a joint plane, with that joint set's strength.
//!
//! At set-up, every pair of blocks of one slide that touch across a plane of one of its joint
//! sets (the two blocks lie on either side of the plane and their faces on it overlap) is a
//! *bond*: its set and the area the two faces share. The contacts of a bonded pair found at
//! the start are bonded and share that area equally. A bonded contact is a Mohr–Coulomb joint
//! with a tension cut-off, as DDA models an intact joint (Shi 1988: a joint's cohesion and
//! tensile strength hold until it opens or slides, and are zero from then on):
//!
//! - normal: the spring carries compression and, while bonded, tension up to `T · A_i`;
//! - shear: up to `c · A_i + N tan φ` (N ≥ 0 the compression);
//!
//! and the first time either limit is passed the bond breaks for good: the contact keeps the
//! set's friction φ, with no cohesion and no tension (the residual strength). Contacts that
//! form later between two blocks of the slide (after they moved) are never bonded; two blocks
//! of a slide that did not touch across a joint at the start use the smallest friction angle
//! of the slide's sets and no cohesion.
//!
//! Everything here is fixed at set-up from the scene in block order: deterministic.

use crate::blocks::block::Block;
use crate::contact::friction::Joint;
use crate::contact::tangents;
use shared::math::{Point, Real, Vector};
use shared::scene::Scene;

/// One joint set's strength and planes.
#[derive(Debug, Clone, Copy)]
struct SetStrength {
    normal: Vector,
    tan_phi: Real,
    cohesion: Real,
    tensile: Real,
}

/// A bonded pair: the set whose plane separates the two blocks, and the area they share on it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Bond {
    pub set: u32,
    pub area: Real,
}

/// The bonds of every slide of a scene.
#[derive(Debug, Clone, Default)]
pub struct SlideJoints {
    /// Per slide, per joint set.
    sets: Vec<Vec<SetStrength>>,
    /// Per slide: the smallest tan φ of its sets (pairs not bonded at the start).
    loose: Vec<Real>,
    /// Bonded pairs (a < b, block indices), sorted.
    bonds: Vec<((u32, u32), Bond)>,
}

/// Relative tolerance (of the blocks' size) for "on the plane".
const PLANE_TOLERANCE: Real = 1e-7;

impl SlideJoints {
    /// Finds the bonds between the blocks (at their scene pose) of the scene's slides.
    pub fn new(scene: &Scene, blocks: &[Block]) -> SlideJoints {
        let sets: Vec<Vec<SetStrength>> = scene
            .slides
            .iter()
            .map(|s| {
                s.joint_sets
                    .iter()
                    .map(|j| SetStrength {
                        normal: j.normal(),
                        tan_phi: j.friction_angle.to_radians().tan(),
                        cohesion: j.cohesion,
                        tensile: j.tensile_strength,
                    })
                    .collect()
            })
            .collect();
        let loose = sets
            .iter()
            .map(|s| s.iter().map(|j| j.tan_phi).fold(Real::INFINITY, Real::min))
            .collect();
        let members: Vec<usize> = (0..blocks.len())
            .filter(|&i| blocks[i].slide.is_some())
            .collect();
        let mut bonds = Vec::new();
        for (k, &a) in members.iter().enumerate() {
            for &b in &members[k + 1..] {
                let (ba, bb) = (&blocks[a], &blocks[b]);
                if ba.slide != bb.slide {
                    continue;
                }
                let tol = PLANE_TOLERANCE * (ba.size() + bb.size());
                if (0..3).any(|d| {
                    ba.aabb_min[d] > bb.aabb_max[d] + tol || bb.aabb_min[d] > ba.aabb_max[d] + tol
                }) {
                    continue;
                }
                let slide = ba.slide.unwrap_or_default();
                if let Some(bond) = bond_between(ba, bb, &sets[slide], tol) {
                    bonds.push(((a as u32, b as u32), bond));
                }
            }
        }
        SlideJoints { sets, loose, bonds }
    }

    /// True when the scene has slides.
    pub fn any(&self) -> bool {
        !self.sets.is_empty()
    }

    /// Number of bonded pairs.
    pub fn bond_count(&self) -> usize {
        self.bonds.len()
    }

    /// The bond of pair a < b, if any.
    pub fn bond(&self, a: u32, b: u32) -> Option<Bond> {
        self.bonds
            .binary_search_by(|(k, _)| k.cmp(&(a, b)))
            .ok()
            .map(|i| self.bonds[i].1)
    }

    /// The joint of two blocks of one slide (a < b), or `None` for any other pair.
    pub fn joint(&self, a: u32, b: u32, ba: &Block, bb: &Block) -> Option<Joint> {
        let slide = ba.slide?;
        if bb.slide != Some(slide) {
            return None;
        }
        Some(match self.bond(a, b) {
            Some(bond) => {
                let s = self.sets[slide][bond.set as usize];
                Joint {
                    tan_phi: s.tan_phi,
                    cohesion: s.cohesion,
                    tensile: s.tensile,
                    bonded: true,
                }
            }
            None => Joint {
                tan_phi: self.loose[slide],
                cohesion: 0.0,
                tensile: 0.0,
                bonded: false,
            },
        })
    }
}

/// The set whose plane separates `a` and `b` (one on each side, both touching it) and the area
/// their faces on it share, if positive.
fn bond_between(a: &Block, b: &Block, sets: &[SetStrength], tol: Real) -> Option<Bond> {
    for (k, s) in sets.iter().enumerate() {
        let n = s.normal;
        let (alo, ahi) = extent(a, &n);
        let (blo, bhi) = extent(b, &n);
        // a below b, or b below a, touching on the plane.
        let (lower, upper, level) = if (ahi - blo).abs() <= tol {
            (a, b, ahi)
        } else if (bhi - alo).abs() <= tol {
            (b, a, bhi)
        } else {
            continue;
        };
        let area = shared_area(lower, upper, &n, level, tol);
        // Blocks meeting along an edge or at a corner share a sliver of rounding, no face.
        let scale = a.size() + b.size();
        if area > PLANE_TOLERANCE * scale * scale {
            return Some(Bond {
                set: k as u32,
                area,
            });
        }
    }
    None
}

fn extent(b: &Block, n: &Vector) -> (Real, Real) {
    b.world_vertices
        .iter()
        .map(|p| n.dot(&p.coords))
        .fold((Real::INFINITY, Real::NEG_INFINITY), |(lo, hi), s| {
            (lo.min(s), hi.max(s))
        })
}

/// Area shared by the face of `lower` on the plane n·x = level (outward normal +n) and the face
/// of `upper` on it (outward normal −n): the intersection of two convex polygons.
fn shared_area(lower: &Block, upper: &Block, n: &Vector, level: Real, tol: Real) -> Real {
    let (t1, t2) = tangents(n);
    let on_plane = |b: &Block| -> Vec<[Real; 2]> {
        let pts: Vec<[Real; 2]> = b
            .world_vertices
            .iter()
            .filter(|p| (n.dot(&p.coords) - level).abs() <= tol)
            .map(|p: &Point| [t1.dot(&p.coords), t2.dot(&p.coords)])
            .collect();
        convex_ring(pts)
    };
    let (p, q) = (on_plane(lower), on_plane(upper));
    if p.len() < 3 || q.len() < 3 {
        return 0.0;
    }
    polygon_area(&clip(&p, &q))
}

/// Orders the corners of a convex polygon counter-clockwise about their mean.
fn convex_ring(mut pts: Vec<[Real; 2]>) -> Vec<[Real; 2]> {
    if pts.is_empty() {
        return pts;
    }
    let m = pts.len() as Real;
    let c = pts
        .iter()
        .fold([0.0, 0.0], |s, p| [s[0] + p[0] / m, s[1] + p[1] / m]);
    pts.sort_by(|a, b| {
        let aa = (a[1] - c[1]).atan2(a[0] - c[0]);
        let ab = (b[1] - c[1]).atan2(b[0] - c[0]);
        aa.total_cmp(&ab)
    });
    pts
}

/// Sutherland–Hodgman: `subject` clipped by the convex counter-clockwise polygon `clipper`.
fn clip(subject: &[[Real; 2]], clipper: &[[Real; 2]]) -> Vec<[Real; 2]> {
    let mut out = subject.to_vec();
    for k in 0..clipper.len() {
        if out.is_empty() {
            break;
        }
        let (a, b) = (clipper[k], clipper[(k + 1) % clipper.len()]);
        let side = |p: &[Real; 2]| (b[0] - a[0]) * (p[1] - a[1]) - (b[1] - a[1]) * (p[0] - a[0]);
        let input = std::mem::take(&mut out);
        for i in 0..input.len() {
            let (p, q) = (input[i], input[(i + 1) % input.len()]);
            let (sp, sq) = (side(&p), side(&q));
            if sp >= 0.0 {
                out.push(p);
            }
            if (sp >= 0.0) != (sq >= 0.0) {
                let t = sp / (sp - sq);
                out.push([p[0] + t * (q[0] - p[0]), p[1] + t * (q[1] - p[1])]);
            }
        }
    }
    out
}

fn polygon_area(p: &[[Real; 2]]) -> Real {
    if p.len() < 3 {
        return 0.0;
    }
    let mut s = 0.0;
    for i in 0..p.len() {
        let (a, b) = (p[i], p[(i + 1) % p.len()]);
        s += a[0] * b[1] - b[0] * a[1];
    }
    0.5 * s.abs()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn overlapping_squares_share_their_intersection() {
        let sq = |x0: Real, y0: Real, s: Real| {
            convex_ring(vec![[x0, y0], [x0 + s, y0], [x0, y0 + s], [x0 + s, y0 + s]])
        };
        let a = clip(&sq(0.0, 0.0, 1.0), &sq(0.5, 0.25, 1.0));
        assert!((polygon_area(&a) - 0.5 * 0.75).abs() < 1e-14);
        assert_eq!(
            polygon_area(&clip(&sq(0.0, 0.0, 1.0), &sq(2.0, 0.0, 1.0))),
            0.0
        );
    }

    #[test]
    fn cubes_cut_from_one_slide_are_bonded_face_to_face() {
        let text = "name = \"b\"\n[time]\nend = 0.1\n[domain]\nmin = [-5, -5, -5]\nmax = [5, 5, 5]\n\
            [[slide]]\nname = \"r\"\nregion = { type = \"box\", min = [0, 0, 0], max = [2, 2, 1] }\n\
            [[slide.joint_set]]\ndip = 90\ndip_direction = 90\nspacing = 1\ncohesion = 5e3\n\
            [[slide.joint_set]]\ndip = 90\ndip_direction = 0\nspacing = 1\ncohesion = 7e3\n";
        let scene = Scene::parse(text, "t").unwrap();
        let blocks: Vec<Block> = scene
            .blocks
            .iter()
            .enumerate()
            .map(|(i, s)| Block::from_spec(i, s).unwrap())
            .collect();
        let j = SlideJoints::new(&scene, &blocks);
        // Four unit columns in a 2×2 square: four face bonds (the diagonal pairs touch along
        // an edge only), each of area 1.
        assert_eq!(j.bond_count(), 4, "{:?}", j.bonds);
        for (_, b) in &j.bonds {
            assert!((b.area - 1.0).abs() < 1e-9, "{b:?}");
        }
        let sets: Vec<u32> = j.bonds.iter().map(|(_, b)| b.set).collect();
        assert_eq!(sets.iter().filter(|&&s| s == 0).count(), 2);
        let (a, b) = j.bonds[0].0;
        let joint = j
            .joint(a, b, &blocks[a as usize], &blocks[b as usize])
            .unwrap();
        assert!(joint.bonded && joint.cohesion > 0.0);
    }
}
