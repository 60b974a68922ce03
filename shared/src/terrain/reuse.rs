//! One load of each terrain per command. `coupler check` and the start of `coupler run` ask
//! for a scene's terrains several times (the scene's checks, the size estimate, the summary
//! lines); a survey-scale DEM takes seconds and hundreds of MB to triangulate, so while a
//! [`Reuse`] guard lives on this thread, [`load`] keeps each terrain it loads and hands the same
//! one out again. Without a guard nothing is kept: the nodes, which load their terrains once
//! and keep them, and any long-lived process hold no second copy.

use super::{Terrain, TerrainError};
use crate::scene::{DomainSpec, TerrainSpec};
use std::cell::RefCell;
use std::sync::Arc;

/// The terrains loaded under the current guard, by their table and domain.
type Kept = Vec<(String, Arc<Terrain>)>;

thread_local! {
    static KEPT: RefCell<Option<Kept>> = const { RefCell::new(None) };
}

/// While alive, [`load`] on this thread loads each `[[terrain]]` table once.
pub struct Reuse(());

impl Reuse {
    pub fn begin() -> Self {
        KEPT.with(|k| *k.borrow_mut() = Some(Vec::new()));
        Reuse(())
    }
}

impl Drop for Reuse {
    fn drop(&mut self) {
        KEPT.with(|k| *k.borrow_mut() = None);
    }
}

/// [`Terrain::load`], or the terrain already loaded for the same table and domain under the
/// current [`Reuse`] guard. Errors are not kept (they come back at once).
pub fn load(spec: &TerrainSpec, domain: &DomainSpec) -> Result<Arc<Terrain>, TerrainError> {
    // Every field of the table (file, placement, crop, decimate, …) and the domain.
    let key = format!("{spec:?}|{domain:?}");
    let kept = KEPT.with(|k| {
        k.borrow()
            .as_ref()
            .and_then(|v| v.iter().find(|(at, _)| *at == key).map(|(_, t)| t.clone()))
    });
    if let Some(t) = kept {
        return Ok(t);
    }
    let t = Arc::new(Terrain::load(spec, domain)?);
    KEPT.with(|k| {
        if let Some(v) = k.borrow_mut().as_mut() {
            v.push((key, t.clone()));
        }
    });
    Ok(t)
}
