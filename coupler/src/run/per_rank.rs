//! What N fluid ranks would hold, before any of them starts: particles and memory per rank
//! (`coupler check --fluid-ranks N`, and the start of `coupler run` on ranks), and the refusal
//! of more ranks than the water's slabs can hold, naming `fluid.ranks` or `--fluid-ranks` and
//! the most that fit.
//!
//! The fluid node cuts the domain into slabs along its longest horizontal axis; each rank owns
//! the particles of its slab and keeps copies of its neighbours' particles near the cuts (the
//! halo). The estimate takes slabs of equal width holding equal shares of the water (the cuts
//! move with the work, which keeps the shares near equal), and a halo on both sides of every
//! slab (the two end slabs have one: an upper estimate).

use crate::run::sizes::{
    BASE_BYTES, BYTES_PER_BOUNDARY_PARTICLE, BYTES_PER_WATER_PARTICLE, estimate,
};
use fluid_node::methods::wcsph::WCSPH_SKIN;
use shared::scene::{FieldError, Scene, fluid_ranks_problem};

/// Kernel support over the particle spacing: the Wendland C2 kernel reaches 2h, with every
/// solver's default h = 1.3 dx.
pub const SUPPORT_OVER_DX: f64 = 2.6;
/// Grid cells of the halo on each side of a slab: the particles within two cells of a cut are
/// copied to the neighbour, and the cut falls inside a column (at an eighth of one) that both
/// ranks hold whole: half a column more on average. The second cell is held whole only in a
/// scene with moving blocks; without, only where a wall is near (a third of the halo fewer in
/// `fluid-bench`'s tank): there this is an upper estimate.
pub const HALO_CELLS: f64 = 2.5;
/// Narrowest slab, in grid cells: a slab narrower than its two halos would hold more copies
/// than particles of its own, and trade most of its water every step.
pub const MIN_SLAB_CELLS: u32 = 4;
/// Rank 0's peak resident bytes on top of its own share, per water particle of the whole run:
/// it gathers every particle to write a checkpoint (the one-rank file) and a frame. Measured on
/// `scenes/fjord.toml --dx 1 --fluid-ranks 2` (29 Nov 2026): rank 0 peaked at 1.65 GB and
/// rank 1 at 1.14 GB, with 1 266 439 water particles (~400 B each); at dx = 4/3 m (28 Nov)
/// rank 0 peaked at 775 MB, ~500 B a particle over its share by the figures above.
pub const LEAD_BYTES_PER_PARTICLE: f64 = 500.0;

/// The slabs of a scene's domain: the axis they are cut along, its length and a grid cell.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Slabs {
    /// 0 for x, 1 for y: the longest horizontal axis of the domain.
    pub axis: usize,
    /// The domain's length along `axis` [m].
    pub length: f64,
    /// A grid cell [m]: the kernel support × (1 + the Verlet skin, [`WCSPH_SKIN`]).
    pub cell: f64,
}

impl Slabs {
    /// The slabs of `scene` at its `fluid.dx`; `None` without water.
    pub fn of(scene: &Scene) -> Option<Slabs> {
        let fluid = scene.fluid.as_ref().filter(|_| scene.has_fluid())?;
        let d = &scene.domain;
        let extent = |k: usize| d.max[k] - d.min[k];
        let axis = if extent(1) > extent(0) { 1 } else { 0 };
        Some(Slabs {
            axis,
            length: extent(axis),
            cell: SUPPORT_OVER_DX * fluid.dx * (1.0 + WCSPH_SKIN),
        })
    }

    /// The most ranks whose slabs are each at least [`MIN_SLAB_CELLS`] cells wide (at least 1).
    pub fn most_ranks(&self) -> u32 {
        let n = (self.length / (f64::from(MIN_SLAB_CELLS) * self.cell)).floor();
        n.clamp(1.0, f64::from(u32::MAX)) as u32
    }

    fn axis_name(&self) -> &'static str {
        ["x", "y"][self.axis]
    }
}

/// What one of N fluid ranks would hold.
#[derive(Debug, Clone)]
pub struct PerRank {
    pub ranks: u32,
    pub slabs: Slabs,
    /// Water particles a rank owns: the water's / N.
    pub particles: f64,
    /// Halo particles a rank keeps: its own × 2 sides × [`HALO_CELLS`] cells over its slab's
    /// width, at most the water it does not own.
    pub halo: f64,
    /// Boundary particles a rank holds: all of them.
    pub boundary: f64,
    /// Memory of one rank [bytes]: [`BASE_BYTES`] + [`BYTES_PER_WATER_PARTICLE`] × (own + halo)
    /// + [`BYTES_PER_BOUNDARY_PARTICLE`] × boundary particles.
    pub memory: f64,
    /// Memory of rank 0 [bytes]: [`Self::memory`] + [`LEAD_BYTES_PER_PARTICLE`] × the whole
    /// water (on one rank, the node's own estimate holds).
    pub lead_memory: f64,
}

impl PerRank {
    /// The estimate for `ranks` ranks; `None` without water.
    pub fn estimate(scene: &Scene, ranks: u32) -> Option<PerRank> {
        let slabs = Slabs::of(scene)?;
        let whole = estimate(scene, None)?;
        let n = f64::from(ranks.max(1));
        let particles = whole.fluid_particles / n;
        let slab = slabs.length / n;
        let halo = if ranks > 1 {
            (particles * 2.0 * HALO_CELLS * slabs.cell / slab)
                .min(whole.fluid_particles - particles)
        } else {
            0.0
        };
        let boundary = whole.boundary_particles;
        let memory = BASE_BYTES
            + BYTES_PER_WATER_PARTICLE * (particles + halo)
            + BYTES_PER_BOUNDARY_PARTICLE * boundary;
        Some(PerRank {
            ranks,
            slabs,
            particles,
            halo,
            boundary,
            memory,
            lead_memory: memory + LEAD_BYTES_PER_PARTICLE * whole.fluid_particles,
        })
    }

    /// One line for `coupler check` and the start of a run.
    pub fn describe(&self) -> String {
        let s = &self.slabs;
        format!(
            "on {} fluid ranks: slabs of {:.3} m along {} (the domain's {:.3} m); each rank about {:.3e} water particles + {:.3e} halo ({:.0} % more: 2 × {} cells of {:.3} m) + {:.3e} boundary (every rank holds them all), about {:.0} MB of memory ({} B per water and {} B per boundary particle, measured), rank 0 about {:.0} MB (it gathers the whole water for checkpoints and frames)",
            self.ranks,
            s.length / f64::from(self.ranks),
            s.axis_name(),
            s.length,
            self.particles,
            self.halo,
            100.0 * self.halo / self.particles.max(1.0),
            HALO_CELLS,
            s.cell,
            self.boundary,
            self.memory / 1e6,
            BYTES_PER_WATER_PARTICLE,
            BYTES_PER_BOUNDARY_PARTICLE,
            self.lead_memory / 1e6
        )
    }
}

/// The fluid ranks a run uses: `flag` (`--fluid-ranks`) or the scene's `[fluid] ranks`,
/// checked: from 1 to [`shared::scene::MAX_FLUID_RANKS`], and no more than the water's slabs
/// can hold ([`Slabs::most_ranks`]). The error names where the count came from and the fix.
pub fn ranks(flag: Option<u32>, scene: &Scene) -> Result<u32, String> {
    let from_scene = scene.fluid.as_ref().map_or(1, |f| f.ranks);
    let ranks = flag.unwrap_or(from_scene);
    if let (Some(n), Some((problem, fix))) = (flag, fluid_ranks_problem(ranks)) {
        return Err(format!("--fluid-ranks {n}: {problem}. Fix: {fix}"));
    }
    let Some(slabs) = Slabs::of(scene) else {
        return Ok(ranks); // no water: no fluid node to start
    };
    let most = slabs.most_ranks();
    if ranks <= most {
        return Ok(ranks);
    }
    let problem = format!(
        "more ranks than the water can fill: the fluid node cuts the domain into slabs along {} ({:.3} m), each at least {MIN_SLAB_CELLS} grid cells of {:.3} m wide ({:.3} m), so at most {most} rank{}",
        slabs.axis_name(),
        slabs.length,
        slabs.cell,
        f64::from(MIN_SLAB_CELLS) * slabs.cell,
        if most == 1 { "" } else { "s" }
    );
    let finer = "or a finer fluid.dx (the cells shrink with it)";
    Err(match flag {
        Some(n) => {
            format!("--fluid-ranks {n}: {problem}. Fix: --fluid-ranks {most} or fewer, {finer}")
        }
        None => FieldError::new(
            &["fluid", "ranks"],
            ranks.to_string(),
            &problem,
            &format!("ranks = {most} or fewer, {finer}"),
        )
        .to_string(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The default scene's tank is 5.65 m along x; at dx = 0.04 m a cell is 2.6 × 1.1 × 0.04 =
    /// 0.1144 m, a slab at least 0.4576 m: 12 ranks fit.
    #[test]
    fn the_slabs_of_the_default_scene_hold_twelve_ranks() {
        let s = Scene::default_scene();
        let slabs = Slabs::of(&s).unwrap();
        assert_eq!(slabs.axis, 0);
        assert!((slabs.cell - 0.1144).abs() < 1e-9, "{slabs:?}");
        assert_eq!(slabs.most_ranks(), 12);
        assert_eq!(ranks(None, &s), Ok(1));
        assert_eq!(ranks(Some(12), &s), Ok(12));
        let msg = ranks(Some(13), &s).unwrap_err();
        for says in [
            "--fluid-ranks 13",
            "along x",
            "at most 12 ranks",
            "Fix: --fluid-ranks 12",
        ] {
            assert!(msg.contains(says), "{says}: {msg}");
        }
        let mut written = s.clone();
        written.fluid.as_mut().unwrap().ranks = 40;
        let msg = ranks(None, &written).unwrap_err();
        assert!(
            msg.starts_with("fluid.ranks = 40: more ranks than the water can fill")
                && msg.contains("fix: ranks = 12 or fewer"),
            "{msg}"
        );
        assert_eq!(
            ranks(Some(2), &written),
            Ok(2),
            "the flag overrides the scene"
        );
        let msg = ranks(Some(0), &s).unwrap_err();
        assert!(
            msg.contains("--fluid-ranks 0: must be at least 1") && msg.contains("Fix:"),
            "{msg}"
        );
        let msg = ranks(Some(5000), &s).unwrap_err();
        assert!(msg.contains("at most 4096"), "{msg}");
    }

    /// Three ranks each own a third of the water and a halo of 2 × 2.5 cells over a slab of a
    /// third of the tank; one rank has no halo.
    #[test]
    fn each_rank_holds_its_share_and_a_halo() {
        let s = Scene::default_scene();
        let whole = estimate(&s, None).unwrap();
        let one = PerRank::estimate(&s, 1).unwrap();
        assert_eq!((one.particles, one.halo), (whole.fluid_particles, 0.0));
        let three = PerRank::estimate(&s, 3).unwrap();
        assert!((three.particles - whole.fluid_particles / 3.0).abs() < 1e-6);
        let halo_share = 5.0 * 0.1144 / (5.65 / 3.0);
        assert!(
            (three.halo / three.particles - halo_share).abs() < 1e-9,
            "{three:?}"
        );
        assert!(three.memory < one.memory);
        assert!(three.lead_memory > three.memory);
        let line = three.describe();
        for says in [
            "on 3 fluid ranks",
            "along x",
            "halo (30 % more: 2 × 2.5 cells",
            "MB of memory",
            "1600 B per water and 90 B per boundary particle, measured), rank 0 about",
        ] {
            assert!(line.contains(says), "{says}: {line}");
        }
        assert!(PerRank::estimate(&s, 12).unwrap().halo <= whole.fluid_particles);
    }
}
