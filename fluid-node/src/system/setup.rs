//! What the system is built from: the scene's water filled ([`Initial`]), what the method asks
//! of the system ([`Layout`]), and the system's parts built from them along their seams: the
//! Eq. 22 constants and obstacles, the blocks' and the terrain's boundary particles, the
//! instruments.

use crate::boundary::bodies::BodyParticles;
use crate::boundary::penalty::{Obstacle, Penalty, resting_state};
use crate::boundary::terrain::TerrainPenalty;
use crate::boundary::walls::WallParticles;
use crate::core::fill::{Fill, fill_water_with, lattice_key};
use crate::core::grid::CellGrid;
use crate::core::particles::Carried;
use crate::instruments::gauges::Recorder;
use crate::instruments::wall_load::{self, WallLoads};
use shared::geometry::Polyhedron;
use shared::math::{Real, Vector};
use shared::protocol::BlockState;
use shared::scene::{BlockKind, FluidSpec, Scene, Walls};
use shared::solver::{SetupContext, SolverError};
use shared::terrain::Terrain;
use std::sync::Arc;

/// The scene's water, filled, and its blocks as polyhedra.
pub struct Initial {
    pub fluid: FluidSpec,
    pub fill: Fill,
    /// Every block in scene order.
    pub blocks: Vec<Polyhedron>,
    /// Depth H of the deepest water [m]: the scale of the default sound speed c = 10·sqrt(2 g H).
    pub depth: Real,
    pub gravity: Vector,
    /// The scene's `[[terrain]]`, read from its files (fixed: rebuilt from the scene on a
    /// resume, the same to the bit).
    pub terrain: Arc<[Terrain]>,
}

/// How the system is built for a scheme.
pub struct Layout {
    /// Initial density of each filled particle, in fill order (e.g. hydrostatic).
    pub density: Vec<Real>,
    /// Kernel support: the neighbour radius and grid cell [m].
    pub support: Real,
    /// Speed of sound [m/s]: sets the default Eq. 22 stiffness K_S = ½ρ0c²·dx.
    pub sound_speed: Real,
    /// Verlet skin of the neighbour lists over the support (0: rebuilt every step). Worth it
    /// for a scheme whose particles move a small part of the support per step (WCSPH, Müller:
    /// the speed of sound bounds their step); a scheme stepping on the flow's CFL moves too far
    /// per step to keep lists.
    pub skin_ratio: Real,
    /// The lists also sum poly6's (h² − r²)³ per particle at each build, h the support
    /// (`NeighborLists::sum_poly6`; Müller's Eq. 12 density without a pass of its own). Only
    /// with lists rebuilt every step (`skin_ratio` 0), so the sums are at the step's positions.
    pub poly6_sums: bool,
    /// The particle arrays the scheme reads across a sort ([`Carried`]).
    pub carried: Carried,
}

impl Initial {
    pub fn from_scene(scene: &Scene) -> Result<Self, SolverError> {
        let fluid = scene
            .fluid
            .clone()
            .ok_or_else(|| SolverError::Failed("the scene has no [fluid] table".into()))?;
        let blocks = scene
            .blocks
            .iter()
            .map(|b| {
                Polyhedron::from_shape(&b.shape)
                    .map_err(|e| SolverError::Failed(format!("block '{}': {e}", b.name)))
            })
            .collect::<Result<Vec<_>, _>>()?;
        let terrain: Arc<[Terrain]> = Terrain::load_all(scene)
            .map_err(SolverError::Failed)?
            .into();
        // Lattice points the terrain's boundary particles take (signed distance < 0,
        // `terrain::sample`) stay dry, so water and terrain make one lattice along a curved bed,
        // as along a block's face (fill.rs); with Eq. 22 alone also those within dx/2 above it.
        let clearance = crate::core::fill::dry_clearance(fluid.walls, fluid.dx);
        let dry = |p: &Vector| crate::boundary::terrain::near_or_inside(&terrain, p, clearance);
        let fill = fill_water_with(&fluid, &blocks, &dry).map_err(SolverError::Failed)?;
        if fill.positions.is_empty() {
            return Err(SolverError::Failed(format!(
                "the water volumes hold no particle at dx = {} m (all inside blocks or thinner than dx)",
                fluid.dx
            )));
        }
        let depth = fill.max_depth(fluid.dx);
        Ok(Self {
            fluid,
            fill,
            blocks,
            depth,
            gravity: Vector::from(scene.gravity),
            terrain,
        })
    }

    /// The default numerical speed of sound, 10·sqrt(2 g H): ten times the largest free-fall
    /// speed of the water, so density varies by ~1 % (Monaghan 1994).
    pub fn default_sound_speed(&self) -> Real {
        10.0 * (2.0 * self.gravity.norm() * self.depth).sqrt().max(1e-6)
    }
}

/// Paper Eq. 22's constants: the spring K_S, the damper K_D, and how far from a surface the
/// force reaches for each kind of obstacle.
pub(super) struct Eq22 {
    pub ks: Real,
    pub kd: Real,
    pub fixed_margin: Real,
    pub moving_margin: Real,
    pub terrain_margin: Real,
}

impl Eq22 {
    /// The scene's `[coupling]` values, or the defaults for particles of `mass` in water of
    /// sound speed `sound_speed`.
    pub(super) fn of(scene: &Scene, fluid: &FluidSpec, sound_speed: Real, mass: Real) -> Self {
        let dx = fluid.dx;
        // Eq. 22 defaults (documented in docs/VALIDATION.md): the spring is as stiff as the
        // water itself over one particle spacing, K_S = ½ρ0c²·dx (bulk modulus ρ0c² times the
        // particle's face dx² over its spacing dx, halved), so a wall yields no more than the
        // water does; the damper is critical for that spring and the particle mass; the margin is
        // half a spacing, the clearance of the initial lattice.
        let ks = scene
            .coupling
            .penalty_stiffness
            .unwrap_or(0.5 * fluid.density * sound_speed * sound_speed * dx);
        let kd = scene
            .coupling
            .penalty_damping
            .unwrap_or(2.0 * (ks * mass).sqrt());
        let margin = scene.coupling.margin.unwrap_or(0.5 * dx);
        // With boundary particles the blocks and the terrain hold the water by pressure; Eq. 22
        // is then a backstop that acts on a block's water closer than half the margin, so it
        // does not bear the load, and on the terrain's only under its surface. The fill lays
        // water anywhere from 0 to dx off a bed that is off the lattice (fill.rs), and a
        // backstop reaching above the bed would push that water at rest: the synthetic
        // reservoir's still water sloshed ±0.75 m at dx = 4 m with it reaching dx/4, ±0.2 m
        // without. The blocks keep it above their faces: a tank's walls are often the domain's
        // bounds, which a particle must not touch (without it the dam breaks of fluid-validate
        // stop at a/dx = 6, a particle on the floor at z = −0.0000 m), and the water the fill
        // lays within dx/4 of a face off the lattice is pushed a little at rest (the default
        // scene's still water moves ±3.5 mm with it, ±2.8 mm without). The terrain looks for
        // crossings as deep as the blocks' backstop reaches.
        let (fixed_margin, terrain_margin) = match fluid.walls {
            Walls::Particles => (0.5 * margin, 0.0),
            Walls::Penalty => (margin, margin),
        };
        Self {
            ks,
            kd,
            fixed_margin,
            moving_margin: fixed_margin,
            terrain_margin,
        }
    }

    /// Eq. 22 between the water and every block, each at its scene pose (the moving ones with
    /// their scene velocities until the solid node sends theirs).
    pub(super) fn penalty(&self, scene: &Scene, init: &Initial) -> Penalty {
        let moving = scene.moving_blocks();
        let obstacles = scene
            .blocks
            .iter()
            .zip(&init.blocks)
            .enumerate()
            .map(|(i, (spec, poly))| {
                let mut state = resting_state(i as u32, poly);
                match moving.iter().position(|&m| m == i) {
                    Some(k) => {
                        state.velocity = spec.velocity;
                        state.angular_velocity = spec.angular_velocity;
                        if spec.elastic.is_some() {
                            state.flags = BlockState::DEFORMABLE;
                        }
                        Obstacle::new(poly.clone(), state, Some(k), self.moving_margin)
                    }
                    None => Obstacle::new(poly.clone(), state, None, self.fixed_margin),
                }
            })
            .collect();
        Penalty::new(self.ks, self.kd, obstacles)
    }

    /// Eq. 22 against the terrain's triangles (the backstop of its boundary particles).
    pub(super) fn terrain(&self, init: &Initial) -> TerrainPenalty {
        TerrainPenalty::new(
            init.terrain.clone(),
            self.ks,
            self.kd,
            self.terrain_margin,
            self.fixed_margin,
        )
    }
}

/// The moving blocks' boundary particles, sampled at the scene pose like the fixed ones (none
/// with `walls = "penalty"` or without moving blocks).
pub(super) fn body_particles(
    scene: &Scene,
    init: &Initial,
    cell: Real,
    grid: &CellGrid,
) -> Option<BodyParticles> {
    let moving = scene.moving_blocks();
    match init.fluid.walls {
        Walls::Penalty => None,
        Walls::Particles if moving.is_empty() => None,
        Walls::Particles => {
            let polys: Vec<Polyhedron> = moving.iter().map(|&i| init.blocks[i].clone()).collect();
            Some(BodyParticles::new(
                &polys,
                &init.fill.anchor,
                init.fluid.dx,
                cell,
                grid.clone(),
            ))
        }
    }
}

/// The fixed blocks' boundary particles and the terrain's, on the water's lattice, each lattice
/// point once, within a cell of the domain `(lo, hi)` (none with `walls = "penalty"`).
pub(super) fn wall_particles(
    scene: &Scene,
    init: &Initial,
    cell: Real,
    (lo, hi): (Vector, Vector),
    grid: &CellGrid,
) -> Option<WallParticles> {
    let dx = init.fluid.dx;
    match init.fluid.walls {
        Walls::Penalty => None,
        Walls::Particles => {
            let fixed = fixed_blocks(scene, init);
            let reach = Vector::repeat(cell);
            let mut pts = WallParticles::sample(
                &fixed,
                &init.fill.anchor,
                dx,
                cell,
                &(lo - reach),
                &(hi + reach),
            );
            // The terrain's, on the same lattice, each lattice point once.
            let anchor = init.fill.anchor;
            let taken: std::collections::BTreeSet<[i64; 3]> =
                pts.iter().map(|p| lattice_key(p, &anchor, dx)).collect();
            pts.extend(
                crate::boundary::terrain::sample(
                    &init.terrain,
                    &anchor,
                    dx,
                    cell,
                    &(lo - reach),
                    &(hi + reach),
                )
                .into_iter()
                .filter(|p| !taken.contains(&lattice_key(p, &anchor, dx))),
            );
            Some(WallParticles::new(pts, grid.clone()))
        }
    }
}

/// The scene's fixed blocks, as polyhedra.
fn fixed_blocks(scene: &Scene, init: &Initial) -> Vec<Polyhedron> {
    scene
        .blocks
        .iter()
        .zip(&init.blocks)
        .filter(|(b, _)| b.kind == BlockKind::Fixed)
        .map(|(_, p)| p.clone())
        .collect()
}

/// The probes whose face reads the wall ([`WallLoads`]) over the fixed blocks' boundary
/// particles `walls`; `support` is the kernel's. One process (`whole`) holds every wall, so a
/// face with no boundary particle behind it is an error there; a rank may hold none of a
/// face's wall, which another rank holds. The leading process (`lead`) warns of a face off
/// the water's lattice ([`wall_load::off_lattice`]).
pub(super) fn wall_loads(
    scene: &Scene,
    init: &Initial,
    walls: Option<&WallParticles>,
    support: Real,
    (whole, lead): (bool, bool),
) -> Result<WallLoads, SolverError> {
    if lead && walls.is_some() {
        for w in wall_load::off_lattice(&scene.probes, &init.fill.anchor, init.fluid.dx) {
            eprintln!("fluid-node: warning: {w}");
        }
    }
    let fixed = fixed_blocks(scene, init);
    WallLoads::new(&scene.probes, walls, &fixed, init.fluid.dx, support, whole)
        .map_err(SolverError::Failed)
}

/// The wave gauges and pressure probes, each gauge with the bed under it (the highest fixed
/// block or terrain surface).
/// The scene's instruments; their files only with `files` (rank 0 of several writes them).
pub(super) fn recorder(
    ctx: &SetupContext,
    init: &Initial,
    files: bool,
) -> Result<Recorder, SolverError> {
    let scene = ctx.scene;
    // The bed under a gauge: the highest fixed block or terrain surface under it.
    let beds: Vec<Real> = scene
        .gauges
        .iter()
        .map(|g| shared::terrain::bed_elevation(scene, &init.terrain, g.x, g.y))
        .collect();
    Ok(Recorder::new(
        ctx.run_dir,
        &scene.gauges,
        &beds,
        &scene.probes,
        scene.output.interval,
        files,
    )?)
}
