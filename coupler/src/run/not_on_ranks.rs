//! What a fluid on several MPI ranks does not do yet, refused by `coupler check` and `coupler
//! run` before anything of the run exists, each message naming the field or flag and the fix:
//! checkpoints (and so `--retries` and `--resume`), fluid solvers that do not split over ranks
//! (the registry's [`shared::registry::Advice::splits_over_ranks`]: no solver is named here)
//! and moving blocks. The fluid node refuses them too, but only once its ranks are up; here
//! the user hears it at once. A run on one rank is never refused.

use shared::scene::{FieldError, Scene};

/// The fix every refusal ends with: on one rank everything runs.
const ONE_RANK: &str = "or run with --fluid-ranks 1";

/// Why a checkpoint cannot be written on several ranks.
const NO_CHECKPOINTS: &str = "checkpoints of a fluid on several ranks are not written yet";

/// The checkpoints a run on `ranks` ranks is asked for, refused when `ranks` > 1: `flags`
/// holds each checkpoint flag given (`--checkpoint-interval`, `--checkpoint-wall-minutes`,
/// `--retries`, `--resume`) with its value; the scene's `output.checkpoint_*` fields count
/// unless `no_checkpoints` (`--no-checkpoints` overrides them).
pub fn checkpoints(
    flags: &[(&str, String)],
    scene: &Scene,
    no_checkpoints: bool,
    ranks: u32,
) -> Result<(), String> {
    if ranks <= 1 || !scene.has_fluid() {
        return Ok(());
    }
    if let Some((flag, value)) = flags.first() {
        let why = match *flag {
            "--retries" => "restarts a run from its last checkpoint, and ",
            "--resume" => "continues a run from its last checkpoint, and ",
            _ => "",
        };
        let fix = match *flag {
            "--resume" => "resume it with --fluid-ranks 1".to_string(),
            _ => format!("drop {flag}, {ONE_RANK}"),
        };
        return Err(format!(
            "{flag} {value}: {why}{NO_CHECKPOINTS} (the run has {ranks} fluid ranks). Fix: {fix}"
        ));
    }
    let out = &scene.output;
    let asked = [
        ("checkpoint_interval", out.checkpoint_interval),
        ("checkpoint_wall_minutes", out.checkpoint_wall_minutes),
    ];
    match asked.iter().find(|(_, v)| v.is_some() && !no_checkpoints) {
        Some((field, Some(v))) => Err(FieldError::new(
            &["output", field],
            v.to_string(),
            &format!("{NO_CHECKPOINTS} (the run has {ranks} fluid ranks)"),
            &format!("remove it (or run with --no-checkpoints), {ONE_RANK}"),
        )
        .to_string()),
        _ => Ok(()),
    }
}

/// The line `coupler check` and `coupler run` print for a run on several ranks that asks for no
/// checkpoints (the default ones of a long run are skipped); `None` on one rank or without
/// water (no fluid node).
pub fn no_checkpoints_line(scene: &Scene, ranks: u32) -> Option<String> {
    (ranks > 1 && scene.has_fluid()).then(|| {
        format!(
            "no checkpoints: {NO_CHECKPOINTS} ({ranks} fluid ranks); a run killed starts again from t = 0"
        )
    })
}

/// The fluid solver `solver` (`None`: the scene's) and the scene's moving blocks on `ranks`
/// ranks: refused when the solver's registry entry says it does not split over ranks, or when
/// the scene moves a block.
pub fn solver_and_blocks(scene: &Scene, solver: Option<&str>, ranks: u32) -> Result<(), String> {
    if ranks <= 1 || !scene.has_fluid() {
        return Ok(());
    }
    let name = solver
        .map(str::to_string)
        .or_else(|| scene.fluid.as_ref().map(|f| f.solver.clone()))
        .unwrap_or_default();
    let registry = &fluid_node::REGISTRY;
    if let Ok(entry) = registry.get(&name)
        && !entry.advice.splits_over_ranks
    {
        let splitting: Vec<&str> = registry
            .entries
            .iter()
            .filter(|e| e.advice.splits_over_ranks)
            .map(|e| e.name)
            .collect();
        return Err(format!(
            "the fluid solver '{name}' does not run on several ranks yet ({ranks} asked). Fix: a solver that does ({}: [fluid] solver or --fluid-solver), {ONE_RANK}",
            splitting.join(", ")
        ));
    }
    let moving = scene.moving_blocks();
    if let Some(&first) = moving.first() {
        let names: Vec<&str> = moving
            .iter()
            .map(|&i| scene.blocks[i].name.as_str())
            .collect();
        return Err(format!(
            "moving blocks with a fluid on several ranks are not handled yet: {} block(s) move ({}; block[{first}] is the first), and the run has {ranks} fluid ranks. Fix: make them kind = \"fixed\", {ONE_RANK}",
            moving.len(),
            names.join(", ")
        ));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The dam break of the MPI tests: wcsph, fixed walls only.
    fn fixed_only() -> Scene {
        let mut s = Scene::default_scene();
        s.blocks
            .retain(|b| b.kind == shared::scene::BlockKind::Fixed);
        s.fluid.as_mut().unwrap().solver = "wcsph".into();
        s
    }

    #[test]
    fn one_rank_runs_everything() {
        let s = Scene::default_scene();
        let flags = [("--retries", "2".to_string())];
        assert_eq!(checkpoints(&flags, &s, false, 1), Ok(()));
        assert_eq!(solver_and_blocks(&s, Some("muller"), 1), Ok(()));
        assert_eq!(no_checkpoints_line(&s, 1), None);
        assert_eq!(solver_and_blocks(&fixed_only(), None, 3), Ok(()));
    }

    #[test]
    fn checkpoint_flags_are_refused_on_ranks() {
        let s = fixed_only();
        assert_eq!(checkpoints(&[], &s, false, 2), Ok(()));
        for (flag, says) in [
            (
                "--checkpoint-interval",
                "Fix: drop --checkpoint-interval, or run with --fluid-ranks 1",
            ),
            (
                "--checkpoint-wall-minutes",
                "Fix: drop --checkpoint-wall-minutes, or run",
            ),
            ("--retries", "restarts a run from its last checkpoint"),
            ("--resume", "Fix: resume it with --fluid-ranks 1"),
        ] {
            let msg = checkpoints(&[(flag, "3".into())], &s, false, 2).unwrap_err();
            assert!(msg.starts_with(&format!("{flag} 3: ")), "{msg}");
            for says in [says, NO_CHECKPOINTS, "2 fluid ranks"] {
                assert!(msg.contains(says), "{says}: {msg}");
            }
        }
        let line = no_checkpoints_line(&s, 3).unwrap();
        assert!(
            line.starts_with("no checkpoints: ") && line.contains("3 fluid ranks"),
            "{line}"
        );
    }

    #[test]
    fn the_scenes_checkpoints_are_refused_unless_turned_off() {
        let mut s = fixed_only();
        s.output.checkpoint_wall_minutes = Some(5.0);
        let msg = checkpoints(&[], &s, false, 2).unwrap_err();
        assert!(
            msg.starts_with("output.checkpoint_wall_minutes = 5: ")
                && msg.contains(NO_CHECKPOINTS)
                && msg.contains(
                    "fix: remove it (or run with --no-checkpoints), or run with --fluid-ranks 1"
                ),
            "{msg}"
        );
        assert_eq!(checkpoints(&[], &s, true, 2), Ok(()), "--no-checkpoints");
        s.output.checkpoint_interval = Some(0.5);
        let msg = checkpoints(&[], &s, false, 2).unwrap_err();
        assert!(
            msg.starts_with("output.checkpoint_interval = 0.5: "),
            "{msg}"
        );
    }

    #[test]
    fn solvers_that_do_not_split_are_refused_by_the_registry_s_word() {
        let s = fixed_only();
        for e in fluid_node::REGISTRY.entries {
            let got = solver_and_blocks(&s, Some(e.name), 2);
            if e.advice.splits_over_ranks {
                assert_eq!(got, Ok(()), "{}", e.name);
                continue;
            }
            let msg = got.unwrap_err();
            for says in [
                format!(
                    "the fluid solver '{}' does not run on several ranks yet",
                    e.name
                ),
                "(2 asked)".into(),
                "wcsph".into(),
                ONE_RANK.into(),
            ] {
                assert!(msg.contains(&says), "{says}: {msg}");
            }
        }
        let mut written = s.clone();
        written.fluid.as_mut().unwrap().solver = "muller".into();
        let msg = solver_and_blocks(&written, None, 3).unwrap_err();
        assert!(msg.contains("'muller'"), "the scene's solver: {msg}");
    }

    #[test]
    fn moving_blocks_are_refused_on_ranks() {
        let mut s = Scene::default_scene();
        s.fluid.as_mut().unwrap().solver = "wcsph".into();
        let first = s.moving_blocks()[0];
        let msg = solver_and_blocks(&s, None, 2).unwrap_err();
        for says in [
            "moving blocks with a fluid on several ranks are not handled yet",
            &s.blocks[first].name,
            "kind = \"fixed\"",
            ONE_RANK,
        ] {
            assert!(msg.contains(says), "{says}: {msg}");
        }
    }
}
