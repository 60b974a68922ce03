//! Validation cases with published or exact references, run in-process through the
//! [`FluidSolver`] interface (no coupler, no shared memory): the `fluid-validate` command runs
//! them at the documented resolutions and the tests at coarse ones.
//!
//! - Still water: pressure against depth, p = ρ0 g (η − z) (DESIGN §8).
//! - Dam break (Martin & Moyce 1952, n² = H/a = 2 and 1): surge front Z = x/a against
//!   T = n·t·sqrt(g/a) at the published points, and self-convergence over three resolutions.
//!
//! Both are thin 3D slabs (a few particle layers between free-slip side walls), i.e. 2D flows
//! at a 3D code's cost of a 2D problem.

use crate::muller::Muller;
use crate::system::FluidSystem;
use crate::wcsph::Wcsph;
use shared::protocol::BlockLoad;
use shared::scene::{Scene, Scheme};
use shared::solver::{FluidSolver, SetupContext, SolverError};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicUsize, Ordering};

/// An SPH solver whose particles the validation can look at.
pub trait SphSolver: FluidSolver {
    fn system(&self) -> &FluidSystem;
}

impl SphSolver for Muller {
    fn system(&self) -> &FluidSystem {
        &self.sys
    }
}

impl SphSolver for Wcsph {
    fn system(&self) -> &FluidSystem {
        &self.sys
    }
}

/// Builds a solver by name, with access to its particles.
pub fn build_sph(name: &str, ctx: &SetupContext) -> Result<Box<dyn SphSolver>, SolverError> {
    match name {
        "muller" => Ok(Box::new(Muller::new(ctx)?)),
        "wcsph" => Ok(Box::new(Wcsph::new(ctx)?)),
        other => Err(SolverError::Failed(format!(
            "unknown fluid solver '{other}'"
        ))),
    }
}

/// A scratch run directory, removed on drop.
pub struct TempRunDir(PathBuf);

impl TempRunDir {
    pub fn new(tag: &str) -> std::io::Result<Self> {
        static COUNTER: AtomicUsize = AtomicUsize::new(0);
        let n = COUNTER.fetch_add(1, Ordering::Relaxed);
        let dir =
            std::env::temp_dir().join(format!("rockwave-fluid-{tag}-{}-{n}", std::process::id()));
        std::fs::create_dir_all(&dir)?;
        Ok(Self(dir))
    }
    pub fn path(&self) -> &Path {
        &self.0
    }
}

impl Drop for TempRunDir {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.0);
    }
}

/// Drives a solver the way the node runtime does (write_loads, advance by the proposed dt)
/// until `end`, calling `observe` after every step.
pub fn run(
    solver: &mut dyn SphSolver,
    scene: &Scene,
    end: f64,
    mut observe: impl FnMut(&dyn SphSolver, f64),
) -> Result<u64, SolverError> {
    let mut loads = vec![BlockLoad::default(); scene.moving_blocks().len()];
    let mut t = 0.0;
    let mut steps = 0;
    observe(solver, t);
    while t < end - 1e-12 {
        solver.write_loads(&mut loads);
        let dt = solver.dt_proposal().min(scene.time.dt_max).min(end - t);
        solver.advance(dt)?;
        t += dt;
        steps += 1;
        observe(solver, t);
    }
    solver.finish()?;
    Ok(steps)
}

/// A slab tank: floor, end walls at x = 0 and x = length, free-slip side walls at y = 0 and y = width.
fn tank(length: f64, width: f64, height: f64, t: f64) -> String {
    let blk = |name: &str, min: [f64; 3], max: [f64; 3]| {
        format!(
            "[[block]]\nname = \"{name}\"\nkind = \"fixed\"\nshape = {{ type = \"box\", min = {min:?}, max = {max:?} }}\n\n"
        )
    };
    let (l, w, h) = (length, width, height);
    [
        blk("floor", [-t, -t, -t], [l + t, w + t, 0.0]),
        blk("left_wall", [-t, -t, -t], [0.0, w + t, h]),
        blk("right_wall", [l, -t, -t], [l + t, w + t, h]),
        blk("south_wall", [-t, -t, -t], [l + t, 0.0, h]),
        blk("north_wall", [-t, w, -t], [l + t, w + t, h]),
    ]
    .concat()
}

fn fluid_table(solver: &str, dx: f64, walls: Option<&str>) -> String {
    let walls = walls
        .map(|w| format!("walls = \"{w}\"\n"))
        .unwrap_or_default();
    format!("[fluid]\nsolver = \"{solver}\"\ndx = {dx}\n{walls}")
}

// ---------------------------------------------------------------------------------------------
// Still water

/// Still water: a box of water of depth `depth` at rest in a closed tank.
pub fn still_water_scene(
    solver: &str,
    depth: f64,
    dx: f64,
    end: f64,
    walls: Option<&str>,
) -> Scene {
    let (l, w) = (2.0 * depth, depth);
    let text = format!(
        "name = \"still_water\"\n[time]\nend = {end}\ndt_max = 1e-3\n[domain]\nmin = [0.0, 0.0, 0.0]\nmax = [{l}, {w}, {h}]\n\
         [output]\ninterval = {end}\n{fluid}\n[[fluid.water]]\nshape = {{ type = \"box\", min = [0.0, 0.0, 0.0], max = [{l}, {w}, {depth}] }}\n\n\
         {tank}\
         [[gauge]]\nname = \"centre\"\nx = {cx}\ny = {cy}\n\n\
         [[probe]]\nname = \"p25\"\nposition = [{cx}, {cy}, {z75}]\n\n\
         [[probe]]\nname = \"p50\"\nposition = [{cx}, {cy}, {z50}]\n\n\
         [[probe]]\nname = \"p75\"\nposition = [{cx}, {cy}, {z25}]\n",
        h = 2.0 * depth,
        fluid = fluid_table(solver, dx, walls),
        tank = tank(l, w, 2.0 * depth, 0.2 * depth),
        cx = 0.5 * l + 0.25 * dx,
        cy = 0.5 * w + 0.25 * dx,
        z75 = 0.75 * depth,
        z50 = 0.5 * depth,
        z25 = 0.25 * depth,
    );
    Scene::parse(&text, "still_water (generated)").expect("generated still-water scene is valid")
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

/// Runs still water and reads the probe and gauge CSV files the solver wrote.
pub fn still_water(
    solver: &str,
    depth: f64,
    dx: f64,
    end: f64,
    walls: Option<&str>,
) -> Result<StillWater, SolverError> {
    let scene = still_water_scene(solver, depth, dx, end, walls);
    let dir = TempRunDir::new("still")?;
    let ctx = SetupContext {
        scene: &scene,
        run_dir: dir.path(),
        scheme: Scheme::Parallel,
        peer_present: false,
    };
    let mut s = build_sph(solver, &ctx)?;
    let particles = s.system().len();
    let steps = run(s.as_mut(), &scene, end, |_, _| {})?;
    drop(s);
    let gauges = read_csv(&dir.path().join("gauges.csv"))?;
    let probes = read_csv(&dir.path().join("probes.csv"))?;
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

fn read_csv(path: &Path) -> Result<Vec<Vec<f64>>, SolverError> {
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

// ---------------------------------------------------------------------------------------------
// Dam break

/// Martin & Moyce (1952) surge-front points (T, Z) for n² = 2 (DESIGN §8).
pub const MARTIN_MOYCE_N2_2: &[(f64, f64)] = &[
    (0.41, 1.11),
    (0.84, 1.22),
    (1.19, 1.44),
    (1.43, 1.67),
    (1.63, 1.89),
    (1.83, 2.11),
    (1.98, 2.33),
    (2.20, 2.56),
    (2.32, 2.78),
    (2.51, 3.00),
    (2.65, 3.22),
    (2.83, 3.44),
    (2.98, 3.67),
    (3.11, 3.89),
    (3.33, 4.11),
];

/// Martin & Moyce (1952) surge-front points (T, Z) for n² = 1 (DESIGN §8).
pub const MARTIN_MOYCE_N2_1: &[(f64, f64)] = &[
    (0.43, 1.11),
    (0.62, 1.22),
    (0.80, 1.44),
    (0.97, 1.67),
    (1.14, 1.89),
    (1.29, 2.11),
    (1.45, 2.33),
    (1.62, 2.56),
    (1.76, 2.78),
    (1.93, 3.00),
    (2.07, 3.22),
    (2.24, 3.44),
    (2.40, 3.67),
    (2.54, 3.89),
    (2.71, 4.11),
    (2.87, 4.33),
];

/// The published points for n² (2 or 1).
pub fn martin_moyce(n2: u32) -> &'static [(f64, f64)] {
    if n2 == 2 {
        MARTIN_MOYCE_N2_2
    } else {
        MARTIN_MOYCE_N2_1
    }
}

/// Particle layers across the slab.
pub const SLAB_LAYERS: usize = 4;

/// The dam-break scene: a column a wide and n²·a high at the left end of a 5.5·a tank.
pub fn dam_break_scene(solver: &str, n2: u32, a: f64, per_a: usize, walls: Option<&str>) -> Scene {
    let dx = a / per_a as f64;
    let height = n2 as f64 * a;
    let (l, w) = (5.5 * a, SLAB_LAYERS as f64 * dx);
    let top = 2.5 * height;
    let end = dam_break_end(n2, a) * 1.01;
    let text = format!(
        "name = \"dam_break\"\n[time]\nend = {end}\ndt_max = 1e-3\n[domain]\nmin = [0.0, 0.0, 0.0]\nmax = [{l}, {w}, {top}]\n\
         [output]\ninterval = {end}\n{fluid}\n[[fluid.water]]\nshape = {{ type = \"box\", min = [0.0, 0.0, 0.0], max = [{a}, {w}, {height}] }}\n\n{tank}",
        fluid = fluid_table(solver, dx, walls),
        tank = tank(l, w, top, 0.2 * a),
    );
    Scene::parse(&text, "dam_break (generated)").expect("generated dam-break scene is valid")
}

/// Simulated time that covers the published points: t = T_last/(n·sqrt(g/a)).
pub fn dam_break_end(n2: u32, a: f64) -> f64 {
    let t_last = martin_moyce(n2).last().expect("points").0;
    t_last / ((n2 as f64).sqrt() * (9.81 / a).sqrt())
}

/// A dam-break run: the front Z(T) after every step.
#[derive(Debug, Clone)]
pub struct DamBreak {
    pub n2: u32,
    pub per_a: usize,
    pub curve: Vec<(f64, f64)>,
    pub particles: usize,
    pub steps: u64,
    pub seconds: f64,
}

impl DamBreak {
    /// Z at T by linear interpolation of the recorded curve.
    pub fn front_at(&self, t: f64) -> f64 {
        let c = &self.curve;
        let k = c.partition_point(|p| p.0 < t).clamp(1, c.len() - 1);
        let (a, b) = (c[k - 1], c[k]);
        let s = if b.0 > a.0 {
            ((t - a.0) / (b.0 - a.0)).clamp(0.0, 1.0)
        } else {
            1.0
        };
        a.1 + s * (b.1 - a.1)
    }

    /// Relative deviation (Z_sim − Z_ref)/Z_ref at each published point.
    pub fn deviations(&self) -> Vec<f64> {
        martin_moyce(self.n2)
            .iter()
            .map(|&(t, z)| (self.front_at(t) - z) / z)
            .collect()
    }

    /// Mean signed relative deviation from the published front (positive: ahead).
    pub fn mean_deviation(&self) -> f64 {
        let d = self.deviations();
        d.iter().sum::<f64>() / d.len() as f64
    }
}

/// Runs a dam break with a = 0.1 m and `per_a` particles across the column.
pub fn dam_break(
    solver: &str,
    n2: u32,
    per_a: usize,
    walls: Option<&str>,
) -> Result<DamBreak, SolverError> {
    let a = 0.1;
    let scene = dam_break_scene(solver, n2, a, per_a, walls);
    let dir = TempRunDir::new("dambreak")?;
    let ctx = SetupContext {
        scene: &scene,
        run_dir: dir.path(),
        scheme: Scheme::Parallel,
        peer_present: false,
    };
    let mut s = build_sph(solver, &ctx)?;
    let particles = s.system().len();
    let dx = a / per_a as f64;
    let scale = (n2 as f64).sqrt() * (9.81 / a).sqrt();
    let mut curve = Vec::new();
    let start = std::time::Instant::now();
    let steps = run(s.as_mut(), &scene, dam_break_end(n2, a) * 1.01, |s, t| {
        let front = s
            .system()
            .particles
            .position
            .iter()
            .map(|p| p.x)
            .fold(f64::NEG_INFINITY, f64::max)
            + 0.5 * dx;
        curve.push((t * scale, front / a));
    })?;
    Ok(DamBreak {
        n2,
        per_a,
        curve,
        particles,
        steps,
        seconds: start.elapsed().as_secs_f64(),
    })
}

/// Self-convergence of three runs at spacings dx, dx/2, dx/4: the mean |ΔZ| between successive
/// resolutions over the published T points, and the observed order log2(e_coarse/e_fine).
pub fn self_convergence(runs: &[DamBreak; 3]) -> (f64, f64, f64) {
    let ts: Vec<f64> = martin_moyce(runs[0].n2).iter().map(|p| p.0).collect();
    let diff = |a: &DamBreak, b: &DamBreak| {
        ts.iter()
            .map(|&t| (a.front_at(t) - b.front_at(t)).abs())
            .sum::<f64>()
            / ts.len() as f64
    };
    let e1 = diff(&runs[0], &runs[1]);
    let e2 = diff(&runs[1], &runs[2]);
    (e1, e2, (e1 / e2).log2())
}

// ---------------------------------------------------------------------------------------------
// The table

/// Tolerance on the mean signed deviation of the dam-break front from Martin & Moyce: converged
/// WCSPH runs 5–15 % ahead of the experiment (no gate, no bed friction; DESIGN §8), a coarse
/// run a few per cent more; behind by more than 5 % or ahead by more than 20 % is a failure.
pub const FRONT_MEAN_BAND: (f64, f64) = (-0.05, 0.20);
/// Tolerance on the largest deviation at any published point.
pub const FRONT_MAX_DEVIATION: f64 = 0.30;
/// Tolerance on hydrostatic pressure error, over ρ0 g H.
pub const HYDROSTATIC_TOLERANCE: f64 = 0.05;

pub use shared::report::Row;

/// Resolutions of a validation run.
#[derive(Debug, Clone, Copy)]
pub struct Plan {
    /// Still water: depth over dx.
    pub still_per_depth: usize,
    /// Still water: simulated seconds.
    pub still_end: f64,
    /// Dam break: the three particles-per-a of the self-convergence study (the finest is
    /// compared with Martin & Moyce).
    pub dam_per_a: [usize; 3],
}

impl Plan {
    /// `fluid-validate`: the documented resolutions.
    pub const FULL: Plan = Plan {
        still_per_depth: 12,
        still_end: 0.5,
        dam_per_a: [6, 12, 24],
    };
    /// `fluid-validate --quick`.
    pub const QUICK: Plan = Plan {
        still_per_depth: 8,
        still_end: 0.3,
        dam_per_a: [4, 8, 16],
    };
}

/// Runs every case for `solver` and returns its rows; `log` receives progress lines.
pub fn validate_solver(
    solver: &str,
    plan: &Plan,
    walls: Option<&str>,
    mut log: impl FnMut(&str),
) -> Vec<Row> {
    let mut rows = Vec::new();
    let label = match walls {
        Some(w) => format!("{solver} (walls = {w})"),
        None => solver.to_string(),
    };
    let depth = 0.1;
    let dx = depth / plan.still_per_depth as f64;
    match still_water(solver, depth, dx, plan.still_end, walls) {
        Ok(s) => {
            log(&format!(
                "still water {label}: {} particles, {} steps, error {:.3}",
                s.particles, s.steps, s.max_error
            ));
            let (d, p, r) = s
                .probes
                .iter()
                .copied()
                .fold((0.0f64, 0.0f64, 0.0f64), |acc, x| {
                    if (x.1 - x.2).abs() > (acc.1 - acc.2).abs() {
                        x
                    } else {
                        acc
                    }
                });
            rows.push(Row {
                case: format!(
                    "still water, H = {depth} m, dx = H/{}",
                    plan.still_per_depth
                ),
                solver: label.clone(),
                quantity: format!(
                    "pressure at depth {:.2}·H (worst of 0.25, 0.5, 0.75) [Pa]",
                    d
                ),
                reference: format!("{r:.1} (ρ0 g (η − z))"),
                measured: format!("{p:.1}"),
                error: format!("{:.1} % of ρ0 g H", 100.0 * s.max_error),
                tolerance: format!("{:.0} %", 100.0 * HYDROSTATIC_TOLERANCE),
                pass: s.max_error <= HYDROSTATIC_TOLERANCE,
            });
            let surf = (s.surface - s.depth) / dx;
            rows.push(Row {
                case: format!(
                    "still water, H = {depth} m, dx = H/{}",
                    plan.still_per_depth
                ),
                solver: label.clone(),
                quantity: "free surface η (gauge) [m]".into(),
                reference: format!("{:.4}", s.depth),
                measured: format!("{:.4}", s.surface),
                error: format!("{surf:+.2} dx"),
                tolerance: "±1 dx".into(),
                pass: surf.abs() <= 1.0,
            });
        }
        Err(e) => rows.push(failed_row("still water", &label, &e)),
    }
    for n2 in [2u32, 1] {
        let mut runs = Vec::new();
        for &per_a in &plan.dam_per_a {
            match dam_break(solver, n2, per_a, walls) {
                Ok(r) => {
                    log(&format!(
                        "dam break n²={n2} {label} a/dx={per_a}: {} particles, {} steps, {:.1} s, mean deviation {:+.3}",
                        r.particles,
                        r.steps,
                        r.seconds,
                        r.mean_deviation()
                    ));
                    runs.push(r);
                }
                Err(e) => {
                    rows.push(failed_row(
                        &format!("dam break n² = {n2}, a/dx = {per_a}"),
                        &label,
                        &e,
                    ));
                    break;
                }
            }
        }
        if let Some(fine) = runs.last() {
            let dev = fine.deviations();
            let mean = fine.mean_deviation();
            let worst = dev
                .iter()
                .copied()
                .fold(0.0, |m: f64, d| if d.abs() > m.abs() { d } else { m });
            let case = format!("dam break n² = {n2}, a = 0.1 m, a/dx = {}", fine.per_a);
            rows.push(Row {
                case: case.clone(),
                solver: label.clone(),
                quantity: format!(
                    "front Z = x/a, mean signed deviation over {} points",
                    dev.len()
                ),
                reference: "Martin & Moyce 1952".into(),
                measured: format!("{:+.1} %", 100.0 * mean),
                error: format!("{:+.1} %", 100.0 * mean),
                tolerance: format!(
                    "[{:+.0} %, {:+.0} %]",
                    100.0 * FRONT_MEAN_BAND.0,
                    100.0 * FRONT_MEAN_BAND.1
                ),
                pass: mean >= FRONT_MEAN_BAND.0 && mean <= FRONT_MEAN_BAND.1,
            });
            let (t_last, z_last) = *martin_moyce(n2).last().expect("points");
            rows.push(Row {
                case: case.clone(),
                solver: label.clone(),
                quantity: format!(
                    "front Z, worst point (last: Z({t_last}) = {:.2})",
                    fine.front_at(t_last)
                ),
                reference: format!("Z({t_last}) = {z_last}"),
                measured: format!("{:+.1} %", 100.0 * worst),
                error: format!("{:+.1} %", 100.0 * worst),
                tolerance: format!("±{:.0} %", 100.0 * FRONT_MAX_DEVIATION),
                pass: worst.abs() <= FRONT_MAX_DEVIATION,
            });
        }
        if let Ok(three) = <[DamBreak; 3]>::try_from(runs) {
            let (e1, e2, order) = self_convergence(&three);
            rows.push(Row {
                case: format!("dam break n² = {n2}, a/dx = {:?}", plan.dam_per_a),
                solver: label.clone(),
                quantity: "self-convergence: mean |ΔZ| coarse→mid, mid→fine; observed order".into(),
                reference: "ΔZ shrinks with dx".into(),
                measured: format!("{e1:.3} → {e2:.3}"),
                error: format!("order {order:.2}"),
                tolerance: "order > 0".into(),
                pass: e2 < e1,
            });
        }
    }
    rows
}

fn failed_row(case: &str, solver: &str, e: &SolverError) -> Row {
    Row {
        case: case.into(),
        solver: solver.into(),
        quantity: "run".into(),
        reference: "completes".into(),
        measured: e.to_string(),
        error: "-".into(),
        tolerance: "-".into(),
        pass: false,
    }
}

pub use shared::report::markdown;
