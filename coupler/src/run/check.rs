//! `coupler check`: a scene's checks and what would run, without running it.

use std::path::Path;

/// Runs `coupler check`; returns the process exit code. A run estimated to crawl
/// ([`crate::run::sizes::crawl`]) fails the check unless `allow_long`.
pub fn run(scene: Option<&Path>, slides_vtk: Option<&Path>, allow_long: bool) -> u8 {
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
