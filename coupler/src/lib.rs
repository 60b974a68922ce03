//! coupler
