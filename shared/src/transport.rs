//! The iceoryx2 services of one run.
//!
//! Every resource of a run carries the run's id twice: in the service names
//! (`rockwave/<id>/...`) and as the file prefix iceoryx2 gives everything it creates in
//! /dev/shm and /tmp/iceoryx2 (`<id>_...`). Two runs on one machine therefore never see each
//! other, and a run's leftovers (after a node was killed) can be found and removed by prefix.
//!
//! iceoryx2 publish–subscribe is poll-only, so each receiver owns one event service (its
//! "wake-up" bell). A sender publishes, then rings the receiver's bell; the receiver blocks on
//! its listener and drains its subscribers when woken. Nobody spins.
//!
//! Every service is opened here and only here, so all three processes agree on its settings.

use crate::protocol::{
    BlockLoad, BlockState, Command, GeometryHeader, Hello, LoadsHeader, SetupHeader, Status,
};
use iceoryx2::port::listener::{Listener, ListenerWaitError};
use iceoryx2::port::notifier::Notifier;
use iceoryx2::port::publisher::Publisher;
use iceoryx2::port::subscriber::Subscriber;
use iceoryx2::prelude::*;
use iceoryx2::service::port_factory::{event, publish_subscribe};
use std::path::{Path, PathBuf};
use std::time::Duration;

/// The service flavour: inter-process, single-threaded ports.
pub type Ipc = ipc::Service;
pub type Pub<T, H = ()> = Publisher<Ipc, T, H>;
pub type Sub<T, H = ()> = Subscriber<Ipc, T, H>;
type PubSub<T, H> = publish_subscribe::PortFactory<Ipc, T, H>;

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
}

fn iox<E: std::fmt::Debug>(what: &str) -> impl FnOnce(E) -> TransportError + '_ {
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
    pub fn config(&self) -> Config {
        let mut config = Config::default();
        config.global.prefix =
            FileName::new(self.file_prefix().as_bytes()).expect("run ids are valid file names");
        config
    }
}

impl std::fmt::Display for RunId {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.0)
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
    fn leaf(self) -> &'static str {
        match self {
            Party::Coupler => "coupler",
            Party::Fluid => "fluid",
            Party::Solid => "solid",
        }
    }
}

/// One process's membership of a run: its iceoryx2 node and the run's service catalogue.
pub struct Run {
    pub id: RunId,
    pub node: Node<Ipc>,
}

/// The one set of publish–subscribe settings: two publishers and two subscribers at most (the
/// hello and status services have one of each side), a few samples of slack, no history.
macro_rules! pubsub {
    ($run:expr, $payload:ty, $header:ty, $leaf:expr, $buffer:expr) => {
        $run.node
            .service_builder(&$run.name($leaf)?)
            .publish_subscribe::<$payload>()
            .user_header::<$header>()
            .max_publishers(2)
            .max_subscribers(2)
            .subscriber_max_buffer_size($buffer)
            .subscriber_max_borrowed_samples(2)
            .history_size(0)
            .enable_safe_overflow(true)
            .open_or_create()
            .map_err(iox($leaf))
    };
}

impl Run {
    /// Joins run `id` as an iceoryx2 node named `name`.
    pub fn join(id: &RunId, name: &str) -> Result<Run, TransportError> {
        // iceoryx2 warns on stderr when it tidies up after a killed peer; our own messages
        // name what happened, so only its errors are shown.
        set_log_level(LogLevel::Error);
        let node = NodeBuilder::new()
            .config(&id.config())
            .name(&NodeName::new(name).map_err(iox("node name"))?)
            .create::<Ipc>()
            .map_err(iox("create node"))?;
        Ok(Run {
            id: id.clone(),
            node,
        })
    }

    fn name(&self, leaf: &str) -> Result<ServiceName, TransportError> {
        ServiceName::new(&format!("rockwave/{}/{leaf}", self.id)).map_err(iox("service name"))
    }

    /// True once SIGINT or SIGTERM reached this process (iceoryx2's own signal handler).
    pub fn termination_requested(&self) -> bool {
        self.node.wait(Duration::ZERO).is_err()
    }

    /// Opens (or creates) a publish–subscribe service with the settings every party uses.
    /// (A macro because iceoryx2 implements `open_or_create` separately for `T` and `[T]`.)
    /// Node → coupler: [`Hello`], re-sent until the setup arrives.
    pub fn hello(&self) -> Result<PubSub<Hello, ()>, TransportError> {
        pubsub!(self, Hello, (), "hello", 8)
    }
    /// Coupler → nodes: the bincode-encoded [`crate::protocol::Setup`].
    pub fn setup(&self) -> Result<PubSub<[u8], SetupHeader>, TransportError> {
        pubsub!(self, [u8], SetupHeader, "setup", 2)
    }
    /// Coupler → nodes: one [`Command`] per step.
    pub fn command(&self) -> Result<PubSub<Command, ()>, TransportError> {
        pubsub!(self, Command, (), "command", 4)
    }
    /// Nodes → coupler: one [`Status`] per command.
    pub fn status(&self) -> Result<PubSub<Status, ()>, TransportError> {
        pubsub!(self, Status, (), "status", 8)
    }
    /// Solid → fluid: pose and velocity of each moving block.
    pub fn geometry_blocks(&self) -> Result<PubSub<[BlockState], GeometryHeader>, TransportError> {
        pubsub!(self, [BlockState], GeometryHeader, "geometry/blocks", 4)
    }
    /// Solid → fluid: world-frame corners of the moving blocks.
    pub fn geometry_vertices(&self) -> Result<PubSub<[[f64; 3]], GeometryHeader>, TransportError> {
        pubsub!(self, [[f64; 3]], GeometryHeader, "geometry/vertices", 4)
    }
    /// Fluid → solid: force and torque on each moving block.
    pub fn loads(&self) -> Result<PubSub<[BlockLoad], LoadsHeader>, TransportError> {
        pubsub!(self, [BlockLoad], LoadsHeader, "loads", 4)
    }

    fn bell(&self, party: Party) -> Result<event::PortFactory<Ipc>, TransportError> {
        self.node
            .service_builder(&self.name(&format!("wake/{}", party.leaf()))?)
            .event()
            .max_notifiers(4)
            .max_listeners(2)
            .open_or_create()
            .map_err(iox("wake-up event"))
    }

    /// The bell `party` waits on; only that party creates a listener on it.
    pub fn listener(&self, party: Party) -> Result<Listener<Ipc>, TransportError> {
        self.bell(party)?
            .listener_builder()
            .create()
            .map_err(iox("listener"))
    }

    /// A handle to ring `party`'s bell.
    pub fn notifier(&self, party: Party) -> Result<Notifier<Ipc>, TransportError> {
        self.bell(party)?
            .notifier_builder()
            .create()
            .map_err(iox("notifier"))
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

/// Blocks on a listener for at most `slice`. Waiting is always in bounded slices so that the
/// caller can check, between slices, that its peers are alive and no signal arrived.
/// A signal interrupting the wait is not an error: the caller checks for termination next.
pub fn wait(listener: &Listener<Ipc>, slice: Duration) -> Result<Wake, TransportError> {
    match listener.timed_wait(|_| {}, slice) {
        Ok(n) if n > 0 => Ok(Wake::Rung),
        Ok(_) | Err(ListenerWaitError::InterruptSignal) => Ok(Wake::Quiet),
        Err(e) => Err(TransportError::Iceoryx(format!("wait: {e:?}"))),
    }
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
/// the coupler dead). Dead iceoryx2 nodes are first cleaned through iceoryx2 itself, then any
/// remaining file carrying the run's prefix is removed. Returns the number of files removed.
pub fn remove_run_files(id: &RunId) -> usize {
    let config = id.config();
    let _ = Node::<Ipc>::list(&config, |state| {
        if let NodeState::Dead(dead) = state {
            let _ = dead.try_remove_stale_resources();
        }
        CallbackProgression::Continue
    });
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
