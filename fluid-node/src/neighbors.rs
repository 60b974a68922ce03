//! Neighbour search on a uniform cell grid (cell size = search radius, the kernel support),
//! particles counting-sorted by cell so that every cell, and every row of three cells along x,
//! is one contiguous index range. A neighbour query is then 9 contiguous scans instead of 27
//! scattered ones, and the particle arrays stay in cell order for cache locality.
//!
//! The grid covers the scene domain (plus one radius of padding), which never changes: particles
//! outside the domain are an instability, so every particle has a cell, and the static grid of
//! boundary particles is built once with the same geometry. The one exception, water above an
//! open top (`[domain] open_top`), is clamped into the top layer of cells: every particle closer
//! than a radius to one up there is above the grid's top less one cell, so in that layer too, and
//! the pair loops measure true distances.

use crate::candidates::Candidates;
use crate::tasks;
use rayon::prelude::*;
use shared::math::{Real, Vector};
use std::cell::RefCell;
use std::ops::Range;

/// Cell geometry and the cell-sorted index ranges of one particle set.
#[derive(Debug, Clone)]
pub struct CellGrid {
    origin: Vector,
    inv_cell: Real,
    cell: Real,
    /// The search radius the grid is made for (the cell size): a query finds every particle
    /// closer than it.
    radius: Real,
    /// How far a particle may have moved since the sort (Verlet lists keep the sort for
    /// several steps): users that test cells by their centre add it.
    stale_reach: Real,
    dims: [usize; 3],
    /// `start[c]..start[c + 1]` are the (sorted) particles of cell c.
    start: Vec<u32>,
    /// Scratch: the cell of each particle before sorting.
    cell_of: Vec<u32>,
    /// Scratch: the sorted order (sorted slot → previous index).
    order: Vec<u32>,
    /// Scratch of the parallel sort: per part and cell, a count, then the next slot.
    counts: Vec<u32>,
    /// Scratch of the parallel sort: the first slot of each block of cells ([`first_slots`]).
    firsts: Vec<u32>,
}

impl CellGrid {
    /// A grid for queries of `radius` covering the box [min, max] with one radius of padding.
    pub fn new(min: Vector, max: Vector, radius: Real) -> Result<Self, String> {
        let cell = radius;
        let origin = min - Vector::repeat(cell);
        let mut dims = [0usize; 3];
        for k in 0..3 {
            dims[k] = (((max[k] - min[k]) / cell).ceil() as usize).max(1) + 2;
        }
        let cells = dims[0] as u128 * dims[1] as u128 * dims[2] as u128;
        if cells > u32::MAX as u128 / 2 {
            return Err(format!(
                "the neighbour grid would need {cells} cells of {cell} m over the domain: shrink the domain or raise dx"
            ));
        }
        Ok(Self {
            origin,
            inv_cell: 1.0 / cell,
            cell,
            radius,
            stale_reach: 0.0,
            dims,
            start: vec![0; cells as usize + 1],
            cell_of: Vec::new(),
            order: Vec::new(),
            counts: Vec::new(),
            firsts: Vec::new(),
        })
    }

    /// Sets how far particles may have moved since the sort ([`Self::stale_reach`]).
    pub fn set_stale_reach(&mut self, reach: Real) {
        self.stale_reach = reach;
    }

    /// How far particles may have moved since the sort.
    pub fn stale_reach(&self) -> Real {
        self.stale_reach
    }

    /// The centre of the grid's box (the origin of the pair loops' f32 coordinates: halfway,
    /// so their rounding is that of half the extent).
    pub fn centre(&self) -> Vector {
        self.origin
            + Vector::new(
                self.dims[0] as Real,
                self.dims[1] as Real,
                self.dims[2] as Real,
            ) * (0.5 * self.cell)
    }

    /// The search radius the grid was made for.
    pub fn radius(&self) -> Real {
        self.radius
    }

    /// The largest side of the grid's box [m].
    pub fn extent(&self) -> Real {
        (0..3)
            .map(|k| self.dims[k] as Real * self.cell)
            .fold(0.0, Real::max)
    }

    pub fn cell_size(&self) -> Real {
        self.cell
    }

    pub fn cell_count(&self) -> usize {
        self.start.len() - 1
    }

    /// Integer cell coordinates of a point, clamped into the grid.
    #[inline]
    pub fn coords(&self, p: &Vector) -> [usize; 3] {
        let mut c = [0usize; 3];
        for k in 0..3 {
            // Truncation is the floor for the non-negative values kept (and a call to `floor`
            // is not inlined without SSE4.1; it was 12 % of a Müller step).
            let f = (p[k] - self.origin[k]) * self.inv_cell;
            c[k] = (f.max(0.0) as usize).min(self.dims[k] - 1);
        }
        c
    }

    /// The index of the cell of a point (clamped into the grid).
    #[inline]
    pub fn cell_index(&self, p: &Vector) -> usize {
        self.index(self.coords(p))
    }

    #[inline]
    fn index(&self, c: [usize; 3]) -> usize {
        c[0] + self.dims[0] * (c[1] + self.dims[1] * c[2])
    }

    /// Counting sort of `positions` by cell. Returns the permutation (sorted slot → old index)
    /// that the caller applies to every per-particle array; afterwards the grid's ranges refer to
    /// the permuted arrays. Buffers are reused: no allocation once they have grown.
    ///
    /// Stable (a cell's particles keep their order) and in parallel: the particles are split
    /// into one contiguous part per thread, each part counts its cells, the counts are turned
    /// into each (part, cell)'s first slot, and each part places its particles. The result is
    /// the serial sort's, whatever the number of parts. (Serial, the histogram and the scatter
    /// kept the second thread idle for a tenth of a Müller step.)
    pub fn sort(&mut self, positions: &[Vector]) -> &[u32] {
        let n = positions.len();
        self.cell_of.resize(n, 0);
        self.order.resize(n, 0);
        let (dims, origin, inv) = (self.dims, self.origin, self.inv_cell);
        self.cell_of
            .par_iter_mut()
            .zip(positions.par_iter())
            .for_each(|(c, p)| {
                let mut ix = [0usize; 3];
                for k in 0..3 {
                    let f = (p[k] - origin[k]) * inv;
                    ix[k] = (f.max(0.0) as usize).min(dims[k] - 1);
                }
                *c = (ix[0] + dims[0] * (ix[1] + dims[1] * ix[2])) as u32;
            });
        let cells = self.cell_count();
        // One part per thread, but none smaller than 4 096 particles, and no more than
        // `COUNTERS_PER_PARTICLE` counters in all (a grid far sparser than its particles sorts
        // serially: clearing and scanning the counters would cost more than the parts save).
        // The counters are cleared and scanned in parallel (`first_slots`), so a grid with more
        // cells than particles, as a tank with headroom has, still splits: with the old cap of
        // two per particle the dam-break bench's grid (two cells per particle) counted and
        // scattered on one thread, and the second, idle for that long, fell asleep before the
        // next pass (docs/PERFORMANCE.md, "fifth round").
        let parts = rayon::current_num_threads()
            .min(n / 4096)
            .min(COUNTERS_PER_PARTICLE * n / cells.max(1))
            .max(1);
        let len = n.div_ceil(parts).max(1);
        self.counts.resize(parts * cells, 0);
        let cell_of = &self.cell_of;
        self.counts
            .par_chunks_mut(cells)
            .enumerate()
            .for_each(|(part, count)| {
                count.iter_mut().for_each(|c| *c = 0);
                for &c in &cell_of[(part * len).min(n)..((part + 1) * len).min(n)] {
                    count[c as usize] += 1;
                }
            });
        first_slots(&mut self.start, &mut self.counts, parts, &mut self.firsts);
        let order = SharedSlots(self.order.as_mut_ptr(), n);
        self.counts
            .par_chunks_mut(cells)
            .enumerate()
            .for_each(|(part, slot)| {
                let lo = (part * len).min(n);
                for (i, &c) in cell_of[lo..((part + 1) * len).min(n)].iter().enumerate() {
                    let s = &mut slot[c as usize];
                    // SAFETY: slot `*s` lies in the range of (part, cell c), which only this part
                    // writes, and each of its slots is written once (the counter advances).
                    unsafe { order.write(*s as usize, (lo + i) as u32) };
                    *s += 1;
                }
            });
        &self.order
    }

    /// The particle ranges of the 3×3×3 block of cells around `p`, as up to 9 rows along x.
    /// Every particle closer than [`Self::radius`] to `p` is in them. (Halving the cells and
    /// trimming the rows to the sphere scans 2.7 times fewer candidates, but the per-row work,
    /// a square root and two conversions, cost more than it saved: measured slower for both
    /// WCSPH and Müller.)
    #[inline]
    pub fn neighbor_rows(&self, p: &Vector, mut f: impl FnMut(Range<usize>)) {
        let [cx, cy, cz] = self.coords(p);
        let x0 = cx.saturating_sub(1);
        let x1 = (cx + 1).min(self.dims[0] - 1);
        for z in cz.saturating_sub(1)..=(cz + 1).min(self.dims[2] - 1) {
            for y in cy.saturating_sub(1)..=(cy + 1).min(self.dims[1] - 1) {
                let a = self.start[self.index([x0, y, z])] as usize;
                let b = self.start[self.index([x1, y, z]) + 1] as usize;
                if b > a {
                    f(a..b);
                }
            }
        }
    }

    /// Every cell overlapping the box [lo, hi], empty or not, with its index and centre.
    pub fn box_all_cells(&self, lo: &Vector, hi: &Vector, mut f: impl FnMut(usize, &Vector)) {
        let a = self.coords(lo);
        let b = self.coords(hi);
        for z in a[2]..=b[2] {
            for y in a[1]..=b[1] {
                for x in a[0]..=b[0] {
                    let centre = self.origin
                        + Vector::new(x as Real + 0.5, y as Real + 0.5, z as Real + 0.5)
                            * self.cell;
                    f(self.index([x, y, z]), &centre);
                }
            }
        }
    }

    /// The (sorted) particles of cell `c`.
    #[inline]
    pub fn cell_range(&self, c: usize) -> Range<usize> {
        self.start[c] as usize..self.start[c + 1] as usize
    }

    /// Every cell overlapping the box [lo, hi] with its centre and its particle range.
    pub fn box_cells(&self, lo: &Vector, hi: &Vector, mut f: impl FnMut(&Vector, Range<usize>)) {
        let a = self.coords(lo);
        let b = self.coords(hi);
        for z in a[2]..=b[2] {
            for y in a[1]..=b[1] {
                for x in a[0]..=b[0] {
                    let c = self.index([x, y, z]);
                    let (s, e) = (self.start[c] as usize, self.start[c + 1] as usize);
                    if e > s {
                        let centre = self.origin
                            + Vector::new(x as Real + 0.5, y as Real + 0.5, z as Real + 0.5)
                                * self.cell;
                        f(&centre, s..e);
                    }
                }
            }
        }
    }

    /// Particles of the cell column within one radius of the vertical line through `p`, over
    /// all z, one layer of cells at a time from the top down; `f` returns true to stop after a
    /// layer.
    pub fn column_rows_top_down(&self, p: &Vector, mut f: impl FnMut(Range<usize>) -> bool) {
        let [cx, cy, _] = self.coords(p);
        let x0 = cx.saturating_sub(1);
        let x1 = (cx + 1).min(self.dims[0] - 1);
        for z in (0..self.dims[2]).rev() {
            let mut stop = false;
            for y in cy.saturating_sub(1)..=(cy + 1).min(self.dims[1] - 1) {
                let a = self.start[self.index([x0, y, z])] as usize;
                let b = self.start[self.index([x1, y, z]) + 1] as usize;
                if b > a {
                    stop |= f(a..b);
                }
            }
            if stop {
                return;
            }
        }
    }
}

/// Cells per task of [`first_slots`].
const PREFIX_BLOCK: usize = 4096;

/// The sort's counters (parts × cells) per particle at most: 64 bytes.
const COUNTERS_PER_PARTICLE: usize = 16;

/// Turns the sort's counts (`counts[part·cells + c]`: part's particles in cell c) into each
/// (part, cell)'s first slot, cells in order and parts in order within a cell, and `start[c]`
/// into cell c's first slot (`start[cells]` the total): an exclusive prefix sum in that order.
///
/// In parallel over blocks of cells: each block sums its counts, a serial scan over the few
/// block totals gives each block's first slot, and each block then scans its own cells. (One
/// serial scan over every cell kept the second thread idle: the grid has more cells than
/// twice the particles of a sparse flow.) The same slots as the serial scan: sums of whole
/// numbers in any order. `firsts` is scratch (a slot per block, kept between sorts).
fn first_slots(start: &mut [u32], counts: &mut [u32], parts: usize, firsts: &mut Vec<u32>) {
    let cells = start.len() - 1;
    firsts.resize(cells.div_ceil(PREFIX_BLOCK), 0);
    let slots = SharedSlots(counts.as_mut_ptr(), counts.len());
    let block_cells = |b: usize| b * PREFIX_BLOCK..((b + 1) * PREFIX_BLOCK).min(cells);
    firsts.par_iter_mut().enumerate().for_each(|(b, total)| {
        *total = block_cells(b)
            // SAFETY: read only; no task writes during this pass.
            .map(|c| {
                (0..parts)
                    .map(|part| unsafe { slots.read(part * cells + c) })
                    .sum::<u32>()
            })
            .sum();
    });
    let mut next = 0u32;
    for f in firsts.iter_mut() {
        let total = *f;
        *f = next;
        next += total;
    }
    start[cells] = next;
    start[..cells]
        .par_chunks_mut(PREFIX_BLOCK)
        .zip(firsts.par_iter())
        .enumerate()
        .for_each(|(b, (start, &first))| {
            let mut next = first;
            for (s, c) in start.iter_mut().zip(block_cells(b)) {
                *s = next;
                for part in 0..parts {
                    let k = part * cells + c;
                    // SAFETY: cell c belongs to this block alone, so slot (part, c) is read and
                    // written by this task only.
                    unsafe {
                        let count = slots.read(k);
                        slots.write(k, next);
                        next += count;
                    }
                }
            }
        });
}

/// The sort's permutation, written at disjoint slots by parallel parts.
#[derive(Clone, Copy)]
struct SharedSlots(*mut u32, usize);

// SAFETY: the parts write disjoint slots (see `CellGrid::sort`); nothing reads meanwhile.
unsafe impl Send for SharedSlots {}
unsafe impl Sync for SharedSlots {}

impl SharedSlots {
    /// # Safety
    /// No other thread may access slot `i` meanwhile.
    unsafe fn write(&self, i: usize, value: u32) {
        assert!(i < self.1, "sort slot {i} outside the {} slots", self.1);
        // SAFETY: in bounds (asserted), exclusive by the caller's contract.
        unsafe { self.0.add(i).write(value) };
    }

    /// # Safety
    /// No other thread may write slot `i` meanwhile.
    unsafe fn read(&self, i: usize) -> u32 {
        assert!(i < self.1, "sort slot {i} outside the {} slots", self.1);
        // SAFETY: in bounds (asserted), not written meanwhile by the caller's contract.
        unsafe { self.0.add(i).read() }
    }
}

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
        debug_assert!(radius <= to_grid.radius() * (1.0 + 1e-12));
        let n_chunks = from.len().div_ceil(CHUNK);
        self.chunks.resize_with(n_chunks, ChunkLists::default);
        let origin = to_grid.origin;
        for axis in self.near.iter_mut() {
            // Padded by one block: the candidates are gathered a whole block at a time.
            axis.resize(to.len() + crate::candidates::LANES, 0.0);
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
                fill_chunk(ch, &from[lo..hi], lo, to_grid, near, &test);
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
    to_grid: &CellGrid,
    near: &[Vec<f32>; 3],
    test: &Test,
) {
    let origin = to_grid.origin;
    ch.start.clear();
    ch.index.clear();
    ch.poly6.clear();
    ch.start.push(0);
    CANDIDATES.with_borrow_mut(|cand| {
        // The coordinates were rewritten for this build.
        cand.invalidate();
        for (k, xi) in from.iter().enumerate() {
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
    fn the_parallel_sort_is_the_stable_serial_sort() {
        let mut rnd = crate::uniform(5);
        let pts: Vec<Vector> = (0..20_000)
            .map(|_| Vector::new(rnd(), 0.5 * rnd(), 0.8 * rnd()))
            .collect();
        let mut grid = CellGrid::new(Vector::zeros(), Vector::new(1.0, 0.5, 0.8), 0.05).unwrap();
        let mut expected: Vec<u32> = (0..pts.len() as u32).collect();
        expected.sort_by_key(|&i| grid.cell_index(&pts[i as usize]));
        for threads in [1, 2, 3] {
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap();
            let order = pool.install(|| grid.sort(&pts).to_vec());
            assert_eq!(order, expected, "{threads} threads");
            let sorted: Vec<Vector> = order.iter().map(|&i| pts[i as usize]).collect();
            for c in [0, 17, 500] {
                for k in grid.cell_range(c) {
                    assert_eq!(grid.cell_index(&sorted[k]), c);
                }
            }
        }
    }

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
