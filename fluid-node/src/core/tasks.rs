//! How finely a parallel pass is cut into tasks, so that no thread waits long enough at its end
//! to fall asleep.
//!
//! rayon cuts a pass into a few large pieces and splits a piece further only when another
//! thread steals it; the piece a thread is running is never cut again. When the work per
//! particle is uneven (a pair loop: a particle at a wall or under the column has more
//! neighbours than one at the free surface; Eq. 22: only particles near a block compute a
//! force), one thread ends its share while the other is still inside a piece of several
//! thousand particles. A rayon worker that finds no work for 32 rounds of `sched_yield` goes to
//! sleep, and the next pass must wake it: a futex call on the thread that starts the pass, and
//! a wait before the woken thread runs that is long on a virtual machine
//! (docs/journal/2026-11-performance.md, "Inner loops, sixth round"). These limits make a step
//! put a thread to sleep far more rarely.
//!
//! The limits are on the tasks, not on the results: every particle is computed as before and
//! written by one task, so a run is the same to the bit with any cut (the sums that must not
//! depend on the cut are in [`crate::core::exact_sum`]). Scatters through an index list cut
//! themselves by their own rule ([`crate::core::scatter`]).

/// Particles per task, at most, in a pass whose work per particle varies (pair loops, Eq. 22,
/// the wall marks): ~15 µs on one core for the heaviest pass (Müller's forces, ~60 ns a
/// particle), a few µs for the lighter ones, all below rayon's ~20 µs of spinning; ~120 tasks
/// for 31 250 particles, whose cost (a deque push and pop each) is lost in the pass (the
/// 1-thread rates did not move).
pub const PARTICLES: usize = 256;

/// Chunks per task, at most, where a pass runs over chunks of particles (the neighbour lists'
/// chunks, the survey's, `exact_sum`'s blocks): each chunk is its own task.
pub const CHUNKS: usize = 1;
