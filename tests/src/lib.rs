//! Toy solvers that speak the rockwave protocol with trivial physics, so the coupling itself
//! can be tested exactly and its cost measured without a solver's cost on top.
//!
//! They are also the smallest example of "any executable that speaks the protocol": the
//! binaries `toy-fluid-node` and `toy-solid-node` run with `coupler run --fluid-cmd ...`.
//!
//! - `toy-solid-node --solver ballistic`: moving blocks fly under gravity plus the loads they
//!   receive, integrated exactly for a load that is constant over the step.
//! - `toy-fluid-node --solver hover`: pushes every moving block up with exactly its weight,
//!   and checks every geometry message against the block standing still. `--solver drop`:
//!   pushes nothing and checks against free fall. A message from the wrong time therefore
//!   fails the run, naming the step: the toys test the data tags of both schemes end to end.

//!
//! [`extension`] holds a third SPH method and a second DDA integrator added from outside the
//! node crates (binaries `extended-fluid-node`, `extended-solid-node`).

pub mod extension;
pub mod toy;
