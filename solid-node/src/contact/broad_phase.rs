//! Broad phase: sweep and prune along x over the blocks' bounding boxes.
//!
//! The sweep order is kept between steps, so the sort of a nearly-sorted list costs O(n), and
//! the sweep itself O(n + overlaps) instead of the O(n²) of testing all pairs. Two active
//! lists are kept, free blocks and the others: a fixed or kinematic block is only ever tested
//! against free blocks, so fixed–fixed (and kinematic–fixed) pairs are never even compared.

use crate::blocks::block::Block;
use shared::math::Real;

/// Candidate pairs of overlapping bounding boxes.
#[derive(Debug, Clone, Default, serde::Serialize, serde::Deserialize)]
pub struct BroadPhase {
    order: Vec<u32>,
    active_free: Vec<u32>,
    active_other: Vec<u32>,
    /// Pairs (a, b) with a < b, sorted, at least one of them free.
    pub pairs: Vec<(u32, u32)>,
}

#[inline]
fn overlap(a: &Block, b: &Block, margin: Real) -> bool {
    // x overlap is guaranteed by the sweep; check y and z.
    (1..3)
        .all(|k| a.aabb_min[k] <= b.aabb_max[k] + margin && b.aabb_min[k] <= a.aabb_max[k] + margin)
}

impl BroadPhase {
    /// Finds the pairs whose boxes, grown by `margin`, overlap. Allocation-free once warm.
    pub fn update(&mut self, blocks: &[Block], margin: Real) {
        if self.order.len() != blocks.len() {
            self.order = (0..blocks.len() as u32).collect();
        }
        self.order.sort_unstable_by(|&i, &j| {
            blocks[i as usize]
                .aabb_min
                .x
                .total_cmp(&blocks[j as usize].aabb_min.x)
        });
        self.active_free.clear();
        self.active_other.clear();
        self.pairs.clear();
        for &i in &self.order {
            let bi = &blocks[i as usize];
            let lo = bi.aabb_min.x - margin;
            self.active_free
                .retain(|&j| blocks[j as usize].aabb_max.x >= lo);
            self.active_other
                .retain(|&j| blocks[j as usize].aabb_max.x >= lo);
            for &j in &self.active_free {
                if overlap(bi, &blocks[j as usize], margin) {
                    self.pairs.push((i.min(j), i.max(j)));
                }
            }
            if bi.is_free() {
                for &j in &self.active_other {
                    if overlap(bi, &blocks[j as usize], margin) {
                        self.pairs.push((i.min(j), i.max(j)));
                    }
                }
                self.active_free.push(i);
            } else {
                self.active_other.push(i);
            }
        }
        self.pairs.sort_unstable();
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use shared::scene::{BlockKind, BlockSpec, ShapeSpec};

    fn cube(kind: BlockKind, min: [f64; 3], size: f64) -> Block {
        let max = [min[0] + size, min[1] + size, min[2] + size];
        let spec = BlockSpec::plain("c", kind, ShapeSpec::Box { min, max }, 1000.0);
        Block::from_spec(0, &spec).unwrap()
    }

    /// Against brute force on a random cloud, and never a fixed–fixed pair.
    #[test]
    fn matches_brute_force_without_fixed_pairs() {
        let mut seed = 12345u64;
        let mut rnd = || {
            seed = seed
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (seed >> 11) as f64 / (1u64 << 53) as f64
        };
        let blocks: Vec<Block> = (0..300)
            .map(|i| {
                let kind = [BlockKind::Free, BlockKind::Fixed, BlockKind::Kinematic][i % 3];
                cube(kind, [rnd() * 10.0, rnd() * 10.0, rnd() * 3.0], 0.3 + rnd())
            })
            .collect();
        let mut bp = BroadPhase::default();
        bp.update(&blocks, 0.01);
        let mut brute = Vec::new();
        for i in 0..blocks.len() {
            for j in i + 1..blocks.len() {
                let (a, b) = (&blocks[i], &blocks[j]);
                if !a.is_free() && !b.is_free() {
                    continue;
                }
                if (0..3).all(|k| {
                    a.aabb_min[k] <= b.aabb_max[k] + 0.01 && b.aabb_min[k] <= a.aabb_max[k] + 0.01
                }) {
                    brute.push((i as u32, j as u32));
                }
            }
        }
        assert!(
            brute.len() > 100,
            "too few overlaps to mean anything: {}",
            brute.len()
        );
        assert_eq!(bp.pairs, brute);
        assert!(
            bp.pairs
                .iter()
                .all(|&(i, j)| blocks[i as usize].is_free() || blocks[j as usize].is_free())
        );
    }
}
