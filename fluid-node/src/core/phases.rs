//! Where a step's time goes: a [`PhaseClock`] that sums wall time per [`Phase`] of the step
//! (the sort, the list builds, the density and force passes, …), for `fluid-bench --phases`.
//!
//! Why here and not in a profiler: the 2 ÷ 1-thread question is about which *parallel region*
//! waits, and a region's wall time on the calling thread is what a sampling profiler does not
//! give directly. The phase tables of docs/PERFORMANCE.md come from this clock.
//!
//! Cost: the clock lives in the [`crate::system::FluidSystem`] and is off unless a caller turns
//! it on. Off, a phase costs one test of a `bool` ([`PhaseClock::start`] returns `None`, and
//! [`PhaseClock::stop`] and [`PhaseClock::lap`] do nothing with `None`); no `Instant::now()`,
//! no allocation (the sums are a fixed array). The clock reads no particle and writes none, so a
//! run is the same to the bit with it on or off (test `fluid-node/tests/phases.rs`).
//!
//! The phases are the function calls a step already makes: the shared ones in
//! [`crate::system`] and [`crate::sph`], the scheme's in its own `step`. Time outside every
//! phase (the step grant, the scheme's bookkeeping) is what a caller's step time exceeds their
//! sum by.

use std::time::{Duration, Instant};

/// A phase of a fluid step. Each scheme enters the ones its step has; which scheme enters
/// which is said per variant.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Phase {
    /// On several ranks: the hand-over of particles at a sort and the halo's rates after each
    /// evaluation, waiting included (`crate::ranks::share`).
    Halo,
    /// The counting sort of the particles by cell (`CellGrid::sort`, grid.rs).
    Sort,
    /// The particle arrays put in the sorted order (`Particles::permute`).
    Permutation,
    /// The fluid's neighbour lists (`NeighborLists::build`; with Müller also the poly6 sums of
    /// its density).
    FluidLists,
    /// The fluid's neighbours among the boundary particles, fixed and moving, and the wall
    /// particles' activation (`Boundary::list_fixed`, `list_moving`).
    WallLists,
    /// Paper Eq. 22 against the blocks and the terrain (`Penalty::apply`,
    /// `TerrainPenalty::apply`).
    Penalty,
    /// The water's loads on the moving blocks: the scheme's `react` or `step_loads`, and
    /// `Boundary::add_loads`.
    BlockLoads,
    /// The density pass: Müller's Eq. 12 and 17 with the pair records; WCSPH's equation of
    /// state and pair records; DFSPH's densities and factors (with its pair values).
    Density,
    /// The boundary particles' pressures (Adami's extrapolation, `Boundary::update`) and
    /// records; DFSPH with mirrored walls: the last step's stiffness they are bounded by.
    WallPressures,
    /// The force pass: Müller's Eqs. 14, 18, 20 with Eq. 21's integration in the same pass;
    /// WCSPH's rates (momentum and continuity); DFSPH's non-pressure forces.
    Forces,
    /// DFSPH's divergence solve (2017 Algorithm 2).
    DivergenceSolve,
    /// DFSPH's constant-density solve (2017 Algorithm 3).
    DensitySolve,
    /// DFSPH's free blocks outside the solves: their damping and their non-pressure part.
    Blocks,
    /// WCSPH's predictor (the half step before the force evaluation).
    Predictor,
    /// The integration after the forces: WCSPH's corrector (or Verlet's step) and the
    /// pressures of the new densities; DFSPH's positions and pressures.
    Integration,
    /// The end-of-step checks (`Survey::of`: finite, in the domain, density bound, moved).
    Survey,
    /// The gauges and probes (`Recorder::sample`).
    Gauges,
}

impl Phase {
    /// Every phase, in step order (the order of [`PhaseClock`]'s array and of the tables).
    pub const ALL: [Phase; 17] = [
        Phase::Halo,
        Phase::Sort,
        Phase::Permutation,
        Phase::FluidLists,
        Phase::WallLists,
        Phase::Penalty,
        Phase::BlockLoads,
        Phase::Density,
        Phase::WallPressures,
        Phase::Forces,
        Phase::DivergenceSolve,
        Phase::DensitySolve,
        Phase::Blocks,
        Phase::Predictor,
        Phase::Integration,
        Phase::Survey,
        Phase::Gauges,
    ];
    pub const COUNT: usize = Self::ALL.len();

    /// The phase's row label in `fluid-bench --phases`.
    pub fn label(self) -> &'static str {
        match self {
            Phase::Halo => "halo messages",
            Phase::Sort => "sort",
            Phase::Permutation => "permutation",
            Phase::FluidLists => "fluid lists",
            Phase::WallLists => "wall lists, activation",
            Phase::Penalty => "Eq. 22",
            Phase::BlockLoads => "loads on moving blocks",
            Phase::Density => "density pass",
            Phase::WallPressures => "wall pressures",
            Phase::Forces => "forces",
            Phase::DivergenceSolve => "divergence solve",
            Phase::DensitySolve => "density solve",
            Phase::Blocks => "free blocks",
            Phase::Predictor => "predictor",
            Phase::Integration => "integration",
            Phase::Survey => "survey",
            Phase::Gauges => "gauges, probes",
        }
    }
}

/// Wall time summed per [`Phase`], and how often each was entered; off by default.
///
/// Use: `let t = clock.start(); …; clock.stop(Phase::Sort, t)`, or `lap` between two phases that
/// follow each other (one `Instant::now()` for the end of one and the start of the next).
#[derive(Debug, Clone, Default)]
pub struct PhaseClock {
    enabled: bool,
    total: [Duration; Phase::COUNT],
    calls: [u64; Phase::COUNT],
}

impl PhaseClock {
    /// Turns the clock on or off (the sums are kept; [`Self::reset`] clears them).
    pub fn set_enabled(&mut self, on: bool) {
        self.enabled = on;
    }

    pub fn enabled(&self) -> bool {
        self.enabled
    }

    /// Clears the sums and counts.
    pub fn reset(&mut self) {
        self.total = [Duration::ZERO; Phase::COUNT];
        self.calls = [0; Phase::COUNT];
    }

    /// The start of a phase: the time now if the clock is on, else `None` (and no clock read).
    #[inline(always)]
    pub fn start(&self) -> Option<Instant> {
        if self.enabled {
            Some(Instant::now())
        } else {
            None
        }
    }

    /// Ends `phase`, begun at `started` ([`Self::start`]); nothing if that was `None`.
    #[inline(always)]
    pub fn stop(&mut self, phase: Phase, started: Option<Instant>) {
        if let Some(t) = started {
            self.add(phase, t.elapsed());
        }
    }

    /// Ends `phase`, begun at `started`, and starts the next one at the same instant.
    #[inline(always)]
    pub fn lap(&mut self, phase: Phase, started: Option<Instant>) -> Option<Instant> {
        started.map(|t| {
            let now = Instant::now();
            self.add(phase, now - t);
            now
        })
    }

    fn add(&mut self, phase: Phase, d: Duration) {
        self.total[phase as usize] += d;
        self.calls[phase as usize] += 1;
    }

    /// Wall time in `phase` since the last reset.
    pub fn total(&self, phase: Phase) -> Duration {
        self.total[phase as usize]
    }

    /// Times `phase` was entered since the last reset.
    pub fn calls(&self, phase: Phase) -> u64 {
        self.calls[phase as usize]
    }

    /// The sum over every phase.
    pub fn sum(&self) -> Duration {
        self.total.iter().sum()
    }

    /// The sums as words, phase by phase (seconds, calls): another rank's clock for rank 0.
    pub fn to_words(&self) -> Vec<f64> {
        Phase::ALL
            .iter()
            .flat_map(|&p| [self.total(p).as_secs_f64(), self.calls(p) as f64])
            .collect()
    }

    /// A clock with the sums of [`Self::to_words`] (off).
    pub fn from_words(words: &[f64]) -> Self {
        let mut clock = Self::default();
        for (k, w) in words.chunks_exact(2).take(Phase::COUNT).enumerate() {
            clock.total[k] = Duration::from_secs_f64(w[0]);
            clock.calls[k] = w[1] as u64;
        }
        clock
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The array index of each phase is its place in `ALL` (the tables' order).
    #[test]
    fn all_lists_every_phase_in_index_order() {
        for (k, p) in Phase::ALL.iter().enumerate() {
            assert_eq!(*p as usize, k, "{p:?}");
        }
    }

    /// Off (the default), nothing is read or recorded.
    #[test]
    fn a_disabled_clock_records_nothing() {
        let mut c = PhaseClock::default();
        assert!(!c.enabled());
        let t = c.start();
        assert!(t.is_none());
        std::thread::sleep(Duration::from_millis(1));
        let t = c.lap(Phase::Sort, t);
        assert!(t.is_none());
        c.stop(Phase::Forces, t);
        for p in Phase::ALL {
            assert_eq!(c.total(p), Duration::ZERO, "{p:?}");
            assert_eq!(c.calls(p), 0, "{p:?}");
        }
    }

    /// On, each phase sums its own intervals; a lap ends one phase where the next begins;
    /// reset clears.
    #[test]
    fn an_enabled_clock_accumulates_per_phase() {
        let mut c = PhaseClock::default();
        c.set_enabled(true);
        let nap = Duration::from_millis(2);
        for _ in 0..2 {
            let t = c.start();
            std::thread::sleep(nap);
            let t = c.lap(Phase::Sort, t);
            std::thread::sleep(nap);
            c.stop(Phase::Forces, t);
        }
        assert_eq!(c.calls(Phase::Sort), 2);
        assert_eq!(c.calls(Phase::Forces), 2);
        assert!(c.total(Phase::Sort) >= 2 * nap);
        assert!(c.total(Phase::Forces) >= 2 * nap);
        assert_eq!(c.total(Phase::Density), Duration::ZERO);
        assert_eq!(c.sum(), c.total(Phase::Sort) + c.total(Phase::Forces));
        c.set_enabled(false);
        let before = c.total(Phase::Sort);
        let t = c.start();
        c.stop(Phase::Sort, t);
        assert_eq!(c.total(Phase::Sort), before, "off again: nothing added");
        c.reset();
        assert_eq!(c.sum(), Duration::ZERO);
        assert_eq!(c.calls(Phase::Sort), 0);
    }
}
