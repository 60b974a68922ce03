//! Parallel sums of per-particle terms whose rounding does not depend on the threads.
//!
//! rayon's `sum` and `reduce` add the parts in the shape of however the work was split, and
//! that shape follows work stealing: the same run could round a total differently, and a
//! 1-thread run differently from a 2-thread one. A solve that stops on such a total (DFSPH's
//! mean errors) is then deterministic only by luck. Here the terms are added in fixed blocks of
//! [`BLOCK`] particles, each in index order, and the blocks' totals in block order: the same
//! bits for any number of threads and any schedule.

use rayon::prelude::*;
use shared::math::Real;

/// Particles per block.
pub const BLOCK: usize = 1024;

/// Σ_i term(i) over i < n, for N quantities at once, added as the module doc says. `partials`
/// is scratch (one entry per block; it keeps its capacity, so no allocation once warmed up).
pub fn fixed_sum<const N: usize>(
    n: usize,
    partials: &mut Vec<[Real; N]>,
    term: impl Fn(usize) -> [Real; N] + Sync + Send,
) -> [Real; N] {
    (0..n.div_ceil(BLOCK))
        .into_par_iter()
        .with_max_len(crate::core::tasks::CHUNKS)
        .map(|b| {
            let mut s = [0.0; N];
            for i in b * BLOCK..((b + 1) * BLOCK).min(n) {
                for (s, t) in s.iter_mut().zip(term(i)) {
                    *s += t;
                }
            }
            s
        })
        .collect_into_vec(partials);
    let mut total = [0.0; N];
    for p in partials.iter() {
        for (s, t) in total.iter_mut().zip(p) {
            *s += t;
        }
    }
    total
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The serial sum in the same order: blocks in index order, then the blocks' totals.
    fn serial(values: &[Real]) -> Real {
        values
            .chunks(BLOCK)
            .map(|c| c.iter().fold(0.0, |s, v| s + v))
            .fold(0.0, |s, v| s + v)
    }

    #[test]
    fn the_same_bits_on_any_number_of_threads() {
        // Terms of mixed magnitude, so that another order of addition rounds differently.
        let values: Vec<Real> = (0..10_000i32)
            .map(|i| ((i * 7919) % 1000) as Real * 10f64.powi(i % 7 - 3) / 3.0)
            .collect();
        let expected = serial(&values);
        assert_ne!(
            expected.to_bits(),
            values.iter().rev().sum::<Real>().to_bits(),
            "the terms must round differently in another order, or the test proves nothing"
        );
        for threads in [1, 2, 3, 8] {
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap();
            for _ in 0..5 {
                let mut partials = Vec::new();
                let [s, twice] = pool.install(|| {
                    fixed_sum(values.len(), &mut partials, |i| {
                        [values[i], 2.0 * values[i]]
                    })
                });
                assert_eq!(s.to_bits(), expected.to_bits(), "{threads} threads");
                assert_eq!(twice.to_bits(), (2.0 * expected).to_bits());
            }
        }
        assert_eq!(fixed_sum(0, &mut Vec::new(), |_| [1.0]), [0.0]);
    }
}
