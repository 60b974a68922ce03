//! `coupler check`: a scene's checks and what would run, without running it.

use std::path::Path;

/// Runs `coupler check`; returns the process exit code. A run estimated to crawl
/// ([`crate::run::sizes::crawl`]) fails the check unless `allow_long`; so do more fluid ranks
/// (`fluid_ranks`, else the scene's) than the water can fill, or than the fluid node can run as.
/// `dx` overrides the scene's particle spacing, as `coupler run --dx` does.
pub fn run(
    scene: Option<&Path>,
    slides_vtk: Option<&Path>,
    allow_long: bool,
    fluid_ranks: Option<u32>,
    dx: Option<f64>,
) -> u8 {
    // A report for a pipe: when its reader stops early (`coupler check | head -3`), end quietly
    // as Unix filters do. Rust ignores SIGPIPE, so the next `println!` panicked with a
    // backtrace instead. Only here: `coupler run` keeps ignoring it, so a closed pipe cannot
    // kill it before it has stopped its nodes.
    // SAFETY: `signal` only sets this process's disposition of SIGPIPE back to the default.
    unsafe {
        libc::signal(libc::SIGPIPE, libc::SIG_DFL);
    }
    // The scene's checks, the summary and the estimate read the terrains once between them.
    let _once = shared::terrain::reuse::Reuse::begin();
    let loaded = crate::run::scenes::load_as_written(scene)
        .map_err(|e| e.to_string())
        .and_then(|mut s| {
            if let Some(dx) = dx {
                crate::run::settings::set_dx(&mut s, dx)?;
                refuse_problems(&s, dx)?;
            }
            Ok(s)
        });
    match loaded {
        Ok(s) => {
            println!(
                "scene '{}' is valid: {} blocks ({} moving), {} terrain(s), water: {}, gauges: {}, domain top: {}",
                s.name,
                s.blocks.len(),
                s.moving_blocks().len(),
                s.terrain.len(),
                if s.has_fluid() { "yes" } else { "no" },
                s.gauges.len(),
                if s.domain.open_top {
                    "open (spray may fly above it)"
                } else {
                    "closed"
                }
            );
            match shared::terrain::Terrain::load_all_kept(&s) {
                Ok(terrain) => terrain.iter().for_each(|t| println!("{}", t.summary())),
                Err(e) => {
                    eprintln!("coupler: error: {e}");
                    return 1;
                }
            }
            for line in crate::run::slides::describe(&s) {
                println!("{line}");
            }
            if let Some(path) = slides_vtk {
                match crate::run::slides::write_vtk(&s, path) {
                    Ok(n) => println!("wrote {n} slide block(s) to {}", path.display()),
                    Err(e) => {
                        eprintln!("coupler: error: {e}");
                        return 1;
                    }
                }
            }
            if let Some(e) = crate::run::sizes::estimate(&s, None) {
                println!("estimate: {}", e.describe());
            }
            match per_rank_lines(&s, fluid_ranks) {
                Ok(lines) => lines.iter().for_each(|line| println!("{line}")),
                Err(e) => {
                    eprintln!("coupler: error: {e}");
                    return 1;
                }
            }
            // After what each rank would hold: that is worth knowing before building with MPI.
            if let Err(e) = node_runs_ranks(&s, fluid_ranks) {
                eprintln!("coupler: error: {e}");
                return 1;
            }
            for e in crate::run::sizes::crawl(&s, None) {
                if allow_long {
                    eprintln!("coupler: warning (--allow-long): {e}");
                } else {
                    eprintln!("coupler: error: {e}");
                    return 1;
                }
            }
            println!("solvers:\n{}", crate::run::scenes::solver_list());
            0
        }
        Err(e) => {
            eprintln!("coupler: error: {e}");
            1
        }
    }
}

/// The scene's checks again at the spacing of `--dx`, as `coupler run --dx` makes them: the
/// scene was checked at its own spacing, and `check --dx 1e300` called valid a scene that
/// `run --dx 1e300` refused (fewer than 4 particles across the domain).
fn refuse_problems(scene: &shared::scene::Scene, dx: f64) -> Result<(), String> {
    let problems = crate::run::scenes::problems(scene);
    if problems.is_empty() {
        return Ok(());
    }
    let list: Vec<String> = problems.iter().map(|e| format!("  {e}")).collect();
    Err(format!("the scene at --dx {dx:?}:\n{}", list.join("\n")))
}

/// What each fluid rank would hold when the run has more than one
/// ([`crate::run::per_rank::PerRank`]) and that it writes no checkpoints, or why those ranks
/// cannot be: more than the water can fill, or what a fluid on several ranks does not do yet
/// ([`crate::run::not_on_ranks`]).
fn per_rank_lines(scene: &shared::scene::Scene, flag: Option<u32>) -> Result<Vec<String>, String> {
    use crate::run::not_on_ranks;
    let ranks = crate::run::per_rank::ranks(flag, scene)?;
    not_on_ranks::solver(scene, None, ranks)?;
    Ok(crate::run::per_rank::PerRank::estimate(scene, ranks)
        .filter(|_| ranks > 1)
        .map(|p| p.describe())
        .into_iter()
        .collect())
}

/// Whether the fluid node beside the coupler can run as the scene's ranks (`flag`, else its
/// `[fluid] ranks`), asked as `coupler run` asks it ([`crate::run::node_ranks`]): a node built
/// without MPI is refused with `run`'s message. A node that is not there gives no answer and is
/// let through: the check is of the scene.
fn node_runs_ranks(scene: &shared::scene::Scene, flag: Option<u32>) -> Result<(), String> {
    use crate::run::{launch::NodeCommand, node_ranks};
    let ranks = crate::run::per_rank::ranks(flag, scene)?;
    if ranks <= 1 || !scene.has_fluid() {
        return Ok(());
    }
    let node = NodeCommand::beside_me(shared::protocol::Role::Fluid)?;
    node_ranks::refuse_without_mpi(&node, &node.program, ranks, &node_ranks::asked(flag, ranks))
}

#[cfg(test)]
mod tests {
    use super::*;
    use shared::scene::Scene;

    /// The dam break of the MPI tests: wcsph, fixed blocks only.
    fn fixed_only() -> Scene {
        let mut s = Scene::default_scene();
        s.blocks
            .retain(|b| b.kind == shared::scene::BlockKind::Fixed);
        s.fluid.as_mut().unwrap().solver = "wcsph".into();
        s
    }

    #[test]
    fn check_says_what_each_rank_holds() {
        let s = fixed_only();
        assert_eq!(
            per_rank_lines(&s, None),
            Ok(vec![]),
            "one rank: nothing more to say"
        );
        assert_eq!(per_rank_lines(&s, Some(1)), Ok(vec![]));
        let lines = per_rank_lines(&s, Some(3)).unwrap();
        assert!(
            lines[0].starts_with("on 3 fluid ranks: slabs of 1.883 m along x"),
            "{lines:?}"
        );
        assert_eq!(lines.len(), 1, "{lines:?}");
        let mut written = s.clone();
        written.fluid.as_mut().unwrap().ranks = 2;
        let lines = per_rank_lines(&written, None).unwrap();
        assert!(lines[0].starts_with("on 2 fluid ranks"), "{lines:?}");
        let msg = per_rank_lines(&s, Some(99)).unwrap_err();
        assert!(msg.contains("at most 12 ranks"), "{msg}");
    }

    /// `coupler check` refuses on ranks what `coupler run` would: solvers that do not split;
    /// moving blocks and checkpoints run on ranks.
    #[test]
    fn check_says_what_each_rank_holds_for_every_solver() {
        for solver in fluid_node::REGISTRY.names() {
            let mut scene = fixed_only();
            scene.fluid.as_mut().unwrap().solver = solver.into();
            assert_eq!(
                per_rank_lines(&scene, Some(2)).map(|l| l.len()),
                Ok(1),
                "{solver}"
            );
            assert_eq!(per_rank_lines(&scene, Some(1)), Ok(vec![]), "{solver}");
        }
        let msg = per_rank_lines(&fixed_only(), Some(4096)).unwrap_err();
        assert!(msg.contains("more ranks than the water can fill"), "{msg}");
        let mut moving = Scene::default_scene();
        moving.fluid.as_mut().unwrap().solver = "wcsph".into();
        assert_eq!(per_rank_lines(&moving, Some(2)).map(|l| l.len()), Ok(1));
        let mut ckpt = fixed_only();
        ckpt.output.checkpoint_interval = Some(0.5);
        assert_eq!(per_rank_lines(&ckpt, Some(2)).map(|l| l.len()), Ok(1));
    }
}
