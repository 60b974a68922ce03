//! `[[slide]]`: a rock mass given as a convex region and its joint sets, as written; the cutting
//! into blocks is [`crate::scene::slide`].

use super::{BlockSpec, ShapeSpec};
use crate::geometry::cutting::PlaneFamily;
use crate::math::Vector;
use serde::{Deserialize, Serialize};

/// Default most blocks one slide may be cut into.
pub const DEFAULT_MAX_BLOCKS: usize = 10_000;
/// Most blocks `max_blocks` may allow. Every process that reads the scene (the coupler, both
/// nodes) cuts the slide and checks its blocks: 8 000 blocks take 0.66 s and 59 MB in
/// `coupler check`, 64 000 took 14 s and 1.1 GB (docs/PERFORMANCE.md, "Slide cutting"); and
/// each block is a 6-DOF body of the solid node (3.5 µs per block-step, explicit).
pub const MAX_BLOCKS_LIMIT: usize = 20_000;

/// One `[[slide]]`: a rock mass cut into free blocks by its joint sets.
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct SlideSpec {
    /// Short name; the blocks are named `<name>/0`, `<name>/1`, …
    pub name: String,
    /// The rock mass before cutting: a convex shape (`box`, `prism` or `convex`).
    pub region: ShapeSpec,
    /// Rock density [kg/m³].
    #[serde(default = "default_rock_density")]
    pub density: f64,
    /// Pieces smaller than this [m³] are dropped (slivers at the region's edges); default
    /// 1e-6 of the region's volume. The count and volume dropped are reported by `coupler check`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub min_block_volume: Option<f64>,
    /// Most blocks the cutting may make; more is refused before they are built (default 10 000).
    #[serde(default = "default_max_blocks")]
    pub max_blocks: usize,
    /// Friction angle [deg] of the slide's blocks against other blocks (terrain, walls); the
    /// joints between its own blocks use their set's. Default: `[solid.contact]`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub friction_angle: Option<f64>,
    /// Cohesion [Pa] of the slide's blocks against other blocks; default `[solid.contact]`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub cohesion: Option<f64>,
    /// `[[slide.joint_set]]`: the families of parallel joints that cut the region.
    #[serde(default, rename = "joint_set")]
    pub joint_sets: Vec<JointSetSpec>,
}

fn default_rock_density() -> f64 {
    2500.0
}
fn default_max_blocks() -> usize {
    DEFAULT_MAX_BLOCKS
}

/// One `[[slide.joint_set]]`: parallel joint planes and their strength.
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct JointSetSpec {
    /// Dip [deg] in [0, 90]: the planes' angle below horizontal.
    pub dip: f64,
    /// Dip direction [deg] in [0, 360): azimuth of the steepest descent, clockwise from north
    /// (+y) — east (+x) is 90°.
    pub dip_direction: f64,
    /// Distance between neighbouring planes [m], along their normal.
    pub spacing: f64,
    /// A point one plane of the set passes through [m]; default the origin.
    #[serde(default)]
    pub offset: [f64; 3],
    /// Friction angle φ of the joints [deg]; also the residual friction once a joint breaks.
    #[serde(default = "default_joint_friction")]
    pub friction_angle: f64,
    /// Cohesion c [Pa] of the intact joint.
    #[serde(default)]
    pub cohesion: f64,
    /// Tensile strength T [Pa] of the intact joint.
    #[serde(default)]
    pub tensile_strength: f64,
}

fn default_joint_friction() -> f64 {
    30.0
}

impl JointSetSpec {
    /// Upward unit normal of the set's planes: (sin δ sin α, sin δ cos α, cos δ) for dip δ and
    /// dip direction α (x east, y north, z up).
    pub fn normal(&self) -> Vector {
        let (d, a) = (self.dip.to_radians(), self.dip_direction.to_radians());
        Vector::new(d.sin() * a.sin(), d.sin() * a.cos(), d.cos())
    }

    /// The family of planes n·x = n·offset + k·spacing.
    pub fn family(&self) -> PlaneFamily {
        let n = self.normal();
        PlaneFamily {
            normal: n,
            base: n.dot(&Vector::from(self.offset)),
            spacing: self.spacing,
        }
    }
}

/// What cutting one slide gave, for `coupler check` and the logs.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct SlideCut {
    /// Index of the first block in [`crate::scene::Scene::blocks`]; the slide's blocks are
    /// contiguous.
    pub first_block: usize,
    pub blocks: usize,
    pub region_volume: f64,
    /// Volume of the kept blocks [m³].
    pub kept_volume: f64,
    pub min_volume: f64,
    pub max_volume: f64,
    /// Pieces dropped as slivers (below `min_block_volume`, or too flat to be a block).
    pub slivers: usize,
    pub sliver_volume: f64,
    /// The volume limit used [m³].
    pub min_block_volume: f64,
    /// Per joint set, how many of its planes cut the region.
    pub planes_used: Vec<usize>,
}

impl SlideCut {
    pub fn mean_volume(&self) -> f64 {
        if self.blocks == 0 {
            0.0
        } else {
            self.kept_volume / self.blocks as f64
        }
    }
}

impl std::fmt::Display for SlideCut {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "{} blocks, volume min {:.4e} / mean {:.4e} / max {:.4e} m³, total {:.6e} of the region's {:.6e} m³; \
             {} sliver(s) below {:.3e} m³ dropped ({:.4e} m³ lost); planes per joint set {:?}",
            self.blocks,
            self.min_volume,
            self.mean_volume(),
            self.max_volume,
            self.kept_volume,
            self.region_volume,
            self.slivers,
            self.min_block_volume,
            self.sliver_volume,
            self.planes_used
        )
    }
}

/// Serialises only the blocks written in the scene (not the ones cut from slides).
pub fn serialize_written_blocks<S: serde::Serializer>(
    blocks: &[BlockSpec],
    s: S,
) -> Result<S::Ok, S::Error> {
    use serde::ser::SerializeSeq;
    let written: Vec<&BlockSpec> = blocks.iter().filter(|b| b.slide.is_none()).collect();
    let mut seq = s.serialize_seq(Some(written.len()))?;
    for b in written {
        seq.serialize_element(b)?;
    }
    seq.end()
}
