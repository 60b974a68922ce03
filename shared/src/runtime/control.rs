//! A node's link to the coupler: the handshake (hello until the setup arrives), commands in,
//! statuses out, and the bounded waits that notice a dead coupler or a signal.
//!
//! Waiting is blocking on this node's iceoryx2 listener, in slices: between slices the node
//! checks that the coupler lives and that no SIGINT/SIGTERM arrived. Nothing spins.

use super::args::NodeArgs;
use crate::protocol::*;
use crate::transport::{self, Ipc, Party, Pub, Run, Sub, TransportError, Wake};
use iceoryx2::port::listener::Listener;
use iceoryx2::port::notifier::Notifier;
use iceoryx2::sample::Sample;
use std::time::{Duration, Instant};

/// How long a node waits in one slice before checking that the coupler lives and no signal
/// arrived. Waking ten times a second costs nothing measurable; it is not a spin.
pub(super) const SLICE: Duration = Duration::from_millis(100);
/// How often a node repeats its hello while no coupler answered.
const HELLO_EVERY: Duration = Duration::from_millis(250);

/// Why a node stops early.
pub(super) enum Fatal {
    Transport(TransportError),
    CouplerGone,
    Signal,
}

impl From<TransportError> for Fatal {
    fn from(e: TransportError) -> Self {
        Fatal::Transport(e)
    }
}

/// Wraps an iceoryx2 error, saying what was being done.
pub(super) fn iox<E: std::fmt::Debug>(what: &'static str) -> impl FnOnce(E) -> Fatal {
    move |e| Fatal::Transport(TransportError::Iceoryx(format!("{what}: {e:?}")))
}

/// The parties a node of `role` is and talks to.
fn parties(role: Role) -> (Party, Party) {
    match role {
        Role::Fluid => (Party::Fluid, Party::Solid),
        Role::Solid => (Party::Solid, Party::Fluid),
    }
}

/// A node that joined a run and received its setup.
pub(super) struct Joined<'r, I> {
    pub control: Control<'r>,
    /// The data subscribers of the node's side, opened before the hello.
    pub inbox: I,
    /// The other node's wake-up bell.
    pub peer_bell: Notifier<Ipc>,
    pub setup: Setup,
}

/// Joins the run as a node of `role`: opens every subscriber (the control ones, and the side's
/// own through `open_inbox`) before the hello goes out, so that nothing sent to this node is
/// lost, then says hello until the coupler answers with the setup.
pub(super) fn join<'r, I>(
    run: &'r Run,
    role: Role,
    args: &NodeArgs,
    open_inbox: impl FnOnce(&Run) -> Result<I, Fatal>,
) -> Result<Joined<'r, I>, Fatal> {
    let (me, peer) = parties(role);
    let setup_in = run
        .setup()?
        .subscriber_builder()
        .create()
        .map_err(iox("setup subscriber"))?;
    let command = run
        .command()?
        .subscriber_builder()
        .create()
        .map_err(iox("command subscriber"))?;
    let inbox = open_inbox(run)?;
    let listener = run.listener(me)?;
    let coupler_bell = run.notifier(Party::Coupler)?;
    let peer_bell = run.notifier(peer)?;
    let hello_out = run
        .hello()?
        .publisher_builder()
        .create()
        .map_err(iox("hello publisher"))?;
    let status = run
        .status()?
        .publisher_builder()
        .create()
        .map_err(iox("status publisher"))?;

    let hello = Hello {
        protocol_version: args.fake_protocol_version.unwrap_or(PROTOCOL_VERSION),
        role: role as u32,
        pid: std::process::id(),
        solver: Text::new(args.solver.as_deref().unwrap_or("")),
    };

    // Say hello until the setup arrives.
    let started = Instant::now();
    let mut last_hello: Option<Instant> = None;
    let setup = loop {
        if run.termination_requested() {
            return Err(Fatal::Signal);
        }
        if last_hello.is_none_or(|t| t.elapsed() >= HELLO_EVERY) {
            hello_out.send_copy(hello).map_err(iox("send hello"))?;
            coupler_bell.notify().map_err(iox("notify coupler"))?;
            last_hello = Some(Instant::now());
        }
        if let Some(sample) = setup_in.receive().map_err(iox("receive setup"))? {
            if sample.user_header().protocol_version != PROTOCOL_VERSION {
                return Err(Fatal::Transport(TransportError::Iceoryx(format!(
                    "the coupler speaks protocol {}, this node {}",
                    sample.user_header().protocol_version,
                    PROTOCOL_VERSION
                ))));
            }
            match Setup::decode(sample.payload()) {
                Ok(s) => break s,
                Err(e) => return Err(Fatal::Transport(TransportError::Iceoryx(e))),
            }
        }
        if started.elapsed().as_secs_f64() > args.connect_timeout {
            return Err(Fatal::Transport(TransportError::Iceoryx(format!(
                "no coupler answered on run id {} within {} s (start `coupler run --attach --run-id {} SCENE`)",
                run.id, args.connect_timeout, run.id
            ))));
        }
        transport::wait(&listener, HELLO_EVERY)?;
    };
    drop(hello_out);

    Ok(Joined {
        control: Control {
            run,
            role,
            command,
            status,
            coupler_bell,
            listener,
            coupler_pid: setup.coupler_pid,
        },
        inbox,
        peer_bell,
        setup,
    })
}

/// The control ports of a node set up: commands in, statuses out, its own bell.
pub(super) struct Control<'r> {
    run: &'r Run,
    role: Role,
    command: Sub<Command>,
    status: Pub<Status>,
    coupler_bell: Notifier<Ipc>,
    listener: Listener<Ipc>,
    coupler_pid: u32,
}

impl<'r> Control<'r> {
    pub fn run(&self) -> &'r Run {
        self.run
    }

    pub fn role(&self) -> Role {
        self.role
    }

    /// Sends a status to the coupler and rings it.
    pub fn report(
        &self,
        code: StatusCode,
        step: u64,
        time: f64,
        dt_proposal: f64,
        compute_seconds: f64,
        message: &str,
    ) -> Result<(), Fatal> {
        let status = Status {
            role: self.role as u32,
            code: code as u32,
            step,
            time,
            dt_proposal,
            compute_seconds,
            cpu_seconds: process_cpu_seconds(),
            message: Text::new(message),
        };
        self.status.send_copy(status).map_err(iox("send status"))?;
        self.coupler_bell.notify().map_err(iox("notify coupler"))?;
        Ok(())
    }

    /// Waits one slice, then checks the coupler and signals.
    fn wait_slice(&self) -> Result<(), Fatal> {
        if transport::wait(&self.listener, SLICE)? == Wake::Quiet
            && !transport::process_alive(self.coupler_pid)
        {
            return Err(Fatal::CouplerGone);
        }
        if self.run.termination_requested() {
            // A dead coupler's nodes get SIGTERM from the kernel (PR_SET_PDEATHSIG): then this
            // is the coupler gone, and the last node out must tidy up the run.
            if !transport::process_alive(self.coupler_pid) {
                return Err(Fatal::CouplerGone);
            }
            return Err(Fatal::Signal);
        }
        Ok(())
    }

    /// Blocks until the coupler's next command.
    pub fn next_command(&self) -> Result<Command, Fatal> {
        loop {
            if let Some(s) = self.command.receive().map_err(iox("receive command"))? {
                return Ok(*s.payload());
            }
            self.wait_slice()?;
        }
    }

    /// Blocks until a sample tagged `want` arrives on `sub`; older ones are dropped. If the
    /// peer died meanwhile, the coupler ends the run and terminates this node with SIGTERM,
    /// which ends the wait within one slice.
    pub fn receive_tagged<E, H>(
        &self,
        sub: &Sub<[E], H>,
        tag: fn(&H) -> u64,
        want: u64,
    ) -> Result<Sample<Ipc, [E], H>, Fatal>
    where
        E: std::fmt::Debug + iceoryx2::prelude::ZeroCopySend + 'static,
        H: std::fmt::Debug + iceoryx2::prelude::ZeroCopySend + 'static,
    {
        loop {
            while let Some(s) = sub.receive().map_err(iox("receive data"))? {
                let got = tag(s.user_header());
                if got == want {
                    return Ok(s);
                }
                if got > want {
                    return Err(Fatal::Transport(TransportError::Iceoryx(format!(
                        "coupling data out of order: expected message {want}, got {got}"
                    ))));
                }
            }
            self.wait_slice()?;
        }
    }
}

/// CPU time (user + system) of this process so far [s].
pub fn process_cpu_seconds() -> f64 {
    // SAFETY: getrusage writes into the zeroed struct we pass and nothing else.
    let usage = unsafe {
        let mut u: libc::rusage = std::mem::zeroed();
        libc::getrusage(libc::RUSAGE_SELF, &mut u);
        u
    };
    let secs = |t: libc::timeval| t.tv_sec as f64 + t.tv_usec as f64 * 1e-6;
    secs(usage.ru_utime) + secs(usage.ru_stime)
}

/// Peak resident memory (high-water mark) of this process so far [bytes]: getrusage's
/// `ru_maxrss`, which Linux reports in KiB.
pub fn process_peak_rss_bytes() -> u64 {
    // SAFETY: getrusage writes into the zeroed struct we pass and nothing else.
    let usage = unsafe {
        let mut u: libc::rusage = std::mem::zeroed();
        libc::getrusage(libc::RUSAGE_SELF, &mut u);
        u
    };
    usage.ru_maxrss.max(0) as u64 * 1024
}

/// Peak resident memory of another live process [bytes]: `VmHWM` of `/proc/<pid>/status`
/// (Linux); None when the process is gone or the field cannot be read.
pub fn peak_rss_bytes_of(pid: u32) -> Option<u64> {
    let status = std::fs::read_to_string(format!("/proc/{pid}/status")).ok()?;
    let line = status.lines().find(|l| l.starts_with("VmHWM:"))?;
    let kib: u64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kib * 1024)
}

#[cfg(test)]
mod memory_tests {
    use super::*;

    #[test]
    fn peak_rss_of_this_process_both_ways() {
        let own = process_peak_rss_bytes();
        let proc_ = peak_rss_bytes_of(std::process::id()).expect("VmHWM of this process");
        assert!(own > 1 << 20 && proc_ > 1 << 20, "{own} {proc_}");
        assert!(peak_rss_bytes_of(u32::MAX).is_none());
    }
}
