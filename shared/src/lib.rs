//! rockwave's solver SDK.
//!
//! - [`added_mass`]: detection of the added-mass instability of partitioned coupling.
//! - [`load_relaxation`]: its remedy, the water's loads under-relaxed by an artificial added mass.
//! - [`checkpoint`]: checkpoint files (atomic writes, format version, scene hash).
//! - [`math`]: the scalar and vector types used everywhere.
//! - [`scene`]: the scene schema (TOML), its validation and the embedded default scene.
//! - [`geometry`]: convex polyhedra built from scene shapes (faces, edges, mass properties).
//! - [`cutting`]: Shi's block cutting of a convex region by joint planes (`[[slide]]`).
//! - [`protocol`]: the versioned wire types exchanged over shared memory each step.
//! - [`strain`]: the constant strain of a deformable (12-DOF) DDA block.
//! - [`terrain`]: fixed terrain from mesh and DEM files (`[[terrain]]`), with BVH queries.
//! - [`registry`]: the solvers a node crate offers, and each solver's own parameter table.
//! - [`step`]: the rule that grants the shared timestep (one pure function).
//! - [`solver`]: the coupling interface a solver implements (preCICE style: read, write, advance).
//! - [`transport`]: the iceoryx2 services of one run, under a unique prefix.
//! - [`runtime`]: the node runtime that does all the talking for a solver.

pub mod added_mass;
pub mod checkpoint;
pub mod cutting;
pub mod geometry;
pub mod load_relaxation;
pub mod math;
pub mod protocol;
pub mod registry;
pub mod report;
pub mod runtime;
pub mod scene;
pub mod solver;
pub mod step;
pub mod strain;
pub mod terrain;
pub mod transport;
pub mod vtk;
