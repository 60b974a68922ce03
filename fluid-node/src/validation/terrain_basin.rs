//! Still water in a basin whose bed is a terrain (`[[terrain]]` from an ESRI ASCII grid): the
//! same hydrostatic check as [`super::still_water`], with the bed a curved surface held by the
//! terrain's boundary particles and Eq. 22 instead of a box floor, and no particle below it.

use super::*;
use shared::math::{Point, Vector};
use shared::terrain::Terrain;
use shared::terrain::dem::Grid;

/// Result of a terrain-basin run.
#[derive(Debug, Clone)]
pub struct TerrainBasin {
    /// The still-water result (probes at the basin's centre, where the bed is at z = 0).
    pub still: StillWater,
    /// Particles whose centre ended inside the ground (must be none).
    pub crossed: usize,
    /// The deepest a particle ended under the surface [m] (≤ 0 when none crossed).
    pub deepest: f64,
    /// Boundary particles of the terrain and of the tank walls.
    pub boundary: usize,
}

/// The bed: a parabolic trough across x, z = 0.3·H·((x − L/2)/(L/2))², as a DEM of spacing
/// `cell` reaching past the tank on every side (its rim outside the domain).
pub fn basin_dem(depth: f64, cell: f64) -> Grid {
    let l = 2.0 * depth;
    let t = 0.3 * depth;
    let n = |extent: f64| ((extent + 2.0 * t) / cell).round() as usize + 1;
    Grid::from_fn(n(l), n(depth), -t, -t, cell, |x, _| {
        0.3 * depth * ((x - 0.5 * l) / (0.5 * l)).powi(2)
    })
}

/// The scene: a 2H × H tank (walls, no floor) over the DEM basin, water to depth H above its
/// lowest point; the DEM file is written into `dir`.
pub fn terrain_basin_scene(solver: &str, depth: f64, dx: f64, end: f64, dir: &Path) -> Scene {
    let (l, w) = (2.0 * depth, depth);
    let file = dir.join("basin.asc");
    std::fs::write(&file, basin_dem(depth, 0.5 * dx).to_asc()).expect("write the DEM");
    let t = 0.3 * depth;
    let h = 2.0 * depth;
    let blk = |name: &str, min: [f64; 3], max: [f64; 3]| {
        format!(
            "[[block]]\nname = \"{name}\"\nkind = \"fixed\"\nshape = {{ type = \"box\", min = {min:?}, max = {max:?} }}\n\n"
        )
    };
    let walls = [
        blk("left_wall", [-t, -t, -t], [0.0, w + t, h]),
        blk("right_wall", [l, -t, -t], [l + t, w + t, h]),
        blk("south_wall", [-t, -t, -t], [l + t, 0.0, h]),
        blk("north_wall", [-t, w, -t], [l + t, w + t, h]),
    ]
    .concat();
    let text = format!(
        "name = \"terrain_basin\"\n[time]\nend = {end}\ndt_max = 1e-3\n[domain]\nmin = [0.0, 0.0, {zmin}]\nmax = [{l}, {w}, {h}]\n\
         [output]\ninterval = {end}\n{fluid}\n[[fluid.water]]\nshape = {{ type = \"box\", min = [0.0, 0.0, 0.0], max = [{l}, {w}, {depth}] }}\n\n\
         [[terrain]]\nname = \"basin\"\nfile = {file:?}\n\n{walls}\
         [[gauge]]\nname = \"centre\"\nx = {cx}\ny = {cy}\n\n\
         [[probe]]\nname = \"p25\"\nposition = [{cx}, {cy}, {z75}]\n\n\
         [[probe]]\nname = \"p50\"\nposition = [{cx}, {cy}, {z50}]\n\n\
         [[probe]]\nname = \"p75\"\nposition = [{cx}, {cy}, {z25}]\n",
        zmin = -0.5 * depth,
        fluid = fluid_table(solver, dx, None),
        file = file.display().to_string(),
        cx = 0.5 * l + 0.25 * dx,
        cy = 0.5 * w + 0.25 * dx,
        z75 = 0.75 * depth,
        z50 = 0.5 * depth,
        z25 = 0.25 * depth,
    );
    Scene::parse_checked(&text, "terrain_basin (generated)", &[&crate::check_scene])
        .expect("generated terrain-basin scene is valid")
}

/// Runs still water in the terrain basin; reads the probes as [`still_water`] does and checks
/// every particle against the terrain at the end.
pub fn terrain_basin(
    solver: &str,
    depth: f64,
    dx: f64,
    end: f64,
) -> Result<TerrainBasin, SolverError> {
    let dir = TempRunDir::new("basin")?;
    let scene = terrain_basin_scene(solver, depth, dx, end, dir.path());
    let terrain = Terrain::load(&scene.terrain[0], &scene.domain)
        .map_err(|e| SolverError::Failed(format!("{e:?}")))?;
    let mut s = build(solver, &scene, dir.path())?;
    let particles = s.system().len();
    let boundary = s.system().boundary.counts().0;
    let steps = run(s.as_mut(), &scene, end, |_, _| {})?;
    let pos: Vec<Vector> = s.system().particles.position.clone();
    drop(s);
    let (mut crossed, mut deepest) = (0, f64::NEG_INFINITY);
    for p in &pos {
        let d = terrain
            .nearest(&Point::from(*p), f64::MAX)
            .map_or(f64::INFINITY, |s| s.distance);
        crossed += usize::from(d < 0.0);
        deepest = deepest.max(-d);
    }
    let still = super::still_water::hydrostatics(dir.path(), &scene, depth, end, particles, steps)?;
    Ok(TerrainBasin {
        still,
        crossed,
        deepest,
        boundary,
    })
}

/// The terrain-basin rows of `fluid-validate`: pressure (the still-water tolerance), surface
/// (±1 dx) and particles under the bed (none), at the plan's still-water resolution.
pub fn validate_terrain_basin(solver: &str, plan: &Plan, mut log: impl FnMut(&str)) -> Vec<Row> {
    let depth = 0.1;
    let dx = depth / plan.still_per_depth as f64;
    let case = format!(
        "still water over a DEM trough ([[terrain]]), H = {depth} m, dx = H/{}",
        plan.still_per_depth
    );
    let row = |quantity: &str,
               reference: String,
               measured: String,
               error: String,
               tolerance: &str,
               pass: bool| Row {
        case: case.clone(),
        solver: solver.into(),
        quantity: quantity.into(),
        reference,
        measured,
        error,
        tolerance: tolerance.into(),
        pass,
        known_limitation: None,
    };
    match terrain_basin(solver, depth, dx, plan.still_end) {
        Err(e) => vec![row(
            "completes",
            "completes".into(),
            format!("failed: {e}"),
            "–".into(),
            "exact",
            false,
        )],
        Ok(r) => {
            let s = &r.still;
            log(&format!(
                "terrain basin {solver}: {} particles, {} terrain/wall particles, {} steps, error {:.3}, deepest {:.2e} m",
                s.particles, r.boundary, s.steps, s.max_error, r.deepest
            ));
            let (d, p, q) = s.worst_probe();
            let surf = (s.surface - s.depth) / dx;
            vec![
                row(
                    &format!("pressure at depth {d:.2}·H (worst of 0.25, 0.5, 0.75) [Pa]"),
                    format!("{q:.1} (ρ0 g (η − z))"),
                    format!("{p:.1}"),
                    format!("{:.1} % of ρ0 g H", 100.0 * s.max_error),
                    &format!("{:.0} %", 100.0 * HYDROSTATIC_TOLERANCE),
                    s.max_error <= HYDROSTATIC_TOLERANCE,
                ),
                row(
                    "free surface η (gauge) [m]",
                    format!("{:.4}", s.depth),
                    format!("{:.4}", s.surface),
                    format!("{surf:+.2} dx"),
                    "±1 dx",
                    surf.abs() <= 1.0,
                ),
                row(
                    "particles under the terrain at the end",
                    "0".into(),
                    format!("{}", r.crossed),
                    format!("{}", r.crossed),
                    "0",
                    r.crossed == 0,
                ),
            ]
        }
    }
}
