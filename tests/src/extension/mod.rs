//! A third SPH method and a second DDA integrator, written against the public API of
//! `fluid-node` and `solid-node` alone, as a user adding a solver would: each is one file, and
//! the node binaries `extended-fluid-node` and `extended-solid-node` list them beside the
//! built-in ones with one line each (`tests/tests/extension.rs` runs them coupled). If adding a
//! solver ever needs more than that, these stop compiling or that test fails.
//!
//! - [`lite`]: weakly compressible SPH in its plainest form (Monaghan 1992): summed density,
//!   linear equation of state, the symmetric pressure gradient, Monaghan's artificial
//!   viscosity, symplectic Euler; plain loops, no pair records.
//! - [`euler`]: semi-implicit (symplectic) Euler for rigid blocks: v_{n+1} = v_n + Δt F_n / m,
//!   x_{n+1} = x_n + Δt v_{n+1}, the same for the angular momentum with an exact rotation.

pub mod euler;
pub mod lite;
