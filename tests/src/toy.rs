//! The toy solvers (see the crate docs).

use nalgebra::{Point3, Vector3};
use shared::geometry::Polyhedron;
use shared::protocol::{BlockLoad, BlockState};
use shared::scene::{BlockKind, CouplingScheme, Scene};
use shared::solver::{FluidSolver, SetupContext, SolidSolver, Solver, SolverError, StepReport};

/// A moving block as the toys see it: corners, mass and the scene pose.
struct ToyBlock {
    index: u32,
    local: Vec<Point3<f64>>,
    mass: f64,
    centroid: Point3<f64>,
    velocity: Vector3<f64>,
}

fn moving_blocks(scene: &Scene) -> Result<Vec<ToyBlock>, SolverError> {
    scene
        .moving_blocks()
        .into_iter()
        .map(|i| {
            let b = &scene.blocks[i];
            let p = Polyhedron::from_shape(&b.shape)
                .map_err(|e| SolverError::Failed(format!("block '{}': {e}", b.name)))?;
            let density = if b.kind == BlockKind::Free {
                b.density
            } else {
                0.0
            };
            Ok(ToyBlock {
                index: i as u32,
                mass: density * p.volume,
                centroid: p.centroid,
                local: p.vertices,
                velocity: Vector3::from(b.velocity),
            })
        })
        .collect()
}

/// Ballistic rigid blocks (no rotation, no contacts).
pub struct Ballistic {
    /// Sleep this long in each advance: a stand-in for an expensive solver that keeps the
    /// other node waiting, without burning CPU itself (used to measure the cost of waiting).
    nap: std::time::Duration,
    blocks: Vec<ToyBlock>,
    forces: Vec<Vector3<f64>>,
    gravity: Vector3<f64>,
    dt_max: f64,
}

impl Ballistic {
    pub fn new(nap: std::time::Duration, ctx: &SetupContext) -> Result<Ballistic, SolverError> {
        let blocks = moving_blocks(ctx.scene)?;
        Ok(Ballistic {
            nap,
            forces: vec![Vector3::zeros(); blocks.len()],
            blocks,
            gravity: Vector3::from(ctx.scene.gravity),
            dt_max: ctx.scene.time.dt_max,
        })
    }
}

impl Solver for Ballistic {
    fn name(&self) -> &str {
        "ballistic"
    }
    fn dt_proposal(&self) -> f64 {
        self.dt_max
    }
    fn advance(&mut self, dt: f64) -> Result<StepReport, SolverError> {
        if !self.nap.is_zero() {
            std::thread::sleep(self.nap);
        }
        for (b, f) in self.blocks.iter_mut().zip(&self.forces) {
            // Exact for an acceleration that is constant over the step.
            let a = if b.mass > 0.0 {
                self.gravity + f / b.mass
            } else {
                Vector3::zeros()
            };
            b.centroid += b.velocity * dt + 0.5 * a * dt * dt;
            b.velocity += a * dt;
        }
        Ok(StepReport::default())
    }
    fn write_frame(&mut self, _frame: u32, _time: f64) -> Result<(), SolverError> {
        Ok(())
    }
}

impl SolidSolver for Ballistic {
    fn read_loads(&mut self, loads: &[BlockLoad]) {
        for (f, l) in self.forces.iter_mut().zip(loads) {
            *f = Vector3::from(l.force);
        }
    }
    fn vertex_count(&self) -> usize {
        self.blocks.iter().map(|b| b.local.len()).sum()
    }
    fn write_geometry(&self, blocks: &mut [BlockState], vertices: &mut [[f64; 3]]) {
        let mut first = 0;
        for (b, out) in self.blocks.iter().zip(blocks.iter_mut()) {
            *out = BlockState {
                block: b.index,
                first_vertex: first as u32,
                vertex_count: b.local.len() as u32,
                centroid: b.centroid.into(),
                orientation: [0.0, 0.0, 0.0, 1.0],
                velocity: b.velocity.into(),
                ..Default::default()
            };
            for (k, v) in b.local.iter().enumerate() {
                vertices[first + k] = (v + b.centroid.coords).into();
            }
            first += b.local.len();
        }
    }
}

/// A fluid stand-in that checks the geometry it is sent (see the crate docs).
pub struct Checker {
    hover: bool,
    blocks: Vec<ToyBlock>,
    gravity: Vector3<f64>,
    scheme: CouplingScheme,
    time: f64,
    step: u64,
    error: Option<String>,
    dt_max: f64,
}

impl Checker {
    pub fn new(hover: bool, ctx: &SetupContext) -> Result<Checker, SolverError> {
        Ok(Checker {
            hover,
            blocks: moving_blocks(ctx.scene)?,
            gravity: Vector3::from(ctx.scene.gravity),
            scheme: ctx.scheme,
            time: 0.0,
            step: 0,
            error: None,
            dt_max: ctx.scene.time.dt_max,
        })
    }
}

impl Solver for Checker {
    fn name(&self) -> &str {
        if self.hover { "hover" } else { "drop" }
    }
    fn dt_proposal(&self) -> f64 {
        self.dt_max
    }
    fn advance(&mut self, dt: f64) -> Result<StepReport, SolverError> {
        if let Some(e) = self.error.take() {
            return Err(SolverError::Failed(e));
        }
        self.time += dt;
        self.step += 1;
        Ok(StepReport::default())
    }
    fn write_frame(&mut self, _frame: u32, _time: f64) -> Result<(), SolverError> {
        Ok(())
    }
}

impl FluidSolver for Checker {
    fn read_geometry(&mut self, blocks: &[BlockState], vertices: &[[f64; 3]]) {
        // The serial scheme shows the fluid the geometry at the end of its step; the parallel
        // one at its start. Free fall is checked only in the parallel scheme, where the time is
        // known before the step (the serial step length is not known here yet).
        let expect_still = self.hover;
        for (b, s) in self.blocks.iter().zip(blocks) {
            let moved = (s.centroid() - b.centroid).norm();
            let expected = if expect_still {
                0.0
            } else if self.scheme == CouplingScheme::Parallel {
                (0.5 * self.gravity * self.time * self.time + b.velocity * self.time).norm()
            } else {
                continue;
            };
            if (moved - expected).abs() > 1e-9 * (1.0 + expected) {
                self.error = Some(format!(
                    "geometry of block {} at step {} (t = {}) is off by {:e} m: a message from the wrong time",
                    b.index,
                    self.step,
                    self.time,
                    moved - expected
                ));
            }
            let corner = vertices[s.first_vertex as usize];
            let c = s.centroid() + b.local[0].coords;
            if (Point3::from(corner) - c).norm() > 1e-9 {
                self.error = Some(format!(
                    "corner 0 of block {} disagrees with its centroid",
                    b.index
                ));
            }
        }
    }
    fn write_loads(&mut self, loads: &mut [BlockLoad]) {
        for (b, l) in self.blocks.iter().zip(loads.iter_mut()) {
            let lift = if self.hover {
                -b.mass * self.gravity
            } else {
                Vector3::zeros()
            };
            *l = BlockLoad {
                block: b.index,
                force: lift.into(),
                ..Default::default()
            };
        }
    }
}

/// Fluid toys offered by `toy-fluid-node`.
pub const FLUID_TOYS: &[&str] = &["hover", "drop"];
/// Solid toys offered by `toy-solid-node`.
pub const SOLID_TOYS: &[&str] = &["ballistic", "ballistic-slow"];

pub fn build_fluid(name: &str, ctx: &SetupContext) -> Result<Box<dyn FluidSolver>, SolverError> {
    Ok(Box::new(Checker::new(name == "hover", ctx)?))
}

pub fn build_solid(name: &str, ctx: &SetupContext) -> Result<Box<dyn SolidSolver>, SolverError> {
    let nap = if name == "ballistic-slow" {
        std::time::Duration::from_millis(1)
    } else {
        std::time::Duration::ZERO
    };
    Ok(Box::new(Ballistic::new(nap, ctx)?))
}
