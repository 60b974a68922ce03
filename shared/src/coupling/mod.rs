//! The rules of the partitioned coupling that are neither solver nor transport, shared by the
//! coupler and both nodes:
//!
//! - [`step`]: the rule that grants the shared timestep (one pure function).
//! - [`added_mass`]: detection of the added-mass instability of the lagged loads.
//! - [`load_relaxation`]: its remedy, the water's loads under-relaxed by an artificial added mass.

pub mod added_mass;
pub mod load_relaxation;
pub mod step;
