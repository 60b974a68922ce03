//! The coupler: reads a scene, launches the fluid and solid nodes, enforces the shared
//! timestep and writes the run directory.

pub mod chart;
pub mod cli;
pub mod launch;
pub mod output;
pub mod povray;
pub mod progress;
pub mod session;
