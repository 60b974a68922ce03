//! What a fluid on several MPI ranks does not do yet, refused by `coupler check` and `coupler
//! run` before anything of the run exists: fluid solvers that do not split over ranks (the
//! registry's [`shared::registry::Advice::splits_over_ranks`]: no solver is named here). The
//! fluid node refuses them too, but only once its ranks are up; here the user hears it at once.
//! A run on one rank is never refused.

use shared::scene::Scene;

/// The fix every refusal ends with: on one rank everything runs.
const ONE_RANK: &str = "or run with --fluid-ranks 1";

/// The fluid solver `solver` (`None`: the scene's) on `ranks` ranks: refused when the solver's
/// registry entry says it does not split over ranks.
pub fn solver(scene: &Scene, solver: Option<&str>, ranks: u32) -> Result<(), String> {
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
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn one_rank_runs_everything() {
        let s = Scene::default_scene();
        assert_eq!(solver(&s, Some("muller"), 1), Ok(()));
        assert_eq!(solver(&s, Some("wcsph"), 3), Ok(()));
    }

    #[test]
    fn solvers_that_do_not_split_are_refused_by_the_registry_s_word() {
        let mut s = Scene::default_scene();
        for e in fluid_node::REGISTRY.entries {
            let got = solver(&s, Some(e.name), 2);
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
        s.fluid.as_mut().unwrap().solver = "dfsph".into();
        let msg = solver(&s, None, 3).unwrap_err();
        assert!(msg.contains("'dfsph'"), "the scene's solver: {msg}");
    }
}
