//! Still water in a closed tank: pressure against depth, p = ρ0 g (η − z), and the free surface.

use super::*;

/// Still water: a box of water of depth `depth` at rest in a closed tank.
pub fn still_water_scene(
    solver: &str,
    depth: f64,
    dx: f64,
    end: f64,
    walls: Option<Walls>,
) -> Scene {
    let (l, w) = (2.0 * depth, depth);
    let text = format!(
        "name = \"still_water\"\n[time]\nend = {end}\ndt_max = 1e-3\n[domain]\nmin = [0.0, 0.0, 0.0]\nmax = [{l}, {w}, {h}]\n\
         [output]\ninterval = {end}\n{fluid}\n[[fluid.water]]\nshape = {{ type = \"box\", min = [0.0, 0.0, 0.0], max = [{l}, {w}, {depth}] }}\n\n\
         {tank}\
         [[gauge]]\nname = \"centre\"\nx = {cx}\ny = {cy}\n\n\
         [[probe]]\nname = \"p25\"\nposition = [{cx}, {cy}, {z75}]\nwindow = {window}\n\n\
         [[probe]]\nname = \"p50\"\nposition = [{cx}, {cy}, {z50}]\nwindow = {window}\n\n\
         [[probe]]\nname = \"p75\"\nposition = [{cx}, {cy}, {z25}]\nwindow = {window}\n",
        h = 2.0 * depth,
        fluid = fluid_table(solver, dx, walls),
        tank = tank(l, w, 2.0 * depth, 0.2 * depth),
        cx = 0.5 * l + 0.25 * dx,
        cy = 0.5 * w + 0.25 * dx,
        z75 = 0.75 * depth,
        z50 = 0.5 * depth,
        z25 = 0.25 * depth,
        // Each row the mean over the steps since the last row ([`PROBE_ROWS`] rows a run), so
        // that the rows' mean over the second half is the pressure's time mean over every
        // step there, not the mean of 25 snapshots: DFSPH's pressure moves from step to step
        // by a fifth of ρ0 g H (docs/VALIDATION.md), and 25 snapshots of it left the row's
        // mean a few per cent of ρ0 g H apart between runs that differed only in the order
        // of their sums (issue 44).
        window = end / PROBE_ROWS,
    );
    let mut scene = Scene::parse(&text, "still_water (generated)")
        .expect("generated still-water scene is valid");
    // A pressure study against fixed walls: a method may ask for other than its defaults
    // (DFSPH: its pressure-change stop).
    if let Some(text) = study_table(solver, STILL_WATER_STUDY) {
        let table = toml::from_str(text).expect("valid table");
        if let Some(f) = scene.fluid.as_mut() {
            f.solvers.insert(solver.into(), toml::Value::Table(table));
        }
    }
    scene
}

/// Rows of `probes.csv` over a run: the recorder writes one every `[output] interval`/50, and
/// the case's interval is the whole run.
pub const PROBE_ROWS: f64 = 50.0;

/// The study name the still-water case asks the methods' tables for
/// ([`shared::registry::Advice::study_table`]).
pub const STILL_WATER_STUDY: &str = "still_water";

/// Solver `solver`'s table for validation study `study`, if it asks for one.
pub fn study_table(solver: &str, study: &str) -> Option<&'static str> {
    REGISTRY
        .get(solver)
        .ok()
        .and_then(|e| (e.advice.study_table)(study))
}

/// Result of a still-water run.
#[derive(Debug, Clone)]
pub struct StillWater {
    /// (depth below the initial surface over depth, measured p, hydrostatic ρ0 g (η − z)) at the
    /// probes, averaged over the second half of the run.
    pub probes: Vec<(f64, f64, f64)>,
    /// Largest |p − p_ref| over ρ0 g H.
    pub max_error: f64,
    /// Mean free-surface elevation over the second half, and the initial depth.
    pub surface: f64,
    pub depth: f64,
    pub particles: usize,
    pub steps: u64,
}

impl StillWater {
    /// The probe farthest from hydrostatic: (depth over H, measured p, reference p).
    pub fn worst_probe(&self) -> (f64, f64, f64) {
        self.probes
            .iter()
            .copied()
            .fold((0.0, 0.0, 0.0), |worst, x| {
                if (x.1 - x.2).abs() > (worst.1 - worst.2).abs() {
                    x
                } else {
                    worst
                }
            })
    }
}

/// Runs still water and reads the probe and gauge CSV files the solver wrote.
pub fn still_water(
    solver: &str,
    depth: f64,
    dx: f64,
    end: f64,
    walls: Option<Walls>,
) -> Result<StillWater, SolverError> {
    let scene = still_water_scene(solver, depth, dx, end, walls);
    still_water_run(&scene, depth, end)
}

/// Runs a still-water scene of [`still_water_scene`] (perhaps changed: its domain moved to
/// shift the neighbour grid's cells, its solver table) and reads its files ([`hydrostatics`]).
pub fn still_water_run(scene: &Scene, depth: f64, end: f64) -> Result<StillWater, SolverError> {
    let solver = scene.fluid.as_ref().expect("fluid").solver.as_str();
    let dir = TempRunDir::new("still")?;
    let mut s = build(solver, scene, dir.path())?;
    let particles = s.system().len();
    let steps = run(s.as_mut(), scene, end, |_, _| {})?;
    drop(s);
    hydrostatics(dir.path(), scene, depth, end, particles, steps)
}

/// Reads a still-water run's files: the free surface at the first gauge and the pressure at
/// the three probes (0.75, 0.5 and 0.25 of `depth` above z = 0), each averaged over the second
/// half of the run, against ρ0 g (η − z).
pub fn hydrostatics(
    dir: &Path,
    scene: &Scene,
    depth: f64,
    end: f64,
    particles: usize,
    steps: u64,
) -> Result<StillWater, SolverError> {
    let gauges = read_csv(&dir.join("gauges.csv"))?;
    let probes = read_csv(&dir.join("probes.csv"))?;
    let late = |rows: &[Vec<f64>], col: usize| {
        let sel: Vec<f64> = rows
            .iter()
            .filter(|r| r[0] >= 0.5 * end)
            .map(|r| r[col])
            .collect();
        sel.iter().sum::<f64>() / sel.len().max(1) as f64
    };
    let surface = late(&gauges, 1);
    let fluid = scene.fluid.as_ref().expect("fluid");
    let rho_g = fluid.density * scene.gravity[2].abs();
    let zs = [0.75 * depth, 0.5 * depth, 0.25 * depth];
    let probes: Vec<(f64, f64, f64)> = zs
        .iter()
        .enumerate()
        .map(|(k, &z)| {
            (
                (depth - z) / depth,
                late(&probes, k + 1),
                rho_g * (surface - z),
            )
        })
        .collect();
    let max_error = probes
        .iter()
        .map(|(_, p, r)| (p - r).abs() / (rho_g * depth))
        .fold(0.0, f64::max);
    Ok(StillWater {
        probes,
        max_error,
        surface,
        depth,
        particles,
        steps,
    })
}

pub(crate) fn read_csv(path: &Path) -> Result<Vec<Vec<f64>>, SolverError> {
    let text = std::fs::read_to_string(path)?;
    Ok(text
        .lines()
        .skip(1)
        .map(|l| {
            l.split(',')
                .map(|v| v.parse::<f64>().unwrap_or(f64::NAN))
                .collect()
        })
        .collect())
}
