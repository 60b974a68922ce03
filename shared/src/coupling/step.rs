//! The rule that grants the shared timestep, as one pure function.
//!
//! Every driver that steps solvers uses [`grant`]: the coupler with the proposals of its nodes,
//! an in-process driver (validation, benchmark, sweep) with the one proposal of its solver.
//! The rule, applied in this order:
//!
//! 1. dt = the smallest proposal, never above `dt_max` (ties keep the earlier candidate,
//!    `dt_max` first);
//! 2. the step has collapsed if any proposal is NaN or that smallest value is below `dt_min`:
//!    a method whose stability limit shrinks without bound has failed, not slowed down;
//! 3. dt is multiplied by `dt_factor` (1 in normal runs; stability experiments step above or
//!    below the methods' own limits on purpose);
//! 4. the step lands exactly on `target` (the next output time, or the end time) when the
//!    remaining time is at most dt (within a relative 1e-9); when it is less than two steps,
//!    the two are split evenly rather than leaving a sliver of a last step.
//!
//! The operations are fixed (same values, same order): runs depend on them bit for bit.

use crate::math::Real;
use std::fmt;

/// The limits a scene (and an experiment) puts on every step.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StepRule {
    /// No step is longer [s].
    pub dt_max: Real,
    /// A proposal below this means the run has collapsed [s].
    pub dt_min: Real,
    /// Multiplies the step once bounded (1 in normal runs).
    pub dt_factor: Real,
}

impl StepRule {
    /// The rule of a scene's `[time]` table, with `dt_factor` 1.
    pub fn new(dt_max: Real, dt_min: Real) -> StepRule {
        StepRule {
            dt_max,
            dt_min,
            dt_factor: 1.0,
        }
    }

    /// The same rule with the step multiplied by `dt_factor`.
    pub fn with_factor(self, dt_factor: Real) -> StepRule {
        StepRule { dt_factor, ..self }
    }
}

/// What bounded a step: a rule's `dt_max`, or one of the proposals (by its label).
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Limit<L> {
    DtMax,
    Proposal(L),
}

impl<L: fmt::Display> fmt::Display for Limit<L> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Limit::DtMax => f.write_str("dt_max"),
            Limit::Proposal(label) => label.fmt(f),
        }
    }
}

/// A granted step.
#[derive(Debug, Clone, PartialEq)]
pub struct Grant<L> {
    /// The step to take [s].
    pub dt: Real,
    /// Whether the step ends exactly on the target: the time reached is then `target` itself,
    /// not `time + dt` (which may differ in the last bit).
    pub lands: bool,
    /// What bounded the step before `dt_factor` and the landing.
    pub limiting: Limit<L>,
    /// Its value [s].
    pub bound: Real,
}

impl<L> Grant<L> {
    /// The time at the end of the step started at `time` towards `target` (the arguments
    /// given to [`grant`]): exactly `target` when the step lands.
    pub fn end_time(&self, time: Real, target: Real) -> Real {
        if self.lands { target } else { time + self.dt }
    }
}

/// The step has collapsed: `limiting` proposed `proposal`, NaN or below `dt_min`.
#[derive(Debug, Clone, PartialEq)]
pub struct Collapse<L> {
    pub limiting: Limit<L>,
    pub proposal: Real,
    pub dt_min: Real,
}

impl<L: fmt::Display> fmt::Display for Collapse<L> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "{} proposed dt = {:e} s, below dt_min = {:e} s",
            self.limiting, self.proposal, self.dt_min
        )
    }
}

/// Grants the step from `time` towards `target` (the next time a step must end on, at most
/// the end time) given labelled proposals [s]. See the module documentation for the rule.
///
/// A driver of one solver without a coupler passes its one proposal and its end time (or its
/// next output time):
///
/// ```
/// use shared::coupling::step::{grant, StepRule};
/// let rule = StepRule::new(1e-3, 1e-9);
/// let g = grant([("fluid", 4e-4)], &rule, 0.0, 1e-3).unwrap();
/// assert_eq!(g.dt, 4e-4);
/// let g = grant([("fluid", 4e-4)], &rule, 0.0008, 1e-3).unwrap();
/// assert!(g.lands); // 2e-4 remain: land on the target
/// ```
pub fn grant<L>(
    proposals: impl IntoIterator<Item = (L, Real)>,
    rule: &StepRule,
    time: Real,
    target: Real,
) -> Result<Grant<L>, Collapse<L>> {
    let mut limiting = Limit::DtMax;
    let mut bound = rule.dt_max;
    for (label, proposal) in proposals {
        if proposal.is_nan() {
            return Err(Collapse {
                limiting: Limit::Proposal(label),
                proposal,
                dt_min: rule.dt_min,
            });
        }
        if proposal < bound {
            limiting = Limit::Proposal(label);
            bound = proposal;
        }
    }
    if bound.is_nan() || bound < rule.dt_min {
        return Err(Collapse {
            limiting,
            proposal: bound,
            dt_min: rule.dt_min,
        });
    }
    let mut dt = bound * rule.dt_factor;
    let remaining = target - time;
    let lands = if remaining <= dt * (1.0 + 1e-9) {
        dt = remaining;
        true
    } else {
        if remaining < 2.0 * dt {
            dt = 0.5 * remaining;
        }
        false
    };
    Ok(Grant {
        dt,
        lands,
        limiting,
        bound,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    const RULE: StepRule = StepRule {
        dt_max: 1e-3,
        dt_min: 1e-8,
        dt_factor: 1.0,
    };

    #[test]
    fn smallest_proposal_wins_and_is_named() {
        let g = grant([("fluid", 4e-4), ("solid", 3e-4)], &RULE, 0.0, 1.0).unwrap();
        assert_eq!(g.dt, 3e-4);
        assert!(!g.lands);
        assert_eq!(g.limiting, Limit::Proposal("solid"));
        assert_eq!(g.bound, 3e-4);
    }

    #[test]
    fn ties_keep_the_earlier_candidate() {
        let g = grant([("fluid", 3e-4), ("solid", 3e-4)], &RULE, 0.0, 1.0).unwrap();
        assert_eq!(g.limiting, Limit::Proposal("fluid"));
        let g = grant([("fluid", 1e-3)], &RULE, 0.0, 1.0).unwrap();
        assert_eq!(g.limiting, Limit::DtMax);
    }

    #[test]
    fn dt_max_binds() {
        let g = grant([("fluid", 5e-3), ("solid", f64::INFINITY)], &RULE, 0.0, 1.0).unwrap();
        assert_eq!(g.dt, 1e-3);
        assert_eq!(g.limiting, Limit::DtMax);
        assert_eq!(g.limiting.to_string(), "dt_max");
        // No proposals at all: dt_max alone.
        let g = grant(std::iter::empty::<(&str, f64)>(), &RULE, 0.0, 1.0).unwrap();
        assert_eq!(g.dt, 1e-3);
    }

    #[test]
    fn dt_factor_scales_the_bounded_step() {
        let rule = RULE.with_factor(0.5);
        let g = grant([("solid", 4e-4)], &rule, 0.0, 1.0).unwrap();
        assert_eq!(g.dt, 4e-4 * 0.5);
        assert_eq!(g.bound, 4e-4);
        // Above 1 it may exceed dt_max: the experiment asks for it.
        let g = grant([("solid", 2e-3)], &RULE.with_factor(3.0), 0.0, 1.0).unwrap();
        assert_eq!(g.dt, 1e-3 * 3.0);
    }

    #[test]
    fn lands_exactly_on_the_target() {
        let (time, target) = (0.1 - 2.5e-4, 0.1);
        let g = grant([("fluid", 3e-4)], &RULE, time, target).unwrap();
        assert!(g.lands);
        assert_eq!(g.dt, target - time);
        assert_eq!(g.end_time(time, target), target);
        // Within the relative tolerance of one step, too.
        let dt = 3e-4;
        let g = grant([("fluid", dt)], &RULE, 0.0, dt * (1.0 + 1e-10)).unwrap();
        assert!(g.lands);
        assert_eq!(g.end_time(0.0, dt * (1.0 + 1e-10)), dt * (1.0 + 1e-10));
    }

    #[test]
    fn splits_the_last_two_steps_rather_than_leave_a_sliver() {
        // 1.5 steps remain: two halves of 0.75 dt, not dt and a 0.5 dt sliver.
        let g = grant([("fluid", 2e-4)], &RULE, 0.0, 3e-4).unwrap();
        assert!(!g.lands);
        assert_eq!(g.dt, 0.5 * 3e-4);
        assert_eq!(g.end_time(0.0, 3e-4), 1.5e-4);
        let g = grant([("fluid", 2e-4)], &RULE, 1.5e-4, 3e-4).unwrap();
        assert!(g.lands);
        // Two full steps or more remain: the full step.
        let g = grant([("fluid", 2e-4)], &RULE, 0.0, 4e-4).unwrap();
        assert_eq!(g.dt, 2e-4);
        assert!(!g.lands);
    }

    #[test]
    fn collapses_below_dt_min() {
        let c = grant([("fluid", 4e-4), ("solid", 1e-9)], &RULE, 0.0, 1.0).unwrap_err();
        assert_eq!(c.limiting, Limit::Proposal("solid"));
        assert_eq!(c.proposal, 1e-9);
        assert_eq!(c.dt_min, 1e-8);
        assert_eq!(
            c.to_string(),
            "solid proposed dt = 1e-9 s, below dt_min = 1e-8 s"
        );
        // dt_min itself is allowed.
        assert!(grant([("solid", 1e-8)], &RULE, 0.0, 1.0).is_ok());
    }

    #[test]
    fn collapses_on_nan_naming_the_node() {
        let c = grant([("fluid", 4e-4), ("solid", f64::NAN)], &RULE, 0.0, 1.0).unwrap_err();
        assert_eq!(c.limiting, Limit::Proposal("solid"));
        assert!(c.proposal.is_nan());
        // A NaN limit is caught as well.
        let rule = StepRule::new(f64::NAN, 1e-8);
        let c = grant(std::iter::empty::<(&str, f64)>(), &rule, 0.0, 1.0).unwrap_err();
        assert_eq!(c.limiting, Limit::DtMax);
    }
}
