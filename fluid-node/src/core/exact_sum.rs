//! Exact sums of per-particle terms: the same bits in any order, on any number of threads and
//! of ranks.
//!
//! A solve that stops on a total (DFSPH's mean errors) stops where the total says, so the total
//! must not depend on how the terms were split. rayon's `sum` adds in the shape of its work
//! stealing; on several ranks each rank holds the particles of its slab, which are not a
//! contiguous run of the one-rank order (cells are x-fastest, the slabs cut along x or y), so no
//! fixed order of floating-point additions is at hand either. Here the terms are accumulated
//! without rounding (Kulisch 2013, "Computer Arithmetic and Validity", the long accumulator): a
//! fixed-point integer covering the whole f64 range, in limbs of 32 bits, each held in an i64
//! so that limbs add without carrying (carry-save: a limb takes 2³¹ terms before it could
//! overflow, and [`ExactSum::merge`] propagates the carries). Integer addition is associative,
//! so any order and any partition give the same integer, and [`ExactSum::value`] rounds it once
//! to the nearest f64 (ties to even). Ranks combine their accumulators as u64 words with a
//! wrapping sum ([`crate::ranks::comm::Comm::sum`]): the limbs' two's complement, exact.
//!
//! Cost: two to three integer additions per term beside a floating-point one, and 568 bytes per
//! accumulator, on the stack.

use rayon::prelude::*;
use shared::math::Real;

/// Terms per block: blocks are accumulated in parallel, each in one task, then merged.
pub const BLOCK: usize = 1024;

/// Bits per limb; the other 32 bits of its i64 hold the carries of up to 2³¹ terms.
const BITS: u32 = 32;

/// Limbs: limb k weighs 2^(32k − 1074). A finite f64 is m·2^(e) with m < 2⁵³ and
/// −1074 ≤ e ≤ 971, so its bits lie between 2⁻¹⁰⁷⁴ and 2¹⁰²⁴ (limbs 0 to 65); the top limb,
/// signed, holds the sign and the growth of a sum of up to 2³¹ such terms (< 2¹⁰⁵⁵).
pub const LIMBS: usize = 68;

/// Words of an accumulator on the wire: its limbs, then its counts of NaN, +∞ and −∞ terms.
pub const WORDS: usize = LIMBS + 3;

/// A sum of f64 terms kept exactly (module doc).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ExactSum {
    limbs: [i64; LIMBS],
    nan: u64,
    pos_inf: u64,
    neg_inf: u64,
}

impl Default for ExactSum {
    fn default() -> Self {
        Self {
            limbs: [0; LIMBS],
            nan: 0,
            pos_inf: 0,
            neg_inf: 0,
        }
    }
}

impl ExactSum {
    /// Adds `x` exactly (at most 2³¹ terms between two [`Self::merge`]s or normalisations).
    #[inline]
    pub fn add(&mut self, x: Real) {
        let bits = x.to_bits();
        let negative = bits >> 63 != 0;
        let exponent = ((bits >> 52) & 0x7ff) as u32;
        let fraction = bits & ((1 << 52) - 1);
        if exponent == 0x7ff {
            match (fraction != 0, negative) {
                (true, _) => self.nan += 1,
                (false, false) => self.pos_inf += 1,
                (false, true) => self.neg_inf += 1,
            }
            return;
        }
        // x = m·2^(offset − 1074): subnormals have offset 0 and no hidden bit.
        let (m, offset) = if exponent == 0 {
            (fraction, 0)
        } else {
            (fraction | 1 << 52, exponent - 1)
        };
        if m == 0 {
            return;
        }
        let wide = (m as u128) << (offset % BITS);
        let k = (offset / BITS) as usize;
        for (j, limb) in self.limbs[k..k + 3].iter_mut().enumerate() {
            let part = ((wide >> (BITS * j as u32)) as u32) as i64;
            *limb += if negative { -part } else { part };
        }
    }

    /// Adds `other` exactly and propagates the carries.
    pub fn merge(&mut self, other: &Self) {
        for (a, b) in self.limbs.iter_mut().zip(&other.limbs) {
            *a += b;
        }
        self.nan += other.nan;
        self.pos_inf += other.pos_inf;
        self.neg_inf += other.neg_inf;
        normalise(&mut self.limbs);
    }

    /// The sum rounded once to the nearest f64, ties to even: NaN if a term was NaN or both
    /// infinities were added, ±∞ if one was (or the sum is past f64's range), +0 for zero.
    pub fn value(&self) -> Real {
        if self.nan > 0 || (self.pos_inf > 0 && self.neg_inf > 0) {
            return Real::NAN;
        }
        if self.pos_inf > 0 {
            return Real::INFINITY;
        }
        if self.neg_inf > 0 {
            return Real::NEG_INFINITY;
        }
        let mut l = self.limbs;
        normalise(&mut l);
        let negative = l[LIMBS - 1] < 0;
        if negative {
            l.iter_mut().for_each(|d| *d = -*d);
            normalise(&mut l);
        }
        // Now the magnitude's digits base 2³², each in [0, 2³²).
        let Some(top) = l.iter().rposition(|&d| d != 0) else {
            return 0.0;
        };
        let low = top.saturating_sub(2);
        let digit = |k: usize| if k <= top { l[k] as u128 } else { 0 };
        let mant = (digit(low + 2) << 64) | (digit(low + 1) << 32) | digit(low);
        let sticky = l[..low].iter().any(|&d| d != 0);
        let magnitude = if low == 0 && mant < 1 << 52 {
            // Below 2⁻¹⁰²²: a subnormal, exactly (every term is a multiple of 2⁻¹⁰⁷⁴).
            Real::from_bits(mant as u64)
        } else {
            // Normal: round the leading bits once (the sticky bit in the last place breaks
            // ties as the digits below would), then scale by the digits' weight.
            let lz = mant.leading_zeros();
            let f = ((mant << lz) | sticky as u128) as Real;
            let e = (BITS * low as u32) as i64 - 1074 - lz as i64;
            let fb = f.to_bits();
            let biased = (fb >> 52) as i64 + e;
            if biased >= 0x7ff {
                Real::INFINITY
            } else {
                Real::from_bits(((biased as u64) << 52) | (fb & ((1 << 52) - 1)))
            }
        };
        if negative { -magnitude } else { magnitude }
    }

    /// The accumulator as [`WORDS`] u64 words: the limbs in two's complement, so that the
    /// wrapping sum of the words of several accumulators is the accumulator of all their terms
    /// (exact while no limb passes i64's range: 2³¹ terms in all).
    pub fn to_words(&self, out: &mut [u64]) {
        for (o, l) in out.iter_mut().zip(&self.limbs) {
            *o = *l as u64;
        }
        out[LIMBS..WORDS].copy_from_slice(&[self.nan, self.pos_inf, self.neg_inf]);
    }

    /// The accumulator of [`Self::to_words`]' words.
    pub fn from_words(words: &[u64]) -> Self {
        let mut s = Self::default();
        for (l, w) in s.limbs.iter_mut().zip(words) {
            *l = *w as i64;
        }
        [s.nan, s.pos_inf, s.neg_inf] = [words[LIMBS], words[LIMBS + 1], words[LIMBS + 2]];
        s
    }
}

/// Moves each limb's carries into the next, leaving limbs 0 to [`LIMBS`] − 2 in [0, 2³²)
/// (the top limb signed).
fn normalise(l: &mut [i64; LIMBS]) {
    for k in 0..LIMBS - 1 {
        let carry = l[k] >> BITS;
        l[k] -= carry << BITS;
        l[k + 1] += carry;
    }
}

/// Σ_i term(i) over i < n, for N quantities at once, exactly: in parallel over blocks of
/// [`BLOCK`] terms, merged (no allocation).
pub fn exact_sums<const N: usize>(
    n: usize,
    term: impl Fn(usize) -> [Real; N] + Sync + Send,
) -> [ExactSum; N] {
    let merge = |mut a: [ExactSum; N], b: [ExactSum; N]| {
        for (a, b) in a.iter_mut().zip(&b) {
            a.merge(b);
        }
        a
    };
    (0..n.div_ceil(BLOCK))
        .into_par_iter()
        .with_max_len(crate::core::tasks::CHUNKS)
        .map(|b| {
            let mut s = [ExactSum::default(); N];
            for i in b * BLOCK..((b + 1) * BLOCK).min(n) {
                for (s, t) in s.iter_mut().zip(term(i)) {
                    s.add(t);
                }
            }
            // Carried, for the merges and the wire.
            merge(s, [ExactSum::default(); N])
        })
        .reduce(|| [ExactSum::default(); N], merge)
}

/// Combines each rank's `sums` into their exact totals on every rank: `sum` is the ranks'
/// element-wise wrapping sum of u64 words ([`crate::ranks::comm::Comm::sum`]).
pub fn combine(sums: &mut [ExactSum], sum: impl FnOnce(&mut [u64])) {
    let mut words = vec![0u64; sums.len() * WORDS];
    for (s, w) in sums.iter().zip(words.chunks_exact_mut(WORDS)) {
        s.to_words(w);
    }
    sum(&mut words);
    for (s, w) in sums.iter_mut().zip(words.chunks_exact(WORDS)) {
        *s = ExactSum::from_words(w);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn exact(values: &[Real]) -> Real {
        let mut s = ExactSum::default();
        values.iter().for_each(|&v| s.add(v));
        s.value()
    }

    /// Terms of mixed magnitude and sign, so that another order of addition rounds differently.
    fn mixed(n: i64) -> Vec<Real> {
        (0..n)
            .map(|i| {
                let v = ((i * 7919) % 1000) as Real * 10f64.powi((i % 7 - 3) as i32) / 3.0;
                if i % 5 == 0 { -v } else { v }
            })
            .collect()
    }

    #[test]
    fn exact_where_floating_point_addition_rounds() {
        // 10¹⁶ + 1 rounds to 10¹⁶ in f64: the naive sum loses the 1.
        let v = [1e16, 1.0, -1e16];
        assert_eq!(v.iter().sum::<Real>(), 0.0);
        assert_eq!(exact(&v), 1.0);
        // 1 + 2⁻⁵³ is a tie (to even: 1); the 2⁻¹⁰⁰ below it makes the exact sum round up.
        let v = [1.0, 2f64.powi(-53), 2f64.powi(-100)];
        assert_eq!(v.iter().sum::<Real>(), 1.0);
        assert_eq!(exact(&v), 1.0 + 2f64.powi(-52));
        assert_eq!(exact(&[1.0, 2f64.powi(-53)]), 1.0, "a tie goes to even");
        assert_eq!(exact(&[-3.5, 1.25]), -2.25);
        assert_eq!(exact(&[]).to_bits(), 0.0f64.to_bits());
        assert_eq!(exact(&[-0.0, 2.0, -2.0]).to_bits(), 0.0f64.to_bits());
        // Subnormals, the largest finite values, and what lies past them.
        let tiny = Real::from_bits(1);
        assert_eq!(exact(&[tiny, tiny, tiny]), Real::from_bits(3));
        assert_eq!(
            exact(&[Real::MIN_POSITIVE, -tiny]),
            Real::MIN_POSITIVE - tiny
        );
        assert_eq!(exact(&[Real::MAX, Real::MAX, -Real::MAX]), Real::MAX);
        assert_eq!(exact(&[Real::MAX, Real::MAX]), Real::INFINITY);
        assert_eq!(exact(&[-Real::MAX, -Real::MAX]), Real::NEG_INFINITY);
        assert!(exact(&[1.0, Real::NAN]).is_nan());
        assert!(exact(&[Real::INFINITY, Real::NEG_INFINITY]).is_nan());
        assert_eq!(exact(&[Real::INFINITY, 1.0]), Real::INFINITY);
    }

    #[test]
    fn rounds_as_the_exact_integer_would() {
        // Multiples of 2⁻³⁰ below 2³⁰: their sum is exact in an i128, whose conversion to f64
        // rounds once to nearest, ties to even.
        let scale = 2f64.powi(30);
        let values: Vec<Real> = mixed(5000)
            .iter()
            .map(|v| (v * 1e3 * scale).round() / scale)
            .collect();
        let reference: i128 = values.iter().map(|v| (v * scale) as i128).sum();
        assert_eq!(exact(&values), reference as Real / scale);
    }

    #[test]
    fn the_same_bits_in_any_order_and_partition() {
        let values = mixed(10_000);
        let expected = exact(&values);
        assert_ne!(
            values.iter().sum::<Real>().to_bits(),
            values.iter().rev().sum::<Real>().to_bits(),
            "the terms must round differently in another order, or the test proves nothing"
        );
        let mut reversed = values.clone();
        reversed.reverse();
        assert_eq!(exact(&reversed).to_bits(), expected.to_bits());
        // Split over "ranks" by a scattered rule, combined by wrapping sums of the words.
        for ranks in [2, 3, 5] {
            let mut words = vec![0u64; WORDS];
            for r in 0..ranks {
                let [s] = exact_sums(values.len(), |i| {
                    [if (i * 31 + i / 97) % ranks == r {
                        values[i]
                    } else {
                        0.0
                    }]
                });
                let mut w = [0u64; WORDS];
                s.to_words(&mut w);
                for (a, b) in words.iter_mut().zip(w) {
                    *a = a.wrapping_add(b);
                }
            }
            let got = ExactSum::from_words(&words).value();
            assert_eq!(got.to_bits(), expected.to_bits(), "{ranks} parts");
        }
        // combine() with a one-rank "sum" is the identity.
        let mut s = exact_sums(values.len(), |i| [values[i]]);
        combine(&mut s, |_| {});
        assert_eq!(s[0].value().to_bits(), expected.to_bits());
    }

    #[test]
    fn the_same_bits_on_any_number_of_threads() {
        let values = mixed(10_000);
        let expected = exact(&values);
        for threads in [1, 2, 3, 8] {
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap();
            for _ in 0..5 {
                let [s, twice] =
                    pool.install(|| exact_sums(values.len(), |i| [values[i], 2.0 * values[i]]));
                assert_eq!(s.value().to_bits(), expected.to_bits(), "{threads} threads");
                assert_eq!(twice.value().to_bits(), (2.0 * expected).to_bits());
            }
        }
        assert_eq!(exact_sums(0, |_| [1.0])[0].value(), 0.0);
    }
}
