//! The transport seam: the traits the runtime and the coupler talk through ([`Transport`],
//! [`Outbox`], [`Inbox`], [`Bell`], [`Waiter`]) and the names both transports share (the run's
//! id, its parties, the error).

use crate::protocol::{
    BlockLoad, BlockState, Command, GeometryHeader, Hello, LoadsHeader, SetupHeader, Status,
};
use iceoryx2::prelude::*;
use std::time::Duration;

/// Why the transport failed.
#[derive(Debug, thiserror::Error)]
pub enum TransportError {
    #[error("invalid run id '{0}': use 1–24 characters from a–z and 0–9, starting with a letter")]
    BadRunId(String),
    #[error("iceoryx2: {0}")]
    Iceoryx(String),
    #[error("zenoh: {0}")]
    Zenoh(String),
    #[error("{0}")]
    Protocol(String),
}

pub(crate) fn iox<E: std::fmt::Debug>(what: &str) -> impl FnOnce(E) -> TransportError + '_ {
    move |e| TransportError::Iceoryx(format!("{what}: {e:?}"))
}

/// The unique name of one run (service-name and file prefix).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct RunId(String);

impl RunId {
    /// A fresh id from the process id, the clock and a counter: unique on this machine.
    pub fn fresh() -> RunId {
        use std::sync::atomic::{AtomicU32, Ordering};
        static COUNTER: AtomicU32 = AtomicU32::new(0);
        let nanos = std::time::SystemTime::now()
            .duration_since(std::time::UNIX_EPOCH)
            .map(|d| d.as_nanos())
            .unwrap_or(0);
        let n = COUNTER.fetch_add(1, Ordering::Relaxed);
        let mix = (nanos as u64) ^ ((std::process::id() as u64) << 32) ^ ((n as u64) << 20);
        RunId(format!("rw{:x}", mix & 0xffff_ffff_ffff))
    }

    pub fn parse(s: &str) -> Result<RunId, TransportError> {
        let ok = (1..=24).contains(&s.len())
            && s.starts_with(|c: char| c.is_ascii_lowercase())
            && s.chars()
                .all(|c| c.is_ascii_lowercase() || c.is_ascii_digit());
        if ok {
            Ok(RunId(s.to_string()))
        } else {
            Err(TransportError::BadRunId(s.to_string()))
        }
    }

    pub fn as_str(&self) -> &str {
        &self.0
    }

    /// The iceoryx2 file prefix of this run.
    pub fn file_prefix(&self) -> String {
        format!("{}_", self.0)
    }

    /// The iceoryx2 configuration that keeps this run's files apart.
    ///
    /// iceoryx2's own clean-up of dead nodes (when a node is created, dropped, or opens a
    /// service) is off. A run never outlives one of its processes (a dead node stops the run,
    /// and the last one out removes the run's files by prefix, [`super::remove_run_files`]), so that
    /// clean-up has nothing to do here; and in iceoryx2 0.10 it can hang for ever. A process
    /// killed between creating a shared-memory file and sizing it leaves a zero-length file,
    /// and opening one loops without its timeout (`posix_shared_memory` `open_impl`: the
    /// `MappingSizeIsZero` arm never checks the elapsed time). That hung `coupler clean` in CI.
    pub fn config(&self) -> Config {
        let mut config = Config::default();
        config.global.prefix =
            FileName::new(self.file_prefix().as_bytes()).expect("run ids are valid file names");
        config.global.node.cleanup_dead_nodes_on_creation = false;
        config.global.node.cleanup_dead_nodes_on_destruction = false;
        config.global.service.cleanup_dead_nodes_on_open = false;
        config
    }
}

impl std::fmt::Display for RunId {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.0)
    }
}

/// Which transport a run uses.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, clap::ValueEnum)]
pub enum Kind {
    /// iceoryx2 shared memory: every process on one host, zero copies (the default).
    #[default]
    Iceoryx2,
    /// zenoh over TCP: nodes may run on other hosts.
    Zenoh,
}

impl std::fmt::Display for Kind {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            Kind::Iceoryx2 => "iceoryx2",
            Kind::Zenoh => "zenoh",
        })
    }
}

/// A message type that is its bytes: `#[repr(C)]`, no padding, no pointers (checked by
/// `bytemuck`), and shareable through iceoryx2.
pub trait Wire: bytemuck::Pod + ZeroCopySend + std::fmt::Debug {}
impl<T: bytemuck::Pod + ZeroCopySend + std::fmt::Debug> Wire for T {}

/// The sending end of one channel: a header `H` and a slice of `T` (`T = ()` and length 0 for
/// a channel of single messages, which travel as the header).
pub trait Outbox<H: Wire, T: Wire = ()> {
    /// Makes room for a message of `len` elements, lets `fill` write its header and elements
    /// in place, and sends it. The receiver is not woken: ring its [`Bell`] after the sends.
    fn publish(
        &self,
        len: usize,
        fill: &mut dyn FnMut(&mut H, &mut [T]),
    ) -> Result<(), TransportError>;
}

impl<M: Wire> dyn Outbox<M> + '_ {
    /// Sends one single message.
    pub fn send(&self, message: M) -> Result<(), TransportError> {
        self.publish(0, &mut |m, _| *m = message)
    }
}

/// The receiving end of one channel.
pub trait Inbox<H: Wire, T: Wire = ()> {
    /// Hands the oldest message waiting to `read` and returns true, or returns false at once
    /// when none is waiting. Never blocks: block on the process's [`Waiter`].
    fn take(&self, read: &mut dyn FnMut(&H, &[T])) -> Result<bool, TransportError>;
}

impl<M: Wire> dyn Inbox<M> + '_ {
    /// The oldest single message waiting, if any.
    pub fn receive(&self) -> Result<Option<M>, TransportError> {
        let mut got = None;
        self.take(&mut |m, _| got = Some(*m))?;
        Ok(got)
    }
}

/// Wakes one party after messages were sent to it.
pub trait Bell {
    fn ring(&self) -> Result<(), TransportError>;
}

/// Where one party blocks until a message may have arrived for it.
pub trait Waiter {
    /// Blocks for at most `slice`. Waiting is always in bounded slices, so that the caller can
    /// check, between slices, that its peers are alive and no signal arrived.
    fn wait(&self, slice: Duration) -> Result<Wake, TransportError>;
}

/// One process's membership of a run: opens the run's channels (every party opens them the
/// same way, so all agree on their settings) and says whether the other parties are there.
///
/// The channels: node → coupler `hello` and `status`; coupler → nodes `setup` (the bincode
/// [`crate::protocol::Setup`]) and `command`; solid → fluid `blocks` and `vertices` (the
/// geometry); fluid → solid `loads`. `max_len` is the most elements one message will hold.
pub trait Transport {
    fn id(&self) -> &RunId;
    fn kind(&self) -> Kind;
    /// True once SIGINT or SIGTERM reached this process.
    fn termination_requested(&self) -> bool;
    /// Whether `party` is still there: its process (`pid`, as its hello or the setup said) on
    /// this host for iceoryx2, its liveliness token for zenoh.
    fn alive(&self, party: Party, pid: u32) -> bool;
    /// How `party` is known to have gone, for messages ("is no longer running").
    fn gone_how(&self) -> &'static str;
    /// The place `me` blocks on; only that party opens it, once.
    fn waiter(&self, me: Party) -> Result<Box<dyn Waiter>, TransportError>;
    /// A handle to wake `party`.
    fn bell(&self, party: Party) -> Result<Box<dyn Bell>, TransportError>;

    fn hello_out(&self) -> Result<Box<dyn Outbox<Hello>>, TransportError>;
    fn hello_in(&self) -> Result<Box<dyn Inbox<Hello>>, TransportError>;
    fn setup_out(&self, max_len: usize)
    -> Result<Box<dyn Outbox<SetupHeader, u8>>, TransportError>;
    fn setup_in(&self) -> Result<Box<dyn Inbox<SetupHeader, u8>>, TransportError>;
    fn command_out(&self) -> Result<Box<dyn Outbox<Command>>, TransportError>;
    fn command_in(&self) -> Result<Box<dyn Inbox<Command>>, TransportError>;
    fn status_out(&self) -> Result<Box<dyn Outbox<Status>>, TransportError>;
    fn status_in(&self) -> Result<Box<dyn Inbox<Status>>, TransportError>;
    fn blocks_out(
        &self,
        max_len: usize,
    ) -> Result<Box<dyn Outbox<GeometryHeader, BlockState>>, TransportError>;
    fn blocks_in(&self) -> Result<Box<dyn Inbox<GeometryHeader, BlockState>>, TransportError>;
    fn vertices_out(
        &self,
        max_len: usize,
    ) -> Result<Box<dyn Outbox<GeometryHeader, [f64; 3]>>, TransportError>;
    fn vertices_in(&self) -> Result<Box<dyn Inbox<GeometryHeader, [f64; 3]>>, TransportError>;
    fn loads_out(
        &self,
        max_len: usize,
    ) -> Result<Box<dyn Outbox<LoadsHeader, BlockLoad>>, TransportError>;
    fn loads_in(&self) -> Result<Box<dyn Inbox<LoadsHeader, BlockLoad>>, TransportError>;
}

/// Where a process finds the run on the network (zenoh): endpoints such as
/// `tcp/127.0.0.1:7447`.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct Endpoints {
    /// Endpoints this process listens on (the coupler).
    pub listen: Vec<String>,
    /// Endpoints this process connects to (the nodes: the coupler's).
    pub connect: Vec<String>,
}

/// The three parties of a run; each owns one wake-up event service.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Party {
    Coupler,
    Fluid,
    Solid,
}

impl Party {
    pub fn leaf(self) -> &'static str {
        match self {
            Party::Coupler => "coupler",
            Party::Fluid => "fluid",
            Party::Solid => "solid",
        }
    }
}

impl From<crate::protocol::Role> for Party {
    fn from(role: crate::protocol::Role) -> Party {
        match role {
            crate::protocol::Role::Fluid => Party::Fluid,
            crate::protocol::Role::Solid => Party::Solid,
        }
    }
}

/// Why a bounded wait ended.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Wake {
    /// Somebody rang: there may be data.
    Rung,
    /// The slice of time passed without a ring.
    Quiet,
}

/// Is the process `pid` still alive (and not a zombie)?
pub fn process_alive(pid: u32) -> bool {
    match std::fs::read_to_string(format!("/proc/{pid}/stat")) {
        // Field 3 is the state; 'Z' (zombie) and 'X' (dead) mean the process has ended.
        Ok(stat) => stat
            .rsplit_once(')')
            .and_then(|(_, rest)| rest.split_whitespace().next())
            .is_some_and(|state| state != "Z" && state != "X"),
        Err(_) => false,
    }
}
