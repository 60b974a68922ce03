//! A [`Comm`] that counts the time spent in its calls (waiting for the other ranks included):
//! what a rank's step spends not computing, so that the cuts can follow the time each rank
//! computes ([`super::share`]).

use super::comm::Comm;
use std::sync::Arc;
use std::sync::atomic::{AtomicU64, Ordering};
use std::time::{Duration, Instant};

pub struct Clocked {
    inner: Arc<dyn Comm>,
    /// Nanoseconds in calls so far.
    nanos: AtomicU64,
}

impl Clocked {
    pub fn new(inner: Arc<dyn Comm>) -> Self {
        Self {
            inner,
            nanos: AtomicU64::new(0),
        }
    }

    /// Time in calls so far.
    pub fn waited(&self) -> Duration {
        Duration::from_nanos(self.nanos.load(Ordering::Relaxed))
    }

    fn timed<T>(&self, call: impl FnOnce(&dyn Comm) -> T) -> T {
        let t = Instant::now();
        let out = call(&*self.inner);
        self.nanos
            .fetch_add(t.elapsed().as_nanos() as u64, Ordering::Relaxed);
        out
    }
}

impl Comm for Clocked {
    fn rank(&self) -> usize {
        self.inner.rank()
    }
    fn size(&self) -> usize {
        self.inner.size()
    }
    fn send(&self, to: usize, bytes: Vec<u8>) {
        self.timed(|c| c.send(to, bytes))
    }
    fn receive(&self, from: usize) -> Vec<u8> {
        self.timed(|c| c.receive(from))
    }
    fn exchange(&self, out: Vec<(usize, Vec<u8>)>) -> Vec<Vec<u8>> {
        self.timed(|c| c.exchange(out))
    }
    fn gather(&self, bytes: Vec<u8>) -> Vec<Vec<u8>> {
        self.timed(|c| c.gather(bytes))
    }
    fn broadcast(&self, bytes: &mut Vec<u8>) {
        self.timed(|c| c.broadcast(bytes))
    }
    fn max(&self, values: &mut [f64]) {
        self.timed(|c| c.max(values))
    }
    fn sum(&self, values: &mut [u64]) {
        self.timed(|c| c.sum(values))
    }
}
