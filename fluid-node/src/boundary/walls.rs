//! Boundary particles on the fixed blocks (Adami, Hu & Adams 2012): a better wall than the
//! paper's Eq. 22 alone, where the validation needs one.
//!
//! With penalty forces only, a particle next to a wall misses the part of its kernel support
//! that lies inside the wall: its summed density (Müller) is low and its pressure gradient is
//! one-sided, so water sticks to walls and hydrostatic pressure is wrong within ~h of the bed.
//! Here the fixed blocks are filled, on the water's own lattice, to a depth of one kernel support
//! with static particles. Each step their pressure is extrapolated from the fluid around them,
//! p_w = (Σ_f p_f W_wf + g·Σ_f ρ_f r_wf W_wf) / Σ_f W_wf (Adami 2012, Eq. 27 for a wall at rest),
//! so the fluid near a wall feels the hydrostatic pressure it would feel in open water. Walls are
//! free-slip (boundary particles take no part in the viscous terms).
//!
//!
//! Moving blocks carry the same particles through [`crate::boundary::bodies`]; [`crate::boundary`]
//! joins both into the one set the schemes see.

use crate::core::grid::CellGrid;
use crate::core::neighbors::NeighborLists;
use crate::core::particles::Particles;
use crate::core::scatter::scatter;
use crate::core::tasks;
use crate::kernels::Kernel;
use rayon::prelude::*;
use shared::geometry::Polyhedron;
use shared::math::{Point, Real, Vector};
use std::sync::atomic::{AtomicBool, Ordering};

/// Static boundary particles with their extrapolated pressure and the density it implies.
#[derive(Debug, Clone)]
pub struct WallParticles {
    pub position: Vec<Vector>,
    pub pressure: Vec<Real>,
    pub density: Vec<Real>,
    pub grid: CellGrid,
    /// Wall particles with a fluid neighbour this step, and their positions: only these need a
    /// pressure (a tall side wall holds many particles no water reaches).
    pub active: Vec<u32>,
    active_position: Vec<Vector>,
    /// Scratch of `activate`: whether each particle has a fluid neighbour (set in parallel;
    /// all clear between calls).
    mark: Marks,
    /// Scratch of `activate`: the marked particles of each part of [`COLLECT`].
    part_counts: Vec<usize>,
    /// Fluid neighbours of each active wall particle.
    pub lists: NeighborLists,
}

/// Wall particles per part when the marked ones are collected.
const COLLECT: usize = 4096;

/// One flag per boundary particle, set from parallel tasks.
#[derive(Debug, Default)]
struct Marks(Vec<AtomicBool>);

impl Clone for Marks {
    fn clone(&self) -> Self {
        Self(
            self.0
                .iter()
                .map(|m| AtomicBool::new(m.load(Ordering::Relaxed)))
                .collect(),
        )
    }
}

impl WallParticles {
    /// Lattice points (`anchor + k·dx`) inside the fixed blocks, at most `depth` below the
    /// surface of the block they are in and within `[lo, hi]`.
    pub fn sample(
        fixed: &[Polyhedron],
        anchor: &Vector,
        dx: Real,
        depth: Real,
        lo: &Vector,
        hi: &Vector,
    ) -> Vec<Vector> {
        let kmin: Vec<i64> = (0..3)
            .map(|k| ((lo[k] - anchor[k]) / dx).floor() as i64)
            .collect();
        let kmax: Vec<i64> = (0..3)
            .map(|k| ((hi[k] - anchor[k]) / dx).ceil() as i64)
            .collect();
        let zs: Vec<i64> = (kmin[2]..=kmax[2]).collect();
        zs.par_iter()
            .flat_map_iter(|&kz| {
                let mut out = Vec::new();
                for ky in kmin[1]..=kmax[1] {
                    for kx in kmin[0]..=kmax[0] {
                        let p = anchor + Vector::new(kx as Real, ky as Real, kz as Real) * dx;
                        if (0..3).any(|k| p[k] < lo[k] || p[k] > hi[k]) {
                            continue;
                        }
                        // Depth into the union of blocks, bounded below by the deepest single block.
                        let inside = fixed
                            .iter()
                            .map(|b| -b.plane_distance(&Point::from(p - b.centroid.coords)).0)
                            .filter(|&d| d > 0.0)
                            .fold(None, |m: Option<Real>, d| Some(m.map_or(d, |m| m.max(d))));
                        if inside.is_some_and(|d| d <= depth) {
                            out.push(p);
                        }
                    }
                }
                out
            })
            .collect()
    }

    /// Sorts `position` into a grid of the fluid grid's geometry, once: the walls never move.
    pub fn new(mut position: Vec<Vector>, mut grid: CellGrid) -> Self {
        let order = grid.sort(&position).to_vec();
        position = order.iter().map(|&i| position[i as usize]).collect();
        let n = position.len();
        Self {
            position,
            pressure: vec![0.0; n],
            density: vec![0.0; n],
            grid,
            active: Vec::new(),
            active_position: Vec::new(),
            mark: Marks((0..n).map(|_| AtomicBool::new(false)).collect()),
            part_counts: Vec::new(),
            lists: NeighborLists::default(),
        }
    }

    pub fn len(&self) -> usize {
        self.position.len()
    }

    pub fn is_empty(&self) -> bool {
        self.position.is_empty()
    }

    /// Finds the wall particles near water from the fluid's wall lists and lists their fluid
    /// neighbours. Called at every sort.
    pub fn activate(
        &mut self,
        fluid_to_wall: &NeighborLists,
        fluid: &[Vector],
        fluid_grid: &CellGrid,
        radius: Real,
    ) {
        // The marks are all clear here: set below, cleared again as they are collected.
        let mark = &self.mark.0;
        (0..fluid.len())
            .into_par_iter()
            .with_max_len(tasks::PARTICLES)
            .for_each(|i| {
                for &w in fluid_to_wall.of(i) {
                    mark[w as usize].store(true, Ordering::Relaxed);
                }
            });
        // Collected in wall order, in parallel (serial, this kept the second thread idle): each
        // part of the marks counts its own, then writes them into its slice of the active list
        // and clears them.
        let counts = &mut self.part_counts;
        counts.resize(self.mark.0.len().div_ceil(COLLECT), 0);
        counts
            .par_iter_mut()
            .zip(self.mark.0.par_chunks(COLLECT))
            .for_each(|(k, marks)| *k = marks.iter().filter(|m| m.load(Ordering::Relaxed)).count());
        let total = counts.iter().sum();
        self.active.resize(total, 0);
        self.active_position.resize(total, Vector::zeros());
        collect(
            0,
            counts,
            &mut self.mark.0,
            &mut self.active,
            &mut self.active_position,
            &self.position,
        );
        self.lists
            .build(&self.active_position, fluid, fluid_grid, radius, false);
    }

    /// Adami's pressure extrapolation, then ρ_w from the solver's inverse equation of state.
    /// Negative wall pressure is clipped to zero so walls never pull water (no sticking).
    pub fn update<K: Kernel>(
        &mut self,
        kernel: &K,
        fluid: &Particles,
        gravity: &Vector,
        rest_density: Real,
        density_of: impl Fn(Real) -> Real + Sync,
    ) {
        let s2 = kernel.support() * kernel.support();
        let (pos, lists) = (&self.active_position, &self.lists);
        // Computed per active particle (in increasing order) and written in place.
        let out = (&mut self.pressure[..], &mut self.density[..]);
        scatter(out, &self.active, &|k, _| {
            let xw = pos[k];
            let (mut sum_w, mut sum_p, mut sum_rho_r) = (0.0, 0.0, Vector::zeros());
            for &f in lists.of(k) {
                let f = f as usize;
                let r = xw - fluid.position[f];
                let r2 = r.norm_squared();
                if r2 < s2 {
                    let wv = kernel.value(r2.sqrt());
                    sum_w += wv;
                    sum_p += fluid.pressure[f] * wv;
                    sum_rho_r += r * (fluid.density[f] * wv);
                }
            }
            let pw = if sum_w > 0.0 {
                ((sum_p + gravity.dot(&sum_rho_r)) / sum_w).max(0.0)
            } else {
                0.0
            };
            let rw = if sum_w > 0.0 {
                density_of(pw)
            } else {
                rest_density
            };
            (pw, rw)
        });
    }
}

/// Writes the marked wall particles of parts `first..` (their marks in `marks`, `counts[p]`
/// marked in part p) and their positions into `active` and `at`, in wall order, clearing the
/// marks: the parts split in halves by `rayon::join` down to one part each, each half taking
/// its share of the output (no allocation, no shared writes).
fn collect(
    first: usize,
    counts: &[usize],
    marks: &mut [AtomicBool],
    active: &mut [u32],
    at: &mut [Vector],
    position: &[Vector],
) {
    match counts.len() {
        0 => {}
        1 => {
            let mut k = 0;
            for (j, m) in marks.iter_mut().enumerate() {
                let m = m.get_mut();
                if *m {
                    *m = false;
                    let w = first * COLLECT + j;
                    active[k] = w as u32;
                    at[k] = position[w];
                    k += 1;
                }
            }
        }
        n => {
            let half = n / 2;
            let taken = counts[..half].iter().sum();
            let (m0, m1) = marks.split_at_mut(half * COLLECT);
            let (a0, a1) = active.split_at_mut(taken);
            let (p0, p1) = at.split_at_mut(taken);
            rayon::join(
                || collect(first, &counts[..half], m0, a0, p0, position),
                || collect(first + half, &counts[half..], m1, a1, p1, position),
            );
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use shared::scene::ShapeSpec;

    #[test]
    fn samples_fill_the_floor_to_the_requested_depth() {
        let floor = Polyhedron::from_shape(&ShapeSpec::Box {
            min: [-1.0, -1.0, -1.0],
            max: [2.0, 2.0, 0.0],
        })
        .unwrap();
        let anchor = Vector::repeat(0.05);
        let lo = Vector::new(0.0, 0.0, -0.5);
        let hi = Vector::new(1.0, 1.0, 1.0);
        let pts = WallParticles::sample(&[floor], &anchor, 0.1, 0.26, &lo, &hi);
        // Three layers (z = -0.05, -0.15, -0.25) of 10 × 10.
        assert_eq!(pts.len(), 300);
        assert!(pts.iter().all(|p| p.z < 0.0 && p.z > -0.3));
    }

    #[test]
    fn marked_walls_are_collected_in_order_and_cleared() {
        let n = 3 * COLLECT + 123;
        let position: Vec<Vector> = (0..n).map(|i| Vector::new(i as Real, 0.0, 0.0)).collect();
        let marked = |w: usize| w % 7 == 3 || (COLLECT..COLLECT + 50).contains(&w) || w == n - 1;
        let mut marks: Vec<AtomicBool> = (0..n).map(|w| AtomicBool::new(marked(w))).collect();
        let counts: Vec<usize> = marks
            .chunks(COLLECT)
            .map(|c| c.iter().filter(|m| m.load(Ordering::Relaxed)).count())
            .collect();
        let total: usize = counts.iter().sum();
        let (mut active, mut at) = (vec![0u32; total], vec![Vector::zeros(); total]);
        collect(0, &counts, &mut marks, &mut active, &mut at, &position);
        let expected: Vec<u32> = (0..n).filter(|&w| marked(w)).map(|w| w as u32).collect();
        assert_eq!(active, expected);
        assert!(at.iter().zip(&active).all(|(x, &w)| x.x == w as Real));
        assert!(marks.iter().all(|m| !m.load(Ordering::Relaxed)));
    }
}
