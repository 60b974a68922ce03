//! The scene file, field by field. Units are SI throughout (m, s, kg, Pa, N); angles in degrees.
//!
//! A scene is a TOML document. Every table rejects unknown keys, so a misspelt field is an error
//! that names the field rather than a silently ignored line. `[fluid]` and `[solid]` keep the
//! tables that are not their fields as solver parameter tables, which the solver registries
//! check (`shared::registry`).
//!
//! This file holds the scene and its settings tables; the bodies have files of their own:
//! `block.rs` (`[[block]]`, its shape and motion), `slide.rs` (`[[slide]]`, a rock mass and its
//! joint sets) and `terrain.rs` (`[[terrain]]`, ground read from a file).

mod block;
mod slide;
mod terrain;

pub use block::*;
pub use slide::*;
pub use terrain::*;

use serde::{Deserialize, Serialize};

/// A whole scene: what is simulated, for how long, and what is recorded.
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct Scene {
    /// Short name, used for the run directory and in messages.
    pub name: String,
    /// Free text: where the dimensions come from, what the scene reproduces.
    #[serde(default)]
    pub description: String,
    /// Gravity vector [m/s²]; z is up.
    #[serde(default = "default_gravity")]
    pub gravity: [f64; 3],
    /// Simulated time span and step limits.
    pub time: TimeSpec,
    /// The box everything must stay in. A particle or free block leaving it is an instability.
    pub domain: DomainSpec,
    /// Water. A scene without a `[fluid]` table runs no fluid node.
    #[serde(default)]
    pub fluid: Option<FluidSpec>,
    /// Rock-block solver settings. Used only when the scene has kinematic or free blocks.
    #[serde(default)]
    pub solid: SolidSpec,
    /// How the two solvers exchange forces (paper Eq. 22).
    #[serde(default)]
    pub coupling: CouplingSpec,
    /// What is written to the run directory.
    #[serde(default)]
    pub output: OutputSpec,
    /// `[[block]]` entries: walls, slopes, pistons and rock blocks, all convex polyhedra.
    /// After reading, also the blocks cut from `[[slide]]`s (after the written ones, marked
    /// [`BlockSpec::slide`]); only the written ones are serialised.
    #[serde(
        default,
        rename = "block",
        serialize_with = "slide::serialize_written_blocks"
    )]
    pub blocks: Vec<BlockSpec>,
    /// `[[terrain]]` entries: fixed ground read from mesh or elevation-model files.
    #[serde(default, rename = "terrain", skip_serializing_if = "Vec::is_empty")]
    pub terrain: Vec<TerrainSpec>,
    /// `[[slide]]` entries: rock masses cut into free blocks by their joint sets
    /// ([`crate::scene::slide`]).
    #[serde(default, rename = "slide", skip_serializing_if = "Vec::is_empty")]
    pub slides: Vec<SlideSpec>,
    /// What cutting each slide gave (filled when the scene is read; never written).
    #[serde(skip)]
    pub slide_cuts: Vec<SlideCut>,
    /// `[[gauge]]` entries: free-surface elevation recorded at (x, y).
    #[serde(default, rename = "gauge")]
    pub gauges: Vec<GaugeSpec>,
    /// `[[probe]]` entries: pressure recorded at a point.
    #[serde(default, rename = "probe")]
    pub probes: Vec<ProbeSpec>,
    /// `[[runup]]` entries: shores (plan-view boxes) whose highest water is reported.
    #[serde(default, rename = "runup", skip_serializing_if = "Vec::is_empty")]
    pub runups: Vec<RunupSpec>,
}

fn default_gravity() -> [f64; 3] {
    [0.0, 0.0, -crate::math::STANDARD_GRAVITY]
}

/// `[time]`: how long to simulate and how the shared step is bounded.
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct TimeSpec {
    /// Simulated end time [s].
    pub end: f64,
    /// Largest step the coupler will ever grant [s], whatever the nodes propose.
    #[serde(default = "default_dt_max")]
    pub dt_max: f64,
    /// A proposal below this [s] means a solver has collapsed: the run stops and names it.
    #[serde(default = "default_dt_min")]
    pub dt_min: f64,
}

fn default_dt_max() -> f64 {
    1e-3
}
fn default_dt_min() -> f64 {
    1e-9
}

/// `[domain]`: an axis-aligned box [m].
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct DomainSpec {
    pub min: [f64; 3],
    pub max: [f64; 3],
    /// Whether the top face is open air: water thrown above `max[2]` (a splash's spray) flies
    /// on as SPH water and falls back, instead of stopping the run as a particle leaving the
    /// domain. Up there the spray meets only itself: the walls' boundary particles end at the
    /// top, and a fixed block or terrain reaching above it is refused (the spray would pass
    /// through it). The sides and the floor stay closed. The step that first lifts water above
    /// the top, after none was, carries a warning with the count. Off by default: a particle
    /// above a closed top is an instability, named.
    #[serde(default)]
    pub open_top: bool,
}

/// `[fluid]`: the water and the SPH solver settings.
///
/// Not `deny_unknown_fields`: every key that is not a field here is kept in [`FluidSpec::solvers`]
/// as a solver's own parameter table (`[fluid.wcsph]`, `[fluid.muller]`, …), read by that solver
/// (`shared::registry::params`). Validation refuses a stray value that is not a table, and the
/// fluid registry refuses a table that names no solver.
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
pub struct FluidSpec {
    /// Solver used when the command line names none (the fluid registry lists them).
    #[serde(default = "default_fluid_solver")]
    pub solver: String,
    /// Rest density ρ0 [kg/m³].
    #[serde(default = "default_water_density")]
    pub density: f64,
    /// Particle spacing [m]; particle mass is ρ0·dx³. `--dx` overrides it.
    pub dx: f64,
    /// Kinematic viscosity ν [m²/s] (water: 1e-6).
    #[serde(default = "default_kinematic_viscosity")]
    pub kinematic_viscosity: f64,
    /// Density ratio ρ/ρ0 outside [1/bound, bound] is an instability.
    #[serde(default = "default_density_ratio_bound")]
    pub density_ratio_bound: f64,
    /// `[[fluid.water]]`: volumes filled with particles on a lattice of spacing dx (minus blocks).
    #[serde(default)]
    pub water: Vec<WaterSpec>,
    /// How every block, fixed or moving, holds the water.
    #[serde(default)]
    pub walls: Walls,
    /// MPI ranks the fluid node runs as (`coupler run --fluid-ranks` overrides it): 1 is one
    /// process; N > 1 makes `coupler run` start the fluid node through an MPI launcher
    /// (`mpirun -n N`, or `--mpirun`), each rank holding a slab of the water. At most
    /// [`MAX_FLUID_RANKS`]. Not written when 1, so a scene without it reads back as written.
    #[serde(default = "one_rank", skip_serializing_if = "is_one_rank")]
    pub ranks: u32,
    /// The fill's rows along one axis, each moved along it by a different fraction of dx up to
    /// this one (`row_shift = [0.25, 0.0, 0.0]`: the rows along x by up to ±dx/4; the
    /// fraction of a row is a low-discrepancy sequence of its other two lattice indices, so
    /// the start is the same on every run). A lattice's rows reach a wall in step, every
    /// column of the wall struck by its particle at once, and the wall's load rings at the
    /// rows' pace (docs/VALIDATION.md, "The wall's load along the width"); shifted rows arrive
    /// one by one. Absent, the lattice.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub row_shift: Option<[f64; 3]>,
    /// Which draw of the shifted rows (`row_shift`): each draw orders the rows' shifts anew
    /// (another pair of multipliers in the sequence), so it is another start with the same
    /// spread of shifts, and the same start on every run. An ensemble of draws is how a run-to-run
    /// spread is measured against an experiment's repeated runs (docs/VALIDATION.md, "The
    /// wall's load along the width"). 0, the default, is not written; at most
    /// [`MAX_ROW_DRAW`].
    #[serde(default, skip_serializing_if = "is_zero_draw")]
    pub row_draw: u32,
    /// `[fluid.<solver>]`: each solver's own parameter table, as written.
    #[serde(flatten)]
    pub solvers: SolverTables,
}

/// Solver parameter tables by solver name, kept as TOML until the solver reads its own.
pub type SolverTables = std::collections::BTreeMap<String, toml::Value>;

/// `[fluid] walls`: the wall treatment of every block.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Walls {
    /// Boundary particles in the blocks with pressure extrapolated from the fluid (Adami, Hu &
    /// Adams 2012), moved with the moving blocks and their reaction summed into the block loads,
    /// plus the paper's Eq. 22 as a backstop.
    #[default]
    Particles,
    /// The paper's Eq. 22 repulsion only.
    Penalty,
}

impl Walls {
    /// As written in a scene.
    pub fn as_str(self) -> &'static str {
        match self {
            Walls::Particles => "particles",
            Walls::Penalty => "penalty",
        }
    }
}

impl std::fmt::Display for Walls {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.as_str())
    }
}

/// The fluid registry's first entry (`fluid_node::REGISTRY.first()`, the default solver),
/// named here because this crate sits below the registries.
fn default_fluid_solver() -> String {
    "wcsph".into()
}
fn default_water_density() -> f64 {
    1000.0
}
fn default_kinematic_viscosity() -> f64 {
    1e-6
}
fn default_density_ratio_bound() -> f64 {
    1.3
}
/// The largest `[fluid] row_draw`: draw d's multipliers are about 3 d, and a row's fraction
/// is its index times them in f64; at a million draws and 10⁴ rows along an axis the product
/// is 3·10¹⁰, whose fraction is still exact to 4·10⁻⁶ (at 4·10⁹ draws, to 0.016).
pub const MAX_ROW_DRAW: u32 = 1_000_000;

fn is_zero_draw(draw: &u32) -> bool {
    *draw == 0
}

fn one_rank() -> u32 {
    1
}
fn is_one_rank(ranks: &u32) -> bool {
    *ranks == 1
}

/// Most MPI ranks `[fluid] ranks` and `--fluid-ranks` accept: a guard against a typo (an extra
/// digit), not a limit of the decomposition. The slabs are cut along one axis, so past a few
/// thousand ranks each slab is thinner than the halos it trades at any resolution a cluster
/// node's memory holds (`coupler check` names the finer limit of each scene), and
/// docs/PERFORMANCE.md models scaling to 1 000 ranks.
pub const MAX_FLUID_RANKS: u32 = 4096;

/// One water volume.
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct WaterSpec {
    pub shape: ShapeSpec,
    /// Start from hydrostatic pressure (density from the Tait/linear EOS) instead of ρ0 everywhere.
    #[serde(default = "yes")]
    pub hydrostatic: bool,
}

fn yes() -> bool {
    true
}

/// `[solid]`: the rock-block solver.
///
/// Not `deny_unknown_fields`: every key that is not a field here is kept in [`SolidSpec::solvers`]
/// as a solver's own parameter table (`[solid.explicit]`: `safety_factor`; `[solid.implicit]`:
/// `displacement_limit`, `max_open_close`), read by that solver (`shared::registry::params`).
/// Validation refuses a stray value that is not a table, and the solid registry refuses a table
/// that names no solver. `[solid.contact]` is the blocks' physics, shared by every solver.
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
pub struct SolidSpec {
    /// Solver used when the command line names none (the solid registry lists them):
    /// `explicit` (the paper's) or `implicit` (Shi's).
    #[serde(default = "default_solid_solver")]
    pub solver: String,
    /// Contact springs and joint strength between blocks.
    #[serde(default)]
    pub contact: ContactSpec,
    /// `[solid.<solver>]`: each solver's own parameter table, as written.
    #[serde(flatten)]
    pub solvers: SolverTables,
}

impl Default for SolidSpec {
    fn default() -> Self {
        Self {
            solver: default_solid_solver(),
            contact: ContactSpec::default(),
            solvers: SolverTables::new(),
        }
    }
}

/// The solid registry's first entry (`solid_node::REGISTRY.first()`, the default solver),
/// named here because this crate sits below the registries.
fn default_solid_solver() -> String {
    "explicit".into()
}

/// `[solid.contact]`: block–block contact (penalty springs, Mohr–Coulomb).
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct ContactSpec {
    /// Normal penalty spring [N/m]; default derived from the lightest free block (ω·dt target).
    pub normal_stiffness: Option<f64>,
    /// Shear spring over normal spring; default 0.4.
    #[serde(default = "default_shear_ratio")]
    pub shear_ratio: f64,
    /// Joint friction angle φ [deg].
    #[serde(default = "default_friction")]
    pub friction_angle: f64,
    /// Joint cohesion c [Pa] over the contact area.
    #[serde(default)]
    pub cohesion: f64,
    /// Viscous contact damping as a fraction of critical; 0 keeps bounces elastic.
    #[serde(default)]
    pub damping_ratio: f64,
    /// When `normal_stiffness` is unset it is derived so that the lightest free block, resting
    /// on one contact, sinks this fraction of its own size under its weight (k_n = m g / (ε L)).
    /// Smaller is stiffer and needs a smaller explicit step (2/ω_max ∝ sqrt(ε)).
    #[serde(default = "default_allowed_penetration")]
    pub allowed_penetration: f64,
}

impl Default for ContactSpec {
    fn default() -> Self {
        Self {
            normal_stiffness: None,
            shear_ratio: default_shear_ratio(),
            friction_angle: default_friction(),
            cohesion: 0.0,
            damping_ratio: 0.0,
            allowed_penetration: default_allowed_penetration(),
        }
    }
}

fn default_allowed_penetration() -> f64 {
    1e-4
}
fn default_shear_ratio() -> f64 {
    0.4
}
fn default_friction() -> f64 {
    30.0
}

/// `[coupling]`: the exchange between fluid and solid.
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct CouplingSpec {
    /// `parallel` (the paper's: both sides use data from t_n) or `serial` (solid first).
    #[serde(default)]
    pub scheme: CouplingScheme,
    /// K_S of paper Eq. 22 [N/m] per particle; default derived from particle mass and dt.
    pub penalty_stiffness: Option<f64>,
    /// K_D of paper Eq. 22 [N·s/m] per particle; default critical damping of the K_S spring.
    pub penalty_damping: Option<f64>,
    /// Distance from a block face [m] within which Eq. 22 acts; default dx/2.
    pub margin: Option<f64>,
    /// Multi-rate coupling: the solid node takes up to this many steps of its own per
    /// coupling step, with the water's loads held, so its stability limit does not bind the
    /// shared step (default 1: one solid step per exchange). `--solid-substeps` overrides it.
    #[serde(default = "one")]
    pub solid_substeps: u32,
    /// Added-mass stabilisation: the water's loads on each block are under-relaxed as if the
    /// block carried an artificial added mass of this many times ρ_water × its volume
    /// (`shared::coupling::load_relaxation`); 0 (the default) hands the loads over as they are.
    /// `--added-mass` overrides it.
    #[serde(default)]
    pub added_mass: f64,
}

fn one() -> u32 {
    1
}

impl Default for CouplingSpec {
    fn default() -> Self {
        Self {
            scheme: CouplingScheme::default(),
            penalty_stiffness: None,
            penalty_damping: None,
            margin: None,
            solid_substeps: one(),
            added_mass: 0.0,
        }
    }
}

/// Coupling scheme.
#[derive(Debug, Clone, Copy, Default, Serialize, Deserialize, PartialEq, Eq)]
#[serde(rename_all = "lowercase")]
pub enum CouplingScheme {
    /// Both solvers advance from data at t_n (the paper's scheme).
    #[default]
    Parallel,
    /// Gauss–Seidel: the solid advances first, the fluid sees its new geometry.
    Serial,
}

impl std::str::FromStr for CouplingScheme {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        match s {
            "parallel" => Ok(CouplingScheme::Parallel),
            "serial" => Ok(CouplingScheme::Serial),
            other => Err(format!(
                "unknown coupling scheme '{other}': use parallel or serial"
            )),
        }
    }
}

impl std::fmt::Display for CouplingScheme {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            CouplingScheme::Parallel => "parallel",
            CouplingScheme::Serial => "serial",
        })
    }
}

/// `[output]`: what the run directory receives.
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct OutputSpec {
    /// Simulated time between frames [s]; the coupler lands a step exactly on each.
    #[serde(default = "default_output_interval")]
    pub interval: f64,
    /// Write VTK frames (particles and blocks) with a .pvd series for ParaView.
    #[serde(default = "yes")]
    pub vtk: bool,
    /// Also write POV-Ray scene files per frame (the paper rendered with POV-Ray).
    #[serde(default)]
    pub povray: bool,
    /// Encoding of the VTK frames: `"binary"` (default: raw little-endian bytes appended to the
    /// XML, exact and fast to write) or `"ascii"` (human-readable numbers).
    #[serde(default)]
    pub vtk_format: VtkFormat,
    /// Checkpoint every this many simulated seconds (`coupler run --checkpoint-interval`);
    /// none by default. A checkpoint never changes the steps taken.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub checkpoint_interval: Option<f64>,
    /// Checkpoint every this many wall-clock minutes (`--checkpoint-wall-minutes`); none by
    /// default, 10 with `--retries`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub checkpoint_wall_minutes: Option<f64>,
    /// Most frames the run may ask for (time.end / interval); 10 000 when unset. Each frame is a
    /// step landed exactly and a VTK file per node: raise it only when you mean it.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub max_frames: Option<f64>,
}

/// `output.vtk_format`: how the .vtp frames store their numbers.
#[derive(Debug, Clone, Copy, Default, Serialize, Deserialize, PartialEq, Eq)]
#[serde(rename_all = "lowercase")]
pub enum VtkFormat {
    /// `format="appended"` with `encoding="raw"`: the values' little-endian bytes after the XML.
    #[default]
    Binary,
    /// `format="ascii"`: every value as shortest round-trip decimal text.
    Ascii,
}

impl Default for OutputSpec {
    fn default() -> Self {
        Self {
            interval: default_output_interval(),
            vtk: true,
            povray: false,
            vtk_format: VtkFormat::Binary,
            checkpoint_interval: None,
            checkpoint_wall_minutes: None,
            max_frames: None,
        }
    }
}

fn default_output_interval() -> f64 {
    0.05
}

/// One `[[gauge]]`: a wave gauge recording the free-surface elevation at (x, y).
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct GaugeSpec {
    pub name: String,
    pub x: f64,
    pub y: f64,
}

/// One `[[runup]]`: a stretch of shore, as a box in plan (x, y), over which the highest water
/// above the still-water level is reported in `summary.json` (`runup.<name>`), as
/// `max_runup` is for every shore of the scene. A far shore gets its own figure this way,
/// instead of the splash on the slide's own flank that usually sets the global maximum.
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct RunupSpec {
    pub name: String,
    /// Corners of the box in plan [m]: [x, y].
    pub min: [f64; 2],
    pub max: [f64; 2],
}

/// One `[[probe]]`: a pressure probe at a point.
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct ProbeSpec {
    pub name: String,
    pub position: [f64; 3],
    /// Averaging window [s]: when given, each row of `probes.csv` holds the time-weighted box
    /// average of the reading taken after every step over the last `window` seconds (a sensor
    /// and its data acquisition's sampling, docs/VALIDATION.md "Pressure probes"); absent, the
    /// row holds the reading at the row's time (the instantaneous value).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub window: Option<f64>,
    /// The sensor's sensing face: when given, the reading is the mean over this disk, centred
    /// on `position`, of the pressure at its points (a transducer integrates the pressure over
    /// its diaphragm); absent, the reading at the point.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub face: Option<ProbeFace>,
}

/// A pressure sensor's circular sensing face (`face = { diameter = 0.0042, normal = [-1, 0, 0] }`).
#[derive(Debug, Clone, Copy, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct ProbeFace {
    /// The face's diameter [m].
    pub diameter: f64,
    /// The face's normal (any length; the disk lies in the plane through `position` normal to it).
    pub normal: [f64; 3],
    /// What the face reads: the water's pressure at its points ([`FaceReading::Fluid`], the
    /// default) or the wall's load behind it ([`FaceReading::Wall`]).
    #[serde(default, skip_serializing_if = "FaceReading::is_fluid")]
    pub reading: FaceReading,
    /// A line in the face's plane, centred on `position`, along which the disk is swept: the
    /// reading is the mean of the disk's reading over the line (a strip of sensors across a
    /// flow that is the same along it, such as a dam break across its tank). Absent, the disk.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub span: Option<[f64; 3]>,
}

/// What a probe's face reads (`face = { …, reading = "wall" }`).
#[derive(Debug, Clone, Copy, Default, Serialize, Deserialize, PartialEq, Eq)]
#[serde(rename_all = "lowercase")]
pub enum FaceReading {
    /// The mean over the disk of the water's pressure, interpolated at seven points (SPH's
    /// Shepard interpolation of the particles' pressures).
    #[default]
    Fluid,
    /// The mean over the disk of the normal load the water puts on the wall behind it: the
    /// force of the fluid on the wall's boundary particles, per unit area of the wall (a
    /// transducer's diaphragm is pushed by that force). Needs boundary particles on a fixed
    /// block whose face the disk lies on, with a normal along x, y or z.
    Wall,
}

impl FaceReading {
    pub fn is_fluid(&self) -> bool {
        *self == Self::Fluid
    }
}

/// The longest `span` a probe face may have, in diameters: the line is read as two disks per
/// diameter, and the wall reading's setup grows with their square.
pub const MAX_SPAN_DIAMETERS: f64 = 1e4;

impl ProbeFace {
    /// The centres of the disks the face's reading is the mean of: `position` alone, or with a
    /// [`Self::span`] the midpoints of equal pieces of the line, at most half a diameter long
    /// (the line's mean to well within a particle spacing's resolution). Total on any input,
    /// since the scene's check reads faces before it refuses their spans: a span that is not
    /// finite gives the position alone, and the pieces are at most 2 × [`MAX_SPAN_DIAMETERS`]
    /// (a longer span is refused).
    pub fn centres(&self, position: [f64; 3]) -> Vec<[f64; 3]> {
        let Some(s) = self.span else {
            return vec![position];
        };
        let length = (s[0] * s[0] + s[1] * s[1] + s[2] * s[2]).sqrt();
        if !length.is_finite() {
            return vec![position];
        }
        let pieces = (length / (0.5 * self.diameter)).ceil();
        let n = if pieces.is_finite() {
            (pieces.min(2.0 * MAX_SPAN_DIAMETERS) as usize).max(1)
        } else {
            1
        };
        (0..n)
            .map(|k| {
                let t = (k as f64 + 0.5) / n as f64 - 0.5;
                std::array::from_fn(|q| position[q] + t * s[q])
            })
            .collect()
    }

    /// The points and weights of the face's mean: [`Self::points`] at each of
    /// [`Self::centres`], the weights shared among the disks.
    pub fn rule(&self, position: [f64; 3]) -> Vec<([f64; 3], f64)> {
        let centres = self.centres(position);
        let share = 1.0 / centres.len() as f64;
        centres
            .iter()
            .flat_map(|&c| self.points(c).map(|(x, w)| (x, w * share)))
            .collect()
    }

    /// The points and weights of Stroud's (1971) seven-point rule for a disk (exact for
    /// polynomials up to degree 5): the centre with weight 1/4 and six points at radius
    /// sqrt(2/3)·R, 60° apart, with weight 1/8 each. `centre` is the probe's position.
    pub fn points(&self, centre: [f64; 3]) -> [([f64; 3], f64); 7] {
        let n = self.normal;
        let len = (n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt();
        let n = [n[0] / len, n[1] / len, n[2] / len];
        // Two unit vectors spanning the face: the axis least aligned with n, made normal to n.
        let k = (0..3)
            .min_by(|&a, &b| n[a].abs().total_cmp(&n[b].abs()))
            .unwrap_or(0);
        let mut e = [0.0; 3];
        e[k] = 1.0;
        let d = e[0] * n[0] + e[1] * n[1] + e[2] * n[2];
        let u = [e[0] - d * n[0], e[1] - d * n[1], e[2] - d * n[2]];
        let ul = (u[0] * u[0] + u[1] * u[1] + u[2] * u[2]).sqrt();
        let u = [u[0] / ul, u[1] / ul, u[2] / ul];
        let v = [
            n[1] * u[2] - n[2] * u[1],
            n[2] * u[0] - n[0] * u[2],
            n[0] * u[1] - n[1] * u[0],
        ];
        let r = 0.5 * self.diameter * (2.0f64 / 3.0).sqrt();
        let mut out = [(centre, 0.25); 7];
        for (j, o) in out.iter_mut().skip(1).enumerate() {
            let a = std::f64::consts::FRAC_PI_3 * j as f64;
            let (s, c) = a.sin_cos();
            o.0 = std::array::from_fn(|q| centre[q] + r * (c * u[q] + s * v[q]));
            o.1 = 0.125;
        }
        out
    }
}
