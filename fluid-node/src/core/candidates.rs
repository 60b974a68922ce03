//! The neighbour-list test, branch-free: the candidates of a query cell (the particles of its
//! 27 cells) gathered once into one contiguous block, then for each particle of the cell a
//! distance test eight candidates per instruction (sixteen with AVX-512) whose hits are packed
//! into the list without a branch per hit.
//!
//! Why: building the lists is a large part of a step (of Müller's most, its lists are rebuilt
//! every step). Scanning the 9 rows of a query separately left a short loop per row
//! whose exit mispredicts (rows hold 2–3 blocks of candidates) and a scalar tail per row; a
//! loop over "is this bit set" mispredicts about once per hit. Particles are sorted by cell, so
//! consecutive queries share their cell and the gathered block is reused; one long loop over it
//! predicts well; and the hits are packed by a permutation looked up from the 8-bit hit mask
//! (the "left-packing" of SIMD stream compaction), written eight at a time.
//!
//! The lists are the same, in the same order, as a per-candidate test gives: rows in the grid's
//! order (z, then y), each row in index order, and the same f32 arithmetic (products and sums in
//! the same order, no fused multiply–add), so outputs do not change.

use crate::core::grid::CellGrid;
use shared::math::Vector;

/// Candidates per block of the portable test (and the padding unit of the gathered block).
pub const LANES: usize = 8;

/// Candidates per instruction of the widest test (AVX-512): the room a packed store needs.
const WIDE: usize = 16;

/// Coordinate of the padding lanes: far enough that its squared distance to any point of a grid
/// is infinite in f32, so it never passes the test.
const FAR: f32 = 1.0e30;

/// The candidates of one query cell, gathered: f32 coordinates relative to the grid origin and
/// their indices, padded with [`FAR`] points to a whole number of [`LANES`].
#[derive(Debug, Default)]
pub struct Candidates {
    /// The index of the cell gathered for (None: nothing gathered yet). One integer, so the
    /// test per query is one compare (comparing the three coordinates as an array stalled on
    /// store forwarding: 20 % of this function).
    cell: Option<usize>,
    x: Vec<f32>,
    y: Vec<f32>,
    z: Vec<f32>,
    index: Vec<u32>,
}

impl Candidates {
    /// Makes the block hold the candidates of the cell of `p` (gathering only when the cell
    /// differs from the last one). `near` holds the coordinates of the grid's particles, with
    /// [`LANES`] elements of padding at the end (copies run whole blocks of [`LANES`]).
    pub fn gather(&mut self, grid: &CellGrid, p: &Vector, near: &[Vec<f32>; 3]) {
        let cell = grid.cell_index(p);
        if self.cell == Some(cell) {
            return;
        }
        self.cell = Some(cell);
        let mut rows = [(0, 0); 9];
        let (mut count, mut total) = (0, 0);
        grid.neighbor_rows(p, |range| {
            total += range.len();
            rows[count] = (range.start, range.end);
            count += 1;
        });
        // Whole blocks of LANES per copy (a copy of constant length is a vector move; one of a
        // row's length was a call to memmove, 4 % of a Müller step): a row's last block runs
        // past its end into the next particles, which the next row overwrites, and the lanes
        // past the last row are set far below.
        let room = total.next_multiple_of(LANES) + LANES;
        for v in [&mut self.x, &mut self.y, &mut self.z] {
            v.resize(room, FAR);
        }
        self.index.resize(room, u32::MAX);
        let mut at = 0;
        for &(start, end) in &rows[..count] {
            let mut j = start;
            while j < end {
                self.x[at..at + LANES].copy_from_slice(&near[0][j..j + LANES]);
                self.y[at..at + LANES].copy_from_slice(&near[1][j..j + LANES]);
                self.z[at..at + LANES].copy_from_slice(&near[2][j..j + LANES]);
                for (k, slot) in self.index[at..at + LANES].iter_mut().enumerate() {
                    *slot = (j + k) as u32;
                }
                let n = LANES.min(end - j);
                at += n;
                j += n;
            }
        }
        let padded = total.next_multiple_of(LANES);
        for v in [&mut self.x, &mut self.y, &mut self.z] {
            v[total..padded].fill(FAR);
            v.truncate(padded);
        }
        self.index[total..padded].fill(u32::MAX);
        self.index.truncate(padded);
    }

    /// Forgets the gathered cell (the candidates' coordinates changed).
    pub fn invalidate(&mut self) {
        self.cell = None;
    }

    /// Appends to `out` the indices of the candidates whose squared distance to `p` is below
    /// `r2`, except `skip`, in candidate order.
    #[inline]
    pub fn select(&self, p: [f32; 3], r2: f32, skip: u32, out: &mut Vec<u32>) {
        self.select_in::<false>(p, r2, skip, out, 0.0);
    }

    /// [`Self::select`], returning also Σ (h² − r²)³ over the selected candidates closer than
    /// `h` (`h2` = h²): poly6's density sum (Müller et al. 2003, paper Eq. 12) without its
    /// constant, from the distances the test computes anyway. Summed per lane in f32 over the
    /// blocks, the eight lanes added in f64 in lane order: the same bits on every CPU.
    #[inline]
    pub fn select_weighed(
        &self,
        p: [f32; 3],
        r2: f32,
        skip: u32,
        out: &mut Vec<u32>,
        h2: f32,
    ) -> f64 {
        self.select_in::<true>(p, r2, skip, out, h2)
    }

    #[inline(always)]
    fn select_in<const WEIGH: bool>(
        &self,
        p: [f32; 3],
        r2: f32,
        skip: u32,
        out: &mut Vec<u32>,
        h2: f32,
    ) -> f64 {
        // Room for the whole block plus one wide vector: the packed stores write full vectors.
        out.reserve(self.index.len() + WIDE);
        #[cfg(target_arch = "x86_64")]
        if std::arch::is_x86_feature_detected!("avx512f")
            && std::arch::is_x86_feature_detected!("popcnt")
        {
            // SAFETY: the CPU has AVX-512F and POPCNT (checked just above).
            let w = unsafe { select_avx512::<WEIGH>(self, p, r2, skip, out, h2) };
            return lane_total(&w);
        }
        #[cfg(target_arch = "x86_64")]
        if std::arch::is_x86_feature_detected!("avx2")
            && std::arch::is_x86_feature_detected!("popcnt")
        {
            // SAFETY: the CPU has AVX2 and POPCNT (checked just above).
            let w = unsafe { select_avx2::<WEIGH>(self, p, r2, skip, out, h2) };
            return lane_total(&w);
        }
        lane_total(&select_portable::<WEIGH>(self, p, r2, skip, out, h2))
    }
}

/// The eight lanes' partial weights added in f64, lane by lane.
#[inline(always)]
fn lane_total(w: &[f32; LANES]) -> f64 {
    w.iter().map(|&x| x as f64).sum()
}

/// The poly6 weight (h² − d²)³ of a selected candidate (0 if it is not closer than h), as both
/// versions compute it: the cube as (t·t)·t.
#[inline(always)]
fn weight(d2: f32, h2: f32, selected: bool) -> f32 {
    let t = (h2 - d2).max(0.0);
    if selected { t * t * t } else { 0.0 }
}

/// The squared distance of one candidate, as both versions compute it: ((dx² + dy²) + dz²).
#[inline(always)]
fn distance2(cx: f32, cy: f32, cz: f32, p: [f32; 3]) -> f32 {
    let (dx, dy, dz) = (cx - p[0], cy - p[1], cz - p[2]);
    dx * dx + dy * dy + dz * dz
}

/// The hit test of one candidate.
#[cfg(test)]
fn inside(cx: f32, cy: f32, cz: f32, p: [f32; 3], r2: f32) -> bool {
    distance2(cx, cy, cz, p) < r2
}

/// The test for any CPU: a block of candidates into a bit mask (the compiler vectorises it),
/// then its set bits; with `WEIGH`, the lanes' poly6 weights.
fn select_portable<const WEIGH: bool>(
    c: &Candidates,
    p: [f32; 3],
    r2: f32,
    skip: u32,
    out: &mut Vec<u32>,
    h2: f32,
) -> [f32; LANES] {
    let mut w = [0.0f32; LANES];
    for b in (0..c.index.len()).step_by(LANES) {
        let mut mask = 0u32;
        for (k, lane) in w.iter_mut().enumerate() {
            let d2 = distance2(c.x[b + k], c.y[b + k], c.z[b + k], p);
            let hit = (d2 < r2) & (c.index[b + k] != skip);
            mask |= (hit as u32) << k;
            if WEIGH {
                *lane += weight(d2, h2, hit);
            }
        }
        while mask != 0 {
            out.push(c.index[b + mask.trailing_zeros() as usize]);
            mask &= mask - 1;
        }
    }
    w
}

/// For each 8-bit hit mask, the lanes of its set bits in order (then zeros): the permutation
/// that packs the hits of a block to its front.
#[cfg(target_arch = "x86_64")]
static PACK: [[u8; 8]; 256] = {
    let mut table = [[0u8; 8]; 256];
    let mut mask = 0;
    while mask < 256 {
        let (mut lane, mut n) = (0, 0);
        while lane < 8 {
            if mask & (1 << lane) != 0 {
                table[mask][n] = lane as u8;
                n += 1;
            }
            lane += 1;
        }
        mask += 1;
    }
    table
};

/// The AVX2 test: eight candidates per instruction, the hits packed by a permutation from
/// [`PACK`] and stored eight at a time (the lanes past the hits are overwritten by the next
/// store or left past the list's end).
///
/// With `WEIGH`, each lane also sums the poly6 weights of its selected candidates.
///
/// # Safety
/// The CPU must support AVX2 and POPCNT (the hit count; without it `count_ones` is a dozen
/// instructions on the loop's critical path), and `out` must have room for `c.index.len() + 8` more elements.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,popcnt")]
unsafe fn select_avx2<const WEIGH: bool>(
    c: &Candidates,
    p: [f32; 3],
    r2: f32,
    skip: u32,
    out: &mut Vec<u32>,
    h2: f32,
) -> [f32; LANES] {
    use std::arch::x86_64::*;
    let len = c.index.len();
    debug_assert!(len.is_multiple_of(8) && out.capacity() - out.len() >= len + 8);
    let (px, py, pz) = (
        _mm256_set1_ps(p[0]),
        _mm256_set1_ps(p[1]),
        _mm256_set1_ps(p[2]),
    );
    let radius2 = _mm256_set1_ps(r2);
    let support2 = _mm256_set1_ps(h2);
    let skipped = _mm256_set1_epi32(skip as i32);
    let base = out.len();
    let mut n = 0usize;
    let mut w = _mm256_setzero_ps();
    // SAFETY: every load reads 8 elements at b < len, len a multiple of 8; every store writes
    // 8 elements at base + n with n ≤ b ≤ len − 8, inside the reserved capacity.
    unsafe {
        let dst = out.as_mut_ptr().add(base);
        let mut b = 0;
        while b < len {
            let dx = _mm256_sub_ps(_mm256_loadu_ps(c.x.as_ptr().add(b)), px);
            let dy = _mm256_sub_ps(_mm256_loadu_ps(c.y.as_ptr().add(b)), py);
            let dz = _mm256_sub_ps(_mm256_loadu_ps(c.z.as_ptr().add(b)), pz);
            // ((dx² + dy²) + dz²), in the portable version's order.
            let d2 = _mm256_add_ps(
                _mm256_add_ps(_mm256_mul_ps(dx, dx), _mm256_mul_ps(dy, dy)),
                _mm256_mul_ps(dz, dz),
            );
            let ids = _mm256_loadu_si256(c.index.as_ptr().add(b).cast());
            let near = _mm256_cmp_ps::<_CMP_LT_OQ>(d2, radius2);
            let itself = _mm256_castsi256_ps(_mm256_cmpeq_epi32(ids, skipped));
            let hit = _mm256_movemask_ps(near) & !_mm256_movemask_ps(itself);
            if WEIGH {
                // (h² − d²)³ where selected, as `weight`: max(·, 0), then (t·t)·t.
                let t = _mm256_max_ps(_mm256_sub_ps(support2, d2), _mm256_setzero_ps());
                let t3 = _mm256_mul_ps(_mm256_mul_ps(t, t), t);
                w = _mm256_add_ps(w, _mm256_and_ps(t3, _mm256_andnot_ps(itself, near)));
            }
            let perm = _mm256_cvtepu8_epi32(_mm_loadl_epi64(
                PACK[hit as usize].as_ptr().cast::<__m128i>(),
            ));
            _mm256_storeu_si256(dst.add(n).cast(), _mm256_permutevar8x32_epi32(ids, perm));
            n += hit.count_ones() as usize;
            b += 8;
        }
        out.set_len(base + n);
        let mut lanes = [0.0f32; LANES];
        _mm256_storeu_ps(lanes.as_mut_ptr(), w);
        lanes
    }
}

/// The AVX-512 test: sixteen candidates per instruction, the hits packed by the compress
/// instruction (into a register, then one store: compressing straight to memory is microcoded
/// on some CPUs). A block of 8 left over at the end is tested with the upper half masked off.
///
/// With `WEIGH`, the weights are summed into eight lanes, the sixteen's lower half first, so
/// lane k adds candidates k, k + 8, k + 16, … in the order the AVX2 and portable tests add them
/// (the same bits).
///
/// # Safety
/// The CPU must support AVX-512F and POPCNT, and `out` must have room for `c.index.len() + 16` more
/// elements.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f,popcnt")]
unsafe fn select_avx512<const WEIGH: bool>(
    c: &Candidates,
    p: [f32; 3],
    r2: f32,
    skip: u32,
    out: &mut Vec<u32>,
    h2: f32,
) -> [f32; LANES] {
    use std::arch::x86_64::*;
    let len = c.index.len();
    debug_assert!(len.is_multiple_of(8) && out.capacity() - out.len() >= len + WIDE);
    let (px, py, pz) = (
        _mm512_set1_ps(p[0]),
        _mm512_set1_ps(p[1]),
        _mm512_set1_ps(p[2]),
    );
    let radius2 = _mm512_set1_ps(r2);
    let support2 = _mm512_set1_ps(h2);
    let skipped = _mm512_set1_epi32(skip as i32);
    let base = out.len();
    let mut n = 0usize;
    let mut w = _mm256_setzero_ps();
    // SAFETY: a load reads 16 elements at b ≤ len − 16, or (masked) 8 at b = len − 8; a store
    // writes 16 elements at base + n with n ≤ b ≤ len − 8, inside the reserved len + 16.
    unsafe {
        let dst = out.as_mut_ptr().add(base);
        let mut b = 0;
        while b < len {
            // The whole vector, or its lower half for a last block of 8.
            let lanes: __mmask16 = if b + WIDE <= len { 0xffff } else { 0x00ff };
            let dx = _mm512_sub_ps(_mm512_maskz_loadu_ps(lanes, c.x.as_ptr().add(b)), px);
            let dy = _mm512_sub_ps(_mm512_maskz_loadu_ps(lanes, c.y.as_ptr().add(b)), py);
            let dz = _mm512_sub_ps(_mm512_maskz_loadu_ps(lanes, c.z.as_ptr().add(b)), pz);
            // ((dx² + dy²) + dz²), in the portable version's order.
            let d2 = _mm512_add_ps(
                _mm512_add_ps(_mm512_mul_ps(dx, dx), _mm512_mul_ps(dy, dy)),
                _mm512_mul_ps(dz, dz),
            );
            let ids = _mm512_maskz_loadu_epi32(lanes, c.index.as_ptr().add(b).cast());
            let hit = _mm512_mask_cmp_ps_mask::<_CMP_LT_OQ>(lanes, d2, radius2)
                & _mm512_cmpneq_epi32_mask(ids, skipped);
            if WEIGH {
                // (h² − d²)³ where selected, as `weight`: max(·, 0), then (t·t)·t; the lower
                // eight lanes, then the upper.
                let t = _mm512_max_ps(_mm512_sub_ps(support2, d2), _mm512_setzero_ps());
                let t3 = _mm512_maskz_mov_ps(hit, _mm512_mul_ps(_mm512_mul_ps(t, t), t));
                w = _mm256_add_ps(w, _mm512_castps512_ps256(t3));
                let upper = _mm512_extractf64x4_pd::<1>(_mm512_castps_pd(t3));
                w = _mm256_add_ps(w, _mm256_castpd_ps(upper));
            }
            _mm512_storeu_si512(dst.add(n).cast(), _mm512_maskz_compress_epi32(hit, ids));
            n += hit.count_ones() as usize;
            b += WIDE;
        }
        out.set_len(base + n);
        let mut lanes = [0.0f32; LANES];
        _mm256_storeu_ps(lanes.as_mut_ptr(), w);
        lanes
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn packed_and_portable_tests_list_the_same_candidates_in_order() {
        let mut seed = 3u64;
        let mut rnd = || {
            seed = seed
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (seed >> 40) as f32 / (1u64 << 24) as f32
        };
        let mut c = Candidates::default();
        for n in [0usize, 1, 7, 8, 9, 200, 15, 16, 17, 24, 40] {
            c.x = (0..n).map(|_| rnd()).collect();
            c.y = (0..n).map(|_| rnd()).collect();
            c.z = (0..n).map(|_| rnd()).collect();
            c.index = (0..n as u32).map(|i| 3 * i + 1).collect();
            let padded = n.next_multiple_of(LANES);
            c.x.resize(padded, FAR);
            c.y.resize(padded, FAR);
            c.z.resize(padded, FAR);
            c.index.resize(padded, u32::MAX);
            let p = [0.5, 0.5, 0.5];
            let skip = if n > 3 { c.index[3] } else { u32::MAX };
            let mut fast = vec![9u32; 2];
            c.select(p, 0.1, skip, &mut fast);
            let mut portable = vec![9u32; 2];
            select_portable::<false>(&c, p, 0.1, skip, &mut portable, 0.0);
            // With weights: the same lists, and the same bits on both paths; h below the list
            // radius, so some listed candidates weigh nothing.
            let h2 = 0.08;
            let mut weighed = vec![9u32; 2];
            let w_fast = c.select_weighed(p, 0.1, skip, &mut weighed, h2);
            let mut weighed_portable = vec![9u32; 2];
            let w_portable = lane_total(&select_portable::<true>(
                &c,
                p,
                0.1,
                skip,
                &mut weighed_portable,
                h2,
            ));
            assert_eq!(weighed, fast, "{n} candidates");
            assert_eq!(weighed_portable, fast, "{n} candidates");
            assert_eq!(w_fast.to_bits(), w_portable.to_bits(), "{n} candidates");
            let exact: f64 = (0..n)
                .filter(|&k| c.index[k] != skip)
                .map(|k| {
                    let d = [c.x[k] - p[0], c.y[k] - p[1], c.z[k] - p[2]].map(|v| v as f64);
                    (h2 as f64 - (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]))
                        .max(0.0)
                        .powi(3)
                })
                .sum();
            assert!(
                (w_fast - exact).abs() <= 1e-5 * exact.max(1e-12),
                "{n} candidates: {w_fast} against {exact}"
            );
            let expected: Vec<u32> = [9, 9]
                .into_iter()
                .chain((0..n).filter_map(|k| {
                    (inside(c.x[k], c.y[k], c.z[k], p, 0.1) && c.index[k] != skip)
                        .then_some(c.index[k])
                }))
                .collect();
            assert_eq!(fast, expected, "{n} candidates");
            assert_eq!(portable, expected, "{n} candidates");
            if n == 200 {
                assert!(expected.len() > 20 && expected.len() < 100);
            }
            // Every vector path this CPU has, called directly (the dispatch above takes the
            // widest): the portable test's lists and bits.
            #[cfg(target_arch = "x86_64")]
            for (path, has) in [
                ("avx512f", std::arch::is_x86_feature_detected!("avx512f")),
                ("avx2", std::arch::is_x86_feature_detected!("avx2")),
            ] {
                if !(has && std::arch::is_x86_feature_detected!("popcnt")) {
                    continue;
                }
                let mut list = vec![9u32; 2];
                list.reserve(c.index.len() + WIDE);
                // SAFETY: the CPU has the feature (checked), `list` has the room.
                let w = unsafe {
                    match path {
                        "avx512f" => select_avx512::<true>(&c, p, 0.1, skip, &mut list, h2),
                        _ => select_avx2::<true>(&c, p, 0.1, skip, &mut list, h2),
                    }
                };
                assert_eq!(list, expected, "{path}, {n} candidates");
                assert_eq!(
                    lane_total(&w).to_bits(),
                    w_portable.to_bits(),
                    "{path}, {n}"
                );
            }
        }
    }
}
