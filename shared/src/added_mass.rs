//! Detection of the added-mass instability of partitioned coupling (Causin, Gerbeau & Nobile
//! 2005; Förster, Wall & Ramm 2007).
//!
//! Both coupling schemes hand the solid the fluid's loads of the previous state: the block's
//! acceleration at step n is answered by the water one step later. When the water that reacts
//! within one step outweighs the block, the lagged reaction overshoots: the load on the block
//! flips direction every step and grows, a period-2 oscillation that no solver of either side
//! sees as its own fault (the fluid is within its CFL limit, the block within its explicit
//! limit, and the energy the loads supply is booked as work).
//!
//! For weakly compressible SPH the water under a block answers within one step as a spring
//! k ≈ ρ_w c² A / h (a kernel-deep layer compressed at sound speed c); a spring whose force
//! lags one step, x_{n+1} − 2x_n + x_{n−1} = −Ω² x_{n−1}, has roots 1 ± iΩ: it always grows,
//! by sqrt(1 + Ω²) per step, in an oscillation of about 2π/atan(Ω) steps, which the water's
//! own dissipation damps only while Ω is small. Ω² = (ρ_w/ρ_b)(c·dt)²/(h·H) for a block of
//! height H, so the limit is a block-to-water density ratio of order (c·dt/h)²·h/H — a few
//! thousandths to a hundredth for the validation tank (docs/stability.md has the measured
//! bracket) — and it falls with dt².
//!
//! The monitor watches, for each free block, the change of the fluid load from one step to
//! the next over the last [`WINDOW`] steps: the oscillation is there when the change
//! (a) exceeds [`SWING`] times the block's weight (the load swings the block's acceleration by
//! more than 10 g per step), (b) has at least doubled from the older to the newer half of the
//! window from more than a weight per step (so a block slamming back into the water after a
//! flight, its load rising from nothing, is not taken for it), and (c) has reversed direction
//! at least twice within it. A stable light block stays
//! below a weight per step; a heavy rock never comes near (a).

use crate::math::{Real, Vector};
use crate::protocol::BlockLoad;
use std::collections::VecDeque;

/// Steps of load history watched.
pub const WINDOW: usize = 24;
/// A step-to-step load change of more than this many block weights is suspicious.
pub const SWING: Real = 10.0;

/// One moving block as the monitor sees it.
#[derive(Debug, Clone, serde::Serialize, serde::Deserialize)]
struct Watched {
    name: String,
    mass: Real,
    density: Real,
    last: Option<Vector>,
    /// The last [`WINDOW`] load changes, oldest first.
    changes: VecDeque<Vector>,
}

/// Watches the loads of the moving blocks, step by step.
#[derive(Debug, Clone, serde::Serialize, serde::Deserialize)]
pub struct AddedMassMonitor {
    blocks: Vec<Watched>,
    /// |g| [m/s²].
    gravity: Real,
    /// ρ_water [kg/m³], for the message.
    water_density: Real,
}

impl AddedMassMonitor {
    /// `blocks`: (name, mass [kg], density [kg/m³]) of each moving block, in loads order.
    /// Kinematic blocks (their motion is prescribed, loads cannot move them) are given an
    /// infinite mass and never flagged.
    pub fn new(blocks: Vec<(String, Real, Real)>, gravity: Real, water_density: Real) -> Self {
        Self {
            blocks: blocks
                .into_iter()
                .map(|(name, mass, density)| Watched {
                    name,
                    mass,
                    density,
                    last: None,
                    changes: VecDeque::with_capacity(WINDOW + 1),
                })
                .collect(),
            gravity,
            water_density,
        }
    }

    /// Takes the loads of one step; the message naming the instability once it is seen.
    pub fn observe(&mut self, loads: &[BlockLoad]) -> Option<String> {
        for (b, load) in self.blocks.iter_mut().zip(loads) {
            let f = Vector::from(load.force);
            if !(b.mass.is_finite() && f.iter().all(|x| x.is_finite())) {
                continue;
            }
            if let Some(last) = b.last {
                if b.changes.len() == WINDOW {
                    b.changes.pop_front();
                }
                b.changes.push_back(f - last);
            }
            b.last = Some(f);
            if let Some(msg) = b.diagnose(self.gravity, self.water_density) {
                return Some(msg);
            }
        }
        None
    }
}

impl Watched {
    fn diagnose(&self, gravity: Real, water_density: Real) -> Option<String> {
        let n = self.changes.len();
        if n < 8 {
            return None;
        }
        let weight = self.mass * gravity;
        let largest = |range: std::ops::Range<usize>| {
            range.map(|i| self.changes[i].norm()).fold(0.0, Real::max)
        };
        let (older, newer) = (largest(0..n / 2), largest(n / 2..n));
        let reversals = (1..n)
            .filter(|&i| self.changes[i].dot(&self.changes[i - 1]) < 0.0)
            .count();
        // An oscillation already above a weight per step that doubled: a block slamming back
        // into the water after a flight (loads from nothing to many weights) is not one.
        let grew = older > weight && newer > 2.0 * older;
        let ratio = self.density / water_density;
        // A light block is outweighed by the water that moves with it; a heavy one only by the
        // film it squeezes against a wall or the floor (docs/REFERENCES.md §4.1–4.1b).
        // The status message that carries this is 512 bytes: the cause and fix are kept short
        // enough that the whole message fits (a test checks it with a long block name).
        let (cause, fix) = if ratio < 1.0 {
            (
                "is too light for one-step-lagged loads",
                "relax the loads (--added-mass 1); DFSPH: blocks in its solve (blocks_in_solve, default; parallel scheme); WCSPH: a smaller --dt-factor",
            )
        } else {
            (
                "squeezes water that outweighs it against a wall",
                "DFSPH's defaults (blocks in solve, mirrored walls) hold most landings, not all; WCSPH holds them; relaxing loads only moves it",
            )
        };
        (newer > SWING * weight && grew && reversals >= 2).then(|| {
            format!(
                "added-mass instability of the partitioned coupling: the water's load on block '{}' swings and grows (×{:.1} in {n} steps to {:.3e} N, {:.0} weights, {reversals} reversals); the block (ρ_b/ρ_w = {ratio:.4}) {cause}; fix: {fix}",
                self.name,
                newer / older.max(Real::MIN_POSITIVE),
                newer,
                newer / weight,
            )
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn load(fz: Real) -> BlockLoad {
        BlockLoad::vertical(fz)
    }

    /// A spring of Ω² = ω²dt² = 0.5 on a light block, the model of the water's one-step answer:
    /// with the force of the previous position it grows (×sqrt(1.5) per step) and is named
    /// within a couple of oscillations; with the force of the current position (no lag) it is
    /// the same swing, bounded, and never flagged.
    fn spring(lagged: bool, steps: usize) -> Option<(usize, String)> {
        let (m, dt, g) = (0.01, 1e-3, 9.81);
        let k = 0.5 * m / (dt * dt);
        let (mut x, mut x_old, mut v) = (1e-3, 1e-3, 0.0);
        let mut mon = AddedMassMonitor::new(vec![("light".into(), m, 10.0)], g, 1000.0);
        for n in 0..steps {
            let f = -k * if lagged { x_old } else { x };
            if let Some(msg) = mon.observe(&[load(f)]) {
                return Some((n, msg));
            }
            v += f / m * dt;
            x_old = x;
            x += v * dt;
        }
        None
    }

    #[test]
    fn names_a_lagged_spring_and_nothing_that_does_not_grow() {
        let (n, msg) = spring(true, 60).expect("the lagged spring is unstable");
        assert!(n < 30, "flagged late, at step {n}");
        assert!(
            msg.contains("added-mass") && msg.contains("'light'") && msg.contains("0.0100"),
            "{msg}"
        );
        assert!(spring(false, 2000).is_none());
        // The whole report fits the 512-byte status message, with the runtime's prefix and a
        // long block name, light or heavy: the fix is not cut off.
        for density in [10.0, 3000.0] {
            let name = "a_block_with_a_forty_character_long_name";
            let mut mon = AddedMassMonitor::new(vec![(name.into(), 0.01, density)], 9.81, 1000.0);
            let msg = (0..200)
                .find_map(|n| {
                    let f = if n % 2 == 0 { 1.0 } else { -1.0 } * 1.2f64.powi(n) * 1e-3;
                    mon.observe(&[load(f)])
                })
                .expect("a growing swing is named");
            let full = format!(
                "solid node (explicit, pid 4194304) went unstable at step 123456, t = 12.345678 s: [explicit] unstable: {msg}"
            );
            assert!(full.len() <= 512, "{} bytes: {full}", full.len());
            assert!(msg.contains(name) && msg.contains("fix: "), "{msg}");
        }

        let g = 9.81;
        let mut heavy = AddedMassMonitor::new(vec![("heavy".into(), 1e6, 2500.0)], g, 1000.0);
        let mut noisy = AddedMassMonitor::new(vec![("noisy".into(), 0.01, 10.0)], g, 1000.0);
        for n in 0..200 {
            let alternating = if n % 2 == 0 { 1.0 } else { -1.0 };
            // Growing, but never a weight of a 1000 t block per step.
            assert!(heavy.observe(&[load(alternating * n as Real)]).is_none());
            // Swings of 50 weights per step that do not grow.
            assert!(noisy.observe(&[load(alternating * 2.5)]).is_none());
        }
    }
}
