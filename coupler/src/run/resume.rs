//! `coupler run --resume RUN_DIR`: the scene and last checkpoint of the run to continue, and
//! the checks that the command line does not ask it to run otherwise than it was started.

use crate::cli::RunArgs;
use crate::run::checkpoint::CouplerCheckpoint;
use crate::run::lock::RunLock;

/// The run to resume (`--resume RUN_DIR`), announced; none without `--resume`.
pub fn resume(args: &RunArgs) -> Result<Option<Resumed>, String> {
    let resume = match &args.resume {
        Some(dir) => Some(resumed(args, dir)?),
        None => None,
    };
    if let Some(r) = &resume {
        let ck = &r.checkpoint;
        eprintln!(
            "coupler: resuming {} from its checkpoint at step {} (t = {:.6} s)",
            args.resume.as_ref().expect("resuming").display(),
            ck.step,
            ck.time
        );
    }
    Ok(resume)
}

/// The scene, last checkpoint and settings of a run to resume (`--resume RUN_DIR`), and the
/// run directory's lock, held until the run ends.
pub struct Resumed {
    pub scene: shared::scene::Scene,
    pub checkpoint: CouplerCheckpoint,
    pub lock: RunLock,
}

fn resumed(args: &RunArgs, dir: &std::path::Path) -> Result<Resumed, String> {
    let path = dir.join("scene.toml");
    if !path.is_file() {
        return Err(format!(
            "--resume {}: no scene.toml there: not a run directory of `coupler run`. Fix: name the directory the run wrote (its --out)",
            dir.display()
        ));
    }
    // Before anything there is read: another coupler may be writing (or pruning) it.
    let lock = RunLock::directory(dir)?;
    let scene = crate::run::scenes::load(Some(&path)).map_err(|e| e.to_string())?;
    let Some(ck) = crate::run::checkpoint::latest(dir, &scene)
        .map_err(|e| format!("--resume {}: {e}", dir.display()))?
    else {
        return Err(format!(
            "--resume {}: the run wrote no complete checkpoint (checkpoints/coupler-*.ckpt). Fix: start it again with --checkpoint-interval or --checkpoint-wall-minutes",
            dir.display()
        ));
    };
    let hash = shared::checkpoint::run_hash(
        &scene,
        &crate::run::session::scene_text(&scene).map_err(|e| e.to_string())?,
    );
    if hash != ck.scene_hash {
        let terrain: Vec<String> = scene
            .terrain
            .iter()
            .map(|t| format!("'{}'", t.file.display()))
            .collect();
        let (what, fix) = if terrain.is_empty() {
            (
                "scene.toml is".to_string(),
                "restore the run's own scene.toml (and its own checkpoints/, if these were copied from another run)",
            )
        } else {
            (
                format!("scene.toml or its terrain file ({}) is", terrain.join(", ")),
                "restore the run's own scene.toml, terrain files (a terrain file changed under the same path is another run) and checkpoints/",
            )
        };
        return Err(format!(
            "--resume {}: {what} not what the checkpoint '{}' was written for (hash {hash:016x}, checkpoint {:016x}): a checkpoint of another run, or the run's files changed. Fix: {fix}",
            dir.display(),
            shared::checkpoint::coupler_file(dir, ck.step).display(),
            ck.scene_hash
        ));
    }
    for (flag, given, saved) in [
        ("--fluid-solver", &args.fluid_solver, &ck.fluid_solver),
        ("--solid-solver", &args.solid_solver, &ck.solid_solver),
    ] {
        if let (Some(g), Some(s)) = (given, saved)
            && g != s
        {
            return Err(format!(
                "--resume: {flag} {g}, but the checkpoint was written by solver '{s}'. Fix: drop {flag} (a resumed run keeps its solvers)"
            ));
        }
    }
    if let Some(scheme) = args.scheme
        && scheme != ck.scheme
    {
        return Err(format!(
            "--resume: --scheme {scheme}, but the run was coupled {}. Fix: drop --scheme",
            ck.scheme
        ));
    }
    if args.dt_factor != 1.0 && args.dt_factor != ck.dt_factor {
        return Err(format!(
            "--resume: --dt-factor {}, but the run was started with {}. Fix: drop --dt-factor",
            shared::math::readable(args.dt_factor),
            shared::math::readable(ck.dt_factor)
        ));
    }
    Ok(Resumed {
        scene,
        checkpoint: ck,
        lock,
    })
}
