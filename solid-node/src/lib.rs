//! 3D-DDA solvers for rockwave: convex blocks in contact, rigid (6 unknowns) or, where a scene
//! asks, deformable with Shi's constant strain (12 unknowns), after Shi (1993) and the
//! explicit 3D-DDA of Geraili Mikola & Sitar (the paper, §2).
//!
//! - [`block`]: a block's shape, mass properties, pose and world geometry;
//! - [`elastic`]: the strain state and matrices of a deformable block (co-rotational);
//! - [`rotation`]: exact rotation updates (no growth of rotating blocks);
//! - [`broad_phase`], [`narrow_phase`], [`contact`]: finding vertex–face and edge–edge contacts;
//! - [`penalty`], [`friction`]: normal and shear springs, Mohr–Coulomb with cohesion;
//! - [`world`]: the block system shared by the integrators;
//! - [`explicit`] (paper Eqs. 5–8) and [`implicit`] (Shi's Newmark β = ½, γ = 1, paper Eq. 4);
//! - [`stability`], [`energy`]: the explicit limit 2/ω_max and the detection of instability;
//! - [`dda`]: the [`SolidSolver`] the node runtime drives; [`output`]: CSV and VTK files;
//! - [`verification`]: the cases `solid-validate` runs and the tests reuse.

pub mod block;
pub mod broad_phase;
pub mod contact;
pub mod dda;
pub mod elastic;
pub mod energy;
pub mod explicit;
pub mod friction;
pub mod implicit;
pub mod integrator;
pub mod linear_system;
pub mod narrow_phase;
pub mod output;
pub mod penalty;
pub mod rotation;
pub mod stability;
pub mod verification;
pub mod world;

use shared::solver::{SetupContext, SolidSolver, SolverError};

/// Solver names accepted by `--solver`.
pub const SOLVERS: &[&str] = &["explicit", "implicit"];

/// Builds the named solver for a scene.
pub fn build(name: &str, ctx: &SetupContext) -> Result<Box<dyn SolidSolver>, SolverError> {
    Ok(Box::new(build_dda(name, ctx)?))
}

/// Like [`build`], with the concrete type (for verification and benchmarks).
pub fn build_dda(name: &str, ctx: &SetupContext) -> Result<dda::DdaSolver, SolverError> {
    let solid = &ctx.scene.solid;
    let integrator: Box<dyn integrator::Integrator> = match name {
        "explicit" => Box::new(explicit::CentralDifference::new(solid.safety_factor)),
        // 12 unknowns per block only when the scene asks for a deformable one.
        "implicit" if ctx.scene.blocks.iter().any(|b| b.elastic.is_some()) => {
            Box::new(implicit::Newmark::<12>::new(solid))
        }
        "implicit" => Box::new(implicit::Newmark::<6>::new(solid)),
        other => {
            return Err(SolverError::Failed(format!(
                "unknown solid solver '{other}'; fix: use one of {}",
                SOLVERS.join(", ")
            )));
        }
    };
    dda::DdaSolver::new(ctx, integrator)
}
