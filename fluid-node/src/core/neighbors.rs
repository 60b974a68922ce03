//! Neighbour lists: for each particle of one set, the particles of another (or the same) set
//! within a radius, found by one scan of the [`CellGrid`] per build (the branch-free test of
//! [`super::candidates`]) and reused by every pass of the step.

use crate::core::candidates::Candidates;
use crate::core::grid::CellGrid;
use crate::core::tasks;
use rayon::prelude::*;
use shared::math::{Real, Vector};
use std::cell::RefCell;

/// Particles per chunk of [`NeighborLists`].
const CHUNK: usize = 512;

/// Neighbour lists of every particle of one set within `radius` in another set (or itself),
/// found once per step by one grid scan and then reused by every pass of the step.
///
/// The cell scan visits 27 cells, about 6.4 times the volume of the support sphere; storing the
/// ~4/27 that are neighbours makes the second and later passes (density then forces, predictor
/// then corrector, wall pressure) cost a neighbour loop, not a scan. Lists are kept per chunk of
/// particles so that chunks fill in parallel into their own buffers, which keep their capacity:
/// no allocation once the run has warmed up.
#[derive(Debug, Default, Clone)]
pub struct NeighborLists {
    chunks: Vec<ChunkLists>,
    /// If set, h: each build also sums, per particle, (h² − r²)³ over its list
    /// ([`NeighborLists::poly6_sum`]).
    poly6_support: Option<Real>,
    /// The candidates' coordinates relative to the grid origin in f32, one array per axis
    /// (scratch): the distance test then runs four or eight candidates per instruction.
    near: [Vec<f32>; 3],
}

#[derive(Debug, Default, Clone)]
struct ChunkLists {
    /// `start[k]..start[k + 1]` index `index` for particle `CHUNK·c + k`.
    start: Vec<u32>,
    index: Vec<u32>,
    /// Σ (h² − r²)³ over each particle's list, if the lists sum it.
    poly6: Vec<f64>,
}

impl NeighborLists {
    /// Makes every build also sum, for each listing point, (h² − r²)³ over its neighbours closer
    /// than `h` (poly6's density sum without its constant; `h` at most the list radius), from
    /// the distances the list test computes anyway. Müller's density (Eq. 12) then costs no pass
    /// of its own: in a developed flow that pass was a fifth of its step.
    pub fn sum_poly6(&mut self, h: Real) {
        self.poly6_support = Some(h);
    }

    /// Σ_j (h² − r_ij²)³ over the neighbours of particle `i` at the last build, in f32 with an
    /// f64 total (see [`NeighborLists::sum_poly6`]; 0 if the lists do not sum it).
    #[inline]
    pub fn poly6_sum(&self, i: usize) -> f64 {
        self.chunks[i / CHUNK]
            .poly6
            .get(i % CHUNK)
            .copied()
            .unwrap_or(0.0)
    }

    /// Lists, for each point of `from`, the points of `to` (sorted in `to_grid`) closer than
    /// `radius`; with `same` the point itself is left out (`from` and `to` are the same set).
    ///
    /// The test is done in f32 with the radius grown by more than f32's rounding over the grid
    /// (a few 10⁻⁷ of its extent), so a list may hold a few points just outside the radius but
    /// never misses one inside: every user of the lists tests the distance again in f64 before
    /// it adds a pair, so sums are those of the exact lists.
    pub fn build(
        &mut self,
        from: &[Vector],
        to: &[Vector],
        to_grid: &CellGrid,
        radius: Real,
        same: bool,
    ) {
        self.build_for(from, to, to_grid, radius, same, None);
    }

    /// [`Self::build`] for the points `listed` marks only (all when None); the others get
    /// empty lists (a rank lists the particles it owns, not its halo: `crate::ranks`).
    pub fn build_for(
        &mut self,
        from: &[Vector],
        to: &[Vector],
        to_grid: &CellGrid,
        radius: Real,
        same: bool,
        listed: Option<&[bool]>,
    ) {
        debug_assert!(radius <= to_grid.radius() * (1.0 + 1e-12));
        let n_chunks = from.len().div_ceil(CHUNK);
        self.chunks.resize_with(n_chunks, ChunkLists::default);
        let origin = to_grid.origin();
        for axis in self.near.iter_mut() {
            // Padded by one block: the candidates are gathered a whole block at a time.
            axis.resize(to.len() + crate::core::candidates::LANES, 0.0);
        }
        let [nx, ny, nz] = &mut self.near;
        nx.par_iter_mut()
            .zip(ny.par_iter_mut().zip(nz.par_iter_mut()))
            .zip(to.par_iter())
            .for_each(|((x, (y, z)), p)| {
                *x = (p.x - origin.x) as f32;
                *y = (p.y - origin.y) as f32;
                *z = (p.z - origin.z) as f32;
            });
        let extent = to_grid.extent();
        let padded = radius * (1.0 + 1e-5) + 1e-6 * extent;
        let test = Test {
            r2: (padded * padded) as f32,
            h2: self.poly6_support.map(|h| {
                debug_assert!(h <= radius);
                (h * h) as f32
            }),
            same,
        };
        let near = &self.near;
        self.chunks
            .par_iter_mut()
            .enumerate()
            .with_max_len(tasks::CHUNKS)
            .for_each(|(c, ch)| {
                let lo = c * CHUNK;
                let hi = (lo + CHUNK).min(from.len());
                let listed = listed.map(|l| &l[lo..hi]);
                fill_chunk(ch, &from[lo..hi], lo, listed, to_grid, near, &test);
            });
    }

    /// The neighbours of particle `i`.
    #[inline]
    pub fn of(&self, i: usize) -> &[u32] {
        let ch = &self.chunks[i / CHUNK];
        let k = i % CHUNK;
        &ch.index[ch.start[k] as usize..ch.start[k + 1] as usize]
    }

    /// Total number of pairs listed.
    pub fn pairs(&self) -> usize {
        self.chunks.iter().map(|c| c.index.len()).sum()
    }

    /// Fills `values` with one value per listed pair, in list order: `f(i, neighbours, out)`
    /// writes particle i's values into `out` (as long as its list). In parallel over the chunks,
    /// into buffers that keep their capacity.
    pub fn fill_pairs<T: Copy + Default + Send>(
        &self,
        values: &mut PairValues<T>,
        f: impl Fn(usize, &[u32], &mut [T]) + Sync,
    ) {
        values
            .chunks
            .resize_with(self.chunks.len(), Default::default);
        values
            .chunks
            .par_iter_mut()
            .zip(self.chunks.par_iter())
            .enumerate()
            .with_max_len(tasks::CHUNKS)
            .for_each(|(c, (out, ch))| {
                out.resize(ch.index.len(), T::default());
                for k in 0..ch.start.len().saturating_sub(1) {
                    let (lo, hi) = (ch.start[k] as usize, ch.start[k + 1] as usize);
                    f(c * CHUNK + k, &ch.index[lo..hi], &mut out[lo..hi]);
                }
            });
    }

    /// The neighbours of particle `i` with their values in `values` (filled by
    /// [`NeighborLists::fill_pairs`] from these lists).
    #[inline]
    pub fn with_values<'a, T>(
        &'a self,
        values: &'a PairValues<T>,
        i: usize,
    ) -> (&'a [u32], &'a [T]) {
        let (c, k) = (i / CHUNK, i % CHUNK);
        let ch = &self.chunks[c];
        let (lo, hi) = (ch.start[k] as usize, ch.start[k + 1] as usize);
        (&ch.index[lo..hi], &values.chunks[c][lo..hi])
    }
}

/// One value per listed pair of a [`NeighborLists`], stored like the lists (per chunk), so a
/// pass over a particle's neighbours streams its values beside their indices. DFSPH keeps the
/// kernel gradients of a step here: its solves make a dozen passes over the same pairs.
#[derive(Debug, Default, Clone)]
pub struct PairValues<T> {
    chunks: Vec<Vec<T>>,
}

std::thread_local! {
    /// Each worker's gathered candidates (scratch that keeps its capacity across builds).
    static CANDIDATES: RefCell<Candidates> = RefCell::new(Candidates::default());
}

/// What a build tests: the padded list radius squared, the poly6 support squared if the lists
/// sum it, and whether a point is left out of its own list.
struct Test {
    r2: f32,
    h2: Option<f32>,
    same: bool,
}

/// The lists of `from` (particles `lo..` of the listing set) into one chunk: for each point,
/// the candidates of its cell (gathered once per cell, [`Candidates`]) tested and packed into
/// the chunk's index buffer.
fn fill_chunk(
    ch: &mut ChunkLists,
    from: &[Vector],
    lo: usize,
    listed: Option<&[bool]>,
    to_grid: &CellGrid,
    near: &[Vec<f32>; 3],
    test: &Test,
) {
    let origin = to_grid.origin();
    ch.start.clear();
    ch.index.clear();
    ch.poly6.clear();
    ch.start.push(0);
    CANDIDATES.with_borrow_mut(|cand| {
        // The coordinates were rewritten for this build.
        cand.invalidate();
        for (k, xi) in from.iter().enumerate() {
            if listed.is_some_and(|l| !l[k]) {
                if test.h2.is_some() {
                    ch.poly6.push(0.0);
                }
                ch.start.push(ch.index.len() as u32);
                continue;
            }
            let p = [
                (xi.x - origin.x) as f32,
                (xi.y - origin.y) as f32,
                (xi.z - origin.z) as f32,
            ];
            let skip = if test.same { (lo + k) as u32 } else { u32::MAX };
            cand.gather(to_grid, xi, near);
            match test.h2 {
                Some(h2) => ch
                    .poly6
                    .push(cand.select_weighed(p, test.r2, skip, &mut ch.index, h2)),
                None => cand.select(p, test.r2, skip, &mut ch.index),
            }
            ch.start.push(ch.index.len() as u32);
        }
    });
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn finds_exactly_the_brute_force_neighbours() {
        let mut rnd = crate::uniform(7);
        let h = 0.13;
        let pts: Vec<Vector> = (0..2000)
            .map(|_| Vector::new(rnd(), 0.5 * rnd(), 0.8 * rnd()))
            .collect();
        let mut grid = CellGrid::new(Vector::zeros(), Vector::new(1.0, 0.5, 0.8), h).unwrap();
        let order = grid.sort(&pts).to_vec();
        let sorted: Vec<Vector> = order.iter().map(|&i| pts[i as usize]).collect();
        // Sorted order is a permutation.
        let mut seen = vec![false; pts.len()];
        order.iter().for_each(|&i| seen[i as usize] = true);
        assert!(seen.iter().all(|&s| s));
        for i in (0..sorted.len()).step_by(37) {
            let mut found = Vec::new();
            grid.neighbor_rows(&sorted[i], |r| {
                for j in r {
                    if (sorted[j] - sorted[i]).norm() < h {
                        found.push(j);
                    }
                }
            });
            found.sort();
            let mut lists = NeighborLists::default();
            lists.build(&sorted, &sorted, &grid, h, true);
            // The lists hold every neighbour, and nothing farther than the f32 padding.
            let mut listed: Vec<usize> = lists.of(i).iter().map(|&j| j as usize).collect();
            assert!(!listed.contains(&i), "particle {i} lists itself");
            listed.push(i);
            listed.sort();
            let inside: Vec<usize> = listed
                .iter()
                .copied()
                .filter(|&j| (sorted[j] - sorted[i]).norm() < h)
                .collect();
            assert_eq!(inside, found, "lists of particle {i}");
            for &j in &listed {
                let r = (sorted[j] - sorted[i]).norm();
                assert!(r < h * (1.0 + 1e-4), "particle {j} at {r} listed for {i}");
            }
            let brute: Vec<usize> = (0..sorted.len())
                .filter(|&j| (sorted[j] - sorted[i]).norm() < h)
                .collect();
            assert_eq!(found, brute, "particle {i}");
        }
    }
}
