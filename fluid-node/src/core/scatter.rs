//! Parallel writes through a strictly increasing index list (the active wall particles, the
//! boundary records): `out[index[k]] = f(k)` for every k.
//!
//! Written serially, each such scatter kept the second thread idle (three per Müller step, over
//! the ~10⁴ wall particles near water). The list is strictly increasing, so its first half
//! writes only below `index[mid]` and its second half only from there on: `rayon::join` on the
//! halves with `out` split at that point needs no `unsafe` and no atomics, and each element is
//! written by exactly one task, as in the serial loop (the same bits, any thread count).

/// Where a scatter writes: one slice, or two written together (the same indices).
pub trait Target: Send + Sized {
    type Item;
    /// The part below `at` and the part from `at` on.
    fn split(self, at: usize) -> (Self, Self);
    fn put(&mut self, at: usize, item: Self::Item);
}

impl<T: Send> Target for &mut [T] {
    type Item = T;
    #[inline]
    fn split(self, at: usize) -> (Self, Self) {
        self.split_at_mut(at)
    }
    #[inline]
    fn put(&mut self, at: usize, item: T) {
        self[at] = item;
    }
}

impl<A: Send, B: Send> Target for (&mut [A], &mut [B]) {
    type Item = (A, B);
    #[inline]
    fn split(self, at: usize) -> (Self, Self) {
        let (a0, a1) = self.0.split_at_mut(at);
        let (b0, b1) = self.1.split_at_mut(at);
        ((a0, b0), (a1, b1))
    }
    #[inline]
    fn put(&mut self, at: usize, (a, b): (A, B)) {
        self.0[at] = a;
        self.1[at] = b;
    }
}

/// Entries per task below which a part is written serially. Small enough that a scatter over
/// a few thousand wall particles splits into several tasks: their cost per entry is uneven
/// (a wall particle under deep water has twice the fluid neighbours of one at the edge), and a
/// larger threshold split Müller's wall pressures into two uneven halves
/// (docs/journal/2026-11-performance.md, "The first committed phase table").
const SERIAL: usize = 512;

/// `out[index[k]] = f(k, index[k])` for every k, in parallel. `index` must be strictly
/// increasing (asserted in debug builds) and every entry below the target's length.
pub fn scatter<O: Target>(out: O, index: &[u32], f: &(impl Fn(usize, usize) -> O::Item + Sync)) {
    debug_assert!(
        index.windows(2).all(|w| w[0] < w[1]),
        "index not increasing"
    );
    part(out, 0, index, 0, f);
}

/// `out` starts at element `base` of the whole target; `index` starts at entry `first`.
fn part<O: Target>(
    mut out: O,
    base: usize,
    index: &[u32],
    first: usize,
    f: &(impl Fn(usize, usize) -> O::Item + Sync),
) {
    if index.len() <= SERIAL {
        for (k, &w) in index.iter().enumerate() {
            let w = w as usize;
            out.put(w - base, f(first + k, w));
        }
        return;
    }
    let mid = index.len() / 2;
    let at = index[mid] as usize;
    let (low, high) = out.split(at - base);
    rayon::join(
        || part(low, base, &index[..mid], first, f),
        || part(high, at, &index[mid..], first + mid, f),
    );
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn writes_exactly_the_serial_scatter_on_any_pool() {
        let n = 50_000;
        let index: Vec<u32> = (0..n as u32).filter(|w| w % 3 != 1 && w % 7 != 2).collect();
        let f = |k: usize, w: usize| (k as f64 + 0.5, w as u32);
        let mut expected = (vec![-1.0; n], vec![0u32; n]);
        for (k, &w) in index.iter().enumerate() {
            let (a, b) = f(k, w as usize);
            expected.0[w as usize] = a;
            expected.1[w as usize] = b;
        }
        for threads in [1, 2, 3] {
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap();
            let (mut a, mut b) = (vec![-1.0; n], vec![0u32; n]);
            pool.install(|| scatter((&mut a[..], &mut b[..]), &index, &f));
            assert_eq!((&a, &b), (&expected.0, &expected.1), "{threads} threads");
            let mut single = vec![-1.0; n];
            pool.install(|| scatter(&mut single[..], &index, &|k, w| f(k, w).0));
            assert_eq!(single, expected.0, "{threads} threads, one slice");
        }
    }
}
