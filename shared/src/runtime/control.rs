//! A node's link to the coupler: the handshake (hello until the setup arrives), commands in,
//! statuses out, and the bounded waits that notice a dead coupler or a signal.
//!
//! Waiting is blocking on this node's [`Waiter`] (its iceoryx2 listener, or its zenoh wake-up
//! channel), in slices: between slices the node checks that the coupler lives and that no
//! SIGINT/SIGTERM arrived. Nothing spins.

use super::args::NodeArgs;
use crate::protocol::*;
use crate::transport::{Bell, Inbox, Outbox, Party, Transport, TransportError, Waiter, Wake, Wire};
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

/// A protocol failure (not the transport's), saying what went wrong.
pub(super) fn protocol(msg: String) -> Fatal {
    Fatal::Transport(TransportError::Protocol(msg))
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
    /// The data inboxes of the node's side, opened before the hello.
    pub inbox: I,
    /// The other node's wake-up bell.
    pub peer_bell: Box<dyn Bell>,
    pub setup: Setup,
}

/// Joins the run as a node of `role`: opens every subscriber (the control ones, and the side's
/// own through `open_inbox`) before the hello goes out, so that nothing sent to this node is
/// lost, then says hello until the coupler answers with the setup.
pub(super) fn join<'r, I>(
    run: &'r dyn Transport,
    role: Role,
    args: &NodeArgs,
    open_inbox: impl FnOnce(&dyn Transport) -> Result<I, Fatal>,
) -> Result<Joined<'r, I>, Fatal> {
    let (me, peer) = parties(role);
    let setup_in = run.setup_in()?;
    let command = run.command_in()?;
    let inbox = open_inbox(run)?;
    let listener = run.waiter(me)?;
    let coupler_bell = run.bell(Party::Coupler)?;
    let peer_bell = run.bell(peer)?;
    let hello_out = run.hello_out()?;
    let status = run.status_out()?;

    let hello = Hello {
        protocol_version: args.fake_protocol_version.unwrap_or(PROTOCOL_VERSION),
        role: role as u32,
        pid: std::process::id(),
        solver: Text::new(args.solver.as_deref().unwrap_or("")),
    };

    if args.stall_startup {
        // Stands for a transport call that never returns (see `watchdog`).
        loop {
            std::thread::park();
        }
    }
    // Say hello until the setup arrives.
    let started = Instant::now();
    let mut last_hello: Option<Instant> = None;
    let setup = loop {
        if run.termination_requested() {
            return Err(Fatal::Signal);
        }
        if last_hello.is_none_or(|t| t.elapsed() >= HELLO_EVERY) {
            hello_out.send(hello)?;
            coupler_bell.ring()?;
            last_hello = Some(Instant::now());
        }
        let mut got: Option<Result<Setup, String>> = None;
        setup_in.take(&mut |header, payload| {
            got = Some(if header.protocol_version != PROTOCOL_VERSION {
                Err(format!(
                    "the coupler speaks protocol {}, this node {}. Fix: build both from the same source",
                    header.protocol_version, PROTOCOL_VERSION
                ))
            } else {
                Setup::decode(payload)
            });
        })?;
        match got {
            Some(Ok(s)) => break s,
            Some(Err(e)) => return Err(protocol(e)),
            None => {}
        }
        if started.elapsed().as_secs_f64() > args.connect_timeout {
            let id = run.id();
            return Err(protocol(format!(
                "no coupler answered on run id {id} within {} s (start `coupler run --attach --run-id {id} SCENE`{})",
                args.connect_timeout,
                match run.kind() {
                    crate::transport::Kind::Iceoryx2 => "",
                    crate::transport::Kind::Zenoh => " with --transport zenoh and --listen",
                }
            )));
        }
        listener.wait(HELLO_EVERY)?;
    };
    drop(hello_out);
    super::watchdog::disarm();

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
    run: &'r dyn Transport,
    role: Role,
    command: Box<dyn Inbox<Command>>,
    status: Box<dyn Outbox<Status>>,
    coupler_bell: Box<dyn Bell>,
    listener: Box<dyn Waiter>,
    coupler_pid: u32,
}

impl<'r> Control<'r> {
    pub fn run(&self) -> &'r dyn Transport {
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
            _reserved: 0,
        };
        self.status.send(status)?;
        self.coupler_bell.ring()?;
        Ok(())
    }

    /// Waits one slice, then checks the coupler and signals.
    fn wait_slice(&self) -> Result<(), Fatal> {
        if self.listener.wait(SLICE)? == Wake::Quiet
            && !self.run.alive(Party::Coupler, self.coupler_pid)
        {
            return Err(Fatal::CouplerGone);
        }
        if self.run.termination_requested() {
            // A dead coupler's nodes get SIGTERM from the kernel (PR_SET_PDEATHSIG): then this
            // is the coupler gone, and the last node out must tidy up the run.
            if !self.run.alive(Party::Coupler, self.coupler_pid) {
                return Err(Fatal::CouplerGone);
            }
            return Err(Fatal::Signal);
        }
        Ok(())
    }

    /// Blocks until the coupler's next command.
    pub fn next_command(&self) -> Result<Command, Fatal> {
        loop {
            if let Some(c) = self.command.receive()? {
                return Ok(c);
            }
            self.wait_slice()?;
        }
    }

    /// Blocks until a message tagged `want` arrives in `inbox` and hands it to `read`; older
    /// ones are dropped. If the peer died meanwhile, the coupler ends the run and terminates
    /// this node with SIGTERM (or, over zenoh, the peer's token vanishes and the coupler stops
    /// the run), which ends the wait within one slice.
    pub fn receive_tagged<H: Wire, T: Wire>(
        &self,
        inbox: &dyn Inbox<H, T>,
        tag: fn(&H) -> u64,
        want: u64,
        read: &mut dyn FnMut(&H, &[T]),
    ) -> Result<(), Fatal> {
        loop {
            // None: keep looking; Some(None): found; Some(Some(got)): a message from the future.
            let mut outcome: Option<Option<u64>> = None;
            while outcome.is_none()
                && inbox.take(&mut |h, payload| {
                    let got = tag(h);
                    if got == want {
                        read(h, payload);
                        outcome = Some(None);
                    } else if got > want {
                        outcome = Some(Some(got));
                    }
                })?
            {}
            match outcome {
                Some(None) => return Ok(()),
                Some(Some(got)) => {
                    return Err(protocol(format!(
                        "coupling data out of order: expected message {want}, got {got}"
                    )));
                }
                None => self.wait_slice()?,
            }
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
