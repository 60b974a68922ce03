//! A bound on start-up that holds even when the transport itself is stuck.
//!
//! Joining a run is bounded by `--connect-timeout` in the hello loop, but that loop only runs
//! between transport calls. iceoryx2 0.10 can block inside one for ever: opening a
//! shared-memory file that a killed process created but never sized loops without checking its
//! timeout (`posix_shared_memory` `open_impl`, the `MappingSizeIsZero` arm), and SIGTERM only
//! sets a flag nobody reads there. A node stuck like that would outlive its coupler and hold
//! its terminal (or a CI log) open. So a thread is armed when the node starts and disarmed once
//! the setup has arrived; if start-up outlasts its own bounds by [`GRACE`], the node says why
//! and exits.

use std::sync::Mutex;
use std::sync::mpsc::{self, RecvTimeoutError, Sender};
use std::time::Duration;

/// How far past `--connect-timeout` a start-up may run before it is called stuck: far longer
/// than any transport call takes when it works, even on a loaded machine.
pub const GRACE: Duration = Duration::from_secs(10);

/// The armed watchdog's line: dropping the sender wakes and ends the thread.
static ARMED: Mutex<Option<Sender<()>>> = Mutex::new(None);

/// Starts the watchdog: unless [`disarm`] is called within `2 × connect_timeout + GRACE`, the
/// process prints a message naming `who` and run `id`, and exits with `code`. (Twice the
/// timeout: over zenoh, reaching the router and the hello loop each take up to one.)
pub fn arm(who: &str, id: &str, connect_timeout: Duration, code: u8) {
    let (tx, rx) = mpsc::channel::<()>();
    let limit = connect_timeout.saturating_mul(2).saturating_add(GRACE);
    let (who, id) = (who.to_string(), id.to_string());
    std::thread::spawn(move || {
        if rx.recv_timeout(limit) == Err(RecvTimeoutError::Timeout) {
            eprintln!(
                "{who}: start-up did not finish within {:.1} s (twice the connect timeout plus {} s): \
                 the transport is stuck, most likely on a file left half-made by a killed \
                 process of run {id}. Fix: `coupler clean {id}`, then start the run again",
                limit.as_secs_f64(),
                GRACE.as_secs()
            );
            std::process::exit(code.into());
        }
    });
    *ARMED.lock().unwrap_or_else(|e| e.into_inner()) = Some(tx);
}

/// Ends the watchdog: start-up finished.
pub fn disarm() {
    ARMED.lock().unwrap_or_else(|e| e.into_inner()).take();
}
