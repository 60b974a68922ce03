//! [`Comm`] over MPI (the `mpi` crate over the system's Open MPI or MPICH): one rank per
//! process, started by `mpirun`, `srun` or any launcher.

use super::comm::Comm;
use mpi::collective::SystemOperation;
use mpi::topology::SimpleCommunicator;
use mpi::traits::*;

/// The MPI world of this process.
pub struct MpiRanks {
    /// Kept for the process's life: MPI is finalised when it is dropped.
    _universe: mpi::environment::Universe,
    world: SimpleCommunicator,
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
        })
    }
}

impl Comm for MpiRanks {
    fn rank(&self) -> usize {
        self.world.rank() as usize
    }

    fn size(&self) -> usize {
        self.world.size() as usize
    }

    fn exchange(&self, out: Vec<(usize, Vec<u8>)>) -> Vec<Vec<u8>> {
        // Every send is posted before any receive is waited for: two ranks sending each other
        // large messages cannot block each other.
        mpi::request::scope(|scope| {
            let sends: Vec<_> = out
                .iter()
                .map(|(to, bytes)| {
                    self.world
                        .process_at_rank(*to as i32)
                        .immediate_send(scope, &bytes[..])
                })
                .collect();
            let got = out
                .iter()
                .map(|(from, _)| {
                    self.world
                        .process_at_rank(*from as i32)
                        .receive_vec::<u8>()
                        .0
                })
                .collect();
            for s in sends {
                s.wait();
            }
            got
        })
    }

    fn gather(&self, bytes: Vec<u8>) -> Vec<Vec<u8>> {
        let root = self.world.process_at_rank(0);
        if self.rank() != 0 {
            root.send(&bytes[..]);
            return Vec::new();
        }
        let mut all = vec![bytes];
        all.extend((1..self.size()).map(|from| {
            self.world
                .process_at_rank(from as i32)
                .receive_vec::<u8>()
                .0
        }));
        all
    }

    fn broadcast(&self, bytes: &mut Vec<u8>) {
        let root = self.world.process_at_rank(0);
        let mut len = bytes.len() as u64;
        root.broadcast_into(&mut len);
        bytes.resize(len as usize, 0);
        if len > 0 {
            root.broadcast_into(&mut bytes[..]);
        }
    }

    fn max(&self, values: &mut [f64]) {
        let mine = values.to_vec();
        self.world
            .all_reduce_into(&mine[..], values, SystemOperation::max());
    }

    fn sum(&self, values: &mut [u64]) {
        let mine = values.to_vec();
        self.world
            .all_reduce_into(&mine[..], values, SystemOperation::sum());
    }
}
