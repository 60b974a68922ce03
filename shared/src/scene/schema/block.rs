//! `[[block]]`: a convex polyhedron (its shape), its kind, and the motion or elasticity it may have.

use serde::{Deserialize, Serialize};

/// One `[[block]]`: a convex polyhedron with a kind.
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct BlockSpec {
    /// Unique name, used in outputs and messages.
    pub name: String,
    /// `fixed` (geometry only), `kinematic` (prescribed motion) or `free` (6-DOF rigid block).
    #[serde(default)]
    pub kind: BlockKind,
    pub shape: ShapeSpec,
    /// Rock density [kg/m³]; used by free blocks.
    #[serde(default = "default_rock_density")]
    pub density: f64,
    /// Initial velocity of the centroid [m/s].
    #[serde(default)]
    pub velocity: [f64; 3],
    /// Initial angular velocity [rad/s].
    #[serde(default)]
    pub angular_velocity: [f64; 3],
    /// Prescribed motion of a kinematic block.
    #[serde(default)]
    pub motion: Option<MotionSpec>,
    /// Joint friction angle for contacts of this block [deg]; a pair uses the smaller of the two.
    #[serde(default)]
    pub friction_angle: Option<f64>,
    /// Joint cohesion for contacts of this block [Pa]; a pair uses the smaller of the two.
    #[serde(default)]
    pub cohesion: Option<f64>,
    /// Makes a free block deformable: Shi's 12-DOF DDA block (6 rigid + 6 constant strains).
    /// Absent, the block is rigid (6 DOF): a rock's elastic strain (~10⁻⁶) changes no wave.
    #[serde(default)]
    pub elastic: Option<ElasticSpec>,
    /// Set on the blocks cut from a `[[slide]]` (never read from or written to a scene file).
    #[serde(skip)]
    pub slide: Option<SlideMember>,
}

impl BlockSpec {
    /// A block of `shape` and nothing else: at rest, no motion, the scene's contact
    /// properties, rigid, in no slide (a terrain's stand-in block, the solid's unit tests).
    pub fn plain(
        name: impl Into<String>,
        kind: BlockKind,
        shape: ShapeSpec,
        density: f64,
    ) -> BlockSpec {
        BlockSpec {
            name: name.into(),
            kind,
            shape,
            density,
            velocity: [0.0; 3],
            angular_velocity: [0.0; 3],
            motion: None,
            friction_angle: None,
            cohesion: None,
            elastic: None,
            slide: None,
        }
    }
}

/// `elastic = { young_modulus = ..., poisson_ratio = ... }` of a deformable block: linear
/// isotropic elasticity of its constant strain (Shi 1993, the 3D-DDA stiffness sub-matrix).
#[derive(Debug, Clone, Copy, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct ElasticSpec {
    /// Young's modulus E [Pa].
    pub young_modulus: f64,
    /// Poisson's ratio ν, in [0, 0.5).
    #[serde(default = "default_poisson_ratio")]
    pub poisson_ratio: f64,
}

fn default_poisson_ratio() -> f64 {
    0.25
}

fn default_rock_density() -> f64 {
    2500.0
}

/// Block kinds. Fixed blocks carry no unknowns and are never checked against each other.
#[derive(Debug, Clone, Copy, Default, Serialize, Deserialize, PartialEq, Eq, Hash)]
#[serde(rename_all = "lowercase")]
pub enum BlockKind {
    Fixed,
    Kinematic,
    #[default]
    Free,
}

/// A convex shape.
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
#[serde(tag = "type", rename_all = "lowercase", deny_unknown_fields)]
pub enum ShapeSpec {
    /// Axis-aligned box.
    Box { min: [f64; 3], max: [f64; 3] },
    /// A convex polygon `profile` in the plane normal to `axis`, extruded over `extent` along it.
    /// For axis `y` the profile points are (x, z); for `x` they are (y, z); for `z`, (x, y).
    /// A wedge is a prism with a triangular profile.
    Prism {
        axis: Axis,
        profile: Vec<[f64; 2]>,
        extent: [f64; 2],
    },
    /// The convex hull of `vertices`; every vertex must be a corner of the hull.
    Convex { vertices: Vec<[f64; 3]> },
}

/// A coordinate axis.
#[derive(Debug, Clone, Copy, Serialize, Deserialize, PartialEq, Eq)]
#[serde(rename_all = "lowercase")]
pub enum Axis {
    X,
    Y,
    Z,
}

/// Prescribed motion of a kinematic block.
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
#[serde(tag = "type", rename_all = "lowercase", deny_unknown_fields)]
pub enum MotionSpec {
    /// Translation d(t) = A·(sin(2πt/T + φ) − sin φ), ramped in smoothly over `ramp` seconds.
    Sine {
        amplitude: [f64; 3],
        period: f64,
        #[serde(default)]
        phase: f64,
        #[serde(default)]
        ramp: f64,
    },
    /// Constant velocity [m/s].
    Linear { velocity: [f64; 3] },
}

/// Marks a block cut from a slide: which `[[slide]]` (index) it came from. Never written: the
/// scene text keeps the slide, not its blocks.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct SlideMember {
    pub slide: usize,
}
