//! What the water is measured with: wave gauges and pressure probes written as CSV time series
//! ([`gauges`]), the load on the wall behind a probe's face ([`wall_load`]), and the one pass over the particles after a step that the stability checks,
//! the next step's proposal and the Verlet lists' validity read ([`survey`]).

pub mod gauges;
pub mod survey;
pub mod wall_load;
