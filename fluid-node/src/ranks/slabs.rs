//! The cuts: each rank owns a slab along one axis (the domain's longest horizontal one), cut
//! where the measured work divides evenly. A cut falls between two of the [`BINS`] parts of a
//! grid column, so the slabs balance to an eighth of a column; a rank holds whole cells: the
//! columns its parts lie in and the next on each side whole, and, in the [`HALO`]th column
//! beyond, the cells a wall is near (`crate::ranks::share`).

use std::ops::Range;

/// Grid columns of halo on each side of a slab. One column (a kernel support plus the Verlet
/// skin) holds every neighbour of an owned particle; the second holds the neighbours of the wall
/// particles in the first, whose extrapolated pressures (Adami et al. 2012) an owned particle
/// reads. With two, every sum a rank computes for its own particles sees the same neighbours
/// as on one rank, so no pressure needs a message of its own. Of the second column only the
/// cells next to a wall are needed ([`Slabs::inner`] is held whole).
pub const HALO: usize = 2;

/// The parts of a grid column a cut may fall between: a power of two, so a point's part
/// (its column coordinate times `BINS`, truncated) divided by `BINS` is its column exactly.
pub const BINS: usize = 8;

/// Imbalance (the busiest rank's work over the mean) past which the cuts move at the next sort:
/// an eighth of a column is ~1 % of a slab of 13 columns, so 2 % is within the cuts' reach, and
/// moving them costs one hand-over of the parts that change hands.
pub const REBALANCE: f64 = 1.02;

/// Time imbalance (the busiest rank's compute time over the mean) past which the cuts move
/// ([`Slabs::retimed`]): above the few per cent a window's time varies by on a quiet machine.
pub const RETIME: f64 = 1.015;

/// Where the slabs of `size` ranks begin and end, in parts of grid columns ([`BINS`] a column)
/// along `axis`.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Slabs {
    pub axis: usize,
    /// `cuts[r]..cuts[r + 1]` are rank r's parts; `cuts[0] = 0`, the last is the part count.
    cuts: Vec<usize>,
}

impl Slabs {
    /// Cuts `work` (per part along `axis`, [`BINS`] parts a column) into `size` slabs of about
    /// equal work, each at least one part wide: rank r's slab ends where the running total
    /// comes closest to (r + 1)/size of the whole (a part goes to the slab if its middle is
    /// below that). Fails when there are fewer columns than ranks.
    pub fn balanced(axis: usize, work: &[u64], size: usize) -> Result<Self, String> {
        let parts = work.len();
        let columns = parts / BINS;
        if columns < size {
            return Err(format!(
                "{size} ranks cannot each own a slab of the {columns} grid columns along the domain's longest axis: use at most {columns} ranks"
            ));
        }
        let total: u128 = work.iter().map(|&w| w as u128).sum();
        if total == 0 {
            // No work measured (no water): equal slabs.
            let cuts = (0..=size).map(|r| parts * r / size).collect();
            return Ok(Self { axis, cuts });
        }
        let mut cuts = vec![0usize; size + 1];
        cuts[size] = parts;
        let mut running: u128 = 0;
        let mut c = 0usize;
        for r in 0..size - 1 {
            let target = total * (r as u128 + 1) / size as u128;
            // At least one part for this rank, and one left for each rank after it.
            let lowest = cuts[r] + 1;
            let highest = parts - (size - 1 - r);
            while c < lowest || (c < highest && 2 * running + (work[c] as u128) <= 2 * target) {
                running += work[c] as u128;
                c += 1;
            }
            // A cut between empty parts moves to the column's edge if it can: the same split
            // of the work, and a column fewer held on one side.
            let (down, up) = (c - c % BINS, c.next_multiple_of(BINS));
            if up <= highest && work[c..up].iter().all(|&w| w == 0) {
                c = up;
            } else if down >= lowest && work[down..c].iter().all(|&w| w == 0) {
                c = down;
            }
            cuts[r + 1] = c;
        }
        Ok(Self { axis, cuts })
    }

    pub fn size(&self) -> usize {
        self.cuts.len() - 1
    }

    /// Rank r's own parts.
    pub fn owned(&self, r: usize) -> Range<usize> {
        self.cuts[r]..self.cuts[r + 1]
    }

    /// The columns rank r holds cells of: those its parts lie in and [`HALO`] on each side.
    pub fn held(&self, r: usize) -> Range<usize> {
        self.reach(r, HALO)
    }

    /// The columns rank r holds whole: those its parts lie in and one on each side (every
    /// neighbour of its particles).
    pub fn inner(&self, r: usize) -> Range<usize> {
        self.reach(r, 1)
    }

    /// The columns rank r's parts lie in and `beyond` more on each side.
    fn reach(&self, r: usize, beyond: usize) -> Range<usize> {
        let own = self.owned(r);
        let columns = *self.cuts.last().unwrap() / BINS;
        (own.start / BINS).saturating_sub(beyond)..((own.end - 1) / BINS + 1 + beyond).min(columns)
    }

    /// The rank owning part `b`.
    pub fn owner(&self, b: usize) -> usize {
        // The last cut at or below b.
        self.cuts[1..self.cuts.len() - 1].partition_point(|&k| k <= b)
    }

    /// The cuts that balance the ranks' compute times, from rank r's time `busy[r]` and the
    /// work it did in that time `done[r]` (both over the same steps): each part's `work`
    /// weighed by the time a unit of its owner's work took. Returns the time imbalance
    /// (busiest over mean) and the new cuts if it is past [`RETIME`] and they differ from
    /// these; None if a rank did no work.
    pub fn retimed(
        &self,
        work: &[u64],
        busy: &[u64],
        done: &[u64],
    ) -> Result<Option<(f64, Option<Slabs>)>, String> {
        let total: u64 = busy.iter().sum();
        if total == 0 || done.contains(&0) {
            return Ok(None);
        }
        let imbalance = *busy.iter().max().unwrap() as f64 * busy.len() as f64 / total as f64;
        if imbalance <= RETIME {
            return Ok(Some((imbalance, None)));
        }
        let rate: Vec<f64> = busy
            .iter()
            .zip(done)
            .map(|(&b, &w)| b as f64 / w as f64)
            .collect();
        let timed: Vec<u64> = (0..work.len())
            .map(|b| (work[b] as f64 * rate[self.owner(b)]).round() as u64)
            .collect();
        let cut = Slabs::balanced(self.axis, &timed, self.size())?;
        Ok(Some((imbalance, Some(cut).filter(|c| c != self))))
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
        // Ten columns of eight parts, a part weighing 1 but in column 4, where it weighs 10.
        let work: Vec<u64> = (0..10 * BINS)
            .map(|b| if b / BINS == 4 { 10 } else { 1 })
            .collect();
        let s = Slabs::balanced(0, &work, 2).unwrap();
        // 152 in all: the first slab takes the parts whose middle is below 76 (part 36 runs
        // from 72 to 82, its middle 77): the cut splits column 4 in half.
        assert_eq!(s.owned(0), 0..36);
        assert_eq!(s.owned(1), 36..80);
        assert_eq!((s.owner(35), s.owner(36), s.owner(79)), (0, 1, 1));
        // Both hold the split column and two more beyond it, the first of them whole.
        assert_eq!(s.held(0), 0..7);
        assert_eq!(s.held(1), 2..10);
        assert_eq!((s.inner(0), s.inner(1)), (0..6, 3..10));
        assert!((s.imbalance(&work) - 80.0 / 76.0).abs() < 1e-12);
        // No work: equal slabs.
        let s = Slabs::balanced(1, &[0; 5 * BINS], 5).unwrap();
        assert_eq!(
            (0..5).map(|r| s.owned(r).len()).collect::<Vec<_>>(),
            [BINS; 5]
        );
        assert_eq!(s.owner(5 * BINS - 1), 4);
        // All the work in the first part: the others still get a slab each, at the columns'
        // edges (the parts between are empty).
        let mut work = vec![0; 4 * BINS];
        work[0] = 100;
        let s = Slabs::balanced(0, &work, 3).unwrap();
        assert_eq!(s.owned(0), 0..BINS);
        assert_eq!(s.owned(1), BINS..2 * BINS);
        assert_eq!(s.owned(2), 2 * BINS..4 * BINS);
        // Two parts of column 2 and one of column 3 hold the work: the first slab takes
        // column 2's (its middle is below half); the cut, in column 2's empty parts, moves to
        // their edge, and the second slab holds a column fewer.
        let mut work = vec![0; 6 * BINS];
        (work[2 * BINS], work[2 * BINS + 1], work[3 * BINS]) = (6, 6, 6);
        let s = Slabs::balanced(0, &work, 2).unwrap();
        assert_eq!(s.owned(0), 0..3 * BINS);
        assert_eq!(s.held(1), 1..6);
        let e = Slabs::balanced(0, &[1; 3 * BINS], 4).unwrap_err();
        assert!(e.contains("use at most 3 ranks"), "{e}");
    }

    #[test]
    fn cuts_follow_the_ranks_times() {
        // Even work in 12 columns, cut in half; rank 0 took twice as long a unit of work.
        let work = vec![10; 12 * BINS];
        let s = Slabs::balanced(0, &work, 2).unwrap();
        assert_eq!(s.owned(0), 0..6 * BINS);
        let (imbalance, cut) = s.retimed(&work, &[200, 100], &[100, 100]).unwrap().unwrap();
        assert!((imbalance - 4.0 / 3.0).abs() < 1e-12);
        // The parts keep the cost they had: rank 0 keeps 36 parts at 2 units of time each,
        // rank 1 takes 12 of them and keeps its 48 at 1: 72 each.
        assert_eq!(cut.unwrap().owned(0), 0..36);
        // Within RETIME: no move; the same cuts: no move; no work done: no judgement.
        let (_, cut) = s.retimed(&work, &[1010, 1000], &[1, 1]).unwrap().unwrap();
        assert_eq!(cut, None);
        let (_, cut) = s.retimed(&work, &[200, 100], &[200, 100]).unwrap().unwrap();
        assert_eq!(cut, None);
        assert_eq!(s.retimed(&work, &[200, 100], &[0, 100]).unwrap(), None);
    }
}
