//! `[[block]]`: each block's own fields (name, shape, size, motion, contact, elasticity), and
//! the blocks that must not start inside each other.

use super::checker::{Checker, Reach, shape_summary};
use crate::geometry::Polyhedron;
use crate::math::{Point, Vector, readable};
use crate::scene::error::Seg;
use crate::scene::schema::{BlockKind, BlockSpec, MotionSpec, Scene};

/// Smallest block, as a fraction of the domain diagonal (cube root of the volume).
const MIN_BLOCK_OF_DOMAIN: f64 = 1e-6;
/// Overlap of two moving blocks at the start, as a fraction of the smaller one's radius, above
/// which their interiors are taken to overlap (rounding in the corner coordinates stays below).
const MAX_START_OVERLAP: f64 = 1e-6;
/// Fastest prescribed block motion [m/s]; a landslide is tens of m/s.
const MAX_SPEED: f64 = 1e3;
/// Densest block a scene may give [kg/m³]: four times osmium's 22 590, the densest element. A
/// density past it is a typo (an exponent, a unit slip); at 1e300 the block's mass and inertia
/// overflow and the solid node's first step is NaN.
pub(crate) const MAX_DENSITY: f64 = 1e5;

/// Each `[[block]]` on its own; `polys` are their polyhedra (`None` where the shape is not one).
pub(super) fn each(c: &mut Checker, s: &Scene, polys: &[Option<Polyhedron>]) {
    let d = &s.domain;
    let diag = (0..3)
        .map(|k| (d.max[k] - d.min[k]).powi(2))
        .sum::<f64>()
        .sqrt();
    let mut names = std::collections::HashSet::new();
    // Blocks cut from a slide reaching outside the domain: one error per slide, on its region
    // (a region past a domain face gave one error per cut block, each telling the user to
    // raise min_block_volume). slide → (cut blocks outside, their span).
    let mut cut_outside = std::collections::BTreeMap::<usize, (usize, Point, Point)>::new();
    for (i, b) in s.blocks.iter().enumerate() {
        if let (Some(m), Some(p)) = (b.slide, polys[i].as_ref()) {
            let (lo, hi) = p.world_aabb();
            if (0..3).any(|k| lo[k] < d.min[k] || hi[k] > d.max[k]) {
                let e = cut_outside.entry(m.slide).or_insert((0, lo, hi));
                *e = (e.0 + 1, e.1.inf(&lo), e.2.sup(&hi));
            }
        }
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
                c.shape(
                    &b.shape,
                    d,
                    match (b.kind, b.slide) {
                        (_, Some(_)) => Reach::Unchecked,
                        (BlockKind::Fixed, None) => Reach::Fixed,
                        _ => Reach::Inside,
                    },
                );
                if let Some(p) = polys[i].as_ref() {
                    size(c, s, b, p, diag);
                }
                if b.kind == BlockKind::Free {
                    c.positive(
                        "density",
                        b.density,
                        "give the rock density in kg/m³, e.g. density = 2500.0",
                    );
                    if b.slide.is_none() {
                        density_plausible(c, b.density);
                    }
                }
                c.finite3("velocity", b.velocity);
                c.finite3("angular_velocity", b.angular_velocity);
                initial_velocity(c, b, polys[i].as_ref());
                motion(c, b);
                if let Some(p) = polys[i].as_ref() {
                    motion_path(c, s, b, p, polys);
                }
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
    for (m, (blocks, lo, hi)) in cut_outside {
        region_fails(
            c,
            s,
            m,
            &format!(
                "reaches outside the domain: {blocks} of the blocks cut from it do, together \
                 spanning [{:.4}, {:.4}, {:.4}] to [{:.4}, {:.4}, {:.4}] against the domain's \
                 {:?} to {:?}",
                readable(lo[0]),
                readable(lo[1]),
                readable(lo[2]),
                readable(hi[0]),
                readable(hi[1]),
                readable(hi[2]),
                d.min,
                d.max
            ),
            "move or shrink the region to inside [domain], or enlarge [domain]",
        );
    }
}

/// A problem of the blocks cut from slide `m`, told once on the slide's region.
fn region_fails(c: &mut Checker, s: &Scene, m: usize, problem: &str, fix: &str) {
    c.key("slide", |c| {
        c.at(Seg::Index(m), |c| {
            c.fail("region", shape_summary(&s.slides[m].region), problem, fix)
        })
    });
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

/// A free block's `density` past [`MAX_DENSITY`] (its being positive is checked with it).
fn density_plausible(c: &mut Checker, density: f64) {
    if density.is_finite() && density > MAX_DENSITY {
        c.fail(
            "density",
            density,
            &format!(
                "is denser than {MAX_DENSITY:e} kg/m³, four times the densest element (osmium): \
                 a typo, which overflows the block's mass and inertia"
            ),
            "give the density in kg/m³, e.g. density = 2500.0 for rock",
        );
    }
}

/// `velocity` and `angular_velocity` at the start. Only a free block has them: the solid node
/// sets a fixed block's to zero and moves a kinematic block by its `motion`, so on those kinds
/// they are silently ignored. A free block's are bounded as a kinematic motion is, by
/// [`MAX_SPEED`] at its centroid and at its corners (|ω| × its radius): faster, it leaves the
/// domain within the first steps (velocity = [1e9, 0, 0] did at step 0, a spin of 1e9 rad/s
/// at step 21), with an error that names the solid node rather than the field.
fn initial_velocity(c: &mut Checker, b: &BlockSpec, p: Option<&Polyhedron>) {
    let finite = b
        .velocity
        .iter()
        .chain(&b.angular_velocity)
        .all(|v| v.is_finite());
    if !finite {
        return; // named by finite3
    }
    let norm = |v: &[f64; 3]| v.iter().map(|x| x * x).sum::<f64>().sqrt();
    if b.kind != BlockKind::Free {
        let (moves, fix) = match b.kind {
            BlockKind::Fixed => (
                "never moves",
                "remove it, or set kind = \"free\" for a block launched with it",
            ),
            _ => (
                "moves only by its motion",
                "remove it; a constant velocity is motion = { type = \"linear\", velocity = [...] }",
            ),
        };
        for (field, v) in [
            ("velocity", b.velocity),
            ("angular_velocity", b.angular_velocity),
        ] {
            if v.iter().any(|x| *x != 0.0) {
                c.fail(
                    field,
                    v,
                    &format!(
                        "is ignored: a {} block {moves} (only a free block starts with a velocity)",
                        kind_name(b.kind)
                    ),
                    fix,
                );
            }
        }
        return;
    }
    let speed = norm(&b.velocity);
    if speed > MAX_SPEED {
        c.fail(
            "velocity",
            b.velocity,
            &format!(
                "is {speed:.3e} m/s, faster than {MAX_SPEED} m/s (a landslide is tens of m/s): \
                 the block would leave the domain within the first steps"
            ),
            "give the initial velocity in m/s",
        );
    }
    if let Some(p) = p {
        let rim = norm(&b.angular_velocity) * p.radius;
        if rim > MAX_SPEED {
            c.fail(
                "angular_velocity",
                b.angular_velocity,
                &format!(
                    "spins the block's corners at {rim:.3e} m/s (|ω| × its radius, {:.3e} m), \
                     faster than {MAX_SPEED} m/s",
                    p.radius
                ),
                "give the angular velocity in rad/s (not rpm or degrees per second)",
            );
        }
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

/// Where a kinematic block's prescribed motion takes it over the run, `[0, time.end]`: clear of
/// every fixed block. Nothing stops a kinematic block there: the solid node computes no contact
/// between two blocks that are not free, so a paddle driven at 1 m/s into the far wall of the
/// default scene ran through it (and the water between) to the end without a word. Only its
/// start is checked by [`start_overlaps`]; this checks its path, the start swept along the
/// motion's line. Leaving the domain is not refused: a gate lifted out of the water does, and
/// no water follows it there.
fn motion_path(
    c: &mut Checker,
    s: &Scene,
    b: &BlockSpec,
    p: &Polyhedron,
    polys: &[Option<Polyhedron>],
) {
    let (Some(m), BlockKind::Kinematic) = (&b.motion, b.kind) else {
        return;
    };
    let end = s.time.end;
    if !(end.is_finite() && end > 0.0) {
        return; // named by [time]
    }
    let Some((u, f_lo, f_hi)) = path_span(m, end) else {
        return; // the motion's own values are named by `motion`
    };
    let field = match m {
        MotionSpec::Linear { .. } => "velocity",
        MotionSpec::Sine { .. } => "amplitude",
    };
    let (d0, d1) = (u * f_lo, u * f_hi);
    for (j, q) in polys.iter().enumerate() {
        let Some(q) = q.as_ref().filter(|_| s.blocks[j].kind == BlockKind::Fixed) else {
            continue;
        };
        let tol = MAX_START_OVERLAP * p.radius.min(q.radius);
        if crate::geometry::overlap_depth(p, q) > tol {
            continue; // already inside it at the start: named by [`start_overlaps`]
        }
        let depth = crate::geometry::swept_overlap_depth(p, d0, d1, q);
        if depth > tol {
            c.key("motion", |c| {
                c.fail(
                    field,
                    [u.x, u.y, u.z],
                    &format!(
                        "drives block '{}' {depth:.3e} m into fixed block '{}' (block[{j}]) before \
                         time.end = {} s: a kinematic block feels no contact with a fixed one, so \
                         it would run through the block and the water between them",
                        b.name,
                        s.blocks[j].name,
                        readable(end)
                    ),
                    "shorten the motion or move the block so that its path clears the fixed blocks \
                     (sliding along a face is fine)",
                )
            });
            return;
        }
    }
}

/// The displacement of a motion over `[0, end]` as `u·f(t)` along one direction `u`, and the
/// least and greatest `f`; `None` when the motion's values are not usable (named elsewhere).
/// A linear motion is `velocity·t`; a sine's is `amplitude·s(t)·(sin(ωt + φ) − sin φ)`, whose
/// extremes after the ramp are the ends and the crests and troughs between them, and during
/// the ramp are sampled (64 samples a period).
fn path_span(m: &MotionSpec, end: f64) -> Option<(Vector, f64, f64)> {
    match *m {
        MotionSpec::Linear { velocity } => velocity
            .iter()
            .all(|v| v.is_finite())
            .then(|| (Vector::from(velocity), 0.0, end)),
        MotionSpec::Sine {
            amplitude,
            period,
            phase,
            ramp,
        } => {
            let usable = amplitude.iter().all(|a| a.is_finite())
                && period.is_finite()
                && period > 0.0
                && phase.is_finite()
                && ramp.is_finite()
                && ramp >= 0.0;
            let u = Vector::from(amplitude);
            let u2 = u.norm_squared();
            if !usable || u2 == 0.0 {
                return None;
            }
            let (mut lo, mut hi) = (0.0_f64, 0.0_f64);
            let mut take = |f: f64| {
                lo = lo.min(f);
                hi = hi.max(f);
            };
            let sin_phase = phase.sin();
            let ramp_end = ramp.min(end);
            if ramp_end > 0.0 {
                let periods = ramp_end / period;
                if periods > 1000.0 {
                    // The ramp reaches its full stroke over many periods: the sine's bounds.
                    take(-1.0 - sin_phase);
                    take(1.0 - sin_phase);
                } else {
                    let n = ((periods * 64.0).ceil() as usize).max(256);
                    for k in 0..=n {
                        let t = ramp_end * k as f64 / n as f64;
                        take(m.displacement(t).dot(&u) / u2);
                    }
                }
            }
            if end > ramp {
                let w = std::f64::consts::TAU / period;
                let g = |t: f64| (w * t + phase).sin() - sin_phase;
                let (t0, t1) = (ramp, end);
                take(g(t0));
                take(g(t1));
                // Crests and troughs at ωt + φ = π/2 + kπ.
                let pi = std::f64::consts::PI;
                let k0 = ((w * t0 + phase - pi / 2.0) / pi).ceil();
                let k1 = ((w * t1 + phase - pi / 2.0) / pi).floor();
                let mut k = k0;
                while k <= k1 && k <= k0 + 1.0 {
                    let crest = if k.rem_euclid(2.0) == 0.0 { 1.0 } else { -1.0 };
                    take(crest - sin_phase);
                    k += 1.0;
                }
            }
            Some((u, lo, hi))
        }
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
    // would carry it through the fixed block, and the water between them, unopposed. Nor a
    // free block inside a fixed one: the contact springs meet a penetration far past the
    // allowed one and throw the block out at the first steps (4 cm into a side wall, the
    // fluid node stopped at step 4 on the density bound, naming neither block).
    let boxes: Vec<Option<(Point, Point)>> = polys
        .iter()
        .map(|p| p.as_ref().map(Polyhedron::world_aabb))
        .collect();
    // Blocks cut from a slide inside a fixed block: one error per slide and fixed block, on the
    // slide's region (a region reaching into a wall gave one error per cut block, each telling
    // the user to raise min_block_volume). (slide, fixed block) → (cut blocks, deepest).
    let mut cut_into = std::collections::BTreeMap::<(usize, usize), (usize, f64)>::new();
    for (i, j) in x_overlapping_pairs(&boxes) {
        let (bi, bj) = (&s.blocks[i], &s.blocks[j]);
        let fixed = [bi.kind, bj.kind]
            .iter()
            .filter(|k| **k == BlockKind::Fixed)
            .count();
        let kinematic = [bi.kind, bj.kind].contains(&BlockKind::Kinematic);
        if fixed == 2 {
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
        if depth <= MAX_START_OVERLAP * size {
            continue;
        }
        let cut = match (bi.slide, bj.slide) {
            (Some(m), None) if bj.kind == BlockKind::Fixed => Some((m.slide, j)),
            (None, Some(m)) if bi.kind == BlockKind::Fixed => Some((m.slide, i)),
            _ => None,
        };
        if let Some(key) = cut {
            let e = cut_into.entry(key).or_insert((0, 0.0));
            *e = (e.0 + 1, e.1.max(depth));
            continue;
        }
        c.key("block", |c| {
            c.at(Seg::Index(i), |c| {
                c.fail(
                    "shape",
                    shape_summary(&bi.shape),
                    &if fixed == 1 && !kinematic {
                        format!(
                            "the interior of block '{}' ({}) overlaps that of block '{}' ({}, block[{j}]) by {depth:.3e} m: \
                             the contact springs would throw the free block out at the first steps",
                            bi.name,
                            kind_name(bi.kind),
                            bj.name,
                            kind_name(bj.kind)
                        )
                    } else if fixed == 1 {
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
    for ((m, j), (blocks, depth)) in cut_into {
        region_fails(
            c,
            s,
            m,
            &format!(
                "reaches into fixed block '{}' (block[{j}]): {blocks} of the blocks cut from \
                 it start inside that block, up to {depth:.3e} m deep, and the contact springs \
                 would throw them out at the first steps",
                s.blocks[j].name
            ),
            &format!(
                "move or shrink the region so that it clears '{}' (touching its faces is fine)",
                s.blocks[j].name
            ),
        );
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
