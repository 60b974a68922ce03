//! [`Comm`] over MPI (the `mpi` crate over the system's Open MPI or MPICH): one rank per
//! process, started by `mpirun`, `srun` or any launcher.

use super::comm::Comm;
use mpi::collective::SystemOperation;
use mpi::point_to_point::MatchedReceiveVec;
use mpi::request::{Request, Scope, StaticScope};
use mpi::topology::SimpleCommunicator;
use mpi::traits::*;
use std::sync::Mutex;
use std::time::{Duration, Instant};

/// The MPI world of this process.
pub struct MpiRanks {
    /// Kept for the process's life: MPI is finalised when it is dropped.
    _universe: mpi::environment::Universe,
    world: SimpleCommunicator,
    /// Sends not yet known to be delivered ([`Self::post`]).
    pending: Mutex<Vec<Posted>>,
}

/// A send in flight and the buffer it reads (leaked at [`MpiRanks::post`], taken back once
/// the send completed).
struct Posted {
    request: Request<'static, [u8], StaticScope>,
    buffer: *mut [u8],
}

impl Posted {
    /// Whether the send completed (its buffer is then freed).
    fn done(self) -> Result<(), Self> {
        match self.request.test() {
            Ok(_) => {
                // SAFETY: `buffer` came from `Box::into_raw` in `post`, and the one request
                // reading it completed: nothing refers to it any more.
                drop(unsafe { Box::from_raw(self.buffer) });
                Ok(())
            }
            Err(request) => Err(Self { request, ..self }),
        }
    }
}

// SAFETY: MPI is initialised at `Threading::Serialized` (checked in `init`): any thread may call
// it, one at a time. The fluid node makes every MPI call from the one thread that drives the
// solver (the step's passes call none), so calls never overlap.
unsafe impl Send for MpiRanks {}
unsafe impl Sync for MpiRanks {}

impl MpiRanks {
    /// Initialises MPI, or says why it cannot.
    pub fn init() -> Result<Self, String> {
        let (universe, level) = mpi::initialize_with_threading(mpi::Threading::Serialized)
            .ok_or("MPI was already initialised in this process")?;
        if level < mpi::Threading::Serialized {
            return Err(format!(
                "this MPI library offers thread level {level:?}; the fluid node needs Serialized (any thread, one at a time): use an MPI built with thread support (Debian's Open MPI and MPICH are)"
            ));
        }
        let world = universe.world();
        Ok(Self {
            _universe: universe,
            world,
            pending: Mutex::new(Vec::new()),
        })
    }
}

/// How long a rank that is done waits at the end for its last sends to be taken.
const LAST_SENDS: Duration = Duration::from_secs(5);

impl Drop for MpiRanks {
    fn drop(&mut self) {
        let mut naps = Naps::new();
        let t = Instant::now();
        while !self.reap() && t.elapsed() < LAST_SENDS {
            naps.take();
        }
        // A rank that never took them is gone (its launcher ends the job): forgetting the
        // requests keeps their drop from panicking at this rank's exit.
        for p in std::mem::take(&mut *self.pending.lock().unwrap()) {
            std::mem::forget(p.request);
        }
    }
}

/// The timer slack of the thread that makes the MPI calls [ns].
const TIMER_SLACK_NS: libc::c_ulong = 1_000;

/// Longest nap between two looks at a pending message.
const MAX_NAP: Duration = Duration::from_micros(500);

/// Shortest nap (the thread's timer slack is set to 1 µs: [`TIMER_SLACK_NS`]).
const MIN_NAP: Duration = Duration::from_micros(5);

/// How long a rank looks again at once (yielding its core between looks) before it naps.
const EAGER: Duration = Duration::from_micros(30);

/// A nap is this fraction of the wait so far: a message is taken at most a sixteenth of the
/// wait after it came.
const NAP_OF_WAIT: u32 = 16;

/// Naps between looks at a pending message. MPI's own blocking calls poll (Open MPI's
/// shared-memory transport spins a core while it waits), and the ranks share their cores with
/// the coupler and the solid node: a rank that waits must sleep. Within a step the other ranks'
/// messages mostly come within tens of µs: for [`EAGER`] a rank yields its core between
/// looks, then naps a sixteenth of the time it has waited ([`NAP_OF_WAIT`]), from [`MIN_NAP`]
/// to [`MAX_NAP`]. What a rank oversleeps it brings late to the next message, where the other
/// rank waits for it: naps that doubled each time overslept a wait by up to its own length, a
/// few per cent of a 20 ms step at 10⁵ particles; Linux's default timer slack (50 µs added to
/// every sleep) was another ~0.1 ms a wait. A rank waiting for the coupler's next step sleeps
/// 2000 times a second.
struct Naps(Option<Instant>);

impl Naps {
    fn new() -> Self {
        Self(None)
    }
    fn take(&mut self) {
        let waited = self.0.get_or_insert_with(Instant::now).elapsed();
        if waited < EAGER {
            std::thread::yield_now();
            return;
        }
        exact_naps();
        std::thread::sleep((waited / NAP_OF_WAIT).clamp(MIN_NAP, MAX_NAP));
    }
}

thread_local! {
    /// Whether this thread's timer slack is set ([`exact_naps`]).
    static EXACT: std::cell::Cell<bool> = const { std::cell::Cell::new(false) };
}

/// Sets the calling thread's timer slack to [`TIMER_SLACK_NS`], once per thread (the slack is a
/// thread's own, and the MPI calls are made from whichever thread drives the solver): a nap of
/// 20 µs then sleeps 20 µs, not Linux's default 50 µs more.
fn exact_naps() {
    if !EXACT.get() {
        // SAFETY: prctl with PR_SET_TIMERSLACK reads no pointer; it sets this thread's slack.
        unsafe { libc::prctl(libc::PR_SET_TIMERSLACK, TIMER_SLACK_NS) };
        EXACT.set(true);
    }
}

/// Waits for `request` to complete, napping.
fn wait<'a, D: ?Sized, S: Scope<'a>>(mut request: Request<'a, D, S>) {
    let mut naps = Naps::new();
    loop {
        match request.test() {
            Ok(_) => return,
            Err(r) => request = r,
        }
        naps.take();
    }
}

impl MpiRanks {
    /// `values` combined element-wise over the ranks by `op`, on every rank, napping.
    fn all_reduce<T: Equivalence + Clone>(&self, values: &mut [T], op: SystemOperation) {
        let mine = values.to_vec();
        mpi::request::scope(|scope| {
            wait(
                self.world
                    .immediate_all_reduce_into(scope, &mine[..], values, op),
            );
        });
    }

    /// Sends `bytes` to rank `to` and returns at once: the send completes while this rank
    /// goes on ([`Self::reap`]). A rank that comes last to an exchange takes the others'
    /// messages and leaves; it need not wait for them to wake from a nap and take its own
    /// (that wait cost the last rank ~0.5–1 ms a step at 10⁵ particles). MPI keeps the order
    /// of the messages between two ranks, so a later message is never taken for this one.
    fn post(&self, to: usize, bytes: Vec<u8>) {
        self.reap();
        let buffer = Box::into_raw(bytes.into_boxed_slice());
        // SAFETY: leaked until the request completes (`Posted::done` takes it back).
        let data: &'static [u8] = unsafe { &*buffer };
        let request = self
            .world
            .process_at_rank(to as i32)
            .immediate_send(StaticScope, data);
        self.pending
            .lock()
            .unwrap()
            .push(Posted { request, buffer });
    }

    /// Frees the buffers of the sends that completed; whether all did.
    fn reap(&self) -> bool {
        let mut pending = self.pending.lock().unwrap();
        let mut left = Vec::new();
        for p in pending.drain(..) {
            if let Err(p) = p.done() {
                left.push(p);
            }
        }
        *pending = left;
        pending.is_empty()
    }

    /// The next message from rank `from`, napping until it is there.
    fn take(&self, from: usize) -> Vec<u8> {
        let source = self.world.process_at_rank(from as i32);
        let mut naps = Naps::new();
        loop {
            if let Some(probed) = source.immediate_matched_probe() {
                return probed.matched_receive_vec::<u8>().0;
            }
            naps.take();
        }
    }
}

impl Comm for MpiRanks {
    fn rank(&self) -> usize {
        self.world.rank() as usize
    }

    fn size(&self) -> usize {
        self.world.size() as usize
    }

    fn send(&self, to: usize, bytes: Vec<u8>) {
        self.post(to, bytes);
    }

    fn receive(&self, from: usize) -> Vec<u8> {
        self.take(from)
    }

    fn gather(&self, bytes: Vec<u8>) -> Vec<Vec<u8>> {
        if self.rank() != 0 {
            self.post(0, bytes);
            return Vec::new();
        }
        let mut all = vec![bytes];
        all.extend((1..self.size()).map(|from| self.take(from)));
        all
    }

    fn broadcast(&self, bytes: &mut Vec<u8>) {
        let root = self.world.process_at_rank(0);
        let mut len = bytes.len() as u64;
        mpi::request::scope(|scope| wait(root.immediate_broadcast_into(scope, &mut len)));
        bytes.resize(len as usize, 0);
        if len > 0 {
            mpi::request::scope(|scope| {
                wait(root.immediate_broadcast_into(scope, &mut bytes[..]));
            });
        }
    }

    fn max(&self, values: &mut [f64]) {
        self.all_reduce(values, SystemOperation::max());
    }

    fn sum(&self, values: &mut [u64]) {
        self.all_reduce(values, SystemOperation::sum());
    }
}
