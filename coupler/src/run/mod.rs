//! One coupled run, as `coupler run`, `check` and `clean` do it. Read `coupler run` from
//! `command.rs` (the run in order), with `resume.rs` and `settings.rs` (the scene, its overrides
//! and the flags), `lock.rs`, `launch.rs`, `launcher.rs` and `node_ranks.rs` (the run id, the
//! node processes, the MPI launcher of the fluid ranks and whether the node can run on them),
//! `output.rs` (the run directory), `session/` (the
//! coupled steps), `checkpoint.rs`, and `summary/` (`summary.json`). `scenes.rs`, `sizes.rs`,
//! `per_rank.rs`, `not_on_ranks.rs`, `slides.rs` and `resolution.rs` check and size a
//! scene; `povray.rs` renders a run directory.
//!
//! Nothing here uses [`crate::studies`]: the studies are built on runs, not the other way.

pub mod check;
pub mod checkpoint;
pub mod clean;
pub mod command;
pub mod error;
pub mod launch;
pub mod launcher;
pub mod lock;
pub mod mpi_segments;
pub mod node_ranks;
pub mod not_on_ranks;
pub mod output;
pub mod per_rank;
pub mod povray;
pub mod progress;
pub mod rank_report;
pub mod resolution;
pub mod resume;
pub mod scenes;
pub mod session;
pub mod settings;
pub mod sizes;
pub mod slides;
pub mod stats;
pub mod summary;
