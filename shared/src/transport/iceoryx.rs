//! The iceoryx2 transport (the default): shared memory on one host.
//!
//! Every resource carries the run's id twice: in the service names (`rockwave/<id>/...`) and
//! as the file prefix iceoryx2 gives everything it creates in /dev/shm and /tmp/iceoryx2
//! (`<id>_...`); see [`super::remove_run_files`].
//!
//! iceoryx2 publish–subscribe is poll-only, so each receiver owns one event service (its
//! "wake-up" bell). A sender publishes, then rings the receiver's bell; the receiver blocks on
//! its listener and drains its subscribers when woken. Nobody spins.
//!
//! Every service is opened here and only here, so all three processes agree on its settings.

use super::seam::{
    Bell, Inbox, Kind, Outbox, Party, RunId, Transport, TransportError, Waiter, Wake, Wire, iox,
    process_alive,
};
use crate::protocol::{
    BlockLoad, BlockState, Command, GeometryHeader, Hello, LoadsHeader, SetupHeader, Status,
};
use iceoryx2::port::listener::{Listener, ListenerWaitError};
use iceoryx2::port::notifier::Notifier;
use iceoryx2::port::publisher::Publisher;
use iceoryx2::port::subscriber::Subscriber;
use iceoryx2::prelude::*;
use iceoryx2::service::port_factory::{event, publish_subscribe};
use std::time::Duration;

/// The service flavour: inter-process, single-threaded ports.
pub type Ipc = ipc::Service;
pub type Pub<T, H = ()> = Publisher<Ipc, T, H>;
pub type Sub<T, H = ()> = Subscriber<Ipc, T, H>;
type PubSub<T, H> = publish_subscribe::PortFactory<Ipc, T, H>;

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

/// A channel of single messages.
struct ValueOut<M: Wire>(Pub<M>);
struct ValueIn<M: Wire>(Sub<M>);
/// A channel of a header and a slice.
struct SliceOut<H: Wire, T: Wire>(Pub<[T], H>);
struct SliceIn<H: Wire, T: Wire>(Sub<[T], H>);

impl<M: Wire> Outbox<M> for ValueOut<M> {
    fn publish(
        &self,
        _len: usize,
        fill: &mut dyn FnMut(&mut M, &mut [()]),
    ) -> Result<(), TransportError> {
        let mut m = M::zeroed();
        fill(&mut m, &mut []);
        self.0.send_copy(m).map_err(iox("send"))?;
        Ok(())
    }
}

impl<M: Wire> Inbox<M> for ValueIn<M> {
    fn take(&self, read: &mut dyn FnMut(&M, &[()])) -> Result<bool, TransportError> {
        match self.0.receive().map_err(iox("receive"))? {
            Some(s) => {
                read(s.payload(), &[]);
                Ok(true)
            }
            None => Ok(false),
        }
    }
}

impl<H: Wire + Default, T: Wire + Default> Outbox<H, T> for SliceOut<H, T> {
    fn publish(
        &self,
        len: usize,
        fill: &mut dyn FnMut(&mut H, &mut [T]),
    ) -> Result<(), TransportError> {
        // Zero copy: the sender writes straight into the loaned shared memory.
        let mut sample = self.0.loan_slice(len).map_err(iox("loan"))?;
        let mut header = H::zeroed();
        fill(&mut header, sample.payload_mut());
        *sample.user_header_mut() = header;
        sample.send().map_err(iox("send"))?;
        Ok(())
    }
}

impl<H: Wire, T: Wire> Inbox<H, T> for SliceIn<H, T> {
    fn take(&self, read: &mut dyn FnMut(&H, &[T])) -> Result<bool, TransportError> {
        match self.0.receive().map_err(iox("receive"))? {
            Some(s) => {
                // Zero copy: the receiver reads the sender's shared memory in place.
                read(s.user_header(), s.payload());
                Ok(true)
            }
            None => Ok(false),
        }
    }
}

impl Waiter for Listener<Ipc> {
    fn wait(&self, slice: Duration) -> Result<Wake, TransportError> {
        wait(self, slice)
    }
}

impl Bell for Notifier<Ipc> {
    fn ring(&self) -> Result<(), TransportError> {
        self.notify().map_err(iox("notify"))?;
        Ok(())
    }
}

fn value_out<M: Wire>(
    f: Result<PubSub<M, ()>, TransportError>,
) -> Result<Box<dyn Outbox<M>>, TransportError> {
    let p = f?.publisher_builder().create().map_err(iox("publisher"))?;
    Ok(Box::new(ValueOut(p)))
}

fn value_in<M: Wire>(
    f: Result<PubSub<M, ()>, TransportError>,
) -> Result<Box<dyn Inbox<M>>, TransportError> {
    let s = f?
        .subscriber_builder()
        .create()
        .map_err(iox("subscriber"))?;
    Ok(Box::new(ValueIn(s)))
}

fn slice_out<H: Wire + Default, T: Wire + Default>(
    f: Result<PubSub<[T], H>, TransportError>,
    max_len: usize,
) -> Result<Box<dyn Outbox<H, T>>, TransportError> {
    let p = f?
        .publisher_builder()
        .initial_max_slice_len(max_len.max(1))
        .allocation_strategy(AllocationStrategy::PowerOfTwo)
        .create()
        .map_err(iox("publisher"))?;
    Ok(Box::new(SliceOut(p)))
}

fn slice_in<H: Wire, T: Wire>(
    f: Result<PubSub<[T], H>, TransportError>,
) -> Result<Box<dyn Inbox<H, T>>, TransportError> {
    let s = f?
        .subscriber_builder()
        .create()
        .map_err(iox("subscriber"))?;
    Ok(Box::new(SliceIn(s)))
}

impl Transport for Run {
    fn id(&self) -> &RunId {
        &self.id
    }
    fn kind(&self) -> Kind {
        Kind::Iceoryx2
    }
    fn termination_requested(&self) -> bool {
        Run::termination_requested(self)
    }
    fn alive(&self, _party: Party, pid: u32) -> bool {
        process_alive(pid)
    }
    fn gone_how(&self) -> &'static str {
        "is no longer running"
    }
    fn waiter(&self, me: Party) -> Result<Box<dyn Waiter>, TransportError> {
        Ok(Box::new(self.listener(me)?))
    }
    fn bell(&self, party: Party) -> Result<Box<dyn Bell>, TransportError> {
        Ok(Box::new(self.notifier(party)?))
    }
    fn hello_out(&self) -> Result<Box<dyn Outbox<Hello>>, TransportError> {
        value_out(self.hello())
    }
    fn hello_in(&self) -> Result<Box<dyn Inbox<Hello>>, TransportError> {
        value_in(self.hello())
    }
    fn setup_out(
        &self,
        max_len: usize,
    ) -> Result<Box<dyn Outbox<SetupHeader, u8>>, TransportError> {
        slice_out(self.setup(), max_len)
    }
    fn setup_in(&self) -> Result<Box<dyn Inbox<SetupHeader, u8>>, TransportError> {
        slice_in(self.setup())
    }
    fn command_out(&self) -> Result<Box<dyn Outbox<Command>>, TransportError> {
        value_out(self.command())
    }
    fn command_in(&self) -> Result<Box<dyn Inbox<Command>>, TransportError> {
        value_in(self.command())
    }
    fn status_out(&self) -> Result<Box<dyn Outbox<Status>>, TransportError> {
        value_out(self.status())
    }
    fn status_in(&self) -> Result<Box<dyn Inbox<Status>>, TransportError> {
        value_in(self.status())
    }
    fn blocks_out(
        &self,
        max_len: usize,
    ) -> Result<Box<dyn Outbox<GeometryHeader, BlockState>>, TransportError> {
        slice_out(self.geometry_blocks(), max_len)
    }
    fn blocks_in(&self) -> Result<Box<dyn Inbox<GeometryHeader, BlockState>>, TransportError> {
        slice_in(self.geometry_blocks())
    }
    fn vertices_out(
        &self,
        max_len: usize,
    ) -> Result<Box<dyn Outbox<GeometryHeader, [f64; 3]>>, TransportError> {
        slice_out(self.geometry_vertices(), max_len)
    }
    fn vertices_in(&self) -> Result<Box<dyn Inbox<GeometryHeader, [f64; 3]>>, TransportError> {
        slice_in(self.geometry_vertices())
    }
    fn loads_out(
        &self,
        max_len: usize,
    ) -> Result<Box<dyn Outbox<LoadsHeader, BlockLoad>>, TransportError> {
        slice_out(self.loads(), max_len)
    }
    fn loads_in(&self) -> Result<Box<dyn Inbox<LoadsHeader, BlockLoad>>, TransportError> {
        slice_in(self.loads())
    }
}
