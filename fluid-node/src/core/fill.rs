//! Filling the scene's water volumes with particles on a cubic lattice of spacing dx.
//!
//! The lattice is anchored half a spacing inside the lower corner of all water volumes, so a box
//! of water against walls gets particles dx/2 from each wall and every particle stands for the
//! cube dx³ around it (mass ρ0·dx³). Overlapping volumes share the lattice, so they never double
//! a particle.
//!
//! Which lattice points next to a block stay dry depends on how the blocks hold the water
//! (`[fluid] walls`). With boundary particles (the default) only the points inside a block: the
//! blocks' boundary particles take exactly those ([`crate::boundary::walls::WallParticles::sample`]), so
//! water and walls make one unbroken lattice along any face, on the lattice or off it. (Until
//! 27 Nov 2026 points closer than dx/2 were left dry as well: right for a face on the lattice's
//! half-spacing, where no point lies that close, but along a face off it, such as the default
//! scene's 25° slope, a band dx/2 wide with neither water nor walls, 17 litres there, into which
//! the water slumped at the start; docs/VALIDATION.md.) With the Eq. 22 penalty alone, which
//! holds the water half a spacing off a face, points closer than dx/2 stay dry too.

use shared::geometry::Polyhedron;
use shared::math::{Point, Real, Vector};
use shared::scene::{FluidSpec, Walls};
use std::collections::HashMap;

/// The particles of the initial state.
#[derive(Debug, Clone, Default)]
pub struct Fill {
    pub positions: Vec<Vector>,
    /// Depth below the local free surface [m] for particles of hydrostatic volumes, else 0.
    pub depth: Vec<Real>,
    /// The lattice anchor: lattice points are `anchor + k·dx`.
    pub anchor: Vector,
}

impl Fill {
    /// Height of the deepest water column [m], from the lowest to the highest particle plus dx.
    pub fn max_depth(&self, dx: Real) -> Real {
        let (lo, hi) = self
            .positions
            .iter()
            .fold((Real::INFINITY, Real::NEG_INFINITY), |(lo, hi), p| {
                (lo.min(p.z), hi.max(p.z))
            });
        if lo > hi { 0.0 } else { hi - lo + dx }
    }
}

/// True when the world point `p` is inside `poly` (at its scene pose) or within `clearance` of it.
/// How close to a wall (a block's face or the terrain's bed) a lattice point may be and still
/// get water (module doc): with boundary particles any point outside (0, the points they take
/// are those inside); with the Eq. 22 penalty alone, which holds the water half a spacing off
/// a wall, dx/2 (less a hair, so a point exactly there on a face on the lattice is kept).
pub fn dry_clearance(walls: Walls, dx: Real) -> Real {
    match walls {
        Walls::Particles => 0.0,
        Walls::Penalty => 0.5 * dx - 1e-6 * dx,
    }
}

pub fn near_or_inside(poly: &Polyhedron, p: &Vector, clearance: Real) -> bool {
    let local = Point::from(p - poly.centroid.coords);
    poly.plane_distance(&local).0 < clearance
}

/// Describes how a volume's extent misses the lattice (None when every extent is a whole number
/// of spacings, within 1 % of dx).
pub fn off_lattice(volume: &Polyhedron, dx: Real) -> Option<String> {
    let (a, b) = volume.world_aabb();
    let axes = ["x", "y", "z"];
    let misses: Vec<String> = (0..3)
        .filter_map(|k| {
            let extent = b[k] - a[k];
            let layers = extent / dx;
            ((layers - layers.round()).abs() > 0.01).then(|| {
                format!(
                    "{} extent {extent} m is {layers:.2}·dx, filled as {:.0} layers ({} m)",
                    axes[k],
                    layers.round(),
                    layers.round() * dx
                )
            })
        })
        .collect();
    (!misses.is_empty()).then(|| {
        format!(
            "{}; choose dx dividing the volume's size for the depth and mass the scene asks",
            misses.join("; ")
        )
    })
}

/// Fills the water volumes of `fluid` with particles, leaving out every block of `blocks`.
pub fn fill_water(fluid: &FluidSpec, blocks: &[Polyhedron]) -> Result<Fill, String> {
    fill_water_with(fluid, blocks, &|_| false)
}

/// [`fill_water`], also leaving dry the lattice points where `dry` holds (those the terrain's
/// boundary particles take, or with Eq. 22 alone also within dx/2 above it: system/setup.rs).
pub fn fill_water_with(
    fluid: &FluidSpec,
    blocks: &[Polyhedron],
    dry: &dyn Fn(&Vector) -> bool,
) -> Result<Fill, String> {
    let dx = fluid.dx;
    let volumes: Vec<Polyhedron> = fluid
        .water
        .iter()
        .enumerate()
        .map(|(i, w)| {
            Polyhedron::from_shape(&w.shape).map_err(|e| format!("fluid.water[{i}]: {e}"))
        })
        .collect::<Result<_, _>>()?;
    if volumes.is_empty() {
        return Ok(Fill::default());
    }
    // A lattice holds whole layers: a volume whose size is not a multiple of dx is filled to
    // the nearest layer, which changes the water depth and mass the scene asked for.
    for (i, v) in volumes.iter().enumerate() {
        if let Some(w) = off_lattice(v, dx) {
            eprintln!("fluid-node: warning: fluid.water[{i}]: {w}");
        }
    }
    let mut lo = Vector::repeat(Real::INFINITY);
    let mut hi = Vector::repeat(Real::NEG_INFINITY);
    for v in &volumes {
        let (a, b) = v.world_aabb();
        lo = lo.inf(&a.coords);
        hi = hi.sup(&b.coords);
    }
    let anchor = lo + Vector::repeat(0.5 * dx);
    let n: Vec<usize> = (0..3)
        .map(|k| (((hi[k] - lo[k]) / dx).round() as usize).max(1))
        .collect();
    let tol = 1e-6 * dx;
    // Points this close to a block stay dry; with boundary particles exactly those inside, as
    // `WallParticles::sample` takes them (plane distance < 0 there, > 0 depth here).
    let clearance = dry_clearance(fluid.walls, dx);

    let mut positions = Vec::new();
    let mut hydro = Vec::new();
    for kz in 0..n[2] {
        for ky in 0..n[1] {
            for kx in 0..n[0] {
                let p = anchor + Vector::new(kx as Real, ky as Real, kz as Real) * dx;
                let Some(vol) = volumes.iter().position(|v| near_or_inside(v, &p, tol)) else {
                    continue;
                };
                if blocks.iter().any(|b| near_or_inside(b, &p, clearance)) || dry(&p) {
                    continue;
                }
                positions.push(p);
                hydro.push(fluid.water[vol].hydrostatic);
            }
        }
    }
    // The free surface of each lattice column is half a spacing above its highest particle.
    let column = |p: &Vector| {
        (
            ((p.x - anchor.x) / dx).round() as i64,
            ((p.y - anchor.y) / dx).round() as i64,
        )
    };
    let mut top: HashMap<(i64, i64), Real> = HashMap::new();
    for p in &positions {
        let t = top.entry(column(p)).or_insert(Real::NEG_INFINITY);
        *t = t.max(p.z + 0.5 * dx);
    }
    let depth = positions
        .iter()
        .zip(&hydro)
        .map(|(p, &h)| if h { top[&column(p)] - p.z } else { 0.0 })
        .collect();
    if let Some(shift) = fluid.row_shift {
        shift_rows(&mut positions, shift, fluid.row_draw, &anchor, dx);
    }
    Ok(Fill {
        positions,
        depth,
        anchor,
    })
}

/// Moves each row of the lattice along the one axis `shift` names (`[fluid] row_shift`, checked
/// to one non-zero fraction a ≤ 1/2) by a·dx·(2 frac((φ + √7 d) j + (√2 + π d) k) − 1), j and
/// k the row's indices along the other two axes (φ = (√5 − 1)/2), d the draw (`[fluid]
/// row_draw`): the rows keep their spacing and a row's neighbours are shifted by unrelated
/// amounts (Weyl's sequence fills [−a, a] evenly for any multipliers independent of each other
/// and of 1 over the rationals), so the rows no longer reach a wall across the flow in step;
/// each draw's multipliers order the rows anew (an offset would only rotate draw 0's order).
/// The depth of each particle (the hydrostatic start) is the lattice column's, computed
/// before.
fn shift_rows(positions: &mut [Vector], shift: [Real; 3], draw: u32, anchor: &Vector, dx: Real) {
    let Some(axis) = (0..3).find(|&k| shift[k] != 0.0) else {
        return;
    };
    let (a, b) = ((axis + 1) % 3, (axis + 2) % 3);
    let d = Real::from(draw);
    // d = 0 adds exact zeros: draw 0 is the sequence of before draws existed, bit for bit.
    let alpha = 0.5 * (5.0f64.sqrt() - 1.0) + d * 7.0f64.sqrt();
    let beta = std::f64::consts::SQRT_2 + d * std::f64::consts::PI;
    for p in positions.iter_mut() {
        let index = |k: usize| ((p[k] - anchor[k]) / dx).round();
        let f = (index(a) * alpha + index(b) * beta).rem_euclid(1.0);
        p[axis] += shift[axis] * dx * (2.0 * f - 1.0);
    }
}

/// Lattice index of a lattice point.
pub fn lattice_key(p: &Vector, anchor: &Vector, dx: Real) -> [i64; 3] {
    let k = (p - anchor) / dx;
    [k.z.round() as i64, k.y.round() as i64, k.x.round() as i64]
}

#[cfg(test)]
mod tests {
    use super::*;
    use shared::scene::{ShapeSpec, WaterSpec};

    fn spec(dx: f64, water: Vec<ShapeSpec>) -> FluidSpec {
        let text = format!("dx = {dx}\n");
        let mut f: FluidSpec = toml::from_str(&text).unwrap();
        f.water = water
            .into_iter()
            .map(|shape| WaterSpec {
                shape,
                hydrostatic: true,
            })
            .collect();
        f
    }

    #[test]
    fn volumes_off_the_lattice_are_named() {
        let b = Polyhedron::from_shape(&ShapeSpec::Box {
            min: [0.0; 3],
            max: [1.0, 0.8, 0.5],
        })
        .unwrap();
        assert!(off_lattice(&b, 0.1).is_none());
        let w = off_lattice(&b, 0.04).expect("0.5 m is 12.5 spacings of 0.04 m");
        assert!(w.contains("z extent") && w.contains("12.50"), "{w}");
    }

    #[test]
    fn box_fill_count_mass_and_depth() {
        let f = spec(
            0.1,
            vec![ShapeSpec::Box {
                min: [0.0; 3],
                max: [1.0, 0.5, 0.3],
            }],
        );
        let fill = fill_water(&f, &[]).unwrap();
        assert_eq!(fill.positions.len(), 10 * 5 * 3);
        // Total particle volume equals the water volume.
        let vol = fill.positions.len() as f64 * 0.1f64.powi(3);
        assert!((vol - 0.15).abs() < 1e-12);
        for (p, d) in fill.positions.iter().zip(&fill.depth) {
            assert!((p.z + d - 0.3).abs() < 1e-12, "surface at {}", p.z + d);
        }
        assert!((fill.max_depth(0.1) - 0.3).abs() < 1e-12);
    }

    /// `row_shift = [0.25, 0, 0]`: every particle moves along x alone, by the same amount in a
    /// row along x (its spacing kept) and within ±dx/4; rows differ (no two of the 15 rows of
    /// this box by less than 1 % of dx); the depths stay the lattice's; the same fill twice.
    #[test]
    fn shifted_rows_keep_their_spacing_and_part_from_their_neighbours() {
        let dx = 0.1;
        let water = vec![ShapeSpec::Box {
            min: [0.0; 3],
            max: [1.0, 0.5, 0.3],
        }];
        let plain = fill_water(&spec(dx, water.clone()), &[]).unwrap();
        let mut f = spec(dx, water);
        f.row_shift = Some([0.25, 0.0, 0.0]);
        let shifted = fill_water(&f, &[]).unwrap();
        assert_eq!(shifted.positions.len(), plain.positions.len());
        assert_eq!(shifted.depth, plain.depth);
        let mut rows: HashMap<(i64, i64), Vec<Real>> = HashMap::new();
        for (p, q) in shifted.positions.iter().zip(&plain.positions) {
            assert!(p.y == q.y && p.z == q.z, "{p} from {q}");
            let d = p.x - q.x;
            assert!(d.abs() <= 0.25 * dx + 1e-12, "{d}");
            let key = lattice_key(q, &plain.anchor, dx);
            rows.entry((key[0], key[1])).or_default().push(d);
        }
        assert_eq!(rows.len(), 15);
        let mut each: Vec<Real> = rows
            .values()
            .map(|d| {
                assert!(d.iter().all(|x| (x - d[0]).abs() < 1e-12), "{d:?}");
                d[0]
            })
            .collect();
        each.sort_by(|a, b| a.total_cmp(b));
        assert!(each.windows(2).all(|w| w[1] - w[0] > 0.01 * dx), "{each:?}");
        let again = fill_water(&f, &[]).unwrap();
        assert_eq!(again.positions, shifted.positions);
    }

    /// `row_draw = 1`: another start with the same bound (±dx/4) and spread (the 15 rows'
    /// shifts apart by more than 1 % of dx), most rows moved from draw 0's place, and most
    /// rows' neighbours in draw 0's order of shifts no longer their neighbours in draw 1's.
    #[test]
    fn another_draw_is_another_start_with_the_same_spread() {
        let dx = 0.1;
        let water = vec![ShapeSpec::Box {
            min: [0.0; 3],
            max: [1.0, 0.5, 0.3],
        }];
        let plain = fill_water(&spec(dx, water.clone()), &[]).unwrap();
        let shifts = |draw: u32| -> Vec<(Real, [i64; 3])> {
            let mut f = spec(dx, water.clone());
            f.row_shift = Some([0.25, 0.0, 0.0]);
            f.row_draw = draw;
            let fill = fill_water(&f, &[]).unwrap();
            let mut rows: Vec<(Real, [i64; 3])> = fill
                .positions
                .iter()
                .zip(&plain.positions)
                .map(|(p, q)| {
                    let mut key = lattice_key(q, &plain.anchor, dx);
                    key[2] = 0;
                    (p.x - q.x, key)
                })
                .collect();
            rows.sort_by_key(|a| a.1);
            rows.dedup_by(|a, b| a.1 == b.1);
            rows
        };
        let (zero, one) = (shifts(0), shifts(1));
        assert_eq!(one.len(), 15);
        assert!(one.iter().all(|(d, _)| d.abs() <= 0.25 * dx + 1e-12));
        let mut spread: Vec<Real> = one.iter().map(|r| r.0).collect();
        spread.sort_by(|a, b| a.total_cmp(b));
        assert!(
            spread.windows(2).all(|w| w[1] - w[0] > 0.01 * dx),
            "{spread:?}"
        );
        let moved = zero
            .iter()
            .zip(&one)
            .filter(|(a, b)| (a.0 - b.0).abs() > 0.01 * dx)
            .count();
        assert!(moved >= 12, "{moved} of 15 rows moved");
        let order = |rows: &[(Real, [i64; 3])]| -> Vec<[i64; 3]> {
            let mut r = rows.to_vec();
            r.sort_by(|a, b| a.0.total_cmp(&b.0));
            r.into_iter().map(|r| r.1).collect()
        };
        let (o0, o1) = (order(&zero), order(&one));
        let kept = o0
            .windows(2)
            .filter(|w| {
                o1.windows(2)
                    .any(|v| v == *w || (v[0] == w[1] && v[1] == w[0]))
            })
            .count();
        assert!(kept <= 7, "{kept} of 14 neighbour pairs kept");
    }

    #[test]
    fn blocks_are_left_dry_and_volumes_do_not_double() {
        let water = vec![
            ShapeSpec::Box {
                min: [0.0; 3],
                max: [1.0, 1.0, 1.0],
            },
            ShapeSpec::Box {
                min: [0.5, 0.0, 0.0],
                max: [1.0, 1.0, 1.0],
            },
        ];
        // The plane x + z = 0.98 passes between lattice points (their x + z = 0.1, 0.2, …).
        let block = Polyhedron::from_shape(&ShapeSpec::Prism {
            axis: shared::scene::Axis::Y,
            profile: vec![[0.0, 0.0], [0.98, 0.0], [0.0, 0.98]],
            extent: [-1.0, 2.0],
        })
        .unwrap();
        let count = |min_sum: f64| {
            (0..10)
                .flat_map(|i| (0..10).map(move |k| (0.05 + 0.1 * i as f64, 0.05 + 0.1 * k as f64)))
                .filter(|(x, z)| x + z >= min_sum)
                .count()
                * 10
        };
        // Boundary particles: every point outside the block is water, no double from the
        // overlapping volumes.
        let mut f = spec(0.1, water);
        let fill = fill_water(&f, std::slice::from_ref(&block)).unwrap();
        assert!(
            fill.positions
                .iter()
                .all(|p| !near_or_inside(&block, p, 0.0))
        );
        assert_eq!(fill.positions.len(), count(0.98));
        // Eq. 22 alone: half a spacing off the face, x + z ≥ 0.98 + 0.05·√2.
        f.walls = Walls::Penalty;
        let fill = fill_water(&f, std::slice::from_ref(&block)).unwrap();
        assert!(
            fill.positions
                .iter()
                .all(|p| !near_or_inside(&block, p, 0.05 - 1e-9))
        );
        assert_eq!(fill.positions.len(), count(0.98 + 0.05 * 2f64.sqrt()));
    }

    /// Along a face off the lattice (the default scene's 25° slope) the water and the block's
    /// boundary particles take every lattice point once, and the water's particles hold the
    /// volume the scene asks for.
    #[test]
    fn water_and_walls_meet_along_an_inclined_face() {
        let dx = 0.04;
        let f = spec(
            dx,
            vec![ShapeSpec::Box {
                min: [0.04, 0.0, 0.0],
                max: [2.0, 0.4, 0.48],
            }],
        );
        let slope = Polyhedron::from_shape(&ShapeSpec::Prism {
            axis: shared::scene::Axis::Y,
            profile: vec![[-0.6, 0.0], [1.5, 0.0], [-0.6, 0.979246]],
            extent: [-0.2, 1.0],
        })
        .unwrap();
        let fill = fill_water(&f, std::slice::from_ref(&slope)).unwrap();
        let (lo, hi) = (Vector::new(0.0, 0.0, 0.0), Vector::new(2.0, 0.4, 0.48));
        let walls = crate::boundary::walls::WallParticles::sample(
            std::slice::from_ref(&slope),
            &fill.anchor,
            dx,
            2.6 * dx,
            &lo,
            &hi,
        );
        let key = |p: &Vector| lattice_key(p, &fill.anchor, dx);
        let water: std::collections::BTreeSet<_> = fill.positions.iter().map(key).collect();
        let wall: std::collections::BTreeSet<_> = walls.iter().map(key).collect();
        assert!(
            water.is_disjoint(&wall),
            "a lattice point is both water and wall"
        );
        // Every lattice point of the water box within the walls' reach of the slope is one of them.
        for kz in 0..12 {
            for ky in 0..10 {
                for kx in 0..49 {
                    let p = fill.anchor + Vector::new(kx as f64, ky as f64, kz as f64) * dx;
                    let depth = -slope
                        .plane_distance(&Point::from(p - slope.centroid.coords))
                        .0;
                    if depth <= 2.6 * dx {
                        let k = key(&p);
                        assert!(water.contains(&k) || wall.contains(&k), "{p} is neither");
                    }
                }
            }
        }
        // The water box minus the slope: ∫ over z of (2 − max(0.04, 1.5 − z/tan 25°)) · 0.4.
        // The particles hold 0.2 % more (the lattice's staircase along the face); the fill that
        // left dx/2 dry along it held 4.4 % less.
        let t = 25f64.to_radians().tan();
        let n = 4800;
        let volume: f64 = (0..n)
            .map(|k| {
                let z = (k as f64 + 0.5) * 0.48 / n as f64;
                (2.0 - (1.5 - z / t).max(0.04)) * 0.4 * 0.48 / n as f64
            })
            .sum();
        let held = fill.positions.len() as f64 * dx.powi(3);
        assert!(
            (held - volume).abs() < 0.01 * volume,
            "the particles hold {held} m³ of {volume} m³"
        );
    }
}
