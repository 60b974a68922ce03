//! The SPH methods, each behind [`SphMethod`] (`method.rs`): what one method does differently
//! from another (kernel, equation of state, forces, integrator, stable step), over the
//! [`crate::system::FluidSystem`] they all share; [`crate::sph::Sph`] turns any of them into a
//! coupled solver, and [`crate::REGISTRY`] lists them by name.
//!
//! - [`muller`]: the paper's method (Müller et al. 2003; paper Eqs. 11–21);
//! - [`wcsph`]: weakly compressible SPH in the DualSPHysics standard;
//! - [`riemann`]: the same with a low-dissipation Riemann solver for the pairs (Zhang, Hu &
//!   Adams 2017);
//! - [`dfsph`]: divergence-free SPH (Bender & Koschier 2015, 2017).
//!
//! # Adding an SPH method
//!
//! A method is one folder here (`methods/<name>/mod.rs`, `pub mod <name>;` above) with a type
//! implementing [`SphMethod`], and one `entry::<Type>()` line in [`crate::REGISTRY`]; its
//! parameters are `[fluid.<name>]` of the scene. The example below compiles against the real
//! trait (a doc-test): every required item, on a method that only falls under gravity.
//! Everything else (sorting, neighbour lists, boundary particles, paper Eq. 22, instruments,
//! checks, frames, checkpoints) is the [`crate::system::FluidSystem`]'s; the optional items
//! (`loads_follow_step`, `step_loads`, `estimate_dt`, `warnings`, `study_table`,
//! `study_variants`, `known_limitation`) have defaults.
//!
//! ```no_run
//! use fluid_node::core::particles::Carried;
//! use fluid_node::kernels::{Kernel, WendlandC2};
//! use fluid_node::methods::SphMethod;
//! use fluid_node::system::{FluidSystem, Initial, Layout};
//! use shared::math::{Real, Vector};
//! use shared::registry::{ParamCheck, SolverParams};
//! use shared::solver::{SolverError, StepReport};
//!
//! /// `[fluid.falling]`: every field optional, unset ones derived.
//! #[derive(Debug, Default, serde::Deserialize)]
//! #[serde(deny_unknown_fields)]
//! struct FallingParams {
//!     /// h/dx.
//!     smoothing_ratio: Option<f64>,
//! }
//!
//! impl SolverParams for FallingParams {
//!     fn check(&self, c: &mut ParamCheck) {
//!         c.positive("smoothing_ratio", self.smoothing_ratio, "set h/dx, e.g. 1.3");
//!     }
//! }
//!
//! /// Saved whole in a checkpoint: whatever it keeps across steps.
//! #[derive(serde::Serialize, serde::Deserialize)]
//! struct Falling {
//!     kernel: WendlandC2,
//!     rest_density: Real,
//!     dx: Real,
//! }
//!
//! impl SphMethod for Falling {
//!     const NAME: &'static str = "falling";
//!     const DESCRIPTION: &'static str = "free fall: an example, not a fluid";
//!     type Params = FallingParams;
//!     type Kernel = WendlandC2;
//!
//!     fn new(params: FallingParams, init: &Initial) -> Result<(Self, Layout), SolverError> {
//!         let dx = init.fluid.dx;
//!         let kernel = WendlandC2::new(params.smoothing_ratio.unwrap_or(1.3) * dx);
//!         let layout = Layout {
//!             density: vec![init.fluid.density; init.fill.positions.len()],
//!             support: kernel.support(),
//!             sound_speed: init.default_sound_speed(),
//!             skin_ratio: 0.0,
//!             poly6_sums: false,
//!             carried: Carried::ALL,
//!         };
//!         let method = Falling { kernel, rest_density: init.fluid.density, dx };
//!         Ok((method, layout))
//!     }
//!
//!     fn start(&mut self, _sys: &mut FluidSystem) {}
//!
//!     fn step(&mut self, sys: &mut FluidSystem, dt: Real) -> Result<StepReport, SolverError> {
//!         let (g, p) = (sys.gravity, &mut sys.particles);
//!         for (x, v) in p.position.iter_mut().zip(p.velocity.iter_mut()) {
//!             *v += g * dt;
//!             *x += *v * dt;
//!         }
//!         Ok(StepReport::default())
//!     }
//!
//!     fn react(&mut self, _sys: &mut FluidSystem) {}
//!
//!     // No pressure, so no wall term: a probe reading the wall reads 0 Pa.
//!     fn fixed_wall_forces(&self, _: &FluidSystem, _: usize, _: &mut dyn FnMut(usize, Vector)) {}
//!
//!     fn kernel(&self) -> &WendlandC2 {
//!         &self.kernel
//!     }
//!
//!     fn density_check(&self) -> (bool, Real) {
//!         (false, self.rest_density)
//!     }
//!
//!     fn dt_proposal(&self, v_max: Real, _a_max: Real) -> Real {
//!         if v_max > 0.0 { (0.4 * self.dx / v_max).min(1e-3) } else { 1e-3 }
//!     }
//! }
//!
//! // The line in `REGISTRY`'s entries (fluid-node/src/lib.rs):
//! let _entry = fluid_node::entry::<Falling>();
//! ```

mod method;

pub mod dfsph;
pub mod muller;
pub mod riemann;
pub mod wcsph;

pub use method::SphMethod;
