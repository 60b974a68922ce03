//! The coupler: reads a scene, launches the fluid and solid nodes, enforces the shared
//! timestep and writes the run directory.

pub mod chart;
pub mod checkpoint;
pub mod cli;
pub mod coupled_sweep;
pub mod fluid_sweep;
pub mod launch;
pub mod linear_waves;
pub mod lock;
pub mod output;
pub mod povray;
pub mod progress;
pub mod resolution;
pub mod runner;
pub mod runup;
pub mod scenes;
pub mod session;
pub mod site;
pub mod sizes;
pub mod slides;
pub mod solid_sweep;
pub mod speed_accuracy;
pub mod spread;
pub mod stability;
pub mod terrain_bench;
pub mod wave_maker;
