//! The command line every node binary accepts.

use crate::transport::Kind;
use clap::Parser;

/// Command line shared by every node binary.
#[derive(Debug, Parser)]
#[command(
    about = "A rockwave solver node. Normally started by `coupler run`; start it by hand with the run id the coupler prints."
)]
pub(super) struct NodeArgs {
    /// Solver to run (overrides the scene's choice).
    #[arg(long)]
    pub solver: Option<String>,
    /// Run id (service prefix) of the coupler to join.
    #[arg(long, required_unless_present = "list_solvers")]
    pub prefix: Option<String>,
    /// How to reach the coupler: iceoryx2 shared memory (same host), or zenoh over TCP (the
    /// coupler may be on another host; give its endpoint with --connect).
    #[arg(long, value_enum, default_value_t = Kind::Iceoryx2)]
    pub transport: Kind,
    /// zenoh endpoint of the coupler, e.g. `tcp/192.0.2.10:7447` (what it `--listen`s on).
    /// Repeat for several.
    #[arg(long, value_name = "ENDPOINT")]
    pub connect: Vec<String>,
    /// Seconds to wait for a coupler to answer the hello.
    #[arg(long, allow_hyphen_values = true, default_value_t = 60.0)]
    pub connect_timeout: f64,
    /// Print the solvers this binary offers and exit.
    #[arg(long)]
    pub list_solvers: bool,
    /// Speak this protocol version instead of the real one (tests the coupler's check).
    #[arg(long, allow_hyphen_values = true, hide = true)]
    pub fake_protocol_version: Option<u32>,
    /// Stop answering after this many steps (tests the coupler's hang detection).
    #[arg(long, allow_hyphen_values = true, hide = true)]
    pub hang_after_steps: Option<u64>,
    /// Kill this node (SIGKILL) when told to take this step, every time it starts (tests the
    /// coupler's restarts: a node that fails again at the same step stops the run).
    #[arg(long, allow_hyphen_values = true, hide = true)]
    pub die_at_step: Option<u64>,
    /// Block for ever before the hello (tests the start-up watchdog).
    #[arg(long, hide = true)]
    pub stall_startup: bool,
}
