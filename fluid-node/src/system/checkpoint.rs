//! A fluid solver's checkpoint (a child module of `system`: it reads the system's private
//! state).
//!
//! Saved: every particle array (positions, velocities, densities, pressures, the last
//! accelerations and density rates, the Eq. 22 forces, and the start-of-step / one-step-back
//! state of the symplectic and Verlet integrators), in their current (cell-sorted) order; the
//! scheme whole (its constants, and its history: WCSPH's Verlet step counter, DFSPH's
//! warm-start factors, Müller's warning counter); the next step proposal; the time and step
//! count; where the instruments are in their sampling; the positions at the last sort (Verlet
//! lists are kept over several steps: they are the lists of those positions). Not saved: what
//! is rebuilt from those before it is used — the cell grid and neighbour lists (rebuilt from the
//! positions at the last sort, in whose order the particles are, so the sort is the identity
//! and the lists are those the uninterrupted run is using), the boundary particles' extrapolated pressures (recomputed
//! in every force evaluation) and the moving blocks' poses (every step reads the solid's newest
//! geometry before it computes anything).
//!
//! On several ranks rank 0 gathers the particles in one-rank order and the probes' averages
//! from the ranks owning them: the file is the one a single rank writes, to the byte, and a run
//! resumes from it on any number of ranks (each takes its slab from the whole).

use super::FluidSystem;
use crate::core::particles::Particles;
use crate::instruments::gauges::RecorderMark;
use shared::checkpoint::{decode, encode};
use shared::math::{Real, Vector};
use shared::solver::SolverError;
use std::path::Path;

#[derive(serde::Serialize)]
struct Saved<'a, S> {
    particles: &'a Particles,
    sorted_at: &'a [Vector],
    time: Real,
    steps: u64,
    recorder: RecorderMark,
    scheme: &'a S,
    dt_next: Real,
}

#[derive(serde::Deserialize)]
struct Restored<S> {
    particles: Particles,
    sorted_at: Vec<Vector>,
    time: Real,
    steps: u64,
    recorder: RecorderMark,
    scheme: S,
    dt_next: Real,
}

/// Flushes the instruments' files and encodes the state (on several ranks: rank 0 the whole
/// state, the others nothing).
pub(crate) fn save<S: serde::Serialize>(
    sys: &mut FluidSystem,
    scheme: &S,
    dt_next: Real,
) -> Result<Vec<u8>, SolverError> {
    sys.recorder.flush()?;
    let mut mark = sys.recorder.mark();
    let gathered;
    let (particles, sorted_at) = match &sys.share {
        None => (&sys.particles, &sys.sorted_at[..]),
        Some(share) => {
            let owners = sys.recorder.probe_owners(share, &sys.grid);
            let whole = share.gather_particles(&sys.particles, &sys.sorted_at);
            let merged = share.merge_encoded(&mark.averages, &owners);
            let (Some(whole), Some(averages)) = (whole, merged) else {
                return Ok(Vec::new());
            };
            mark.averages = averages;
            gathered = whole;
            (&gathered.0, &gathered.1[..])
        }
    };
    encode(&Saved {
        particles,
        sorted_at,
        time: sys.time,
        steps: sys.steps,
        recorder: mark,
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
    if r.particles.len() != sys.global_len() {
        return Err(SolverError::Failed(format!(
            "the checkpoint holds {} particles, the scene fills {}: it was written for another scene or build",
            r.particles.len(),
            sys.global_len()
        )));
    }
    if r.sorted_at.len() != r.particles.len() {
        return Err(SolverError::Failed(
            "the checkpoint's sorted positions do not match its particles: the file is damaged"
                .into(),
        ));
    }
    sys.particles = r.particles;
    sys.sorted_at = r.sorted_at;
    sys.time = r.time;
    sys.steps = r.steps;
    // Counted again from the positions: as the step the checkpoint followed ended.
    sys.aloft = sys.count_aloft();
    if let Some(share) = &mut sys.share {
        // This rank's slab of the whole, in the order of the last sort.
        share.restore(&mut sys.particles, &mut sys.sorted_at, &sys.grid);
    }
    *scheme = r.scheme;
    sys.run_dir = run_dir.to_path_buf();
    sys.recorder.resume(run_dir, r.recorder)?;
    // As after the step the checkpoint followed: sorted and listed as at the last sort, Eq. 22
    // forces to come.
    sys.bodies_valid = false;
    sys.prepared = false;
    sys.relist_as_sorted()?;
    Ok(r.dt_next)
}
