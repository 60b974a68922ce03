//! What the solid node's integration tests share: a scratch run directory and a solver built
//! from a scene as the node builds it.

use shared::scene::{CouplingScheme, Scene};
use shared::solver::{SetupContext, SolidSolver};

/// A run directory under the system's temporary directory, removed on drop.
pub struct Dir(pub std::path::PathBuf);

impl Dir {
    pub fn new(tag: &str) -> Dir {
        let d = std::env::temp_dir().join(format!("rockwave-solid-{tag}-{}", std::process::id()));
        std::fs::create_dir_all(&d).unwrap();
        Dir(d)
    }
}

impl Drop for Dir {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.0);
    }
}

/// Solver `solver` of the registry for `scene`, writing into `dir` (parallel scheme, alone).
pub fn build(solver: &str, scene: &Scene, dir: &Dir) -> Box<dyn SolidSolver> {
    let ctx = SetupContext {
        scene,
        run_dir: &dir.0,
        scheme: CouplingScheme::Parallel,
        peer_present: false,
    };
    solid_node::REGISTRY.build(solver, &ctx).unwrap()
}
