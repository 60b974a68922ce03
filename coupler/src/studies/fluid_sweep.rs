//! The fluid-only sweeps, in-process through `fluid_node::validation` (no coupler, no shared
//! memory: nothing to couple): the Martin & Moyce dam break (n² = 2, a = 0.1 m) at a given
//! resolution with every step multiplied by a dt factor.

use fluid_node::sph::SphSolver;
use fluid_node::validation::{self, DamBreak};
use shared::coupling::step::StepRule;
use shared::protocol::BlockLoad;
use shared::solver::SolverError;
use std::time::Instant;

/// Column height over width of the dam break the sweeps run.
pub const N2: u32 = 2;
/// Column width a [m].
pub const A: f64 = 0.1;

/// One dam-break run.
#[derive(Debug, Clone)]
pub struct DamRun {
    pub solver: String,
    pub per_a: usize,
    pub dt_factor: f64,
    pub wall_seconds: f64,
    /// The front curve, or how the run failed.
    pub result: Result<DamBreak, String>,
    /// Warnings the solver raised (the last one and how many).
    pub warnings: u64,
    pub last_warning: Option<String>,
}

impl DamRun {
    /// Mean |Z − Z_ref|/Z_ref over the published points (Martin & Moyce).
    pub fn experiment_error(&self) -> f64 {
        match &self.result {
            Ok(d) => {
                let dev = d.deviations();
                dev.iter().map(|x| x.abs()).sum::<f64>() / dev.len() as f64
            }
            Err(_) => f64::NAN,
        }
    }

    /// Particles across the water depth (N of the convergence fit).
    pub fn per_depth(&self) -> f64 {
        (N2 as usize * self.per_a) as f64
    }
}

/// Mean |Z_a − Z_b| / Z_b over the published T points.
pub fn front_difference(a: &DamBreak, b: &DamBreak) -> f64 {
    let pts = validation::martin_moyce(a.n2);
    pts.iter()
        .map(|&(t, _)| (a.front_at(t) - b.front_at(t)).abs() / b.front_at(t))
        .sum::<f64>()
        / pts.len() as f64
}

/// Runs the dam break with `per_a` particles across the column, stepping by the solver's
/// proposal (capped by the scene's dt_max) times `dt_factor`.
pub fn dam_break(solver: &str, per_a: usize, dt_factor: f64) -> DamRun {
    let start = Instant::now();
    let mut warnings = 0;
    let mut last_warning = None;
    let result = run(solver, per_a, dt_factor, &mut warnings, &mut last_warning)
        .map_err(|e| format!("{solver}: {e}"));
    DamRun {
        solver: solver.into(),
        per_a,
        dt_factor,
        wall_seconds: start.elapsed().as_secs_f64(),
        result,
        warnings,
        last_warning,
    }
}

fn run(
    solver: &str,
    per_a: usize,
    dt_factor: f64,
    warnings: &mut u64,
    last_warning: &mut Option<String>,
) -> Result<DamBreak, SolverError> {
    let scene = validation::dam_break_scene(solver, N2, A, per_a, None);
    let dir = validation::TempRunDir::new("sweep")?;
    let mut s = validation::build(solver, &scene, dir.path())?;
    let particles = s.system().len();
    let dx = A / per_a as f64;
    let scale = (N2 as f64).sqrt() * (9.81 / A).sqrt();
    let end = validation::dam_break_end(N2, A) * 1.01;
    let front = |s: &dyn SphSolver| validation::front(s, dx);
    let mut curve = vec![(0.0, front(s.as_ref()) / A)];
    let mut loads: Vec<BlockLoad> = Vec::new();
    // As the coupler does with --dt-factor: the granted step (proposal within the scene's
    // limits) multiplied by the factor.
    let rule = StepRule::new(scene.time.dt_max, scene.time.dt_min).with_factor(dt_factor);
    let started = Instant::now();
    // On a rayon worker, as the fluid node runs (`fluid_node::on_pool`).
    let steps = fluid_node::on_pool(|| -> Result<u64, SolverError> {
        let (mut t, mut steps) = (0.0, 0u64);
        while t < end {
            let (reached, report) = validation::step(s.as_mut(), &rule, t, end, &mut loads)?;
            if let Some(w) = report.warning {
                *warnings += 1;
                *last_warning = Some(w);
            }
            t = reached;
            steps += 1;
            curve.push((t * scale, front(s.as_ref()) / A));
        }
        s.finish()?;
        Ok(steps)
    })?;
    Ok(DamBreak {
        n2: N2,
        per_a,
        curve,
        particles,
        steps,
        seconds: started.elapsed().as_secs_f64(),
    })
}
