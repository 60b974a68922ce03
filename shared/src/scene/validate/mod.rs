//! Scene validation: every impossible value is reported with its field, the value, the problem
//! and the fix. All problems are collected, not just the first, part by part in the order of
//! [`validate`] (the order the messages come in).

mod blocks;
mod checker;
mod coupling;
mod fluid;
mod instruments;
mod run;
mod solid;
mod terrain;

pub(super) use blocks::MAX_DENSITY;
pub use fluid::fluid_ranks_problem;
pub(crate) use terrain::{indexed_field_error, terrain_field_error, terrain_reach_problem};

use super::error::FieldError;
use super::schema::Scene;
use crate::geometry::Polyhedron;
use checker::Checker;

/// Every problem of the scene's values (the slides' own fields are checked when they are cut,
/// [`super::slide`]).
pub(super) fn validate(s: &Scene) -> Vec<FieldError> {
    let mut c = Checker::new();
    run::name_and_gravity(&mut c, s);
    run::time(&mut c, s);
    run::domain(&mut c, s);
    run::output(&mut c, s);
    fluid::check(&mut c, s);
    solid::check(&mut c, s);
    coupling::check(&mut c, s);
    let polys: Vec<Option<Polyhedron>> = s
        .blocks
        .iter()
        .map(|b| Polyhedron::from_shape(&b.shape).ok())
        .collect();
    blocks::each(&mut c, s, &polys);
    blocks::start_overlaps(&mut c, s, &polys);
    let block_names: Vec<&str> = s.blocks.iter().map(|b| b.name.as_str()).collect();
    c.errors
        .extend(terrain::check(&s.terrain, &s.domain, &block_names));
    instruments::check(&mut c, s, &polys);
    c.errors
}
