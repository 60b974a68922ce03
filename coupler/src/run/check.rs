//! `coupler check`: a scene's checks and what would run, without running it.

use std::path::Path;

/// Runs `coupler check`; returns the process exit code. A run estimated to crawl
/// ([`crate::run::sizes::crawl`]) fails the check unless `allow_long`; so do more fluid ranks
/// (`fluid_ranks`, else the scene's) than the water can fill.
pub fn run(
    scene: Option<&Path>,
    slides_vtk: Option<&Path>,
    allow_long: bool,
    fluid_ranks: Option<u32>,
) -> u8 {
    // The scene's checks, the summary and the estimate read the terrains once between them.
    let _once = shared::terrain::reuse::Reuse::begin();
    let loaded = crate::run::scenes::load_as_written(scene);
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
            match per_rank_line(&s, fluid_ranks) {
                Ok(Some(line)) => println!("{line}"),
                Ok(None) => {}
                Err(e) => {
                    eprintln!("coupler: error: {e}");
                    return 1;
                }
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

/// What each fluid rank would hold when the run has more than one
/// ([`crate::run::per_rank::PerRank`]), or why those ranks cannot be.
fn per_rank_line(
    scene: &shared::scene::Scene,
    flag: Option<u32>,
) -> Result<Option<String>, String> {
    let ranks = crate::run::per_rank::ranks(flag, scene)?;
    Ok(crate::run::per_rank::PerRank::estimate(scene, ranks)
        .filter(|_| ranks > 1)
        .map(|p| p.describe()))
}

#[cfg(test)]
mod tests {
    use super::*;
    use shared::scene::Scene;

    #[test]
    fn check_says_what_each_rank_holds() {
        let s = Scene::default_scene();
        assert_eq!(
            per_rank_line(&s, None),
            Ok(None),
            "one rank: nothing more to say"
        );
        assert_eq!(per_rank_line(&s, Some(1)), Ok(None));
        let line = per_rank_line(&s, Some(3)).unwrap().unwrap();
        assert!(
            line.starts_with("on 3 fluid ranks: slabs of 1.883 m along x"),
            "{line}"
        );
        let mut written = s.clone();
        written.fluid.as_mut().unwrap().ranks = 2;
        let line = per_rank_line(&written, None).unwrap().unwrap();
        assert!(line.starts_with("on 2 fluid ranks"), "{line}");
        let msg = per_rank_line(&s, Some(99)).unwrap_err();
        assert!(msg.contains("at most 12 ranks"), "{msg}");
    }
}
