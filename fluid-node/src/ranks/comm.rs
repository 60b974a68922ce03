//! What the ranks of one fluid say to each other: the few collective operations the
//! decomposition needs, behind one trait ([`Comm`]) so that the decomposition is the same code
//! over MPI ([`super::mpi`], one rank per process) and over threads of one process
//! ([`ThreadRanks`], the unit tests' ranks).
//!
//! Every rank calls the same operations in the same order (the solver's passes are the same on
//! every rank), so no message needs a tag: between two ranks messages arrive in the order sent.

use std::collections::VecDeque;
use std::sync::{Arc, Condvar, Mutex};

/// The collective operations of the fluid's ranks.
pub trait Comm: Send + Sync {
    /// This rank's number, 0 ≤ rank < size. Rank 0 is the node the coupler talks to.
    fn rank(&self) -> usize;
    /// The number of ranks.
    fn size(&self) -> usize;
    /// Sends `bytes` to rank `to` and returns at once (the send completes while this rank goes
    /// on); the other rank takes it with [`Self::receive`].
    fn send(&self, to: usize, bytes: Vec<u8>);
    /// The next message from rank `from`, waiting (without spinning) until it is there.
    fn receive(&self, from: usize) -> Vec<u8>;
    /// Sends `out[k].1` to rank `out[k].0` for every k and returns what each of those ranks sent
    /// back to this one, in the same order: every listed rank lists this one in its own call.
    /// Every send is posted before any receive waits: two ranks sending each other large
    /// messages cannot block each other.
    fn exchange(&self, out: Vec<(usize, Vec<u8>)>) -> Vec<Vec<u8>> {
        let peers: Vec<usize> = out.iter().map(|(to, _)| *to).collect();
        for (to, bytes) in out {
            self.send(to, bytes);
        }
        peers.into_iter().map(|from| self.receive(from)).collect()
    }
    /// Every rank's `bytes` on rank 0, in rank order (empty on the other ranks).
    fn gather(&self, bytes: Vec<u8>) -> Vec<Vec<u8>>;
    /// Rank 0's `bytes` on every rank.
    fn broadcast(&self, bytes: &mut Vec<u8>);
    /// The element-wise maximum over the ranks, on every rank (exact: a maximum does not round).
    fn max(&self, values: &mut [f64]);
    /// The element-wise sum over the ranks, on every rank (exact: integers, wrapping: two's
    /// complement words add as signed ones, `crate::core::exact_sum`).
    fn sum(&self, values: &mut [u64]);
}

/// Little-endian words in and out of message bytes.
pub mod wire {
    /// Appends `values` to `out`.
    pub fn put_f64(out: &mut Vec<u8>, values: impl IntoIterator<Item = f64>) {
        for v in values {
            out.extend_from_slice(&v.to_le_bytes());
        }
    }

    /// Appends `values` to `out`.
    pub fn put_u64(out: &mut Vec<u8>, values: impl IntoIterator<Item = u64>) {
        for v in values {
            out.extend_from_slice(&v.to_le_bytes());
        }
    }

    /// The 8-byte words of `bytes`.
    pub fn words(bytes: &[u8]) -> impl Iterator<Item = [u8; 8]> + '_ {
        bytes
            .chunks_exact(8)
            .map(|c| c.try_into().expect("8-byte chunks"))
    }

    /// `bytes` as f64 words.
    pub fn f64s(bytes: &[u8]) -> impl Iterator<Item = f64> + '_ {
        words(bytes).map(f64::from_le_bytes)
    }

    /// `bytes` as u64 words.
    pub fn u64s(bytes: &[u8]) -> impl Iterator<Item = u64> + '_ {
        words(bytes).map(u64::from_le_bytes)
    }
}

/// One mailbox per (sender, receiver) pair.
struct Mailboxes {
    size: usize,
    queues: Vec<(Mutex<VecDeque<Vec<u8>>>, Condvar)>,
    /// A rank that panicked (its handle dropped while unwinding): the others stop waiting for
    /// it and panic too, so a failing test fails instead of hanging.
    dead: Mutex<Option<usize>>,
}

impl Mailboxes {
    fn post(&self, from: usize, to: usize, bytes: Vec<u8>) {
        let (queue, ready) = &self.queues[from * self.size + to];
        queue.lock().expect("a rank panicked").push_back(bytes);
        ready.notify_one();
    }

    /// Blocks (no spinning) until a message from `from` to `to` is there; panics if a rank
    /// died meanwhile.
    fn take(&self, from: usize, to: usize) -> Vec<u8> {
        let (queue, ready) = &self.queues[from * self.size + to];
        let mut q = queue.lock().expect("a rank panicked");
        loop {
            if let Some(m) = q.pop_front() {
                return m;
            }
            let dead = *self.dead.lock().unwrap_or_else(|e| e.into_inner());
            if let Some(r) = dead {
                panic!("rank {r} panicked: rank {to} stops waiting for rank {from}");
            }
            q = ready.wait(q).expect("a rank panicked");
        }
    }

    /// Rank `rank` is gone: every waiting rank wakes and panics.
    fn bury(&self, rank: usize) {
        self.dead
            .lock()
            .unwrap_or_else(|e| e.into_inner())
            .get_or_insert(rank);
        for (queue, ready) in &self.queues {
            // Taken and released so a rank between its check and its wait is not missed.
            drop(queue.lock());
            ready.notify_all();
        }
    }
}

/// Ranks as threads of one process, over mailboxes: the decomposition's tests run several
/// ranks without MPI. Posting never blocks, so an exchange cannot deadlock.
pub struct ThreadRanks {
    rank: usize,
    boxes: Arc<Mailboxes>,
}

impl ThreadRanks {
    /// `size` ranks, one handle each (hand handle k to the thread of rank k).
    pub fn handles(size: usize) -> Vec<Arc<dyn Comm>> {
        let boxes = Arc::new(Mailboxes {
            size,
            queues: (0..size * size).map(|_| Default::default()).collect(),
            dead: Mutex::new(None),
        });
        (0..size)
            .map(|rank| {
                Arc::new(ThreadRanks {
                    rank,
                    boxes: boxes.clone(),
                }) as Arc<dyn Comm>
            })
            .collect()
    }

    /// Every rank's `values` on rank 0, combined there by `join` and sent back to all.
    fn all_reduce<T: Copy>(
        &self,
        values: &mut [T],
        encode: fn(&[T]) -> Vec<u8>,
        decode: fn(&[u8]) -> Vec<T>,
        join: fn(T, T) -> T,
    ) {
        let all = self.gather(encode(values));
        let mut out = Vec::new();
        if self.rank == 0 {
            for part in &all[1..] {
                for (v, w) in values.iter_mut().zip(decode(part)) {
                    *v = join(*v, w);
                }
            }
            out = encode(values);
        }
        self.broadcast(&mut out);
        values.copy_from_slice(&decode(&out));
    }
}

impl Drop for ThreadRanks {
    fn drop(&mut self) {
        if std::thread::panicking() {
            self.boxes.bury(self.rank);
        }
    }
}

impl Comm for ThreadRanks {
    fn rank(&self) -> usize {
        self.rank
    }

    fn size(&self) -> usize {
        self.boxes.size
    }

    fn send(&self, to: usize, bytes: Vec<u8>) {
        self.boxes.post(self.rank, to, bytes);
    }

    fn receive(&self, from: usize) -> Vec<u8> {
        self.boxes.take(from, self.rank)
    }

    fn gather(&self, bytes: Vec<u8>) -> Vec<Vec<u8>> {
        if self.rank != 0 {
            self.boxes.post(self.rank, 0, bytes);
            return Vec::new();
        }
        let mut all = vec![bytes];
        all.extend((1..self.size()).map(|from| self.boxes.take(from, 0)));
        all
    }

    fn broadcast(&self, bytes: &mut Vec<u8>) {
        if self.rank == 0 {
            for to in 1..self.size() {
                self.boxes.post(0, to, bytes.clone());
            }
        } else {
            *bytes = self.boxes.take(0, self.rank);
        }
    }

    fn max(&self, values: &mut [f64]) {
        self.all_reduce(
            values,
            |v| {
                let mut b = Vec::new();
                wire::put_f64(&mut b, v.iter().copied());
                b
            },
            |b| wire::f64s(b).collect(),
            f64::max,
        );
    }

    fn sum(&self, values: &mut [u64]) {
        self.all_reduce(
            values,
            |v| {
                let mut b = Vec::new();
                wire::put_u64(&mut b, v.iter().copied());
                b
            },
            |b| wire::u64s(b).collect(),
            u64::wrapping_add,
        );
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Three thread ranks exchange, gather, broadcast and reduce as MPI ranks would.
    /// A rank that panics (a failing assertion on one rank of a test) makes the ranks waiting
    /// for it panic too: the test fails instead of hanging.
    #[test]
    fn a_rank_that_panics_wakes_the_others() {
        let mut ranks = ThreadRanks::handles(2);
        let (one, zero) = (ranks.pop().unwrap(), ranks.pop().unwrap());
        let (waiter, dier) = std::thread::scope(|s| {
            let waiter = s.spawn(move || zero.gather(vec![1]));
            let dier = s.spawn(move || {
                let _held = one;
                panic!("rank 1 fails");
            });
            (waiter.join(), dier.join())
        });
        assert!(dier.is_err());
        let msg = waiter.unwrap_err();
        let msg = msg.downcast_ref::<String>().unwrap();
        assert!(msg.contains("rank 1 panicked"), "{msg}");
    }

    #[test]
    fn thread_ranks_do_what_mpi_ranks_do() {
        let ranks = ThreadRanks::handles(3);
        let results: Vec<_> = std::thread::scope(|s| {
            let handles: Vec<_> = ranks
                .iter()
                .map(|c| {
                    s.spawn(move || {
                        let me = c.rank();
                        // Each rank sends its number to the others.
                        let out = (0..3)
                            .filter(|&q| q != me)
                            .map(|q| (q, vec![me as u8, q as u8]))
                            .collect();
                        let got = c.exchange(out);
                        let all = c.gather(vec![me as u8]);
                        let mut b = if me == 0 { vec![7, 8] } else { Vec::new() };
                        c.broadcast(&mut b);
                        let mut m = [me as f64, -(me as f64)];
                        c.max(&mut m);
                        // A negative word (two's complement) sums as a signed one.
                        let mut n = [me as u64 + 1, (me as u64).wrapping_neg()];
                        c.sum(&mut n);
                        (me, got, all, b, m, n)
                    })
                })
                .collect();
            handles.into_iter().map(|h| h.join().unwrap()).collect()
        });
        for (me, got, all, b, m, n) in results {
            let from: Vec<u8> = (0..3u8).filter(|&q| q as usize != me).collect();
            assert_eq!(
                got,
                from.iter().map(|&q| vec![q, me as u8]).collect::<Vec<_>>()
            );
            assert_eq!(all.len(), if me == 0 { 3 } else { 0 });
            assert_eq!(b, vec![7, 8]);
            assert_eq!(m, [2.0, 0.0]);
            assert_eq!(n, [6, 3u64.wrapping_neg()]);
        }
    }
}
