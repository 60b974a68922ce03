//! 3D-DDA solvers for rockwave: convex blocks in contact, rigid (6 unknowns) or, where a scene
//! asks, deformable with Shi's constant strain (12 unknowns), after Shi (1993) and the
//! explicit 3D-DDA of Geraili Mikola & Sitar (the paper, §2).
//!
//! - [`blocks`]: a block's shape, mass properties, pose and world geometry, its strain when
//!   deformable, and exact rotation updates;
//! - [`contact`]: finding vertex–face and edge–edge contacts (between blocks and against the
//!   fixed `[[terrain]]` mesh), the normal and shear springs, Mohr–Coulomb with cohesion, and the
//!   bonded joints between blocks cut from one `[[slide]]`;
//! - [`integrators`]: the time integrators ([`integrators::Integrator`], one file each) and what
//!   they share: the linear system, the explicit limit 2/ω_max and the energy check;
//! - [`world`]: the block system shared by the integrators; [`settle`]: the slides' gravity
//!   loading before t = 0;
//! - [`checkpoint`]: what a checkpoint saves of the block system to continue exactly;
//! - [`dda`]: the [`shared::solver::SolidSolver`] the node runtime drives, built by a scheme
//!   of [`REGISTRY`] (read by the node binary, `solid-validate`, `solid-bench` and the
//!   coupler's sweeps); [`output`]: CSV and VTK files;
//! - [`verification`]: the cases `solid-validate` runs and the tests reuse.

pub mod blocks;
pub mod checkpoint;
pub mod contact;
pub mod dda;
pub mod integrators;
pub mod output;
pub mod settle;
pub mod verification;
pub mod world;

use dda::DdaSolver;
use integrators::DdaMethod;
use shared::registry::{Entry, Registry, check_params, solver_params};
use shared::scene::{FieldError, Scene};
use shared::solver::{SetupContext, SolverError};

/// Every solid solver, by name: add a scheme here with one `entry` line. Each builds the same
/// [`DdaSolver`] (blocks, contacts, loads, outputs) around its own [`integrators::Integrator`];
/// its parameters sit in `[solid.<name>]`, the contact physics in `[solid.contact]`.
pub static REGISTRY: Registry<DdaSolver> = Registry {
    role: "solid",
    entries: &[
        entry::<integrators::explicit::CentralDifference>(),
        entry::<integrators::implicit::Implicit>(),
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
