//! The cuts: each rank owns a slab of whole grid columns along one axis (the domain's longest
//! horizontal one), cut where the measured work of the columns divides evenly.

use std::ops::Range;

/// Grid columns of halo on each side of a slab. One column (a kernel support plus the Verlet
/// skin) holds every neighbour of an owned particle; the second holds the neighbours of the wall
/// particles in the first, whose extrapolated pressures (Adami et al. 2012) an owned particle
/// reads. With two, every sum a rank computes for its own particles sees the same neighbours
/// as on one rank, so no pressure needs a message of its own.
pub const HALO: usize = 2;

/// Imbalance (the busiest rank's work over the mean) past which the cuts move at the next sort.
pub const REBALANCE: f64 = 1.05;

/// Where the slabs of `size` ranks begin and end, in grid columns along `axis`.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Slabs {
    pub axis: usize,
    /// `cuts[r]..cuts[r + 1]` are rank r's columns; `cuts[0] = 0`, the last is the column count.
    cuts: Vec<usize>,
}

impl Slabs {
    /// Cuts `work` (per column along `axis`) into `size` slabs of about equal work, each at least
    /// one column wide: rank r's slab ends where the running total comes closest to
    /// (r + 1)/size of the whole (a column goes to the slab if its middle is below that).
    /// Fails when there are fewer columns than ranks.
    pub fn balanced(axis: usize, work: &[u64], size: usize) -> Result<Self, String> {
        let columns = work.len();
        if columns < size {
            return Err(format!(
                "{size} ranks cannot each own a slab of the {columns} grid columns along the domain's longest axis: use at most {columns} ranks"
            ));
        }
        let total: u128 = work.iter().map(|&w| w as u128).sum::<u128>().max(1);
        let mut cuts = vec![0usize; size + 1];
        cuts[size] = columns;
        let mut running: u128 = 0;
        let mut c = 0usize;
        for r in 0..size - 1 {
            let target = total * (r as u128 + 1) / size as u128;
            // At least one column for this rank, and one left for each rank after it.
            let lowest = cuts[r] + 1;
            let highest = columns - (size - 1 - r);
            while c < lowest || (c < highest && 2 * running + (work[c] as u128) <= 2 * target) {
                running += work[c] as u128;
                c += 1;
            }
            cuts[r + 1] = c;
        }
        Ok(Self { axis, cuts })
    }

    pub fn size(&self) -> usize {
        self.cuts.len() - 1
    }

    /// Rank r's own columns.
    pub fn owned(&self, r: usize) -> Range<usize> {
        self.cuts[r]..self.cuts[r + 1]
    }

    /// The columns rank r holds: its own and [`HALO`] on each side.
    pub fn held(&self, r: usize) -> Range<usize> {
        let own = self.owned(r);
        own.start.saturating_sub(HALO)..(own.end + HALO).min(*self.cuts.last().unwrap())
    }

    /// The rank owning column `c`.
    pub fn owner(&self, c: usize) -> usize {
        // The last cut at or below c.
        self.cuts[1..self.cuts.len() - 1].partition_point(|&k| k <= c)
    }

    /// Each rank's share of `work`, over the mean (1 = balanced).
    pub fn imbalance(&self, work: &[u64]) -> f64 {
        let per: Vec<u64> = (0..self.size())
            .map(|r| work[self.owned(r)].iter().sum())
            .collect();
        let mean = per.iter().sum::<u64>() as f64 / self.size() as f64;
        if mean == 0.0 {
            return 1.0;
        }
        *per.iter().max().unwrap() as f64 / mean
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cuts_divide_the_work_and_name_the_owner() {
        let work = [1, 1, 1, 1, 10, 1, 1, 1, 1, 2];
        let s = Slabs::balanced(0, &work, 2).unwrap();
        // 20 in all: the first slab takes the columns whose middle is below 10 (column 4 runs
        // from 4 to 14, its middle 9).
        assert_eq!(s.owned(0), 0..5);
        assert_eq!(s.owned(1), 5..10);
        assert_eq!(s.owner(4), 0);
        assert_eq!(s.owner(5), 1);
        assert_eq!(s.owner(9), 1);
        assert_eq!(s.held(0), 0..7);
        assert_eq!(s.held(1), 3..10);
        assert!((s.imbalance(&work) - 14.0 / 10.0).abs() < 1e-12);
        // Empty work still gives every rank a column.
        let s = Slabs::balanced(1, &[0; 5], 5).unwrap();
        assert_eq!((0..5).map(|r| s.owned(r).len()).collect::<Vec<_>>(), [1; 5]);
        assert_eq!(s.owner(4), 4);
        // All the work in the first column: the others still get one column each.
        let s = Slabs::balanced(0, &[100, 0, 0, 0], 3).unwrap();
        assert_eq!(s.owned(0), 0..1);
        assert_eq!(s.owned(2), 2..4);
        let e = Slabs::balanced(0, &[1; 3], 4).unwrap_err();
        assert!(e.contains("use at most 3 ranks"), "{e}");
    }
}
