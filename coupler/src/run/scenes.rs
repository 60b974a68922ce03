//! Reading a scene as the coupler does: the schema and its validation (`shared::scene`), plus
//! each solver registry's check of the solver tables (`[fluid.<name>]`, `[solid.<name>]`), so a
//! bad solver parameter is named with its field and line before any node starts, the terrain
//! files' checks (`shared::terrain::check_scene`), and the size
//! check (`crate::run::sizes`): a scene that cannot fit in this machine's memory is refused.

use shared::scene::{DEFAULT_SCENE, DEFAULT_SCENE_ORIGIN, FieldError, Scene, SceneError};
use std::path::Path;

/// The registries' checks, in the form `Scene::parse_checked` takes.
pub fn solver_checks(scene: &Scene) -> Vec<FieldError> {
    let mut all = fluid_node::check_scene(scene);
    all.extend(solid_node::check_scene(scene));
    // The terrain files: read, placed and checked (topology, normals, no-data, domain) here,
    // so a bad file is named before any node starts.
    all.extend(shared::terrain::check_scene(scene));
    all
}

/// [`solver_checks`] and the size check, for a scene as it will run (after overrides such as
/// `--dx`). Sizes only for a scene otherwise valid: the estimate reads its shapes.
pub fn run_checks(scene: &Scene) -> Vec<FieldError> {
    let all = solver_checks(scene);
    if all.is_empty() && scene.validate().is_empty() {
        return crate::run::sizes::check(scene, None);
    }
    all
}

/// [`load`] with the size check too: the scene runs as written (`coupler check`).
pub fn load_as_written(path: Option<&Path>) -> Result<Scene, SceneError> {
    match path {
        Some(p) => Scene::load_checked(p, &[&run_checks]),
        None => Scene::parse_checked(DEFAULT_SCENE, DEFAULT_SCENE_ORIGIN, &[&run_checks]),
    }
}

/// Loads `path`, or the embedded default scene, with every check.
pub fn load(path: Option<&Path>) -> Result<Scene, SceneError> {
    match path {
        Some(p) => Scene::load_checked(p, &[&solver_checks]),
        None => Scene::parse_checked(DEFAULT_SCENE, DEFAULT_SCENE_ORIGIN, &[&solver_checks]),
    }
}

/// Every problem of a scene already parsed (after command-line overrides).
pub fn problems(scene: &Scene) -> Vec<FieldError> {
    let mut all = scene.validate();
    all.extend(run_checks(scene));
    all
}

/// The solvers each node binary offers, one per line, for `coupler check`.
pub fn solver_list() -> String {
    let fluid = fluid_node::REGISTRY
        .entries
        .iter()
        .map(|e| format!("  fluid {:<9} {}", e.name, e.description));
    let solid = solid_node::REGISTRY
        .entries
        .iter()
        .map(|e| format!("  solid {:<9} {}", e.name, e.description));
    fluid.chain(solid).collect::<Vec<_>>().join("\n")
}
