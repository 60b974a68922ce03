//! What the water is measured with: wave gauges and pressure probes written as CSV time series
//! ([`gauges`]), and the one pass over the particles after a step that the stability checks,
//! the next step's proposal and the Verlet lists' validity read ([`survey`]).

pub mod gauges;
pub mod survey;
