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

use rayon::prelude::*;
use shared::math::{Real, Vector};
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

    /// The grid's lower corner: cell (0, 0, 0) starts there.
    #[inline]
    pub fn origin(&self) -> Vector {
        self.origin
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

    /// Cells along each axis.
    pub fn dims(&self) -> [usize; 3] {
        self.dims
    }

    /// The permutation of the last [`Self::sort`] (sorted slot → previous index).
    pub fn last_order(&self) -> &[u32] {
        &self.order
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

    /// Which of `parts` equal parts of the grid's extent along `axis` a point is in (clamped):
    /// with `parts` a power of two times the cells along `axis`, the part divided by
    /// `parts / dims[axis]` is the point's cell coordinate [`Self::coords`] exactly.
    #[inline]
    pub fn part(&self, p: &Vector, axis: usize, parts: usize) -> usize {
        let per_cell = (parts / self.dims[axis]) as Real;
        let f = (p[axis] - self.origin[axis]) * self.inv_cell * per_cell;
        (f.max(0.0) as usize).min(parts - 1)
    }

    /// The index of the cell of a point (clamped into the grid).
    #[inline]
    pub fn cell_index(&self, p: &Vector) -> usize {
        self.index(self.coords(p))
    }

    /// The index of the cell at `c` (column, row, layer).
    #[inline]
    pub fn index(&self, c: [usize; 3]) -> usize {
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
        // cells than particles, as a tank with headroom has, still splits: a grid with a few
        // cells per particle would otherwise count and scatter on one thread, and the second,
        // idle for that long, fall asleep before the next pass
        // (docs/journal/2026-11-performance.md, "Inner loops, fifth round").
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
}
