//! One coupled run, as `coupler run`, `check` and `clean` do it: the scene and its checks,
//! the node processes and the run lock, the session that steps them, checkpoints, and the run
//! directory with its summary (gauges, run-up, wave maker) and POV-Ray frames.
//!
//! Nothing here uses [`crate::studies`]: the studies are built on runs, not the other way.

pub mod check;
pub mod checkpoint;
pub mod clean;
pub mod command;
pub mod error;
pub mod launch;
pub mod lock;
pub mod output;
pub mod povray;
pub mod progress;
pub mod resolution;
pub mod resume;
pub mod scenes;
pub mod session;
pub mod settings;
pub mod sizes;
pub mod slides;
pub mod stats;
pub mod summary;
