//! Verification cases with closed-form references (docs/REFERENCES.md §2): free fall, a block on an
//! incline that sticks or slides (with and without cohesion), slide-or-topple, the restitution
//! of an undamped penalty bounce for both schemes, the explicit scheme pushed past its limit,
//! a stack at rest, a column of flush boxes pressed several contact margins deep, the embedded
//! default scene's wedge, and a spinning block that must not grow; jointed slopes cut from a
//! `[[slide]]` against limit equilibrium (planar and wedge failure, explicit solver); the
//! incline on a terrain mesh and a block on a terrain bump ([`terrain`]); and the deformable
//! (12-DOF) blocks' cases in [`deformable`]. `solid-validate` prints them as a table; the tests
//! run the same functions.
//!
//! Every case drives the solver through the [`SolidSolver`] interface, as the node runtime
//! does, with the run directory in a temporary folder.

use crate::dda::DdaSolver;
use crate::world::World;
use shared::coupling::step::{StepRule, grant};
use shared::math::{Real, Vector};
use shared::scene::{CouplingScheme, Scene};
use shared::solver::{SetupContext, Solver, SolverError};
use std::f64::consts::PI;
use std::path::PathBuf;

const G: Real = shared::math::STANDARD_GRAVITY;

pub use shared::report::{Row, Tolerance, markdown};

/// The central difference scheme's registry name: the cases whose reference is that scheme's
/// own (its limit 2/ω_max, paper Eq. 8; its restitution and period) choose by it.
pub const EXPLICIT: &str =
    <crate::explicit::CentralDifference as crate::integrator::DdaMethod>::NAME;

mod contact;
pub mod deformable;
mod harness;
mod incline;
mod jointed;
mod motion;
mod scenes;
mod terrain;

pub use contact::*;
pub use harness::*;
pub use incline::*;
pub use jointed::*;
pub use motion::*;
pub use scenes::*;
pub use terrain::*;

/// All cases for both solvers (`quick` shortens the stack run to 3 s).
pub fn run_all(quick: bool) -> Vec<Row> {
    let mut rows = Vec::new();
    let solvers = crate::REGISTRY.names();
    for &solver in &solvers {
        rows.push(free_fall(solver));
        rows.push(spinning_block(solver));
        rows.extend(incline_rows(solver));
        rows.extend(slide_or_topple(solver));
        rows.extend(restitution_rows(solver));
        if solver == EXPLICIT {
            rows.extend(explicit_limit_rows());
        }
        rows.extend(jointed_rows(solver));
        rows.push(stack_row(solver, if quick { 3.0 } else { 10.0 }));
        rows.push(flush_column_row(solver));
        rows.extend(default_wedge_rows(solver));
        rows.extend(incline_on_terrain_rows(solver));
        rows.extend(bump_rows(solver));
        rows.extend(mesa_rows(solver));
        rows.extend(rim_rows(solver));
    }
    for &solver in &solvers {
        rows.extend(deformable::rows(solver));
    }
    rows
}
