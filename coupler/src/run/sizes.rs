//! What a scene will cost before anything is allocated: particles, memory, steps and disk, and
//! the refusal of a scene that cannot fit in this machine's memory (naming `fluid.dx`).
//!
//! The memory figures are measured, not derived: the peak resident set (VmHWM) of a fluid rank
//! of the synthetic reservoir at dx = 1 m, 22 631 steps on 2 ranks, over the water and boundary
//! particles it held ([`BYTES_PER_WATER_PARTICLE`], [`BYTES_PER_BOUNDARY_PARTICLE`]), over a base
//! of [`BASE_BYTES`] (the sliding wedge at dx = 0.04 m). A rank and a one-process node hold
//! the same arrays per particle; the long run is the one to plan by (docs/PERFORMANCE.md,
//! "Sizes and memory").

use shared::geometry::Polyhedron;
use shared::scene::{BlockKind, FieldError, Scene, Walls};
use shared::terrain::Terrain;

/// Peak resident bytes of the fluid node (or of a rank) per water particle it holds, own or
/// halo, measured as above: the per-particle arrays, the WCSPH records and the neighbour lists
/// (~100 entries within the lists' reach of 1.1 supports), as a developed flow keeps them after
/// thousands of sorts (the allocator had 761 MB in use of 923 MB mapped at that run's end), and
/// the rank's piece of a checkpoint. A short run holds less: `fluid-bench --ranks 2 --sizes 1000000 --steps 3` ~660 B (docs/PERFORMANCE.md).
pub const BYTES_PER_WATER_PARTICLE: f64 = 1600.0;
/// Peak resident bytes per boundary (wall, terrain, block) particle: from one process and one
/// rank of `fluid-bench --ranks 2 --sizes 1000000` (737 MB for 992 319 water and ~642 000
/// boundary particles; 464 MB on a rank holding 577 806 of the water and all the boundary: two
/// equations, two unknowns). Every rank holds every boundary particle.
pub const BYTES_PER_BOUNDARY_PARTICLE: f64 = 90.0;
/// Peak resident bytes of the fluid node with no particles.
pub const BASE_BYTES: f64 = 25e6;
/// Bytes of one particle in one ASCII VTK frame (a particles_NNNNN.vtp of the sliding wedge at
/// dx = 0.02 m over its particles).
pub const VTK_BYTES_PER_PARTICLE: f64 = 83.0;
/// Bytes of one particle in one binary VTK frame, exactly: position, velocity (3 × 8), density,
/// pressure (8 each), connectivity and offset (Int64, 8 each).
pub const VTK_BINARY_BYTES_PER_PARTICLE: f64 = 80.0;
/// Share of the available memory a run may plan to use (the machine is shared).
const MEMORY_SHARE: f64 = 0.8;
/// Layers of boundary particles: the walls are filled one kernel support deep, 2h = 2.6 dx
/// with the default smoothing ratio 1.3, i.e. three lattice layers.
const BOUNDARY_LAYERS: f64 = 3.0;
/// Wall time of one water particle-step [s] in the wall-time estimate: the cheapest measured,
/// WCSPH and Müller on two threads (9.2·10⁶–1.0·10⁷ particle-steps/s, `fluid-bench`,
/// docs/PERFORMANCE.md), so that the estimate is a floor: DFSPH costs ~8× more per step, and
/// the boundary particles and the solid come on top.
pub const SECONDS_PER_PARTICLE_STEP: f64 = 1e-7;
/// Wall time of a coupling step without particles [s]: two iceoryx2 round trips in sequence
/// (12.8–13.2 µs each, `coupling-bench`, docs/PERFORMANCE.md).
pub const SECONDS_PER_STEP: f64 = 2.6e-5;
/// Longest estimated wall time `coupler check` passes and `coupler run` starts without
/// `--allow-long` [s]: two days, past which a run is nearly always a wrong step bound or
/// spacing rather than a plan.
pub const MAX_WALL_SECONDS: f64 = 48.0 * 3600.0;
/// Most estimated steps passed without `--allow-long`: 10⁸ steps take 45 min at the bare
/// exchange's cost and days with any water; the repository's scenes take 10³–10⁵.
pub const MAX_STEPS: f64 = 1e8;

/// A scene's estimated cost.
#[derive(Debug, Clone)]
pub struct Estimate {
    /// Water particles: water volume / dx³.
    pub fluid_particles: f64,
    /// Boundary particles: three layers over the domain's surface when fixed blocks make the
    /// tank's walls (an upper estimate), plus three layers under each terrain surface inside
    /// the domain; zero with `walls = "penalty"`.
    pub boundary_particles: f64,
    /// Peak memory of the fluid node [bytes].
    pub memory: f64,
    /// Steps to time.end at the estimated step.
    pub steps: f64,
    /// Estimated step [s], at most dt_max. A weakly compressible scheme (wcsph, muller): the CFL
    /// limit Δt = C h / c0 with C = 0.2, h = 1.3 dx and the default speed of sound
    /// c0 = 10 sqrt(2 g H) for the water height H (Monaghan 1994). DFSPH steps on the flow:
    /// Δt = C dx / v with its default C = 0.4 and v the long-wave speed sqrt(g H), about the
    /// fastest water a wave or a slide of that depth makes.
    pub dt: f64,
    /// Output frames: time.end / output.interval.
    pub frames: f64,
    /// VTK particle frames on disk [bytes] (zero without VTK).
    pub disk: f64,
    /// Wall time [s], a floor: steps × ([`SECONDS_PER_STEP`] + water particles ×
    /// [`SECONDS_PER_PARTICLE_STEP`]).
    pub wall: f64,
    /// Wall time [s] as likely as the estimate can make it: steps × (water + boundary
    /// particles) ÷ the solver's one-thread rate (the registry's
    /// [`shared::registry::Advice::particle_steps_per_second`]; the slowest measured for a
    /// solver without one), so that it errs long. What the default checkpoints go by.
    pub wall_likely: f64,
    /// What sets the estimated step: `time.dt_max`, the viscous limit of
    /// `fluid.kinematic_viscosity`, or the solver's own step at `fluid.dx`.
    pub bound_by: &'static str,
}

impl Estimate {
    /// One line for `coupler check` and the start of a run.
    pub fn describe(&self) -> String {
        format!(
            "{:.3e} water + {:.3e} boundary particles, about {:.0} MB of memory; about {:.3e} steps of {:.2e} s; {:.0} frames, about {:.0} MB of VTK; {} of wall time or more",
            self.fluid_particles,
            self.boundary_particles,
            self.memory / 1e6,
            self.steps,
            self.dt,
            self.frames,
            self.disk / 1e6,
            duration(self.wall)
        )
    }
}

/// The estimate of a scene with water (`None` without), stepped as `solver` would step it
/// (`None`: the scene's own `fluid.solver`; `coupler run --fluid-solver` names another).
pub fn estimate(scene: &Scene, solver: Option<&str>) -> Option<Estimate> {
    let fluid = scene.fluid.as_ref().filter(|_| scene.has_fluid())?;
    let solver = solver.unwrap_or(&fluid.solver);
    let dx = fluid.dx;
    let mut volume: f64 = fluid
        .water
        .iter()
        .filter_map(|w| Polyhedron::from_shape(&w.shape).ok())
        .map(|p| p.volume)
        .sum();
    let (bottom, top) = scene.water_span().unwrap_or((0.0, 0.0));
    let d = &scene.domain;
    let e: Vec<f64> = (0..3).map(|k| d.max[k] - d.min[k]).collect();
    let walls = scene.blocks.iter().any(|b| b.kind == BlockKind::Fixed);
    let mut area = if walls {
        2.0 * (e[0] * e[1] + e[1] * e[2] + e[0] * e[2])
    } else {
        0.0
    };
    // A terrain that does not load is reported by the scene check; it adds nothing here.
    let terrain = Terrain::load_all_kept(scene).unwrap_or_default();
    if !terrain.is_empty() {
        volume -= water_in_ground(scene, &terrain, dx);
        area += terrain
            .iter()
            .map(|t| area_in_domain(t, scene))
            .sum::<f64>();
    }
    let fluid_particles = volume.max(0.0) / dx.powi(3);
    let boundary_particles = match fluid.walls {
        Walls::Particles => BOUNDARY_LAYERS * area / (dx * dx),
        Walls::Penalty => 0.0,
    };
    let memory = BASE_BYTES
        + BYTES_PER_WATER_PARTICLE * fluid_particles
        + BYTES_PER_BOUNDARY_PARTICLE * boundary_particles;
    let height = (top - bottom).max(dx);
    // The solver's own step for this water (its registry entry); one without an estimate is
    // taken at the scene's largest step.
    let solver_dt = |scene: &Scene| {
        fluid_node::REGISTRY
            .get(solver)
            .ok()
            .and_then(|e| (e.advice.estimate_dt)(scene, dx, height))
    };
    let own = solver_dt(scene);
    let dt = own.unwrap_or(scene.time.dt_max).min(scene.time.dt_max);
    let bound_by = if own.is_none_or(|d| d >= scene.time.dt_max) {
        "time.dt_max"
    } else if own < solver_dt(&inviscid(scene)) {
        "fluid.kinematic_viscosity"
    } else {
        "fluid.dx"
    };
    let frames = scene.time.end / scene.output.interval;
    let disk = if scene.output.vtk {
        let per_particle = match scene.output.vtk_format {
            shared::scene::VtkFormat::Binary => VTK_BINARY_BYTES_PER_PARTICLE,
            shared::scene::VtkFormat::Ascii => VTK_BYTES_PER_PARTICLE,
        };
        frames * fluid_particles * per_particle
    } else {
        0.0
    };
    let steps = scene.time.end / dt;
    Some(Estimate {
        fluid_particles,
        boundary_particles,
        memory,
        steps,
        dt,
        frames,
        disk,
        wall: steps * (SECONDS_PER_STEP + fluid_particles * SECONDS_PER_PARTICLE_STEP),
        wall_likely: steps * (fluid_particles + boundary_particles) / one_thread_rate(solver),
        bound_by,
    })
}

/// The registry's one-thread particle-steps per second of `solver`, or the slowest of those
/// measured for a solver without its own.
fn one_thread_rate(solver: &str) -> f64 {
    let rate = |e: &shared::registry::Entry<_>| e.advice.particle_steps_per_second;
    let slowest = fluid_node::REGISTRY
        .entries
        .iter()
        .filter_map(rate)
        .fold(f64::INFINITY, f64::min);
    fluid_node::REGISTRY
        .get(solver)
        .ok()
        .and_then(rate)
        .unwrap_or(slowest)
}

/// The scene with inviscid water, to tell whether the viscous limit sets the solver's step.
fn inviscid(scene: &Scene) -> Scene {
    let mut s = scene.clone();
    if let Some(f) = s.fluid.as_mut() {
        f.kinematic_viscosity = 0.0;
    }
    s
}

/// A wall time in words: seconds, minutes, hours, days or years.
pub fn duration(seconds: f64) -> String {
    match seconds {
        s if s < 120.0 => format!("{s:.0} s"),
        s if s < 7200.0 => format!("{:.0} min", s / 60.0),
        s if s < 2.0 * 86400.0 => format!("{:.1} h", s / 3600.0),
        s if s < 365.0 * 86400.0 => format!("{:.1} days", s / 86400.0),
        s => format!("{:.2e} years", s / (365.25 * 86400.0)),
    }
}

/// Steps to time.end, the step [s], the wall time [s] (a floor) and what sets the step, by the
/// estimate (a scene without water steps at `time.dt_max`).
pub fn steps_dt_wall(scene: &Scene, solver: Option<&str>) -> (f64, f64, f64, &'static str) {
    let t = &scene.time;
    match estimate(scene, solver) {
        Some(e) => (e.steps, e.dt, e.wall, e.bound_by),
        None => {
            let steps = t.end / t.dt_max;
            (steps, t.dt_max, steps * SECONDS_PER_STEP, "time.dt_max")
        }
    }
}

/// Refuses a run that would crawl: more than [`MAX_STEPS`] steps or [`MAX_WALL_SECONDS`] of
/// wall time by the estimate (a scene without water steps at `time.dt_max`), naming the field
/// that sets the step and the fix, `--allow-long` among them. `solver` as in [`estimate`].
pub fn crawl(scene: &Scene, solver: Option<&str>) -> Vec<FieldError> {
    let t = &scene.time;
    if !(t.end > 0.0 && t.dt_max > 0.0) {
        return Vec::new(); // the scene's own validation names them
    }
    let (steps, dt, wall, bound_by) = steps_dt_wall(scene, solver);
    if steps <= MAX_STEPS && wall <= MAX_WALL_SECONDS {
        return Vec::new();
    }
    let fluid = scene.fluid.as_ref();
    let (path, value, fix): (&[&str], String, String) = match bound_by {
        "fluid.kinematic_viscosity" => (
            &["fluid", "kinematic_viscosity"],
            format!("{:?}", fluid.map_or(0.0, |f| f.kinematic_viscosity)),
            "the viscous step limit 0.125 h²/ν falls as ν grows: water is kinematic_viscosity = 1e-6 m²/s".into(),
        ),
        "fluid.dx" => (
            &["fluid", "dx"],
            format!("{:?}", fluid.map_or(0.0, |f| f.dx)),
            format!(
                "a coarser dx (the step grows with it, the particles as dx⁻³), or a shorter \
                 time.end (now {} s)",
                t.end
            ),
        ),
        _ => (
            &["time", "dt_max"],
            format!("{:?}", t.dt_max),
            "a larger dt_max, e.g. dt_max = 1e-3 (the default): the solvers take shorter steps \
             themselves where they need them"
                .into(),
        ),
    };
    vec![FieldError::new(
        path,
        value,
        &format!(
            "makes the run crawl: about {steps:.3e} steps of {dt:.2e} s to time.end = {} s, \
             {} of wall time or more ({SECONDS_PER_STEP:e} s per step + \
             {SECONDS_PER_PARTICLE_STEP:e} s per water particle-step, measured); past the \
             limit of {MAX_STEPS:e} steps or {:.0} h",
            shared::math::readable(t.end),
            duration(wall),
            MAX_WALL_SECONDS / 3600.0
        ),
        &format!("{fix}; or pass --allow-long to run it anyway"),
    )]
}

/// Area [m²] of a terrain's triangles whose centroid is inside the domain (the fluid node fills
/// boundary particles under them).
fn area_in_domain(t: &Terrain, scene: &Scene) -> f64 {
    let d = &scene.domain;
    t.mesh
        .triangles()
        .filter(|tri| {
            let c = tri.center();
            (0..3).all(|k| c[k] >= d.min[k] && c[k] <= d.max[k])
        })
        .map(|tri| tri.area())
        .sum()
}

/// Volume [m³] of the water boxes that lies under the terrain (left dry by the fill): the
/// water's bounding boxes sampled on columns 2 dx apart, each column's water below the highest
/// terrain surface over it counted. Boxes only (the water of every repository scene with a
/// terrain); another shape adds nothing, keeping the estimate an upper one.
fn water_in_ground(scene: &Scene, terrain: &[std::sync::Arc<Terrain>], dx: f64) -> f64 {
    let Some(fluid) = scene.fluid.as_ref() else {
        return 0.0;
    };
    let step = 2.0 * dx;
    let mut dry = 0.0;
    for w in &fluid.water {
        let shared::scene::ShapeSpec::Box { min, max } = &w.shape else {
            continue;
        };
        let (nx, ny) = (
            ((max[0] - min[0]) / step).ceil().max(1.0) as usize,
            ((max[1] - min[1]) / step).ceil().max(1.0) as usize,
        );
        let (cx, cy) = ((max[0] - min[0]) / nx as f64, (max[1] - min[1]) / ny as f64);
        for i in 0..nx {
            for j in 0..ny {
                let (x, y) = (
                    min[0] + (i as f64 + 0.5) * cx,
                    min[1] + (j as f64 + 0.5) * cy,
                );
                let bed = terrain
                    .iter()
                    .filter_map(|t| t.top_at(x, y))
                    .fold(f64::NEG_INFINITY, f64::max);
                dry += (bed.min(max[2]) - min[2]).max(0.0) * cx * cy;
            }
        }
    }
    dry
}

/// Memory available to new processes on this machine [bytes] (MemAvailable of /proc/meminfo).
pub fn available_memory() -> Option<f64> {
    let text = std::fs::read_to_string("/proc/meminfo").ok()?;
    let line = text.lines().find(|l| l.starts_with("MemAvailable:"))?;
    let kb: f64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kb * 1024.0)
}

/// Refuses a scene whose particles do not fit in `available` bytes (this machine's, when
/// `None`), naming `fluid.dx` with the estimate and the spacing that would fit.
pub fn check(scene: &Scene, available: Option<f64>) -> Vec<FieldError> {
    let Some(f) = scene.fluid.as_ref() else {
        return Vec::new();
    };
    if !(f.dx.is_finite() && f.dx > 0.0) {
        return Vec::new(); // the scene's own validation names it
    }
    let Some(est) = estimate(scene, None) else {
        return Vec::new();
    };
    let Some(available) = available.or_else(available_memory) else {
        return Vec::new();
    };
    let budget = MEMORY_SHARE * available;
    // Particle indices are 32-bit: beyond that no machine helps.
    let too_many = est.fluid_particles + est.boundary_particles > u32::MAX as f64;
    if est.memory.is_finite() && est.memory <= budget && !too_many {
        return Vec::new();
    }
    // Memory grows as dx⁻³ (water) and dx⁻² (walls): scaling dx by the cube root of the excess
    // is enough for both.
    let excess = ((est.memory - BASE_BYTES) / (budget - BASE_BYTES).max(1.0)).max(1.0);
    let fits = if excess.is_finite() {
        f.dx * excess.cbrt() * 1.05
    } else {
        f64::NAN
    };
    vec![FieldError::new(
        &["fluid", "dx"],
        format!("{:?}", f.dx),
        &format!(
            "asks for {:.3e} water and {:.3e} boundary particles, about {:.3e} GB of memory \
             ({BYTES_PER_WATER_PARTICLE:.0} B per water and {BYTES_PER_BOUNDARY_PARTICLE:.0} B \
             per boundary particle, measured on a long run); this machine has {:.1} GB \
             available and a run may plan {:.0} % of it",
            est.fluid_particles,
            est.boundary_particles,
            est.memory / 1e9,
            available / 1e9,
            MEMORY_SHARE * 100.0
        ),
        &if fits.is_finite() {
            format!("use dx >= {fits:.3e} m (or --dx), or a smaller water volume")
        } else {
            "use a particle spacing of millimetres or more".to_string()
        },
    )]
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn default_scene_fits_and_a_fine_one_does_not() {
        let mut s = Scene::default_scene();
        let e = estimate(&s, None).unwrap();
        // 4.96 × 0.8 × 0.48 m³ at dx = 0.04.
        assert!((e.fluid_particles - 29_760.0).abs() < 1.0, "{e:?}");
        assert!(check(&s, Some(8e9)).is_empty());
        s.set_dx(1e-3);
        let errs = check(&s, Some(8e9));
        assert_eq!(errs.len(), 1);
        assert_eq!(errs[0].path, "fluid.dx");
        assert!(errs[0].fix.contains("dx >="), "{}", errs[0]);
        s.set_dx(1e-300);
        assert_eq!(check(&s, Some(8e9)).len(), 1);
    }

    #[test]
    fn a_run_that_crawls_names_the_field_that_makes_it() {
        let s = Scene::default_scene();
        let e = estimate(&s, None).unwrap();
        assert!(e.wall > 1.0 && e.wall < 120.0, "{e:?}");
        assert!(crawl(&s, None).is_empty());
        let mut tiny = s.clone();
        tiny.time.dt_max = 1e-9;
        tiny.time.dt_min = 1e-12;
        let errs = crawl(&tiny, None);
        assert_eq!(errs.len(), 1);
        let msg = errs[0].to_string();
        assert!(
            msg.starts_with("time.dt_max = 1e-9")
                && msg.contains("2.500e9 steps")
                && msg.contains("dt_max = 1e-3")
                && msg.contains("--allow-long"),
            "{msg}"
        );
        let mut thick = s.clone();
        thick.fluid.as_mut().unwrap().kinematic_viscosity = 1e5;
        let msg = crawl(&thick, None)[0].to_string();
        assert!(
            msg.starts_with("fluid.kinematic_viscosity = 100000.0") && msg.contains("1e-6"),
            "{msg}"
        );
        let mut fine = s.clone();
        fine.set_dx(2e-3);
        let msg = crawl(&fine, None)[0].to_string();
        assert!(
            msg.starts_with("fluid.dx = 0.002") && msg.contains("coarser dx"),
            "{msg}"
        );
        // Without water the step is dt_max's.
        let mut dry = tiny.clone();
        dry.fluid = None;
        assert!(crawl(&dry, None)[0].path == "time.dt_max");
        assert_eq!(duration(90.0), "90 s");
        assert_eq!(duration(5400.0), "90 min");
        assert_eq!(duration(3.0 * 86400.0), "3.0 days");
    }

    /// Example 1 with DFSPH steps at its 10 ms limit, the flow's step, not the sound speed's
    /// (docs/journal/2026-11-performance.md "Example 1 runs DFSPH by default: the wave maker
    /// against linear theory").
    #[test]
    fn dfsph_steps_are_estimated_on_the_flow_not_the_sound_speed() {
        let text = include_str!("../../../scenes/wave_maker.toml");
        let mut s = Scene::parse(text, "wave_maker").unwrap();
        let e = estimate(&s, None).unwrap();
        assert!((e.steps - 4_000.0).abs() < 1.0, "{e:?}");
        // `coupler run --fluid-solver wcsph`: WCSPH steps by the sound speed.
        let e = estimate(&s, Some("wcsph")).unwrap();
        assert!((60_000.0..80_000.0).contains(&e.steps), "{e:?}");
        s.fluid.as_mut().unwrap().solver = "wcsph".into();
        assert_eq!(estimate(&s, None).unwrap().steps, e.steps);
        // And back: a WCSPH scene run with `--fluid-solver dfsph`.
        assert!(estimate(&s, Some("dfsph")).unwrap().steps < 5_000.0);
    }
}
