//! What a fluid on several MPI ranks does not do yet, refused by `coupler check` and `coupler
//! run` before anything of the run exists: fluid solvers that do not split over ranks (the
//! registry's [`shared::registry::Advice::splits_over_ranks`]: no solver is named here; every
//! built-in one splits). The
//! fluid node refuses them too, but only once its ranks are up; here the user hears it at once.
//! A run on one rank is never refused.

use fluid_node::sph::SphSolver;
use shared::registry::Registry;
use shared::scene::Scene;

/// The fix every refusal ends with: on one rank everything runs.
const ONE_RANK: &str = "or run with --fluid-ranks 1";

/// The fluid solver `solver` (`None`: the scene's) on `ranks` ranks: refused when the solver's
/// registry entry says it does not split over ranks (every built-in solver does).
pub fn solver(scene: &Scene, solver: Option<&str>, ranks: u32) -> Result<(), String> {
    solver_in(&fluid_node::REGISTRY, scene, solver, ranks)
}

/// [`solver`] against the solvers of `registry`.
fn solver_in(
    registry: &Registry<dyn SphSolver>,
    scene: &Scene,
    solver: Option<&str>,
    ranks: u32,
) -> Result<(), String> {
    if ranks <= 1 || !scene.has_fluid() {
        return Ok(());
    }
    let name = solver
        .map(str::to_string)
        .or_else(|| scene.fluid.as_ref().map(|f| f.solver.clone()))
        .unwrap_or_default();
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
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use fluid_node::methods::wcsph::Wcsph;
    use shared::registry::{Advice, Entry};

    /// WCSPH's entry under another name, saying it does not split: what a solver added to the
    /// registry before it splits looks like.
    const UNSPLIT: Entry<dyn SphSolver> = {
        let wcsph = fluid_node::entry::<Wcsph>();
        Entry {
            name: "unsplit",
            advice: Advice {
                splits_over_ranks: false,
                ..wcsph.advice
            },
            ..wcsph
        }
    };
    static REGISTRY: Registry<dyn SphSolver> = Registry {
        role: "fluid",
        entries: &[fluid_node::entry::<Wcsph>(), UNSPLIT],
    };

    #[test]
    fn every_built_in_solver_runs_on_ranks_and_one_rank_runs_everything() {
        let s = Scene::default_scene();
        for e in fluid_node::REGISTRY.entries {
            assert_eq!(solver(&s, Some(e.name), 3), Ok(()), "{}", e.name);
        }
        assert_eq!(solver_in(&REGISTRY, &s, Some("unsplit"), 1), Ok(()));
    }

    #[test]
    fn a_solver_that_does_not_split_is_refused_by_the_registry_s_word() {
        let mut s = Scene::default_scene();
        let msg = solver_in(&REGISTRY, &s, Some("unsplit"), 2).unwrap_err();
        for says in [
            "the fluid solver 'unsplit' does not run on several ranks yet",
            "(2 asked)",
            "a solver that does (wcsph:",
            ONE_RANK,
        ] {
            assert!(msg.contains(says), "{says}: {msg}");
        }
        s.fluid.as_mut().unwrap().solver = "unsplit".into();
        let msg = solver_in(&REGISTRY, &s, None, 3).unwrap_err();
        assert!(msg.contains("'unsplit'"), "the scene's solver: {msg}");
    }
}
