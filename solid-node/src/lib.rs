//! 3D-DDA solvers for rockwave: convex blocks in contact, rigid (6 unknowns) or, where a scene
//! asks, deformable with Shi's constant strain (12 unknowns), after Shi (1993) and the
//! explicit 3D-DDA of Geraili Mikola & Sitar (the paper, §2).
//!
//! - [`block`]: a block's shape, mass properties, pose and world geometry;
//! - [`elastic`]: the strain state and matrices of a deformable block (co-rotational);
//! - [`rotation`]: exact rotation updates (no growth of rotating blocks);
//! - [`broad_phase`], [`narrow_phase`], [`contact`]: finding vertex–face and edge–edge contacts;
//! - [`terrain_contact`]: blocks against the fixed `[[terrain]]` mesh (BVH queries);
//! - [`penalty`], [`friction`]: normal and shear springs, Mohr–Coulomb with cohesion;
//! - [`joints`]: the bonded joints between blocks cut from one `[[slide]]` (tension cut-off,
//!   residual friction once broken); [`settle`]: their gravity loading before t = 0;
//! - [`world`]: the block system shared by the integrators;
//! - [`explicit`] (paper Eqs. 5–8) and [`implicit`] (Shi's Newmark β = ½, γ = 1, paper Eq. 4);
//! - [`stability`], [`energy`]: the explicit limit 2/ω_max and the detection of instability;
//! - [`checkpoint`]: what a checkpoint saves of the block system to continue exactly;
//! - [`dda`]: the [`shared::solver::SolidSolver`] the node runtime drives, built by a scheme
//!   of [`REGISTRY`] (read by the node binary, `solid-validate`, `solid-bench` and the
//!   coupler's sweeps); [`output`]: CSV and VTK files;
//! - [`verification`]: the cases `solid-validate` runs and the tests reuse.

pub mod block;
pub mod broad_phase;
pub mod checkpoint;
pub mod contact;
pub mod dda;
pub mod elastic;
pub mod energy;
pub mod explicit;
pub mod friction;
pub mod implicit;
pub mod integrator;
pub mod joints;
pub mod linear_system;
pub mod narrow_phase;
pub mod output;
pub mod penalty;
pub mod rotation;
pub mod settle;
pub mod stability;
pub mod terrain_contact;
pub mod verification;
pub mod world;

use dda::DdaSolver;
use integrator::DdaMethod;
use shared::registry::{Entry, Registry, check_params, solver_params};
use shared::scene::{FieldError, Scene};
use shared::solver::{SetupContext, SolverError};

/// Every solid solver, by name: add a scheme here with one `entry` line. Each builds the same
/// [`DdaSolver`] (blocks, contacts, loads, outputs) around its own [`integrator::Integrator`];
/// its parameters sit in `[solid.<name>]`, the contact physics in `[solid.contact]`.
pub static REGISTRY: Registry<DdaSolver> = Registry {
    role: "solid",
    entries: &[
        entry::<explicit::CentralDifference>(),
        entry::<implicit::Implicit>(),
    ],
};

/// The registry entry of scheme `S`: a [`DdaSolver`] with `S`'s integrator, its parameters in
/// `[solid.<S::NAME>]`.
pub const fn entry<S: DdaMethod>() -> Entry<DdaSolver> {
    Entry {
        name: S::NAME,
        description: S::DESCRIPTION,
        build: build_scheme::<S>,
        check: check_scheme::<S>,
        advice: shared::registry::Advice::NONE,
    }
}

fn build_scheme<S: DdaMethod>(ctx: &SetupContext) -> Result<Box<DdaSolver>, SolverError> {
    let params: S::Params = solver_params(&ctx.scene.solid.solvers, "solid", S::NAME)?;
    let integrator = S::integrator(&params, ctx.scene);
    Ok(Box::new(DdaSolver::new(ctx, integrator)?))
}

fn check_scheme<S: DdaMethod>(scene: &Scene) -> Vec<FieldError> {
    check_params::<S::Params>(&scene.solid.solvers, "solid", S::NAME)
}

/// The solid registry's checks of a scene: `[solid] solver` names a solver, every
/// `[solid.<name>]` table belongs to one and holds valid parameters.
pub fn check_scene(scene: &Scene) -> Vec<FieldError> {
    REGISTRY.check(scene, &scene.solid.solvers, &scene.solid.solver)
}
