//! Studies built on runs: the speed-accuracy charts (`coupler chart`), the stability maps
//! (`coupler stability`), the spread of a scene's gauges (`coupler spread`), and the tools
//! `make-site` and `terrain-bench`. The sweeps start `coupler run` as real processes
//! ([`runner`]) or step the solvers in-process (the fluid and solid sweeps).

pub mod chart;
pub mod coupled_sweep;
pub mod fluid_sweep;
pub mod runner;
pub mod site;
pub mod solid_sweep;
pub mod speed_accuracy;
pub mod spread;
pub mod stability;
pub mod terrain_bench;
