//! `coupler terrain-bench`: what a terrain of many triangles costs per step against the same
//! scene with a box floor, for each node alone (in-process, as `fluid-bench`/`solid-bench`).
//!
//! - fluid: still water 0.5 m deep in a 2 m × 1 m tank (dx = 0.03 m) whose floor is a fixed box,
//!   or a flat DEM of about N triangles at the same height;
//! - solid: a 5 × 5 grid of free 0.2 m cubes resting on a fixed box floor, or on the same flat
//!   DEM.
//!
//! The terrain is flat so both variants are the same physics: only the triangle count differs.
//! Printed per variant: the set-up time (reading and checking the terrain, sampling its
//! boundary particles) and the mean wall time of a step after warm-up, in rounds (each variant
//! timed in turn, round after round, so a change of the machine's load hits all alike): the
//! best and the median round.

use clap::Args;
use shared::scene::Scene;
use shared::terrain::dem::Grid;
use std::path::Path;
use std::time::Instant;

#[derive(Debug, Args)]
pub struct TerrainBenchArgs {
    /// Terrain sizes to time, in triangles (about: the DEM is a whole number of cells).
    #[arg(
        long,
        allow_hyphen_values = true,
        value_delimiter = ',',
        default_value = "100000,1000000"
    )]
    pub triangles: Vec<usize>,
    /// Timed fluid steps per variant and round.
    #[arg(long, allow_hyphen_values = true, default_value_t = 20)]
    pub fluid_steps: usize,
    /// Timed solid steps per variant and round.
    #[arg(long, allow_hyphen_values = true, default_value_t = 2000)]
    pub solid_steps: usize,
    /// Rounds: each variant is timed once per round, in turn.
    #[arg(long, allow_hyphen_values = true, default_value_t = 5)]
    pub rounds: usize,
    /// Instead of timing steps: write a survey-scale DEM of N × N cells of 1 m (a GeoTIFF in
    /// strips of 16 rows, deflate; and an ESRI grid when N ≤ 2000) into --survey-dir, with the
    /// scenes that load it (`whole.toml`: the ESRI grid uncropped; `cropped.toml`: the GeoTIFF
    /// cropped to its central 1000 × 1000 cells), for `coupler check` to be timed on.
    #[arg(long)]
    pub survey: Option<u32>,
    /// Where --survey writes.
    #[arg(long, default_value = "survey")]
    pub survey_dir: std::path::PathBuf,
}

const TANK: (f64, f64) = (2.0, 1.0);

/// A flat DEM at z = 0 over the tank and 0.1 m past it, of about `triangles` triangles.
fn flat_dem(dir: &Path, triangles: usize) -> std::path::PathBuf {
    let (lx, ly) = (TANK.0 + 0.2, TANK.1 + 0.2);
    // 2 (nx − 1)(ny − 1) = N with square cells.
    let cell = (2.0 * lx * ly / triangles as f64).sqrt();
    let n = |l: f64| (l / cell).round() as usize + 1;
    let g = Grid::from_fn(n(lx), n(ly), -0.1, -0.1, cell, |_, _| 0.0);
    let file = dir.join(format!("flat_{triangles}.asc"));
    std::fs::write(&file, g.to_asc()).expect("write the DEM");
    file
}

fn box_toml(name: &str, min: [f64; 3], max: [f64; 3]) -> String {
    format!(
        "[[block]]\nname = \"{name}\"\nkind = \"fixed\"\nshape = {{ type = \"box\", min = {min:?}, max = {max:?} }}\n\n"
    )
}

fn floor(terrain: Option<&Path>) -> String {
    let t = 0.1;
    match terrain {
        None => box_toml("floor", [-t, -t, -t], [TANK.0 + t, TANK.1 + t, 0.0]),
        Some(f) => format!(
            "[[terrain]]\nname = \"flat\"\nfile = {:?}\n\n",
            f.display().to_string()
        ),
    }
}

fn fluid_scene(terrain: Option<&Path>) -> Scene {
    let (l, w, h, t) = (TANK.0, TANK.1, 1.0, 0.1);
    let walls = [
        box_toml("left", [-t, -t, -t], [0.0, w + t, h]),
        box_toml("right", [l, -t, -t], [l + t, w + t, h]),
        box_toml("south", [-t, -t, -t], [l + t, 0.0, h]),
        box_toml("north", [-t, w, -t], [l + t, w + t, h]),
    ]
    .concat();
    let text = format!(
        "name = \"terrain_bench\"\n[time]\nend = 1.0\n[domain]\nmin = [0.0, 0.0, -0.05]\nmax = [{l}, {w}, {h}]\n\
         [output]\ninterval = 1.0\nvtk = false\n[fluid]\ndx = 0.03\n[[fluid.water]]\nshape = {{ type = \"box\", min = [0.0, 0.0, 0.0], max = [{l}, {w}, 0.51] }}\n\n{}{walls}",
        floor(terrain)
    );
    Scene::parse(&text, "terrain bench (generated)").expect("bench scene is valid")
}

fn solid_scene(terrain: Option<&Path>) -> Scene {
    let mut blocks = String::new();
    for i in 0..5 {
        for j in 0..5 {
            let (x, y) = (0.2 + 0.35 * i as f64, 0.1 + 0.2 * j as f64 - 0.05);
            blocks += &format!(
                "[[block]]\nname = \"b{i}{j}\"\nshape = {{ type = \"box\", min = [{x}, {y}, 0.0], max = [{}, {}, 0.1] }}\n\n",
                x + 0.1,
                y + 0.1
            );
        }
    }
    let text = format!(
        "name = \"terrain_bench_solid\"\n[time]\nend = 10.0\n[domain]\nmin = [0.0, 0.0, -0.5]\nmax = [2.0, 1.0, 1.0]\n\
         [output]\ninterval = 10.0\nvtk = false\n[solid.contact]\ndamping_ratio = 0.2\n\n{}{blocks}",
        floor(terrain)
    );
    Scene::parse(&text, "terrain bench (generated)").expect("bench scene is valid")
}

/// One variant being timed: a solver built for it, and its times.
struct Timed<S> {
    label: String,
    triangles: usize,
    setup: f64,
    solver: S,
    /// Mean step time of each round [ms].
    rounds: Vec<f64>,
}

fn fluid_step(s: &mut dyn fluid_node::sph::SphSolver, dt_max: f64) -> Result<(), String> {
    s.write_loads(&mut []);
    let dt = s.dt_proposal().min(dt_max);
    s.advance(dt).map(|_| ()).map_err(|e| e.to_string())
}

/// The mean of `steps` steps of `step`, in ms.
fn time_steps(steps: usize, mut step: impl FnMut() -> Result<(), String>) -> Result<f64, String> {
    let t = Instant::now();
    for _ in 0..steps {
        step()?;
    }
    Ok(1e3 * t.elapsed().as_secs_f64() / steps as f64)
}

fn row<S>(node: &str, v: &Timed<S>, count: usize) -> String {
    let mut r = v.rounds.clone();
    r.sort_by(f64::total_cmp);
    format!(
        "| {node} | {} | {} | {:.2} | {:.3} | {:.3} | {count} |",
        v.label,
        v.triangles,
        v.setup,
        r[0],
        r[r.len() / 2]
    )
}

/// Runs the bench and prints a markdown table; the exit code.
pub fn run(args: TerrainBenchArgs) -> u8 {
    if let Some(n) = args.survey {
        return match survey(n, &args.survey_dir) {
            Ok(()) => 0,
            Err(e) => {
                eprintln!("coupler: error: {e}");
                1
            }
        };
    }
    match bench(&args) {
        Ok(rows) => {
            println!("{}", rows.join("\n"));
            0
        }
        Err(e) => {
            eprintln!("coupler: error: {e}");
            1
        }
    }
}

/// Rolling ground: a few metres of relief over the survey, 1 m cells.
fn survey_z(x: f64, y: f64) -> f64 {
    2.0 * (x * 0.013).sin() * (y * 0.011).cos() + 0.5 * (x * 0.07 + y * 0.05).sin()
}

/// The files of `--survey`.
fn survey(n: u32, dir: &Path) -> Result<(), String> {
    const STRIP_ROWS: u32 = 16;
    const KEPT: f64 = 1000.0;
    if n < 2 {
        return Err(format!("--survey {n}: give at least 2 cells"));
    }
    std::fs::create_dir_all(dir).map_err(|e| format!("cannot create {}: {e}", dir.display()))?;
    let side = n as f64;
    let grid = (n <= 2000).then(|| Grid::from_fn(n as usize, n as usize, 0.5, 0.5, 1.0, survey_z));
    let mut z = Vec::with_capacity(n as usize * n as usize);
    for r in 0..n {
        let y = side - 0.5 - r as f64;
        z.extend((0..n).map(|c| survey_z(c as f64 + 0.5, y) as f32));
    }
    let tif = dir.join("survey.tif");
    shared::terrain::geotiff::write(&tif, (n, n), [0.0, side], 1.0, STRIP_ROWS, true, &z)?;
    drop(z);
    let scene = |terrain: &str, lo: f64, hi: f64, crop: bool| {
        let crop = if crop {
            format!("crop = {{ min = [{lo}, {lo}, -10], max = [{hi}, {hi}, 10] }}\n")
        } else {
            String::new()
        };
        format!(
            "name = \"survey\"\n[time]\nend = 0.1\n[domain]\nmin = [{lo}, {lo}, -10]\nmax = [{hi}, {hi}, 10]\n\n[[terrain]]\nname = \"ground\"\nfile = \"{terrain}\"\n{crop}"
        )
    };
    let write = |name: &str, text: String| {
        std::fs::write(dir.join(name), text).map_err(|e| format!("cannot write {name}: {e}"))
    };
    let (lo, hi) = (0.5 * (side - KEPT.min(side)), 0.5 * (side + KEPT.min(side)));
    write("cropped.toml", scene("survey.tif", lo, hi, true))?;
    if let Some(g) = grid {
        write("survey.asc", g.to_asc())?;
        write("whole.toml", scene("survey.asc", 0.5, side - 0.5, false))?;
    }
    println!("wrote {n} × {n} cells into {}", dir.display());
    Ok(())
}

fn bench(args: &TerrainBenchArgs) -> Result<Vec<String>, String> {
    let dir = std::env::temp_dir().join(format!("rockwave-terrain-bench-{}", std::process::id()));
    std::fs::create_dir_all(&dir).map_err(|e| e.to_string())?;
    let mut variants: Vec<(String, Option<std::path::PathBuf>)> = vec![("box".into(), None)];
    for &n in &args.triangles {
        variants.push(("terrain (flat DEM)".into(), Some(flat_dem(&dir, n))));
    }
    let mut rows = vec![
        "| node | floor | triangles | set-up [s] | step, best round [ms] | step, median round [ms] | boundary particles / contacts |".to_string(),
        "|---|---|---|---|---|---|---|".to_string(),
    ];
    // Fluid: every variant built, then timed in turn, round after round, so a change of the
    // machine's load hits them all alike; the best and the median round are reported.
    let run_dirs: Vec<fluid_node::validation::TempRunDir> = variants
        .iter()
        .map(|_| {
            fluid_node::validation::TempRunDir::new("terrain-bench").map_err(|e| e.to_string())
        })
        .collect::<Result<_, _>>()?;
    let mut fluid = Vec::new();
    for ((label, file), d) in variants.iter().zip(&run_dirs) {
        let scene = fluid_scene(file.as_deref());
        let t0 = Instant::now();
        let mut solver =
            fluid_node::validation::build(fluid_node::REGISTRY.first().name, &scene, d.path())
                .map_err(|e| e.to_string())?;
        let setup = t0.elapsed().as_secs_f64();
        for _ in 0..5 {
            fluid_step(solver.as_mut(), scene.time.dt_max)?;
        }
        fluid.push(Timed {
            label: label.clone(),
            triangles: triangles(&scene),
            setup,
            solver,
            rounds: Vec::new(),
        });
    }
    for _ in 0..args.rounds {
        for v in fluid.iter_mut() {
            let s = &mut v.solver;
            v.rounds.push(time_steps(args.fluid_steps, || {
                fluid_step(s.as_mut(), 1e-3)
            })?);
        }
    }
    for v in &fluid {
        let r = row("fluid", v, v.solver.system().boundary.counts().0);
        eprintln!("{r}");
        rows.push(r);
    }
    drop(fluid);
    let mut solid = Vec::new();
    for (label, file) in &variants {
        let scene = solid_scene(file.as_deref());
        let t0 = Instant::now();
        let mut h =
            solid_node::verification::Harness::new(&scene, solid_node::verification::EXPLICIT)
                .map_err(|e| e.to_string())?;
        let setup = t0.elapsed().as_secs_f64();
        let rule = h.rule;
        for _ in 0..50 {
            h.step(&rule, f64::INFINITY).map_err(|e| e.to_string())?;
        }
        solid.push(Timed {
            label: label.clone(),
            triangles: triangles(&scene),
            setup,
            solver: h,
            rounds: Vec::new(),
        });
    }
    for _ in 0..args.rounds {
        for v in solid.iter_mut() {
            let h = &mut v.solver;
            let rule = h.rule;
            v.rounds.push(time_steps(args.solid_steps, || {
                h.step(&rule, f64::INFINITY)
                    .map(|_| ())
                    .map_err(|e| e.to_string())
            })?);
        }
    }
    for v in &solid {
        let r = row("solid", v, v.solver.world().contacts.len());
        eprintln!("{r}");
        rows.push(r);
    }
    let _ = std::fs::remove_dir_all(&dir);
    Ok(rows)
}

/// Triangles of the scene's terrain (12 for the box floor).
fn triangles(scene: &Scene) -> usize {
    shared::terrain::Terrain::load_all(scene)
        .ok()
        .and_then(|t| t.first().map(|t| t.triangles()))
        .unwrap_or(12)
}
