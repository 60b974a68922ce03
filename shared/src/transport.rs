//! How the three processes of a run talk: the transport seam, and the run's identity.
//!
//! The node runtime and the coupler talk through the traits here and nothing else: an
//! [`Outbox`] and an [`Inbox`] per channel (one typed message, or a typed header with a slice
//! of elements), a [`Bell`] to wake the receiver after sending, and a [`Waiter`] to block on
//! (with a timeout) until something arrived. A [`Transport`] opens them; two implement it:
//!
//! - [`iceoryx::Run`] (the default): iceoryx2 shared memory on one host. Senders loan memory
//!   and the solver writes straight into it; receivers read in place. Zero copies.
//! - [`zenoh::ZenohRun`] (`--transport zenoh`): zenoh over TCP, so that nodes can run on other
//!   hosts. The same `#[repr(C)]` messages travel as their bytes (see [`crate::protocol`]).
//!
//! The traits hand the message to a closure instead of returning it: iceoryx2's samples borrow
//! shared memory, and the closure is how a solver writes into (or reads from) it in place.
//!
//! Every resource of a run carries the run's id: in iceoryx2's service names and file prefix,
//! in zenoh's key expressions (`rockwave/<id>/...`). Two runs never see each other, and a
//! run's leftovers (after a node was killed) can be found and removed by prefix.

pub mod iceoryx;
pub mod zenoh;

pub use iceoryx::{Ipc, Pub, Run, Sub, wait};

use crate::protocol::{
    BlockLoad, BlockState, Command, GeometryHeader, Hello, LoadsHeader, SetupHeader, Status,
};
use iceoryx2::prelude::*;
use std::path::{Path, PathBuf};
use std::time::Duration;

/// Where iceoryx2 keeps its non-shared-memory files (node monitors, service descriptions).
pub const ICEORYX2_ROOT: &str = "/tmp/iceoryx2";
/// Where iceoryx2 keeps its shared-memory segments.
pub const SHM_ROOT: &str = "/dev/shm";

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
    /// and the last one out removes the run's files by prefix, [`remove_run_files`]), so that
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

/// Joins run `id` as `party` (named `name` for iceoryx2) over the transport `kind`.
pub fn join(
    kind: Kind,
    id: &RunId,
    party: Party,
    name: &str,
    endpoints: &Endpoints,
    connect_timeout: Duration,
) -> Result<Box<dyn Transport>, TransportError> {
    match kind {
        Kind::Iceoryx2 => Ok(Box::new(Run::join(id, name)?)),
        Kind::Zenoh => Ok(Box::new(zenoh::ZenohRun::join(
            id,
            party,
            endpoints,
            connect_timeout,
        )?)),
    }
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

/// Removes every file of run `id` that iceoryx2 left behind. Call only when no process of the
/// run is alive any more (the coupler does, after its nodes exited; a node does when it finds
/// the coupler dead). Every file of the run carries its prefix, so removing by prefix is
/// complete; iceoryx2's stale-resource clean-up is not used, because it opens each dead port's
/// shared memory first and hangs on a zero-length one (see [`RunId::config`]). Returns the
/// number of files removed.
pub fn remove_run_files(id: &RunId) -> usize {
    let prefix = id.file_prefix();
    let mut removed = 0;
    for root in [Path::new(SHM_ROOT), Path::new(ICEORYX2_ROOT)] {
        removed += remove_prefixed(root, &prefix, 0);
    }
    removed
}

fn remove_prefixed(dir: &Path, prefix: &str, depth: usize) -> usize {
    let Ok(entries) = std::fs::read_dir(dir) else {
        return 0;
    };
    let mut removed = 0;
    for entry in entries.flatten() {
        let path = entry.path();
        let name = entry.file_name();
        let name = name.to_string_lossy();
        let is_dir = entry.file_type().is_ok_and(|t| t.is_dir());
        if name.starts_with(prefix) {
            let ok = if is_dir {
                std::fs::remove_dir_all(&path)
            } else {
                std::fs::remove_file(&path)
            };
            removed += ok.is_ok() as usize;
        } else if is_dir && depth < 3 {
            let inner = remove_prefixed(&path, prefix, depth + 1);
            removed += inner;
            // A node's folder that held only this run's files is this run's too. A folder
            // that was empty already may be another run's node being created: leave it.
            if inner > 0
                && depth > 0
                && std::fs::read_dir(&path).is_ok_and(|mut d| d.next().is_none())
            {
                let _ = std::fs::remove_dir(&path);
            }
        }
    }
    removed
}

/// Run ids that have files in /dev/shm, with the age of their newest file.
pub fn runs_with_files() -> Vec<(RunId, Duration)> {
    let mut found: Vec<(RunId, Duration)> = Vec::new();
    let Ok(entries) = std::fs::read_dir(SHM_ROOT) else {
        return found;
    };
    for entry in entries.flatten() {
        let name = entry.file_name().to_string_lossy().to_string();
        let Some((id, _)) = name.split_once('_') else {
            continue;
        };
        let Ok(id) = RunId::parse(id) else { continue };
        if !id.0.starts_with("rw") {
            continue;
        }
        let age = entry
            .metadata()
            .and_then(|m| m.modified())
            .ok()
            .and_then(|t| t.elapsed().ok())
            .unwrap_or_default();
        match found.iter_mut().find(|(r, _)| *r == id) {
            Some((_, a)) => *a = (*a).min(age),
            None => found.push((id, age)),
        }
    }
    found
}

/// Is any iceoryx2 node of run `id` still alive?
pub fn run_has_live_nodes(id: &RunId) -> bool {
    let mut alive = false;
    let _ = Node::<Ipc>::list(&id.config(), |state| {
        alive |= matches!(state, NodeState::Alive(_));
        CallbackProgression::Continue
    });
    alive
}

/// Removes the files of runs whose processes all died (a coupler killed with SIGKILL leaves
/// them). Runs younger than `min_age` are left alone: their nodes may still be starting.
pub fn remove_stale_runs(min_age: Duration) -> Vec<RunId> {
    let mut cleaned = Vec::new();
    for (id, age) in runs_with_files() {
        if age >= min_age && !run_has_live_nodes(&id) {
            remove_run_files(&id);
            cleaned.push(id);
        }
    }
    cleaned
}

/// The files of run `id` still present (for tests and `coupler clean --dry-run`).
pub fn run_files(id: &RunId) -> Vec<PathBuf> {
    fn walk(dir: &Path, prefix: &str, out: &mut Vec<PathBuf>, depth: usize) {
        let Ok(entries) = std::fs::read_dir(dir) else {
            return;
        };
        for e in entries.flatten() {
            let p = e.path();
            if e.file_name().to_string_lossy().starts_with(prefix) {
                out.push(p);
            } else if depth < 3 && e.file_type().is_ok_and(|t| t.is_dir()) {
                walk(&p, prefix, out, depth + 1);
            }
        }
    }
    let mut out = Vec::new();
    for root in [SHM_ROOT, ICEORYX2_ROOT] {
        walk(Path::new(root), &id.file_prefix(), &mut out, 0);
    }
    out
}
