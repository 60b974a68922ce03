//! rockwave's solver SDK.
//!
//! - [`coupling`]: the rules of the partitioned coupling: the shared timestep's grant
//!   ([`coupling::step`]), the added-mass instability's detection and its remedy.
//! - [`checkpoint`]: checkpoint files (atomic writes, format version, scene hash).
//! - [`math`]: the scalar and vector types used everywhere.
//! - [`scene`]: the scene schema (TOML), its validation and the embedded default scene.
//! - [`geometry`]: convex polyhedra built from scene shapes (faces, edges, mass properties),
//!   Shi's block cutting by joint planes (`[[slide]]`) and a deformable block's constant strain.
//! - [`protocol`]: the versioned wire types exchanged over shared memory each step.
//! - [`terrain`]: fixed terrain from mesh and DEM files (`[[terrain]]`), with BVH queries.
//! - [`registry`]: the solvers a node crate offers, and each solver's own parameter table.
//! - [`solver`]: the coupling interface a solver implements (preCICE style: read, write, advance).
//! - [`transport`]: how the processes of a run talk (iceoryx2 on one host, or zenoh), under the
//!   run's unique id.
//! - [`runtime`]: the node runtime that does all the talking for a solver.
//! - [`report`]: the validation tables (one row per checked quantity).
//! - [`vtk`]: the VTK frames a run writes, and reading them back.

pub mod checkpoint;
pub mod coupling;
pub mod geometry;
pub mod math;
pub mod protocol;
pub mod registry;
pub mod report;
pub mod runtime;
pub mod scene;
pub mod solver;
pub mod terrain;
pub mod transport;
pub mod vtk;
