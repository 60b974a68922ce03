//! What the SPH pair loops share to run eight neighbours per instruction in f32: the 32-byte
//! record a loop reads of a neighbour ([`Packed`]), the load of eight records as eight lanes of
//! each field ([`gather`]), and the sum of a loop's lane partial sums in f64 in a fixed order
//! ([`sum`]).
//!
//! Why f32: a pair's terms need six significant digits, not sixteen. The particles' state stays
//! f64 and is integrated in f64; a loop reads a copy of it rounded once per evaluation:
//! positions relative to the grid's centre (rounding ≤ ulp(extent/2)/2: 0.1 µm in a 4 m tank,
//! 4 µm along Example 1's 107 m flume, against a particle's move of ~100 µm per step), and
//! whatever scalars the scheme needs, chosen so that differences keep their digits (WCSPH
//! stores ρ − ρ0, not ρ). Rounding each particle's copy once keeps every pair exactly
//! antisymmetric (r_ji = −r_ij to the bit), so pair forces still conserve momentum. Sums run in
//! eight f32 lanes (~10 terms each) and are added in f64.
//!
//! The same bits on every CPU: the lanes are written out in the source (a multiversioned loop
//! compiles them to one AVX2 or NEON register, or to scalar code), there is no fused
//! multiply–add (Rust never contracts), and sqrt and division are correctly rounded everywhere.

use shared::math::{Real, Vector};

/// Lanes of the pair loops.
pub const L: usize = 8;

/// A particle's state as a pair loop reads it: position (relative to the loop's origin),
/// velocity and two scalars whose meaning the scheme fixes (documented where it fills them).
/// 32 bytes, two records per cache line; one 256-bit load.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
#[repr(C, align(32))]
pub struct Packed {
    pub position: [f32; 3],
    pub s0: f32,
    pub velocity: [f32; 3],
    pub s1: f32,
}

impl Packed {
    /// The record of a particle at `position` moving at `velocity`, with scalars `s0`, `s1`.
    #[inline]
    pub fn new(position: &Vector, origin: &Vector, velocity: &Vector, s0: Real, s1: Real) -> Self {
        let r = position - origin;
        Self {
            position: [r.x as f32, r.y as f32, r.z as f32],
            s0: s0 as f32,
            velocity: [velocity.x as f32, velocity.y as f32, velocity.z as f32],
            s1: s1 as f32,
        }
    }
}

/// The records' fields as lanes, in [`Packed`]'s order: x, y, z, s0, vx, vy, vz, s1.
pub type Fields = [[f32; L]; 8];

/// The indices of the block of up to [`L`] list entries from `k0`, and how many are real: the
/// missing lanes repeat the first entry (a valid record), and the loop masks them.
#[inline(always)]
pub fn block(list: &[u32], k0: usize) -> ([usize; L], usize) {
    let n = L.min(list.len() - k0);
    let mut idx = [list[k0] as usize; L];
    for (k, slot) in idx.iter_mut().enumerate().take(n) {
        *slot = list[k0 + k] as usize;
    }
    (idx, n)
}

/// The eight records `idx` as lanes of each field. With AVX2 each record is one 32-byte load
/// and the eight are transposed by 24 shuffles; loading field by field takes 64 scalar loads
/// and inserts, which were two thirds of WCSPH's pair-loop instructions. Both give the same
/// values.
#[inline(always)]
pub fn gather(records: &[Packed], idx: &[usize; L]) -> Fields {
    #[cfg(target_arch = "x86_64")]
    if std::arch::is_x86_feature_detected!("avx2") {
        // SAFETY: the CPU has AVX2 (checked just above).
        return unsafe { transpose_avx2(records, idx) };
    }
    let mut out = [[0.0f32; L]; 8];
    for (k, &j) in idx.iter().enumerate() {
        let r = &records[j];
        let fields = [
            r.position[0],
            r.position[1],
            r.position[2],
            r.s0,
            r.velocity[0],
            r.velocity[1],
            r.velocity[2],
            r.s1,
        ];
        for (f, v) in fields.into_iter().enumerate() {
            out[f][k] = v;
        }
    }
    out
}

/// The positions (and s0) of the eight records `idx` as lanes: [`gather`]'s first four fields
/// at less cost, for loops that read nothing else (with AVX2: the records' first halves paired
/// into four registers and transposed by 8 shuffles instead of 24).
#[inline(always)]
pub fn gather_positions(records: &[Packed], idx: &[usize; L]) -> [[f32; L]; 4] {
    #[cfg(target_arch = "x86_64")]
    if std::arch::is_x86_feature_detected!("avx2") {
        // SAFETY: the CPU has AVX2 (checked just above).
        return unsafe { transpose_halves_avx2(records, idx) };
    }
    let [x, y, z, s0, ..] = gather(records, idx);
    [x, y, z, s0]
}

/// The first 16 bytes of eight records, k and k + 4 paired in one register, transposed
/// (a 4 × 4 transpose in each 128-bit half).
///
/// # Safety
/// The CPU must support AVX2.
#[cfg(target_arch = "x86_64")]
#[inline(always)]
unsafe fn transpose_halves_avx2(records: &[Packed], idx: &[usize; L]) -> [[f32; L]; 4] {
    use std::arch::x86_64::*;
    // SAFETY: as `transpose_avx2`: AVX2 by the caller's contract, unaligned 16-byte reads of
    // live records, register shuffles, same-size transmute.
    unsafe {
        let half = |k: usize| _mm_loadu_ps((&records[idx[k]] as *const Packed).cast());
        let pair =
            |k: usize| _mm256_insertf128_ps::<1>(_mm256_castps128_ps256(half(k)), half(k + 4));
        let a = [pair(0), pair(1), pair(2), pair(3)];
        let t0 = _mm256_unpacklo_ps(a[0], a[1]);
        let t1 = _mm256_unpackhi_ps(a[0], a[1]);
        let t2 = _mm256_unpacklo_ps(a[2], a[3]);
        let t3 = _mm256_unpackhi_ps(a[2], a[3]);
        std::mem::transmute::<[__m256; 4], [[f32; L]; 4]>([
            _mm256_shuffle_ps::<0x44>(t0, t2),
            _mm256_shuffle_ps::<0xEE>(t0, t2),
            _mm256_shuffle_ps::<0x44>(t1, t3),
            _mm256_shuffle_ps::<0xEE>(t1, t3),
        ])
    }
}

/// Eight records loaded as rows and transposed to eight field vectors (unpack, shuffle,
/// permute: the classic 8 × 8 f32 transpose).
///
/// Not a `#[target_feature]` function, so that it can be `#[inline(always)]`: the pair loops
/// that call it are compiled for AVX2 (multiversion), and the intrinsics inline there. (As a
/// target-feature function it was left as a call, 8.5 % of a Müller step.)
///
/// # Safety
/// The CPU must support AVX2.
#[cfg(target_arch = "x86_64")]
#[inline(always)]
unsafe fn transpose_avx2(records: &[Packed], idx: &[usize; L]) -> Fields {
    use std::arch::x86_64::*;
    // SAFETY: the CPU has AVX2 (the caller's contract); a Packed is 8 f32 (repr(C), 32 bytes),
    // read unaligned from a live reference; the rest are register shuffles; __m256 and
    // [f32; 8] have the same size and every bit pattern is valid for both.
    unsafe {
        let load = |k: usize| _mm256_loadu_ps((&records[idx[k]] as *const Packed).cast());
        let r = [
            load(0),
            load(1),
            load(2),
            load(3),
            load(4),
            load(5),
            load(6),
            load(7),
        ];
        let t = [
            _mm256_unpacklo_ps(r[0], r[1]),
            _mm256_unpackhi_ps(r[0], r[1]),
            _mm256_unpacklo_ps(r[2], r[3]),
            _mm256_unpackhi_ps(r[2], r[3]),
            _mm256_unpacklo_ps(r[4], r[5]),
            _mm256_unpackhi_ps(r[4], r[5]),
            _mm256_unpacklo_ps(r[6], r[7]),
            _mm256_unpackhi_ps(r[6], r[7]),
        ];
        let u = [
            _mm256_shuffle_ps::<0x44>(t[0], t[2]),
            _mm256_shuffle_ps::<0xEE>(t[0], t[2]),
            _mm256_shuffle_ps::<0x44>(t[1], t[3]),
            _mm256_shuffle_ps::<0xEE>(t[1], t[3]),
            _mm256_shuffle_ps::<0x44>(t[4], t[6]),
            _mm256_shuffle_ps::<0xEE>(t[4], t[6]),
            _mm256_shuffle_ps::<0x44>(t[5], t[7]),
            _mm256_shuffle_ps::<0xEE>(t[5], t[7]),
        ];
        std::mem::transmute::<[__m256; 8], Fields>([
            _mm256_permute2f128_ps::<0x20>(u[0], u[4]),
            _mm256_permute2f128_ps::<0x20>(u[1], u[5]),
            _mm256_permute2f128_ps::<0x20>(u[2], u[6]),
            _mm256_permute2f128_ps::<0x20>(u[3], u[7]),
            _mm256_permute2f128_ps::<0x31>(u[0], u[4]),
            _mm256_permute2f128_ps::<0x31>(u[1], u[5]),
            _mm256_permute2f128_ps::<0x31>(u[2], u[6]),
            _mm256_permute2f128_ps::<0x31>(u[3], u[7]),
        ])
    }
}

/// The lanes' partial sums in f64, in a fixed order.
#[inline(always)]
pub fn sum(a: [f32; L]) -> Real {
    let a = a.map(Real::from);
    ((a[0] + a[1]) + (a[2] + a[3])) + ((a[4] + a[5]) + (a[6] + a[7]))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn gather_gives_each_field_in_lane_order() {
        let records: Vec<Packed> = (0..20)
            .map(|i| {
                let f = |k: usize| (10 * i + k) as f32;
                Packed {
                    position: [f(0), f(1), f(2)],
                    s0: f(3),
                    velocity: [f(4), f(5), f(6)],
                    s1: f(7),
                }
            })
            .collect();
        let idx = [3, 17, 0, 9, 9, 12, 5, 19];
        let fields = gather(&records, &idx);
        for (f, lanes) in fields.iter().enumerate() {
            for (k, &v) in lanes.iter().enumerate() {
                assert_eq!(v, (10 * idx[k] + f) as f32, "field {f} lane {k}");
            }
        }
        assert_eq!(gather_positions(&records, &idx), fields[..4]);
        let (ids, n) = block(&[4, 5, 6], 0);
        assert_eq!((ids, n), ([4, 5, 6, 4, 4, 4, 4, 4], 3));
    }
}
