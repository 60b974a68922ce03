//! The node runtime: everything a solver binary needs besides the solver.
//!
//! A node binary's `main` is one call, e.g. `runtime::fluid_main(&["muller", "wcsph"], build)`.
//! The runtime joins the run named by `--prefix`, says hello until the coupler answers with the
//! setup, builds the solver, and then serves commands: for each step it exchanges coupling data
//! with the other node (see [`crate::solver`] for the order) and reports a
//! [`Status`](crate::protocol::Status).
//!
//! Data tags. Geometry message k holds the blocks at t_k (the solid sends G_0 at set-up and
//! G_{n+1} at the end of step n). A loads message is tagged with the solid step that consumes
//! it. In the parallel scheme the fluid at step n reads G_n and its loads feed solid step n; in
//! the serial scheme the fluid reads G_{n+1} and its loads feed solid step n+1 (the first ones
//! are computed at set-up from G_0).
//!
//! Modules, by role:
//! - `args`: the command line of every node binary;
//! - `control`: the link to the coupler (handshake, commands, statuses, bounded waits);
//! - `serve`: building the solver and the command loop both roles share;
//! - `fluid`, `solid`: each role's data ports and its exchange around the solver's advance;
//! - `exit`: the exit codes of a node process;
//! - `watchdog`: a bound on start-up that holds even inside a stuck transport call.

mod args;
mod control;
pub mod exit;
mod fluid;
mod presence;
mod serve;
mod solid;
mod watchdog;

pub use control::{peak_rss_bytes_of, process_cpu_seconds, process_peak_rss_bytes};
pub use serve::{FluidFactory, SolidFactory};

use crate::protocol::Role;
use crate::transport::{self, Endpoints, Kind, Party, RunId, Transport};
use args::NodeArgs;
use clap::Parser;
use control::Fatal;
use std::process::ExitCode;

/// Runs a fluid node: parses the command line, handshakes, then serves steps until told to stop.
pub fn fluid_main(solvers: &[&str], build: FluidFactory) -> ExitCode {
    node_main(Role::Fluid, solvers, |run, args| {
        fluid::run_node(run, solvers, build, args)
    })
}

/// Runs a solid node.
pub fn solid_main(solvers: &[&str], build: SolidFactory) -> ExitCode {
    node_main(Role::Solid, solvers, |run, args| {
        solid::run_node(run, solvers, build, args)
    })
}

/// What both roles do around serving: the command line, joining the run, and turning how the
/// node ended into its exit code (and a message on stderr).
fn node_main(
    role: Role,
    solvers: &[&str],
    serve: impl FnOnce(&dyn Transport, &NodeArgs) -> Result<u8, Fatal>,
) -> ExitCode {
    let args = NodeArgs::parse();
    if args.list_solvers {
        println!("{}", solvers.join("\n"));
        return ExitCode::SUCCESS;
    }
    let prefix = args.prefix.as_deref().unwrap_or_default();
    let who = format!("{}-node", role.name());
    let id = match RunId::parse(prefix) {
        Ok(id) => id,
        Err(e) => {
            eprintln!("{who}: --prefix: {e}");
            return ExitCode::from(exit::TRANSPORT);
        }
    };
    let local = args.transport == Kind::Iceoryx2;
    // A claim on the run's shared memory, so that of two orphaned nodes the last one out
    // tidies up (zenoh leaves nothing on the host to tidy).
    let presence = if local {
        presence::Presence::hold(&id)
    } else {
        None
    };
    let endpoints = Endpoints {
        listen: Vec::new(),
        connect: args.connect.clone(),
    };
    let timeout = std::time::Duration::from_secs_f64(args.connect_timeout.clamp(0.0, 1e6));
    watchdog::arm(&who, id.as_str(), timeout, exit::TRANSPORT);
    // The run (this process's iceoryx2 node or zenoh session) is gone again before the exit
    // is handled.
    let served = transport::join(
        args.transport,
        &id,
        Party::from(role),
        &who,
        &endpoints,
        timeout,
    )
    .map_err(Fatal::from)
    .and_then(|run| serve(run.as_ref(), &args));
    match served {
        Ok(code) => ExitCode::from(code),
        Err(Fatal::Transport(e)) => {
            eprintln!("{who}: {e}");
            ExitCode::from(exit::TRANSPORT)
        }
        Err(Fatal::CouplerGone) => {
            eprintln!("{who}: the coupler of run {id} is gone; stopping");
            // Nobody else may be left to tidy up: the last one out removes the run's files.
            let last = presence.map_or_else(
                || !transport::run_has_live_nodes(&id),
                |p| p.release_is_last(&id),
            );
            if last && local {
                transport::remove_run_files(&id);
            }
            ExitCode::from(exit::TRANSPORT)
        }
        Err(Fatal::Signal) => ExitCode::from(exit::SIGNAL),
    }
}
