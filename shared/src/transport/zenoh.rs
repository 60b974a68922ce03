//! The zenoh transport (`--transport zenoh`): nodes on other hosts, over TCP.
//!
//! Topology: the coupler's zenoh session is a *router* listening on the run's endpoints
//! (`--listen tcp/HOST:PORT`); each node is a *client* connecting to it (`--connect`). Every
//! message goes through the coupler's router, so a node needs to reach the coupler's host
//! only, and the coupler is the star's centre exactly as with iceoryx2. Scouting (multicast
//! and gossip) is off: nothing is sent anywhere but to the endpoints named.
//!
//! Each channel is one key expression, `rockwave/<run id>/<channel>`, so runs sharing a router
//! or a port range never see each other's messages. A message is the bytes of its `#[repr(C)]`
//! header followed by those of its elements (see [`crate::protocol`]); the receiver checks the
//! length and copies it into aligned memory it reuses.
//!
//! Waking: a subscriber's callback (on zenoh's own threads) queues the message and rings the
//! process's one wake-up channel; the process blocks on that channel with a timeout, just as
//! it blocks on its iceoryx2 listener. Sending needs no bell: the message itself wakes.
//!
//! Liveness: each party holds a liveliness token `rockwave/<run id>/alive/<party>`. zenoh
//! withdraws it when the party's session closes, its process dies (the TCP connection
//! resets) or its host stops answering (the link's lease, [`LEASE`], expires): the others see
//! the party gone within that bound, and the coupler names the node.

use super::seam::{
    Bell, Endpoints, Inbox, Kind, Outbox, Party, RunId, Transport, TransportError, Waiter, Wake,
    Wire,
};
use crate::protocol::{
    BlockLoad, BlockState, Command, GeometryHeader, Hello, LoadsHeader, SetupHeader, Status,
};
use ::zenoh::Wait;
use ::zenoh::bytes::ZBytes;
use ::zenoh::liveliness::LivelinessToken;
use ::zenoh::pubsub::{Publisher, Subscriber};
use ::zenoh::qos::CongestionControl;
use ::zenoh::sample::{Sample, SampleKind};
use std::cell::RefCell;
use std::collections::VecDeque;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc::{Receiver, RecvTimeoutError, SyncSender, TrySendError};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

/// The link lease: a peer that sends nothing (not even zenoh's keep-alives, four per lease)
/// for this long is taken for gone, and its liveliness token withdrawn. It bounds how long a
/// vanished host goes unnoticed; keep-alives run on zenoh's own threads, so a node busy
/// computing still sends them.
pub const LEASE: Duration = Duration::from_secs(3);

/// How long after joining a party that was never seen still counts as alive (its token may
/// not have reached this process yet).
const GRACE: Duration = Duration::from_secs(10);

fn zerr<E: std::fmt::Display>(what: &str) -> impl FnOnce(E) -> TransportError + '_ {
    move |e| TransportError::Zenoh(format!("{what}: {e}"))
}

/// Set by SIGINT or SIGTERM (the iceoryx2 transport has iceoryx2's own handler).
static TERMINATE: AtomicBool = AtomicBool::new(false);

extern "C" fn on_signal(_: libc::c_int) {
    TERMINATE.store(true, Ordering::Relaxed);
}

fn install_signal_handlers() {
    // SAFETY: the handler only stores to an atomic, which is async-signal-safe.
    unsafe {
        libc::signal(libc::SIGINT, on_signal as *const () as libc::sighandler_t);
        libc::signal(libc::SIGTERM, on_signal as *const () as libc::sighandler_t);
    }
}

/// Which parties this process has seen holding a token, and which withdrew theirs.
#[derive(Default)]
struct Liveness {
    seen: [bool; 3],
    gone: [bool; 3],
}

fn index(party: Party) -> usize {
    match party {
        Party::Coupler => 0,
        Party::Fluid => 1,
        Party::Solid => 2,
    }
}

fn party_of(leaf: &str) -> Option<Party> {
    [Party::Coupler, Party::Fluid, Party::Solid]
        .into_iter()
        .find(|p| p.leaf() == leaf)
}

/// One process's membership of a run over zenoh.
pub struct ZenohRun {
    id: RunId,
    session: ::zenoh::Session,
    wake: SyncSender<()>,
    waiter: Mutex<Option<Receiver<()>>>,
    liveness: Arc<Mutex<Liveness>>,
    joined: Instant,
    _token: LivelinessToken,
    _liveness_sub: Subscriber<()>,
}

/// A JSON5 list of strings.
fn json_list(items: &[String]) -> String {
    let quoted: Vec<String> = items.iter().map(|s| format!("{s:?}")).collect();
    format!("[{}]", quoted.join(","))
}

impl ZenohRun {
    /// Joins run `id` as `party`: the coupler as a router listening on `endpoints.listen`
    /// (and connecting to `endpoints.connect`, e.g. other routers), a node as a client of
    /// `endpoints.connect`, retrying for up to `connect_timeout`.
    pub fn join(
        id: &RunId,
        party: Party,
        endpoints: &Endpoints,
        connect_timeout: Duration,
    ) -> Result<ZenohRun, TransportError> {
        install_signal_handlers();
        let router = party == Party::Coupler;
        if router && endpoints.listen.is_empty() {
            return Err(TransportError::Zenoh(
                "the coupler needs an endpoint to listen on. Fix: --listen tcp/HOST:PORT".into(),
            ));
        }
        if !router && endpoints.connect.is_empty() {
            return Err(TransportError::Zenoh(
                "a node needs the coupler's endpoint. Fix: --connect tcp/HOST:PORT (what the coupler listens on)".into(),
            ));
        }
        let timeout_ms = (connect_timeout.as_secs_f64() * 1e3).round().max(1.0) as u64;
        let settings = [
            (
                "mode",
                format!("{:?}", if router { "router" } else { "client" }),
            ),
            (
                "listen/endpoints",
                json_list(if router { &endpoints.listen } else { &[] }),
            ),
            ("connect/endpoints", json_list(&endpoints.connect)),
            ("connect/timeout_ms", timeout_ms.to_string()),
            ("connect/exit_on_failure", "true".into()),
            (
                "connect/retry",
                "{ period_init_ms: 100, period_max_ms: 1000, period_increase_factor: 2 }".into(),
            ),
            ("scouting/multicast/enabled", "false".into()),
            ("scouting/gossip/enabled", "false".into()),
            ("timestamping/enabled", "false".into()),
            ("transport/link/tx/lease", LEASE.as_millis().to_string()),
            ("transport/link/tx/keep_alive", "4".into()),
        ];
        let mut config = ::zenoh::Config::default();
        for (key, value) in &settings {
            config
                .insert_json5(key, value)
                .map_err(zerr(&format!("config {key} = {value}")))?;
        }
        let session = ::zenoh::open(config).wait().map_err(|e| {
            TransportError::Zenoh(if router && !endpoints.connect.is_empty() {
                // The router also connects (--connect): either may be what failed.
                format!(
                    "cannot listen on {} and connect to {}: {e}. Fix: check that the --connect \
                     endpoints are running zenoh routers reachable from here (address and port), \
                     and that the --listen port is free on an address of this host",
                    endpoints.listen.join(", "),
                    endpoints.connect.join(", ")
                )
            } else if router {
                format!(
                    "cannot listen on {}: {e}. Fix: choose a free port, or an address of this host",
                    endpoints.listen.join(", ")
                )
            } else {
                format!(
                    "no coupler reachable at {} within {:.0} s: {e}. Fix: start `coupler run --transport zenoh --attach --listen ...` first, and check the address and port",
                    endpoints.connect.join(", "),
                    connect_timeout.as_secs_f64()
                )
            })
        })?;
        let (wake, waiter) = std::sync::mpsc::sync_channel(1);
        let liveness = Arc::new(Mutex::new(Liveness::default()));
        let token = session
            .liveliness()
            .declare_token(format!("rockwave/{id}/alive/{}", party.leaf()))
            .wait()
            .map_err(zerr("liveliness token"))?;
        let sub = {
            let liveness = liveness.clone();
            let wake = wake.clone();
            session
                .liveliness()
                .declare_subscriber(format!("rockwave/{id}/alive/*"))
                .history(true)
                .callback(move |sample: Sample| {
                    let key = sample.key_expr().as_str();
                    let Some(p) = key.rsplit('/').next().and_then(party_of) else {
                        return;
                    };
                    let mut l = liveness.lock().unwrap_or_else(|e| e.into_inner());
                    match sample.kind() {
                        SampleKind::Put => {
                            l.seen[index(p)] = true;
                            l.gone[index(p)] = false;
                        }
                        SampleKind::Delete => l.gone[index(p)] = true,
                    }
                    drop(l);
                    // A party gone is news for whoever waits.
                    let _ = wake.try_send(());
                })
                .wait()
                .map_err(zerr("liveliness subscriber"))?
        };
        Ok(ZenohRun {
            id: id.clone(),
            session,
            wake,
            waiter: Mutex::new(Some(waiter)),
            liveness,
            joined: Instant::now(),
            _token: token,
            _liveness_sub: sub,
        })
    }

    fn key(&self, leaf: &str) -> String {
        format!("rockwave/{}/{leaf}", self.id)
    }

    fn outbox<H: Wire, T: Wire>(
        &self,
        leaf: &str,
        max_len: usize,
    ) -> Result<Box<dyn Outbox<H, T>>, TransportError> {
        let publisher = self
            .session
            .declare_publisher(self.key(leaf))
            // Never drop a message (the default drops under congestion), and send each at
            // once instead of waiting to batch it with others: a step waits for it.
            .congestion_control(CongestionControl::Block)
            .express(true)
            .wait()
            .map_err(zerr(leaf))?;
        Ok(Box::new(ZOut {
            publisher,
            scratch: RefCell::new((H::zeroed(), Vec::with_capacity(max_len))),
            leaf: leaf.to_string(),
        }))
    }

    fn inbox<H: Wire, T: Wire>(&self, leaf: &str) -> Result<Box<dyn Inbox<H, T>>, TransportError> {
        let queue: Arc<Mutex<VecDeque<ZBytes>>> = Arc::default();
        let subscriber = {
            let (queue, wake) = (queue.clone(), self.wake.clone());
            self.session
                .declare_subscriber(self.key(leaf))
                .callback(move |sample: Sample| {
                    queue
                        .lock()
                        .unwrap_or_else(|e| e.into_inner())
                        .push_back(sample.payload().clone());
                    match wake.try_send(()) {
                        // Full: a wake-up is pending already; the receiver drains everything.
                        Ok(())
                        | Err(TrySendError::Full(()))
                        | Err(TrySendError::Disconnected(())) => {}
                    }
                })
                .wait()
                .map_err(zerr(leaf))?
        };
        Ok(Box::new(ZIn {
            queue,
            _subscriber: subscriber,
            payload: RefCell::new(Vec::new()),
            leaf: leaf.to_string(),
        }))
    }
}

/// The sending end of a channel: the message is built in reused memory, then its bytes go.
struct ZOut<H, T> {
    publisher: Publisher<'static>,
    scratch: RefCell<(H, Vec<T>)>,
    leaf: String,
}

impl<H: Wire, T: Wire> Outbox<H, T> for ZOut<H, T> {
    fn publish(
        &self,
        len: usize,
        fill: &mut dyn FnMut(&mut H, &mut [T]),
    ) -> Result<(), TransportError> {
        let mut scratch = self.scratch.borrow_mut();
        let (header, payload) = &mut *scratch;
        payload.clear();
        payload.resize(len, T::zeroed());
        fill(header, payload);
        let head = bytemuck::bytes_of(header);
        let body: &[u8] = bytemuck::cast_slice(payload.as_slice());
        let mut bytes = Vec::with_capacity(head.len() + body.len());
        bytes.extend_from_slice(head);
        bytes.extend_from_slice(body);
        self.publisher
            .put(bytes)
            .wait()
            .map_err(zerr(&format!("send on {}", self.leaf)))
    }
}

/// The receiving end: messages the callback queued, copied out into aligned memory.
struct ZIn<T> {
    queue: Arc<Mutex<VecDeque<ZBytes>>>,
    _subscriber: Subscriber<()>,
    payload: RefCell<Vec<T>>,
    leaf: String,
}

impl<H: Wire, T: Wire> Inbox<H, T> for ZIn<T> {
    fn take(&self, read: &mut dyn FnMut(&H, &[T])) -> Result<bool, TransportError> {
        let Some(message) = self
            .queue
            .lock()
            .unwrap_or_else(|e| e.into_inner())
            .pop_front()
        else {
            return Ok(false);
        };
        let bytes = message.to_bytes();
        let (hs, es) = (size_of::<H>(), size_of::<T>());
        let body = bytes.len().checked_sub(hs);
        let n = match body {
            Some(0) => 0,
            Some(b) if es > 0 && b % es == 0 => b / es,
            _ => {
                return Err(TransportError::Protocol(format!(
                    "malformed message on '{}': {} bytes for a {hs}-byte header and {es}-byte elements (a peer of another protocol version?)",
                    self.leaf,
                    bytes.len()
                )));
            }
        };
        let header: H = bytemuck::pod_read_unaligned(&bytes[..hs]);
        let mut payload = self.payload.borrow_mut();
        payload.clear();
        payload.resize(n, T::zeroed());
        bytemuck::cast_slice_mut::<T, u8>(payload.as_mut_slice()).copy_from_slice(&bytes[hs..]);
        read(&header, &payload);
        Ok(true)
    }
}

/// The process's one wake-up channel.
struct ZWaiter(Receiver<()>);

impl Waiter for ZWaiter {
    fn wait(&self, slice: Duration) -> Result<Wake, TransportError> {
        match self.0.recv_timeout(slice) {
            Ok(()) => Ok(Wake::Rung),
            Err(RecvTimeoutError::Timeout) => Ok(Wake::Quiet),
            Err(RecvTimeoutError::Disconnected) => {
                Err(TransportError::Zenoh("the wake-up channel closed".into()))
            }
        }
    }
}

/// Nothing to ring: a zenoh message wakes its receiver itself.
struct NoBell;

impl Bell for NoBell {
    fn ring(&self) -> Result<(), TransportError> {
        Ok(())
    }
}

impl Transport for ZenohRun {
    fn id(&self) -> &RunId {
        &self.id
    }
    fn kind(&self) -> Kind {
        Kind::Zenoh
    }
    fn termination_requested(&self) -> bool {
        TERMINATE.load(Ordering::Relaxed)
    }
    fn alive(&self, party: Party, _pid: u32) -> bool {
        let l = self.liveness.lock().unwrap_or_else(|e| e.into_inner());
        let i = index(party);
        !l.gone[i] && (l.seen[i] || self.joined.elapsed() < GRACE)
    }
    fn gone_how(&self) -> &'static str {
        "is no longer reachable: its zenoh liveliness token was withdrawn (process ended, host down or network cut)"
    }
    fn waiter(&self, _me: Party) -> Result<Box<dyn Waiter>, TransportError> {
        let rx = self
            .waiter
            .lock()
            .unwrap_or_else(|e| e.into_inner())
            .take()
            .ok_or_else(|| TransportError::Zenoh("the waiter was opened twice".into()))?;
        Ok(Box::new(ZWaiter(rx)))
    }
    fn bell(&self, _party: Party) -> Result<Box<dyn Bell>, TransportError> {
        Ok(Box::new(NoBell))
    }
    fn hello_out(&self) -> Result<Box<dyn Outbox<Hello>>, TransportError> {
        self.outbox("hello", 0)
    }
    fn hello_in(&self) -> Result<Box<dyn Inbox<Hello>>, TransportError> {
        self.inbox("hello")
    }
    fn setup_out(
        &self,
        max_len: usize,
    ) -> Result<Box<dyn Outbox<SetupHeader, u8>>, TransportError> {
        self.outbox("setup", max_len)
    }
    fn setup_in(&self) -> Result<Box<dyn Inbox<SetupHeader, u8>>, TransportError> {
        self.inbox("setup")
    }
    fn command_out(&self) -> Result<Box<dyn Outbox<Command>>, TransportError> {
        self.outbox("command", 0)
    }
    fn command_in(&self) -> Result<Box<dyn Inbox<Command>>, TransportError> {
        self.inbox("command")
    }
    fn status_out(&self) -> Result<Box<dyn Outbox<Status>>, TransportError> {
        self.outbox("status", 0)
    }
    fn status_in(&self) -> Result<Box<dyn Inbox<Status>>, TransportError> {
        self.inbox("status")
    }
    fn blocks_out(
        &self,
        max_len: usize,
    ) -> Result<Box<dyn Outbox<GeometryHeader, BlockState>>, TransportError> {
        self.outbox("geometry/blocks", max_len)
    }
    fn blocks_in(&self) -> Result<Box<dyn Inbox<GeometryHeader, BlockState>>, TransportError> {
        self.inbox("geometry/blocks")
    }
    fn vertices_out(
        &self,
        max_len: usize,
    ) -> Result<Box<dyn Outbox<GeometryHeader, [f64; 3]>>, TransportError> {
        self.outbox("geometry/vertices", max_len)
    }
    fn vertices_in(&self) -> Result<Box<dyn Inbox<GeometryHeader, [f64; 3]>>, TransportError> {
        self.inbox("geometry/vertices")
    }
    fn loads_out(
        &self,
        max_len: usize,
    ) -> Result<Box<dyn Outbox<LoadsHeader, BlockLoad>>, TransportError> {
        self.outbox("loads", max_len)
    }
    fn loads_in(&self) -> Result<Box<dyn Inbox<LoadsHeader, BlockLoad>>, TransportError> {
        self.inbox("loads")
    }
}

impl Drop for ZenohRun {
    fn drop(&mut self) {
        // Closing flushes what is queued and withdraws this party's token at once (rather
        // than at the lease's end).
        let _ = self.session.close().wait();
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn endpoint() -> String {
        let port = std::net::TcpListener::bind("127.0.0.1:0")
            .and_then(|l| l.local_addr())
            .unwrap()
            .port();
        format!("tcp/127.0.0.1:{port}")
    }

    /// Blocks on `waiter` until `inbox` yields a message (bounded: 5 s).
    fn take_one<H: Wire, T: Wire>(
        waiter: &dyn Waiter,
        inbox: &dyn Inbox<H, T>,
        resend: &mut dyn FnMut(),
    ) -> Result<(H, Vec<T>), TransportError> {
        let start = Instant::now();
        loop {
            let mut got = None;
            inbox.take(&mut |h, p| got = Some((*h, p.to_vec())))?;
            if let Some(g) = got {
                return Ok(g);
            }
            assert!(start.elapsed() < Duration::from_secs(5), "nothing arrived");
            // The client learns of the router's subscriber asynchronously: say it again.
            resend();
            waiter.wait(Duration::from_millis(100))?;
        }
    }

    #[test]
    fn messages_cross_whole_malformed_ones_are_named_and_a_leaver_is_seen() {
        let id = RunId::fresh();
        let ep = endpoint();
        let timeout = Duration::from_secs(5);
        let coupler = ZenohRun::join(
            &id,
            Party::Coupler,
            &Endpoints {
                listen: vec![ep.clone()],
                connect: vec![],
            },
            timeout,
        )
        .unwrap();
        let waiter = coupler.waiter(Party::Coupler).unwrap();
        let inbox = coupler.blocks_in().unwrap();
        let solid = ZenohRun::join(
            &id,
            Party::Solid,
            &Endpoints {
                listen: vec![],
                connect: vec![ep],
            },
            timeout,
        )
        .unwrap();
        let outbox = solid.blocks_out(3).unwrap();
        let header = GeometryHeader {
            step: 7,
            time: 0.25,
            vertex_count: 24,
            _reserved: 0,
        };
        let states: Vec<BlockState> = (0..3)
            .map(|i| BlockState {
                block: i,
                centroid: [i as f64, -1.5, 1e-300],
                ..Default::default()
            })
            .collect();
        let mut send = || {
            outbox
                .publish(3, &mut |h, p| {
                    *h = header;
                    p.copy_from_slice(&states);
                })
                .unwrap()
        };
        send();
        let (h, p) = take_one(&*waiter, &*inbox, &mut send).unwrap();
        assert_eq!((h.step, h.time, h.vertex_count), (7, 0.25, 24));
        assert_eq!(p, states, "the elements arrive bit for bit");
        // Bytes that are not a header plus whole elements are refused, naming the channel
        // (copies of the good message the retries sent may still come first).
        let raw = solid.key("geometry/blocks");
        let start = Instant::now();
        let err = loop {
            solid.session.put(&raw, vec![1u8, 2, 3]).wait().unwrap();
            match inbox.take(&mut |_, _| {}) {
                Err(e) => break e,
                Ok(_) => assert!(start.elapsed() < Duration::from_secs(5), "not refused"),
            }
            waiter.wait(Duration::from_millis(100)).unwrap();
        };
        assert!(
            err.to_string()
                .contains("malformed message on 'geometry/blocks'"),
            "{err}"
        );

        // The solid's token was seen; once it leaves, the coupler knows within the lease.
        assert!(coupler.alive(Party::Solid, 0));
        drop((outbox, solid));
        let start = Instant::now();
        while coupler.alive(Party::Solid, 0) {
            assert!(
                start.elapsed() < LEASE * 2,
                "the solid's leaving went unseen"
            );
            waiter.wait(Duration::from_millis(100)).unwrap();
        }
        assert!(coupler.alive(Party::Coupler, 0));
    }
}
