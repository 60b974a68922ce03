//! A pressure solve that does nothing, step after step, stops the run by name.
//!
//! A solve whose error grows goes back to its iterate of smallest error (module doc,
//! "Stopping"). When that iterate is the solve's start (the warm start, before its first
//! iteration) and the error is above the tolerance, the step applied no correction of its own:
//! the solve *stalled*. One such step need not be a failure (the next solve starts from a
//! new state). Step after step it means the Jacobi iteration diverges from its first iteration
//! on this particle arrangement, and the water is no longer held: it compresses a little more
//! each step until a density passes `density_ratio_bound`, whose message points at the step
//! instead of the solve, or, if a later solve catches up at once, it is thrown apart (the first
//! seen with `smoothing_ratio` = 1.8 and `relaxation` = 1.0, the second at `smoothing_ratio` =
//! 2.0, refused since, both in the Lobovský column at rest: docs/VALIDATION.md, "DFSPH", "A
//! solve that does nothing" and "The widest kernel").

use shared::math::Real;

/// Consecutive stalled steps of one solve that stop the run. In the Lobovský column at
/// `smoothing_ratio` = 1.8 with `relaxation` = 1.0 the density solve stalls from its 3rd step
/// on, its mean compression growing from 0.08 % to 6.5 % over the next 50; in DFSPH's rows of
/// the validation plan, its impact study, the jointed slide and the default scene no solve
/// stalls even once (docs/VALIDATION.md, "DFSPH", "A solve that does nothing").
pub const STALLED_STEPS: usize = 10;

/// One solve's run of stalled steps.
#[derive(Debug, Default, Clone, Copy, serde::Serialize, serde::Deserialize)]
pub struct Stall {
    steps: usize,
}

impl Stall {
    /// Notes a step's solve: `kept`, the iterate it went back to (None if it did not);
    /// `error` and `tolerance` its final mean error and its tolerance. Returns how many steps
    /// in a row it has stalled, this one included (0: it did not).
    pub fn note(&mut self, kept: Option<usize>, error: Real, tolerance: Real) -> usize {
        self.steps = if kept == Some(0) && error > tolerance {
            self.steps + 1
        } else {
            0
        };
        self.steps
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Only a solve that went back to its start with its error above the tolerance stalls,
    /// and any other step ends the run of stalls.
    #[test]
    fn a_solve_stalls_only_when_it_keeps_its_start_above_its_tolerance() {
        let mut s = Stall::default();
        assert_eq!(s.note(Some(0), 2e-3, 1e-3), 1);
        assert_eq!(s.note(Some(0), 3e-3, 1e-3), 2);
        // Went back to a later iterate: it corrected something.
        assert_eq!(s.note(Some(4), 3e-3, 1e-3), 0);
        assert_eq!(s.note(Some(0), 3e-3, 1e-3), 1);
        // Back to its start, but within the tolerance: nothing was left to correct.
        assert_eq!(s.note(Some(0), 5e-4, 1e-3), 0);
        assert_eq!(s.note(Some(0), 3e-3, 1e-3), 1);
        // Converged.
        assert_eq!(s.note(None, 3e-4, 1e-3), 0);
        for n in 1..=STALLED_STEPS {
            assert_eq!(s.note(Some(0), 1.0, 1e-3), n);
        }
    }
}
