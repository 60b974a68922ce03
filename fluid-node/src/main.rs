//! `fluid-node --solver NAME`: the SPH side of a rockwave run, with any solver of
//! [`fluid_node::REGISTRY`]. Started by the coupler, or by hand with the run's `--prefix` (see
//! the README). Started as N MPI ranks (built with `--features mpi`), rank 0 is the node and
//! the others follow it ([`fluid_node::ranks`]). `fluid-node --ranks-support` says whether it can
//! ([`fluid_node::ranks::probe`]). `--help` does not list it, on purpose: it is the coupler's
//! question, answered here before MPI is joined and before the command line is parsed (that is
//! the node runtime's, shared with the toy and extended nodes of tests/, which do not answer
//! it); a user asks with `coupler check --fluid-ranks N`.

use fluid_node::ranks::{self, leader};
use shared::solver::{FluidSolver, SetupContext, SolverError};
use std::process::ExitCode;

fn build(name: &str, ctx: &SetupContext) -> Result<Box<dyn FluidSolver>, SolverError> {
    Ok(fluid_node::REGISTRY.build(name, ctx)?)
}

/// Rank 0's solvers: the other ranks are told to build theirs alike.
fn lead(name: &str, ctx: &SetupContext) -> Result<Box<dyn FluidSolver>, SolverError> {
    match ranks::current() {
        Some(comm) => leader::Leader::build(comm, name, ctx, build),
        None => build(name, ctx),
    }
}

fn main() -> ExitCode {
    // The coupler's question, before anything that could start MPI or wait for a coupler.
    let mut args = std::env::args_os().skip(1);
    if args.next().is_some_and(|a| a == ranks::probe::FLAG) && args.next().is_none() {
        println!("{}", ranks::probe::answer());
        return ExitCode::SUCCESS;
    }
    if let Some(code) = join_ranks() {
        return code;
    }
    // On one of rayon's workers, not on the main thread (`on_pool`: a wake-up per parallel pass
    // otherwise).
    let code =
        fluid_node::on_pool(|| shared::runtime::fluid_main(&fluid_node::REGISTRY.names(), lead));
    // The last handle: MPI is finalised here, after the solver is gone.
    drop(ranks::uninstall());
    code
}

/// Joins the MPI job when started as one of several ranks: rank 0 goes on as the node (None),
/// the others follow it here and exit.
#[cfg(feature = "mpi")]
fn join_ranks() -> Option<ExitCode> {
    ranks::launched_ranks().filter(|&n| n > 1)?;
    let comm: std::sync::Arc<dyn ranks::comm::Comm> = match ranks::mpi::MpiRanks::init() {
        Ok(c) => std::sync::Arc::new(c),
        Err(e) => {
            eprintln!("fluid-node: cannot join the MPI job: {e}");
            return Some(ExitCode::from(shared::runtime::exit::SOLVER));
        }
    };
    ranks::install(comm.clone());
    if comm.rank() == 0 {
        return None;
    }
    let rank = comm.rank();
    let followed = fluid_node::on_pool(|| leader::follow(comm, build));
    drop(ranks::uninstall());
    match followed {
        Ok(()) => Some(ExitCode::SUCCESS),
        Err(e) => {
            eprintln!("fluid-node rank {rank}: {e}");
            Some(ExitCode::from(shared::runtime::exit::SOLVER))
        }
    }
}

/// Built without MPI: refuses to be one of several ranks (each would join the run as the
/// fluid node).
#[cfg(not(feature = "mpi"))]
fn join_ranks() -> Option<ExitCode> {
    let n = ranks::launched_ranks().filter(|&n| n > 1)?;
    eprintln!(
        "fluid-node: started as one of {n} MPI ranks, but built without MPI: {}",
        ranks::probe::WITHOUT_MPI_FIX
    );
    Some(ExitCode::from(shared::runtime::exit::SOLVER))
}
