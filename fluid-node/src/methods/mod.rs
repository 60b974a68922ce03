//! The SPH methods, each behind [`SphMethod`] (`method.rs`): what one method does differently
//! from another (kernel, equation of state, forces, integrator, stable step), over the
//! [`crate::system::FluidSystem`] they all share; [`crate::sph::Sph`] turns any of them into a
//! coupled solver, and [`crate::REGISTRY`] lists them by name.
//!
//! - [`muller`]: the paper's method (Müller et al. 2003; paper Eqs. 11–21);
//! - [`wcsph`]: weakly compressible SPH in the DualSPHysics standard;
//! - [`dfsph`]: divergence-free SPH (Bender & Koschier 2015, 2017).

mod method;

pub mod dfsph;
pub mod muller;
pub mod wcsph;

pub use method::SphMethod;
