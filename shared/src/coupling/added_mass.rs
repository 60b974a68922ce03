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
//! below a weight per step; a heavy rock in open water never comes near (a).
//!
//! A heavy block (ρ_b ≥ ρ_w) is outweighed only by the film it squeezes against the floor or a
//! wall as it lands, and that film is gone once the block rests on the contact: its swing is a
//! burst, not a growth without end: with the watch off under DFSPH, such bursts rose to some
//! tens of weights per step, decayed within a few dozen steps, and the runs completed, while the
//! one heavy landing that did grow without end (walls' pressure extrapolated) went on to
//! thousands of weights and threw the block (docs/stability.md). So for a heavy block (a) with
//! (b) and (c) is a warning, once per burst, naming what is unreliable (the block's motion over
//! the burst: it may bounce), and only a swing past [`HEAVY_SWING`] weights, well above any
//! landing burst and well below a growth without end, stops the run. A light block's swing
//! stops it at (a).

use crate::math::{Real, Vector};
use crate::protocol::BlockLoad;
use std::collections::VecDeque;

/// Steps of load history watched.
pub const WINDOW: usize = 24;
/// A step-to-step load change of more than this many block weights is suspicious.
pub const SWING: Real = 10.0;
/// A heavy block's swing past this many weights per step stops the run (below it, above
/// [`SWING`], it is a landing's burst: a warning): between the landing bursts and a growth
/// without end (module doc).
pub const HEAVY_SWING: Real = 1000.0;

/// What the watch makes of a step's loads, when it is not nothing.
#[derive(Debug, Clone, PartialEq)]
pub enum Verdict {
    /// The added-mass instability: the run must stop.
    Unstable(String),
    /// A heavy block's landing burst: the run goes on, with this warning.
    Burst(String),
}

/// One moving block as the monitor sees it.
#[derive(Debug, Clone, serde::Serialize, serde::Deserialize)]
struct Watched {
    name: String,
    mass: Real,
    density: Real,
    last: Option<Vector>,
    /// The last [`WINDOW`] load changes, oldest first.
    changes: VecDeque<Vector>,
    /// Within a burst already warned of (a heavy block's swing above [`SWING`] weights).
    bursting: bool,
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
                    bursting: false,
                })
                .collect(),
            gravity,
            water_density,
        }
    }

    /// Takes the loads of one step; the verdict once an instability or a burst is seen. Every
    /// block's load is taken (a burst does not stop the run, so no block may miss a step); an
    /// instability of any block comes before another's burst.
    pub fn observe(&mut self, loads: &[BlockLoad]) -> Option<Verdict> {
        let mut verdict = None;
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
            match (b.diagnose(self.gravity, self.water_density), &verdict) {
                (Some(v @ Verdict::Unstable(_)), _) => return Some(v),
                // One warning per step: a second block's burst is named at its next step.
                (Some(v), None) => {
                    b.bursting = true;
                    verdict = Some(v);
                }
                _ => {}
            }
        }
        verdict
    }
}

impl Watched {
    fn diagnose(&mut self, gravity: Real, water_density: Real) -> Option<Verdict> {
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
        let oscillates = |swing: Real| newer > swing * weight && grew && reversals >= 2;
        let growth = newer / older.max(Real::MIN_POSITIVE);
        if ratio < 1.0 {
            return oscillates(SWING).then(|| {
                self.unstable(
                    (n, growth, newer, weight, reversals, ratio),
                    "is too light for one-step-lagged loads",
                    "relax the loads (--added-mass 1); DFSPH: blocks in its solve (blocks_in_solve, default; parallel scheme); WCSPH: a smaller --dt-factor",
                )
            });
        }
        if oscillates(HEAVY_SWING) {
            return Some(self.unstable(
                (n, growth, newer, weight, reversals, ratio),
                "squeezes water against a wall past a landing's burst",
                "WCSPH holds such landings; DFSPH (blocks in solve, mirrored walls) most, not all; relaxing loads only moves it",
            ));
        }
        if newer <= SWING * weight {
            self.bursting = false;
            return None;
        }
        if !oscillates(SWING) || self.bursting {
            return None;
        }
        Some(Verdict::Burst(format!(
            "the water's load on block '{}' (ρ_b/ρ_w = {ratio:.4}) bursts to {:.0} weights per step (×{growth:.1} in {n} steps, {reversals} reversals): a landing squeezing water against a wall; the run goes on (it stops past {HEAVY_SWING:.0} weights), but the block's motion over the burst is unreliable (it may bounce)",
            self.name,
            newer / weight,
        )))
    }

    /// The added-mass instability, named. The status message that carries it is 512 bytes: the
    /// cause and fix are kept short enough that the whole message fits (a test checks it with a
    /// long block name).
    ///
    /// Given the window's length, the swing's growth over it, the newest swing [N], the
    /// block's weight [N], the reversals and ρ_b/ρ_w.
    fn unstable(
        &self,
        (n, growth, newer, weight, reversals, ratio): (usize, Real, Real, Real, usize, Real),
        cause: &str,
        fix: &str,
    ) -> Verdict {
        Verdict::Unstable(format!(
            "added-mass instability of the partitioned coupling: the water's load on block '{}' swings and grows (×{growth:.1} in {n} steps to {newer:.3e} N, {:.0} weights, {reversals} reversals); the block (ρ_b/ρ_w = {ratio:.4}) {cause}; fix: {fix}",
            self.name,
            newer / weight,
        ))
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
            if let Some(Verdict::Unstable(msg)) = mon.observe(&[load(f)]) {
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
            let mut burst = None;
            let msg = (0..200)
                .find_map(|n| {
                    let f = if n % 2 == 0 { 1.0 } else { -1.0 } * 1.2f64.powi(n) * 1e-3;
                    match mon.observe(&[load(f)])? {
                        Verdict::Unstable(msg) => Some(msg),
                        Verdict::Burst(msg) => {
                            burst = Some(msg);
                            None
                        }
                    }
                })
                .expect("a growing swing is named");
            let full = format!(
                "solid node (explicit, pid 4194304) went unstable at step 123456, t = 12.345678 s: [explicit] unstable: {msg}"
            );
            assert!(full.len() <= 512, "{} bytes: {full}", full.len());
            assert!(msg.contains(name) && msg.contains("fix: "), "{msg}");
            // A heavy block's swing is first a burst (a warning, its own 512-byte message),
            // and named unstable only past HEAVY_SWING.
            if density > 1000.0 {
                let burst = burst.expect("a heavy block's growing swing warns first");
                assert!(burst.len() <= 512, "{} bytes: {burst}", burst.len());
                assert!(
                    burst.contains(name) && burst.contains("unreliable"),
                    "{burst}"
                );
                assert!(msg.contains("past a landing's burst"), "{msg}");
            } else {
                assert!(burst.is_none());
            }
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

    /// A heavy block's landings, shaped like those seen under DFSPH: the swing rises past `SWING`
    /// weights to 47, decays, and later rises to 145. One warning per burst, no stop; the same
    /// swing on a light block stops the run at once.
    #[test]
    fn a_heavy_blocks_landing_burst_warns_once_and_goes_on() {
        let (g, m) = (9.81, 10.0);
        let weight = m * g;
        // Steps of quiet noise (a tenth of a weight), then an alternating swing growing ×1.5 per
        // step to 47 weights and decaying ×0.6 per step.
        let burst = |n: usize, peak: Real| -> Real {
            let k = n as i32;
            let amplitude = if k < 14 {
                1.5 * 1.5f64.powi(k)
            } else {
                1.5 * 1.5f64.powi(13) * 0.6f64.powi(k - 13)
            };
            amplitude.clamp(0.1, peak)
        };
        let series: Vec<Real> = (0..300)
            .map(|n| {
                let alternating = if n % 2 == 0 { 1.0 } else { -1.0 };
                let swing = match n {
                    0..50 => 0.1,
                    50..150 => burst(n - 50, 47.0),
                    150..200 => 0.1,
                    _ => burst(n - 200, 145.0),
                };
                alternating * 0.5 * swing * weight
            })
            .collect();
        assert!(series.iter().any(|f| f.abs() > 70.0 * weight));
        let mut heavy = AddedMassMonitor::new(vec![("rock".into(), m, 2500.0)], g, 1000.0);
        let verdicts: Vec<Verdict> = series
            .iter()
            .filter_map(|&f| heavy.observe(&[load(f)]))
            .collect();
        assert_eq!(verdicts.len(), 2, "{verdicts:?}");
        for v in &verdicts {
            assert!(
                matches!(v, Verdict::Burst(msg) if msg.contains("'rock'") && msg.contains("2.5000")),
                "{v:?}"
            );
        }
        // Two heavy blocks, the second bursting a step after the first: each burst is named
        // once (one warning per step, so the second's maybe a step late) and the second block
        // misses no step of its history for the first one's warning.
        let mut two = AddedMassMonitor::new(
            vec![("rock".into(), m, 2500.0), ("wedge".into(), m, 2500.0)],
            g,
            1000.0,
        );
        let shifted = std::iter::once(0.0).chain(series.iter().copied());
        let named: Vec<String> = series
            .iter()
            .zip(shifted)
            .filter_map(|(&a, b)| two.observe(&[load(a), load(b)]))
            .map(|v| match v {
                Verdict::Burst(msg) => msg,
                Verdict::Unstable(msg) => panic!("{msg}"),
            })
            .collect();
        for name in ["'rock'", "'wedge'"] {
            assert_eq!(
                named.iter().filter(|m| m.contains(name)).count(),
                2,
                "{named:?}"
            );
        }
        let mut light = AddedMassMonitor::new(vec![("raft".into(), m, 500.0)], g, 1000.0);
        let first = series.iter().find_map(|&f| light.observe(&[load(f)]));
        assert!(
            matches!(&first, Some(Verdict::Unstable(msg)) if msg.contains("too light")),
            "{first:?}"
        );
    }
}
