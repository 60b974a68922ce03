//! `[[block]]`: each block's own fields (name, shape, size, motion, contact, elasticity), and
//! the blocks that must not start inside each other.

use super::checker::{Checker, shape_summary};
use crate::geometry::Polyhedron;
use crate::math::Point;
use crate::scene::error::Seg;
use crate::scene::schema::{BlockKind, BlockSpec, MotionSpec, Scene};

/// Smallest block, as a fraction of the domain diagonal (cube root of the volume).
const MIN_BLOCK_OF_DOMAIN: f64 = 1e-6;
/// Overlap of two moving blocks at the start, as a fraction of the smaller one's radius, above
/// which their interiors are taken to overlap (rounding in the corner coordinates stays below).
const MAX_START_OVERLAP: f64 = 1e-6;
/// Fastest prescribed block motion [m/s]; a landslide is tens of m/s.
const MAX_SPEED: f64 = 1e3;

/// Each `[[block]]` on its own; `polys` are their polyhedra (`None` where the shape is not one).
pub(super) fn each(c: &mut Checker, s: &Scene, polys: &[Option<Polyhedron>]) {
    let d = &s.domain;
    let diag = (0..3)
        .map(|k| (d.max[k] - d.min[k]).powi(2))
        .sum::<f64>()
        .sqrt();
    let mut names = std::collections::HashSet::new();
    for (i, b) in s.blocks.iter().enumerate() {
        c.key("block", |c| {
            c.at(Seg::Index(i), |c| {
                c.label("name", &b.name, "block");
                if !names.insert(b.name.as_str()) {
                    c.fail(
                        "name",
                        &b.name,
                        "is used by an earlier block (blocks.csv and summary.json key blocks by name)",
                        "give every block a unique name",
                    );
                }
                c.shape(&b.shape, d, b.kind != BlockKind::Fixed);
                if let Some(p) = polys[i].as_ref() {
                    size(c, s, b, p, diag);
                }
                if b.kind == BlockKind::Free {
                    c.positive(
                        "density",
                        b.density,
                        "give the rock density in kg/m³, e.g. density = 2500.0",
                    );
                }
                c.finite3("velocity", b.velocity);
                c.finite3("angular_velocity", b.angular_velocity);
                motion(c, b);
                if let Some(phi) = b.friction_angle
                    && !(0.0..90.0).contains(&phi)
                {
                    c.fail(
                        "friction_angle",
                        phi,
                        "must be in [0, 90) degrees",
                        "e.g. friction_angle = 30.0",
                    );
                }
                if let Some(coh) = b.cohesion
                    && (coh.is_nan() || coh < 0.0)
                {
                    c.fail("cohesion", coh, "must be >= 0", "give cohesion in Pa");
                }
                elastic(c, b);
            })
        });
    }
}

/// A block too small to simulate: below 1e-6 of the domain diagonal, or (a moving block, in
/// a scene with water) below a quarter of the particle spacing.
fn size(c: &mut Checker, s: &Scene, b: &BlockSpec, p: &Polyhedron, diag: f64) {
    let size = p.volume.cbrt();
    let dx = s.fluid.as_ref().map_or(0.0, |f| f.dx);
    let floor = if b.kind == BlockKind::Fixed {
        MIN_BLOCK_OF_DOMAIN * diag
    } else {
        (MIN_BLOCK_OF_DOMAIN * diag).max(dx / 4.0)
    };
    if size < floor {
        c.key("shape", |c| {
            c.fail(
                "",
                shape_summary(&b.shape),
                &format!(
                    "block '{}' is {size:.3e} m across (the cube root of its volume), \
                     below {floor:.3e} m ({}): too small to simulate",
                    b.name,
                    if floor > MIN_BLOCK_OF_DOMAIN * diag {
                        "a quarter of fluid.dx: no particle would see it"
                    } else {
                        "1e-6 of the domain diagonal"
                    }
                ),
                "make the block larger, or remove it",
            )
        });
    }
}

/// `motion`: a kinematic block's, finite and not faster than [`MAX_SPEED`]; no other kind has one.
fn motion(c: &mut Checker, b: &BlockSpec) {
    match (&b.kind, &b.motion) {
        (BlockKind::Kinematic, None) => c.fail(
            "motion",
            "nothing",
            "a kinematic block needs a prescribed motion",
            "add motion = { type = \"sine\", amplitude = [0.1, 0, 0], period = 2.0 }",
        ),
        (BlockKind::Kinematic, Some(MotionSpec::Linear { velocity })) => c.key("motion", |c| {
            c.finite3("velocity", *velocity);
            if velocity.iter().any(|v| v.abs() > MAX_SPEED) {
                c.fail(
                    "velocity",
                    velocity,
                    &format!("is faster than {MAX_SPEED} m/s"),
                    "give the velocity in m/s",
                );
            }
        }),
        (
            BlockKind::Kinematic,
            Some(MotionSpec::Sine {
                amplitude,
                period,
                phase,
                ramp,
            }),
        ) => {
            c.key("motion", |c| {
                c.finite3("amplitude", *amplitude);
                if !phase.is_finite() {
                    c.fail("phase", *phase, "must be finite", "give the phase in radians, or 0");
                }
                if ramp.is_infinite() {
                    c.fail("ramp", *ramp, "must be finite", "give the ramp-in time in seconds, or 0");
                }
                c.positive("period", *period, "give the period in seconds");
                // The peak speed of A·sin(2πt/T) is 2π|A|/T.
                let a = amplitude.iter().map(|x| x * x).sum::<f64>().sqrt();
                let peak = 2.0 * std::f64::consts::PI * a / period;
                if a.is_finite() && *period > 0.0 && peak > MAX_SPEED {
                    c.fail(
                        "period",
                        *period,
                        &format!(
                            "gives a peak speed 2π·|amplitude|/period = {peak:.3e} m/s, faster than {MAX_SPEED} m/s"
                        ),
                        &format!(
                            "lengthen the period to at least {:.3e} s or shrink the amplitude",
                            2.0 * std::f64::consts::PI * a / MAX_SPEED
                        ),
                    );
                }
                if ramp.is_nan() || *ramp < 0.0 {
                    c.fail(
                        "ramp",
                        *ramp,
                        "must be >= 0",
                        "give the ramp-in time in seconds, or 0",
                    );
                }
            })
        }
        (BlockKind::Fixed | BlockKind::Free, Some(_)) => c.fail(
            "motion",
            format!("{:?}", b.kind).to_lowercase(),
            "only kinematic blocks follow a prescribed motion",
            "set kind = \"kinematic\" or remove motion",
        ),
        _ => {}
    }
}

/// `elastic`: a free block's Young's modulus and Poisson's ratio.
fn elastic(c: &mut Checker, b: &BlockSpec) {
    if let Some(el) = &b.elastic {
        if b.kind != BlockKind::Free {
            c.fail(
                "elastic",
                format!("{:?}", b.kind).to_lowercase(),
                "only free blocks deform (fixed and kinematic blocks have no unknowns)",
                "remove elastic, or set kind = \"free\"",
            );
        }
        c.key("elastic", |c| {
            c.positive(
                "young_modulus",
                el.young_modulus,
                "give Young's modulus in Pa, e.g. young_modulus = 1e10 for rock",
            );
            if !(0.0..0.5).contains(&el.poisson_ratio) {
                c.fail(
                    "poisson_ratio",
                    el.poisson_ratio,
                    "must be in [0, 0.5) (0.5 is incompressible: no finite bulk modulus)",
                    "e.g. poisson_ratio = 0.25",
                );
            }
        });
    }
}

/// Pairs of blocks whose interiors overlap at the start.
pub(super) fn start_overlaps(c: &mut Checker, s: &Scene, polys: &[Option<Polyhedron>]) {
    // Moving blocks must not start inside each other: the contact springs act on penetrations
    // of the order of allowed_penetration, and two blocks sharing their interiors move as one.
    // Nor may a kinematic block start inside a fixed one: the solid node computes no contact
    // between two blocks that are not free (their motions are given), so the prescribed motion
    // would carry it through the fixed block, and the water between them, unopposed.
    let boxes: Vec<Option<(Point, Point)>> = polys
        .iter()
        .map(|p| p.as_ref().map(Polyhedron::world_aabb))
        .collect();
    for (i, j) in x_overlapping_pairs(&boxes) {
        let (bi, bj) = (&s.blocks[i], &s.blocks[j]);
        let fixed = [bi.kind, bj.kind]
            .iter()
            .filter(|k| **k == BlockKind::Fixed)
            .count();
        let kinematic = [bi.kind, bj.kind].contains(&BlockKind::Kinematic);
        if fixed == 2 || (fixed == 1 && !kinematic) {
            continue;
        }
        let (Some(pi), Some(pj)) = (&polys[i], &polys[j]) else {
            continue;
        };
        let (Some((li, hi)), Some((lj, hj))) = (boxes[i], boxes[j]) else {
            continue;
        };
        if (0..3).any(|k| li[k] >= hj[k] || lj[k] >= hi[k]) {
            continue; // apart or touching: the bounding boxes already tell
        }
        let depth = crate::geometry::overlap_depth(pi, pj);
        let size = pi.radius.min(pj.radius);
        if depth > MAX_START_OVERLAP * size {
            c.key("block", |c| {
                    c.at(Seg::Index(i), |c| {
                        c.fail(
                            "shape",
                            shape_summary(&bi.shape),
                            &if fixed == 1 {
                                format!(
                                    "the interior of block '{}' ({}) overlaps that of block '{}' ({}, block[{j}]) by {depth:.3e} m: \
                                     a kinematic block feels no contact with a fixed one and its prescribed motion would run through it",
                                    bi.name,
                                    kind_name(bi.kind),
                                    bj.name,
                                    kind_name(bj.kind)
                                )
                            } else {
                                format!(
                                    "the interior of block '{}' overlaps that of block '{}' (block[{j}]) by {depth:.3e} m: \
                                     moving blocks that start inside each other feel no contact and move as one",
                                    bi.name, bj.name
                                )
                            },
                            "move the blocks apart (touching faces are fine)",
                        )
                    })
                });
        }
    }
}

/// The pairs (i, j), j < i, of bounding boxes whose x ranges overlap, in increasing (i, j):
/// a sweep along x over the boxes sorted by their lower x, so that the thousands of blocks cut
/// from a slide are not compared pair by pair (O(n²) took seconds at 8 000 blocks).
fn x_overlapping_pairs(boxes: &[Option<(Point, Point)>]) -> Vec<(usize, usize)> {
    let mut order: Vec<(usize, Point, Point)> = boxes
        .iter()
        .enumerate()
        .filter_map(|(i, b)| b.map(|(lo, hi)| (i, lo, hi)))
        .collect();
    order.sort_by(|a, b| a.1.x.total_cmp(&b.1.x));
    let mut pairs = Vec::new();
    for (k, &(a, _, ha)) in order.iter().enumerate() {
        for &(b, lb, _) in &order[k + 1..] {
            if lb.x >= ha.x {
                break; // this box and every later one start right of box a
            }
            pairs.push((a.max(b), a.min(b)));
        }
    }
    pairs.sort_unstable();
    pairs
}

/// A block kind as the scene writes it.
fn kind_name(k: BlockKind) -> &'static str {
    match k {
        BlockKind::Fixed => "fixed",
        BlockKind::Kinematic => "kinematic",
        BlockKind::Free => "free",
    }
}
