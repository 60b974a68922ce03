//! Exit codes of a node process.

/// The solver went unstable or failed; its status message says why.
pub const SOLVER: u8 = 2;
/// The transport failed or the coupler vanished.
pub const TRANSPORT: u8 = 3;
/// SIGINT or SIGTERM.
pub const SIGNAL: u8 = 130;
