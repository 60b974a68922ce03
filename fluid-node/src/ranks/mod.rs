//! The fluid on several ranks: domain decomposition with the same bits on any rank count.
//!
//! `fluid-node` started as N ranks (an MPI job: `coupler run --fluid-ranks N`) splits the water
//! into slabs along the domain's longest horizontal axis ([`slabs`]), one per rank, cut at an
//! eighth of a grid column, each held with whole columns and a halo two columns deep; the cuts
//! follow the measured work (listed pairs) and move when it drifts. Rank 0 is the node the coupler sees; the others
//! follow its calls ([`leader`]). What one rank holds and the messages that keep its halo exact
//! are in [`share`]; the messages themselves go through [`comm::Comm`]: MPI between processes
//! ([`mpi`], cargo feature `mpi`), or threads of one process in the tests.
//!
//! The outputs are byte-identical on any number of ranks and to one rank ([`share`]'s module
//! doc says why). On several ranks: every built-in method (WCSPH, Müller, DFSPH), with fixed,
//! moving and free blocks, walls and terrain, gauges and probes, frames and checkpoints
//! (resumed on any number of ranks); a method that is not
//! [`crate::methods::SphMethod::SPLITS`] is refused with a message.

pub mod clocked;
pub mod comm;
pub mod leader;
#[cfg(feature = "mpi")]
pub mod mpi;
pub mod probe;
pub mod share;
pub mod slabs;

use comm::Comm;
use std::sync::{Arc, Mutex};

/// The ranks of this process's fluid, if it is one of several.
static RANKS: Mutex<Option<Arc<dyn Comm>>> = Mutex::new(None);

/// Makes `comm` the ranks every solver built in this process splits over.
pub fn install(comm: Arc<dyn Comm>) {
    *RANKS.lock().unwrap() = Some(comm);
}

/// Forgets the installed ranks (MPI is finalised when the last handle goes).
pub fn uninstall() -> Option<Arc<dyn Comm>> {
    RANKS.lock().unwrap().take()
}

/// The installed ranks, if more than one.
pub fn current() -> Option<Arc<dyn Comm>> {
    RANKS.lock().unwrap().clone().filter(|c| c.size() > 1)
}

/// Whether any rank says yes (exact: a maximum of 0 and 1). Every rank must call it.
pub fn any(comm: &dyn Comm, yes: bool) -> bool {
    let mut v = [yes as u8 as f64];
    comm.max(&mut v);
    v[0] > 0.0
}

/// How many ranks a launcher started this process among, read from the environment Open MPI
/// (`OMPI_COMM_WORLD_SIZE`), MPICH's Hydra and Slurm's PMI (`PMI_SIZE`) and PMIx
/// (`PMIX_SIZE`) give every rank: a node built without MPI refuses to run as one of many.
pub fn launched_ranks() -> Option<usize> {
    ["OMPI_COMM_WORLD_SIZE", "PMI_SIZE", "PMIX_SIZE"]
        .iter()
        .find_map(|v| std::env::var(v).ok()?.parse().ok())
}

#[cfg(test)]
mod same_bits;
