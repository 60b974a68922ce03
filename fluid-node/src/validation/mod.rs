//! Validation cases with published or exact references, run in-process through the
//! [`FluidSolver`] interface (no coupler, no shared memory): the `fluid-validate` command runs
//! them at the documented resolutions and the tests at coarse ones.
//!
//! - Still water: pressure against depth, p = ρ0 g (η − z) (hydrostatics; docs/REFERENCES.md).
//! - Dam break (Martin & Moyce 1952, n² = H/a = 2 and 1): surge front Z = x/a against
//!   T = n·t·sqrt(g/a) at the published points, and self-convergence over three resolutions.
//! - Impact pressure (Lobovský et al. 2014): the peak and the impulse of the surge on the
//!   downstream wall, at pressure probes with an averaging window.
//!
//! - Still water over a terrain (`[[terrain]]`, a DEM trough): the same hydrostatic check, and
//!   no particle under the terrain's surface.
//!
//! All are thin 3D slabs (a few particle layers between free-slip side walls), i.e. 2D flows
//! at a 3D code's cost of a 2D problem.

use crate::REGISTRY;
use crate::sph::SphSolver;
use shared::coupling::step::{StepRule, grant};
use shared::protocol::BlockLoad;
use shared::scene::{CouplingScheme, Scene, Walls};
use shared::solver::{SetupContext, SolverError, StepReport};
use std::path::Path;

mod dam_break;
mod impact;
mod richardson;
mod still_water;
mod table;
mod terrain_basin;

pub use dam_break::*;
pub use impact::*;
pub use richardson::*;
pub use still_water::*;
pub use table::*;
pub use terrain_basin::*;

/// Prefix of every [`TempRunDir`] in the system's temporary directory.
const TEMP_PREFIX: &str = "rockwave-fluid-";

/// A scratch run directory, removed on drop. Its name carries the process id
/// (`rockwave-fluid-<tag>-<pid>-<random>`), so that a run killed before its drop (SIGTERM or
/// SIGKILL of `fluid-validate`, `coupler chart`, an example) leaves a directory the next one
/// recognises as orphaned and removes ([`remove_orphans`]).
pub struct TempRunDir(tempfile::TempDir);

impl TempRunDir {
    pub fn new(tag: &str) -> std::io::Result<Self> {
        remove_orphans(&std::env::temp_dir());
        let dir = tempfile::Builder::new()
            .prefix(&format!("{TEMP_PREFIX}{tag}-{}-", std::process::id()))
            .tempdir()?;
        Ok(Self(dir))
    }
    pub fn path(&self) -> &Path {
        self.0.path()
    }
}

/// Removes the run directories in `tmp` left by processes that no longer exist (no
/// `/proc/<pid>`); directories of live processes, and names without a process id (older
/// versions), are left alone. Best effort: a directory that cannot be read or removed is skipped.
pub fn remove_orphans(tmp: &Path) {
    let Ok(entries) = std::fs::read_dir(tmp) else {
        return;
    };
    for entry in entries.flatten() {
        let name = entry.file_name();
        if let Some(pid) = name.to_str().and_then(owner_pid)
            && !Path::new(&format!("/proc/{pid}")).exists()
        {
            let _ = std::fs::remove_dir_all(entry.path());
        }
    }
}

/// The process id in a [`TempRunDir`] name `rockwave-fluid-<tag>-<pid>-<random>`: the last
/// all-digit field before the random suffix.
fn owner_pid(name: &str) -> Option<u32> {
    let rest = name.strip_prefix(TEMP_PREFIX)?;
    let mut fields = rest.rsplitn(3, '-');
    let (_random, pid) = (fields.next()?, fields.next()?);
    fields.next()?;
    pid.parse().ok()
}

/// Builds solver `name` from the registry for `scene`, writing into `dir`, with no peer.
pub fn build(name: &str, scene: &Scene, dir: &Path) -> Result<Box<dyn SphSolver>, SolverError> {
    let ctx = SetupContext {
        scene,
        run_dir: dir,
        scheme: CouplingScheme::Parallel,
        peer_present: false,
    };
    REGISTRY.build(name, &ctx)
}

/// What reading scene `text` reports with the fluid registry's checks of the solver tables
/// (as `coupler check` does): the error message, or empty for a valid scene.
pub fn scene_errors(text: &str) -> String {
    Scene::parse_checked(text, "scene", &[&crate::check_scene])
        .err()
        .map(|e| e.to_string())
        .unwrap_or_default()
}

/// One step of a solver alone, granted by the coupler's rule ([`shared::coupling::step::grant`]: its
/// proposal bounded by the scene's dt limits, times `rule.dt_factor`, landing on `target`), the
/// way the node runtime drives it (prepare_step, write_loads, advance). Returns the time reached and the
/// step's report; a collapsed proposal is an instability.
pub fn step(
    solver: &mut dyn SphSolver,
    rule: &StepRule,
    time: f64,
    target: f64,
    loads: &mut [BlockLoad],
) -> Result<(f64, StepReport), SolverError> {
    solver.prepare_step();
    solver.write_loads(loads);
    let (dt, reached) = grant([(solver.name(), solver.dt_proposal())], rule, time, target)
        .map(|g| (g.dt, g.end_time(time, target)))
        .map_err(|c| SolverError::Unstable(format!("step collapsed: {c}")))?;
    let report = solver.advance(dt)?;
    Ok((reached, report))
}

/// Steps a solver alone until `end` ([`step`] with the scene's limits), calling `observe` after
/// every step.
///
/// The loop runs on one of rayon's workers ([`crate::on_pool`]), as the fluid node's does.
pub fn run(
    solver: &mut dyn SphSolver,
    scene: &Scene,
    end: f64,
    mut observe: impl FnMut(&dyn SphSolver, f64) + Send,
) -> Result<u64, SolverError> {
    let mut loads = vec![BlockLoad::default(); scene.moving_blocks().len()];
    let rule = StepRule::new(scene.time.dt_max, scene.time.dt_min);
    crate::on_pool(|| {
        let (mut t, mut steps) = (0.0, 0);
        observe(solver, t);
        while t < end {
            t = step(solver, &rule, t, end, &mut loads)?.0;
            steps += 1;
            observe(solver, t);
        }
        solver.finish()?;
        Ok(steps)
    })
}

/// A slab tank: floor, end walls at x = 0 and x = length, free-slip side walls at y = 0 and y = width.
pub fn tank(length: f64, width: f64, height: f64, t: f64) -> String {
    let blk = |name: &str, min: [f64; 3], max: [f64; 3]| {
        format!(
            "[[block]]\nname = \"{name}\"\nkind = \"fixed\"\nshape = {{ type = \"box\", min = {min:?}, max = {max:?} }}\n\n"
        )
    };
    let (l, w, h) = (length, width, height);
    [
        blk("floor", [-t, -t, -t], [l + t, w + t, 0.0]),
        blk("left_wall", [-t, -t, -t], [0.0, w + t, h]),
        blk("right_wall", [l, -t, -t], [l + t, w + t, h]),
        blk("south_wall", [-t, -t, -t], [l + t, 0.0, h]),
        blk("north_wall", [-t, w, -t], [l + t, w + t, h]),
    ]
    .concat()
}

/// The `[fluid]` table of a generated scene: `solver`, `dx` and, if given, the walls.
pub fn fluid_table(solver: &str, dx: f64, walls: Option<Walls>) -> String {
    let walls = walls
        .map(|w| format!("walls = \"{}\"\n", w.as_str()))
        .unwrap_or_default();
    format!("[fluid]\nsolver = \"{solver}\"\ndx = {dx}\n{walls}")
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A run directory whose process is gone is removed; one of a live process, and one whose
    /// name carries no process id, are kept.
    #[test]
    fn orphaned_run_directories_are_removed_and_live_ones_kept() {
        let tmp = tempfile::tempdir().unwrap();
        // No process has an id above the kernel's pid_max.
        let pid_max: u64 = std::fs::read_to_string("/proc/sys/kernel/pid_max")
            .unwrap()
            .trim()
            .parse()
            .unwrap();
        let dead = tmp
            .path()
            .join(format!("{TEMP_PREFIX}impact-{}-aB3xYz", pid_max + 1));
        let live = tmp
            .path()
            .join(format!("{TEMP_PREFIX}impact-{}-aB3xYz", std::process::id()));
        let old = tmp.path().join(format!("{TEMP_PREFIX}impact-aB3xYz"));
        for d in [&dead, &live, &old] {
            std::fs::create_dir(d).unwrap();
            std::fs::write(d.join("probes.csv"), "time\n").unwrap();
        }
        remove_orphans(tmp.path());
        assert!(!dead.exists(), "the dead process's directory is left");
        assert!(live.exists() && old.exists());
        let made = TempRunDir::new("sweep").unwrap();
        assert_eq!(
            made.path()
                .file_name()
                .and_then(|n| n.to_str())
                .and_then(owner_pid),
            Some(std::process::id())
        );
    }
}
