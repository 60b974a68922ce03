//! The coupler: reads a scene, launches the fluid and solid nodes, enforces the shared
//! timestep and writes the run directory.
//!
//! - [`cli`]: the command line (argument types and dispatch);
//! - [`run`]: `coupler run`, `check` and `clean`: one coupled run and its run directory;
//! - [`studies`]: the sweeps and tools built on runs (`chart`, `stability`, `spread`,
//!   `make-site`, `terrain-bench`).

pub mod cli;
pub mod run;
pub mod studies;
