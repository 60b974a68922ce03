//! The fixed terrain (`[[terrain]]`, [`shared::terrain`]) as the water sees it: a fixed wall of
//! arbitrary shape.
//!
//! - Boundary particles: the lattice points under the surface, to one kernel support deep, join
//!   the fixed blocks' wall particles ([`crate::boundary::walls`], Adami, Hu & Adams 2012), so the water
//!   over the terrain has the full kernel support and hydrostatic pressure at the bed.
//! - The paper's Eq. 22 against the triangles as a backstop, f = (K_S·d − (v·n)·K_D)·n on a
//!   particle within the margin of the surface, with d and n from the nearest surface point
//!   (parry's BVH projection with pseudo-normals, O(log n) in the triangle count).
//!
//! Both find their candidates from the triangles once (the terrain and the grid never move), so
//! a step costs the particles near the surface times log n, whatever the triangle count.

use crate::core::grid::CellGrid;
use crate::core::particles::Particles;
use crate::core::tasks;
use rayon::prelude::*;
use shared::math::{Point, Real, Vector};
use shared::terrain::Terrain;
use std::sync::Arc;

/// Lattice points (`anchor + k·dx`) inside the ground of `terrains`, at most `depth` under the
/// surface and within [lo, hi], in lattice order (z, y, x), each once.
pub fn sample(
    terrains: &[Terrain],
    anchor: &Vector,
    dx: Real,
    depth: Real,
    lo: &Vector,
    hi: &Vector,
) -> Vec<Vector> {
    let mut keys: Vec<[i64; 3]> = Vec::new();
    // Candidates: the lattice points in coarse cells (one depth wide, over [lo, hi]) that a
    // triangle's box, grown by the depth, touches, marked in a bitmap (a million small
    // triangles mark the same few cells many times over) and visited in index order.
    let coarse = depth.max(dx);
    let dims: [usize; 3] = std::array::from_fn(|k| ((hi[k] - lo[k]) / coarse).ceil() as usize + 1);
    let cell =
        |x: Real, k: usize| (((x - lo[k]) / coarse).floor().max(0.0) as usize).min(dims[k] - 1);
    for t in terrains {
        let mut marked = vec![false; dims[0] * dims[1] * dims[2]];
        for tri in t.mesh.triangles() {
            let (mut a, mut b) = (tri.a.coords, tri.a.coords);
            for p in [tri.b, tri.c] {
                a = a.inf(&p.coords);
                b = b.sup(&p.coords);
            }
            let (a, b) = (a.add_scalar(-depth).sup(lo), b.add_scalar(depth).inf(hi));
            if (0..3).any(|k| a[k] > b[k]) {
                continue;
            }
            for z in cell(a.z, 2)..=cell(b.z, 2) {
                for y in cell(a.y, 1)..=cell(b.y, 1) {
                    for x in cell(a.x, 0)..=cell(b.x, 0) {
                        marked[x + dims[0] * (y + dims[1] * z)] = true;
                    }
                }
            }
        }
        let cells: Vec<[usize; 3]> = (0..marked.len())
            .filter(|&i| marked[i])
            .map(|i| {
                [
                    i % dims[0],
                    (i / dims[0]) % dims[1],
                    i / (dims[0] * dims[1]),
                ]
            })
            .collect();
        let per = (coarse / dx).ceil() as i64 + 1;
        let found: Vec<[i64; 3]> = cells
            .par_iter()
            .flat_map_iter(|c| {
                // The lattice indices from the cell's lower corner on, one spare layer.
                let first: [i64; 3] = std::array::from_fn(|k| {
                    ((lo[k] + c[k] as Real * coarse - anchor[k]) / dx).floor() as i64
                });
                let mut out = Vec::new();
                for kz in first[2]..first[2] + per {
                    for ky in first[1]..first[1] + per {
                        for kx in first[0]..first[0] + per {
                            let p = anchor + Vector::new(kx as Real, ky as Real, kz as Real) * dx;
                            if (0..3).any(|k| p[k] < lo[k] || p[k] > hi[k]) {
                                continue;
                            }
                            let under = t
                                .nearest(&Point::from(p), depth)
                                .is_some_and(|s| s.distance < 0.0 && -s.distance <= depth);
                            if under {
                                out.push([kz, ky, kx]);
                            }
                        }
                    }
                }
                out
            })
            .collect();
        keys.extend(found);
    }
    keys.sort_unstable();
    keys.dedup();
    keys.iter()
        .map(|&[kz, ky, kx]| anchor + Vector::new(kx as Real, ky as Real, kz as Real) * dx)
        .collect()
}

/// True when `p` is inside the ground of a terrain or within `clearance` above its surface:
/// the water's fill leaves such lattice points dry.
pub fn near_or_inside(terrains: &[Terrain], p: &Vector, clearance: Real) -> bool {
    terrains.iter().any(|t| {
        t.nearest(&Point::from(*p), Real::MAX)
            .is_some_and(|s| s.distance < clearance)
    })
}

/// Eq. 22 between the particles and the terrain (fixed: no reaction is summed anywhere).
#[derive(Debug, Clone)]
pub struct TerrainPenalty {
    pub terrains: Arc<[Terrain]>,
    pub stiffness: Real,
    pub damping: Real,
    /// Height above the surface where the force begins: with boundary particles 0, so the
    /// water the fill lays on the bed (anywhere from 0 to dx above it) is never pushed at rest;
    /// with Eq. 22 alone the margin, dx/2 by default.
    pub margin: Real,
    /// How far from the surface a particle is looked for (≥ the margin): under the surface, how
    /// deep a crossing is still pushed back out.
    pub reach: Real,
    /// Grid cells near the surface, found once.
    cells: Option<Vec<u32>>,
    candidates: Vec<u32>,
    forces: Vec<Vector>,
}

impl TerrainPenalty {
    pub fn new(
        terrains: Arc<[Terrain]>,
        stiffness: Real,
        damping: Real,
        margin: Real,
        reach: Real,
    ) -> Self {
        Self {
            terrains,
            stiffness,
            damping,
            margin,
            reach: reach.max(margin),
            cells: None,
            candidates: Vec::new(),
            forces: Vec::new(),
        }
    }

    pub fn is_empty(&self) -> bool {
        self.terrains.is_empty()
    }

    /// Eq. 22 force on a particle at `x` moving at `v`: zero above the margin. A particle that
    /// has crossed the surface (by less than the reach) is pushed back out along the surface
    /// normal; one deeper in the ground is left to the boundary particles' pressure.
    #[inline]
    pub fn force(&self, x: &Vector, v: &Vector) -> Vector {
        let mut f = Vector::zeros();
        let x = Point::from(*x);
        for t in self.terrains.iter() {
            // Most candidates are farther than the reach: a box test in the BVH says so
            // without the nearest-point search.
            if !t.may_be_within(&x, self.reach) {
                continue;
            }
            if let Some(s) = t.nearest(&x, self.reach)
                && s.distance < self.margin
            {
                let d = self.margin - s.distance;
                let magnitude = (self.stiffness * d - v.dot(&s.normal) * self.damping).max(0.0);
                f += s.normal * magnitude;
            }
        }
        f
    }

    /// Adds the Eq. 22 force of the terrain to `particles.penalty` (which the blocks' Eq. 22
    /// has just written).
    pub fn apply(&mut self, particles: &mut Particles, grid: &CellGrid) {
        if self.terrains.is_empty() {
            return;
        }
        let cells = self
            .cells
            .get_or_insert_with(|| near_cells(&self.terrains, grid, self.reach));
        self.candidates.clear();
        for &c in cells.iter() {
            self.candidates
                .extend(grid.cell_range(c as usize).map(|i| i as u32));
        }
        let mut forces = std::mem::take(&mut self.forces);
        forces.resize(self.candidates.len(), Vector::zeros());
        let (pos, vel) = (&particles.position, &particles.velocity);
        let this = &*self;
        forces
            .par_iter_mut()
            .zip(this.candidates.par_iter())
            .with_max_len(tasks::PARTICLES)
            .for_each(|(out, &i)| *out = this.force(&pos[i as usize], &vel[i as usize]));
        for (&i, f) in self.candidates.iter().zip(&forces) {
            particles.penalty[i as usize] += f;
        }
        self.forces = forces;
    }
}

/// The grid cells whose particles may come within `margin` of a terrain: those whose centre is
/// within the margin plus half the cell diagonal (plus the grid's stale reach) of the surface.
fn near_cells(terrains: &[Terrain], grid: &CellGrid, margin: Real) -> Vec<u32> {
    let reach = margin + 0.5 * 3f64.sqrt() * grid.cell_size() + grid.stale_reach();
    let mut marked = vec![false; grid.cell_count()];
    let mut near = vec![false; grid.cell_count()];
    for t in terrains {
        marked.iter_mut().for_each(|m| *m = false);
        for tri in t.mesh.triangles() {
            let (mut a, mut b) = (tri.a.coords, tri.a.coords);
            for p in [tri.b, tri.c] {
                a = a.inf(&p.coords);
                b = b.sup(&p.coords);
            }
            grid.box_all_cells(&a.add_scalar(-reach), &b.add_scalar(reach), |c, _| {
                marked[c] = true
            });
        }
        let (lo, hi) = t.bounds();
        let mut centres = Vec::new();
        grid.box_all_cells(
            &lo.coords.add_scalar(-reach),
            &hi.coords.add_scalar(reach),
            |c, centre| {
                if marked[c] {
                    centres.push((c, *centre));
                }
            },
        );
        let hits: Vec<usize> = centres
            .par_iter()
            .filter(|(_, centre)| t.nearest(&Point::from(*centre), reach).is_some())
            .map(|&(c, _)| c)
            .collect();
        hits.into_iter().for_each(|c| near[c] = true);
    }
    (0..near.len())
        .filter(|&c| near[c])
        .map(|c| c as u32)
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::core::fill::lattice_key;
    use shared::scene::{DomainSpec, TerrainSpec};
    use shared::terrain::dem::Grid;

    fn slope(dir: &str) -> Terrain {
        // The terrain is read into memory: its folder goes when this returns.
        let tmp = tempfile::Builder::new()
            .prefix(&format!("rockwave-fluid-terrain-{dir}-"))
            .tempdir()
            .unwrap();
        let p = tmp.path().join("slope.asc");
        // z = 0.2 + 0.1 x over [0, 1] × [0, 1].
        std::fs::write(
            &p,
            Grid::from_fn(21, 21, 0.0, 0.0, 0.05, |x, _| 0.2 + 0.1 * x).to_asc(),
        )
        .unwrap();
        let spec: TerrainSpec =
            toml::from_str(&format!("file = {:?}", p.display().to_string())).unwrap();
        Terrain::load(
            &spec,
            &DomainSpec {
                min: [0.0; 3],
                max: [1.0; 3],
                open_top: false,
            },
        )
        .unwrap()
    }

    /// The sample is the lattice points under the slope to the requested depth, no more.
    #[test]
    fn samples_fill_under_the_surface_to_the_depth() {
        let t = slope("sample");
        let (dx, depth) = (0.05, 0.1);
        let anchor = Vector::repeat(0.025);
        let pts = sample(
            std::slice::from_ref(&t),
            &anchor,
            dx,
            depth,
            &Vector::zeros(),
            &Vector::repeat(1.0),
        );
        let cos = 1.0 / 1.01f64.sqrt();
        let mut brute = 0;
        for kz in 0..20 {
            for ky in 0..20 {
                for kx in 0..20 {
                    let p = anchor + Vector::new(kx as Real, ky as Real, kz as Real) * dx;
                    // Distance under the plane z = 0.2 + 0.1 x.
                    let under = (0.2 + 0.1 * p.x - p.z) * cos;
                    if under > 1e-9 && under <= depth - 1e-9 {
                        brute += 1;
                    }
                }
            }
        }
        assert!(brute > 500, "{brute}");
        assert_eq!(pts.len(), brute);
        for p in &pts {
            let under = (0.2 + 0.1 * p.x - p.z) * cos;
            assert!(under > 0.0 && under <= depth + 1e-12, "{p}");
        }
    }

    /// With boundary particles the fill leaves dry exactly the lattice points the sample takes
    /// (`near_or_inside` at the fill's clearance, system/setup.rs): along the slope, off the lattice, every
    /// point within the sample's depth under the surface or above it is one or the other, never
    /// both, never neither; with clearance dx/2 (Eq. 22 alone) a layer is neither.
    #[test]
    fn the_fill_and_the_sample_meet_along_the_slope() {
        use crate::core::fill::dry_clearance;
        use shared::scene::Walls;
        let t = slope("meet");
        let terrains = std::slice::from_ref(&t);
        let (dx, depth) = (0.05, 0.1);
        let anchor = Vector::repeat(0.025);
        let key = |p: &Vector| lattice_key(p, &anchor, dx);
        let under: std::collections::BTreeSet<_> = sample(
            terrains,
            &anchor,
            dx,
            depth,
            &Vector::zeros(),
            &Vector::repeat(1.0),
        )
        .iter()
        .map(key)
        .collect();
        let (mut both, mut neither, mut gap, mut water) = (0, 0, 0, 0);
        for kz in 0..20 {
            for ky in 0..20 {
                for kx in 0..20 {
                    let p = anchor + Vector::new(kx as Real, ky as Real, kz as Real) * dx;
                    let d = t.nearest(&Point::from(p), Real::MAX).unwrap().distance;
                    if d < -depth + 1e-9 {
                        continue; // deeper than the boundary layer: dry, no particle either
                    }
                    let wet = !near_or_inside(terrains, &p, dry_clearance(Walls::Particles, dx));
                    let wall = under.contains(&key(&p));
                    both += usize::from(wet && wall);
                    neither += usize::from(!wet && !wall);
                    water += usize::from(wet);
                    let penalty = dry_clearance(Walls::Penalty, dx);
                    gap += usize::from(near_or_inside(terrains, &p, penalty) && !wall);
                }
            }
        }
        assert_eq!((both, neither), (0, 0));
        assert!(water > 2000, "{water}");
        // The old rule's layer: about half a spacing over 1 m² of slope, 200 lattice points.
        assert!(gap > 100, "{gap}");
    }

    #[test]
    fn eq22_pushes_out_of_the_slope_along_its_normal() {
        let t = slope("force");
        let pen = TerrainPenalty::new(vec![t].into(), 1000.0, 10.0, 0.02, 0.02);
        let n = Vector::new(-0.1, 0.0, 1.0).normalize();
        let on = Vector::new(0.5, 0.5, 0.25);
        // 0.01 above the surface, at rest: K_S·(margin − 0.01) along n.
        let f = pen.force(&(on + n * 0.01), &Vector::zeros());
        assert!((f - n * 10.0).norm() < 1e-9, "{f}");
        // 0.01 under it, moving down into it at 1 m/s: K_S·0.03 + K_D·|v·n|.
        let v = -Vector::z();
        let f = pen.force(&(on - n * 0.01), &v);
        assert!((f - n * (30.0 + 10.0 * n.z)).norm() < 1e-9, "{f}");
        assert_eq!(
            pen.force(&(on + n * 0.05), &Vector::zeros()),
            Vector::zeros()
        );
    }

    /// With boundary particles the backstop starts at the surface (system/setup.rs): water resting
    /// on the bed, however close, feels nothing; water that has crossed it, to the reach, is
    /// pushed back out.
    #[test]
    fn the_backstop_leaves_water_on_the_bed_alone() {
        let t = slope("onset");
        let pen = TerrainPenalty::new(vec![t].into(), 1000.0, 10.0, 0.0, 0.02);
        let n = Vector::new(-0.1, 0.0, 1.0).normalize();
        let on = Vector::new(0.5, 0.5, 0.25);
        assert_eq!(
            pen.force(&(on + n * 1e-4), &Vector::zeros()),
            Vector::zeros()
        );
        let f = pen.force(&(on - n * 0.01), &Vector::zeros());
        assert!((f - n * 10.0).norm() < 1e-9, "{f}");
        // Deeper than the reach: left to the boundary particles.
        assert_eq!(
            pen.force(&(on - n * 0.03), &Vector::zeros()),
            Vector::zeros()
        );
    }
}
