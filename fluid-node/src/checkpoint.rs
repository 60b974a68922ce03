//! A fluid solver's checkpoint (a child module of `system`: it reads the system's private
//! state).
//!
//! Saved: every particle array (positions, velocities, densities, pressures, the last
//! accelerations and density rates, the Eq. 22 forces, and the start-of-step / one-step-back
//! state of the symplectic and Verlet integrators), in their current (cell-sorted) order; the
//! scheme whole (its constants, and its history: WCSPH's Verlet step counter, DFSPH's
//! warm-start factors, Müller's warning counter); the next step proposal; the time and step
//! count; where the instruments are in their sampling. Not saved: what is rebuilt from those
//! before it is used — the cell grid and neighbour lists (the particles are already sorted, so
//! re-sorting them is the identity), the boundary particles' extrapolated pressures (recomputed
//! in every force evaluation) and the moving blocks' poses (every step reads the solid's newest
//! geometry before it computes anything).

use super::FluidSystem;
use crate::particles::Particles;
use shared::checkpoint::{decode, encode};
use shared::math::Real;
use shared::solver::SolverError;
use std::path::Path;

#[derive(serde::Serialize)]
struct Saved<'a, S> {
    particles: &'a Particles,
    time: Real,
    steps: u64,
    recorder: (Real, usize),
    scheme: &'a S,
    dt_next: Real,
}

#[derive(serde::Deserialize)]
struct Restored<S> {
    particles: Particles,
    time: Real,
    steps: u64,
    recorder: (Real, usize),
    scheme: S,
    dt_next: Real,
}

/// Flushes the instruments' files and encodes the state.
pub(crate) fn save<S: serde::Serialize>(
    sys: &mut FluidSystem,
    scheme: &S,
    dt_next: Real,
) -> Result<Vec<u8>, SolverError> {
    sys.recorder.flush()?;
    encode(&Saved {
        particles: &sys.particles,
        time: sys.time,
        steps: sys.steps,
        recorder: sys.recorder.mark(),
        scheme,
        dt_next,
    })
    .map_err(SolverError::Failed)
}

/// Restores [`save`]'s state into a system just built from the same scene, continues the
/// instruments' files in `run_dir` and writes the frames there; returns the step proposal.
pub(crate) fn restore<S: serde::de::DeserializeOwned>(
    sys: &mut FluidSystem,
    scheme: &mut S,
    state: &[u8],
    run_dir: &Path,
) -> Result<Real, SolverError> {
    let r: Restored<S> = decode(state, "fluid checkpoint").map_err(SolverError::Failed)?;
    if r.particles.len() != sys.particles.len() {
        return Err(SolverError::Failed(format!(
            "the checkpoint holds {} particles, the scene fills {}: it was written for another scene or build",
            r.particles.len(),
            sys.particles.len()
        )));
    }
    sys.particles = r.particles;
    sys.time = r.time;
    sys.steps = r.steps;
    *scheme = r.scheme;
    sys.run_dir = run_dir.to_path_buf();
    sys.recorder.resume(run_dir, r.recorder)?;
    // As after the step the checkpoint followed: sorted, listed, Eq. 22 forces to come.
    sys.grid_valid = false;
    sys.bodies_valid = false;
    sys.penalty_fresh = false;
    sys.prepare();
    Ok(r.dt_next)
}
