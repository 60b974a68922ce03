//! The solid-only sweeps, in-process through `solid_node::verification` (a scene without water
//! needs no coupler): the block sliding down an incline (α = 30°, φ = 20°, closed-form d(t))
//! over contact stiffness and dt factor, and a block resting on undamped contact springs pushed
//! past the explicit limit ω·dt = 2 by the dt factor or by the stiffness.

use shared::coupling::step::grant;
use shared::solver::{Solver, SolverError};
use solid_node::verification::{self, Harness, Incline};
use std::time::Instant;

/// The incline the speed–accuracy chart runs: sliding, with the closed-form reference.
pub const INCLINE: Incline = Incline {
    alpha: 30.0,
    phi: 20.0,
    cohesion: 0.0,
    b: 0.4,
    h: 0.2,
};
/// Simulated time of an incline run [s].
pub const INCLINE_END: f64 = 1.0;

/// dt_max of the sweeps' scenes [s]: far above any proposal, so that the dt factor multiplies
/// what the solver proposes and not the verification scenes' 1 ms cap.
pub const UNCAPPED_DT: f64 = 0.05;

/// One incline run.
#[derive(Debug, Clone)]
pub struct InclineRun {
    pub solver: String,
    /// Normal contact spring [N/m].
    pub stiffness: f64,
    pub dt_factor: f64,
    pub wall_seconds: f64,
    /// |d − d_ref| / d_ref at 1 s, or how the run failed.
    pub result: Result<f64, String>,
    pub steps: u64,
}

/// Advances with the granted step × factor, as the coupler does with --dt-factor.
fn advance_to(h: &mut Harness, end: f64, dt_factor: f64) -> Result<u64, SolverError> {
    let rule = h.rule.with_factor(dt_factor);
    let mut steps = 0;
    while h.time() < end - 1e-12 {
        h.step(&rule, end)?;
        steps += 1;
    }
    Ok(steps)
}

/// Runs the incline once with the given contact stiffness and dt factor. Runs shorter than
/// 0.2 s of wall time are repeated (up to 10 times) and the mean taken, so the chart's time
/// axis is not timer noise.
pub fn incline(solver: &str, stiffness: f64, dt_factor: f64) -> InclineRun {
    let mut scene = INCLINE.scene();
    scene.solid.contact.normal_stiffness = Some(stiffness);
    // The verification scenes cap dt at 1 ms; the sweep steps by the solver's own proposal.
    scene.time.dt_max = UNCAPPED_DT;
    let reference = INCLINE.reference_distance(INCLINE_END);
    let start = Instant::now();
    let mut reps = 0;
    let mut steps = 0;
    let result = loop {
        reps += 1;
        let one = (|| -> Result<f64, SolverError> {
            let mut h = Harness::new(&scene, solver)?;
            let p0 = h.block("rock").position;
            steps = advance_to(&mut h, INCLINE_END, dt_factor)?;
            let d = (h.block("rock").position - p0).dot(&INCLINE.downhill());
            Ok((d - reference).abs() / reference)
        })();
        match one {
            Ok(e) if start.elapsed().as_secs_f64() < 0.2 && reps < 10 => {
                let _ = e;
                continue;
            }
            Ok(e) => break Ok(e),
            Err(e) => break Err(format!("{solver}: {e}")),
        }
    };
    InclineRun {
        solver: solver.into(),
        stiffness,
        dt_factor,
        wall_seconds: start.elapsed().as_secs_f64() / reps as f64,
        result,
        steps,
    }
}

/// Mass of the resting block [kg] (0.2 × 0.2 × 0.4 m of rock).
pub const RESTING_MASS: f64 = 2500.0 * 0.2 * 0.2 * 0.4;

/// The resting-block scene of `verification::resting_block`: four undamped corner springs of
/// stiffness `k` and no shear springs, so ω = sqrt(4k/m) is the highest mode.
fn resting_scene(k: f64) -> shared::scene::Scene {
    verification::scene(
        "resting",
        [0.0, 0.0, -shared::math::STANDARD_GRAVITY],
        5.0,
        "",
        &format!("normal_stiffness = {k}\nshear_ratio = 0.0"),
        &[
            verification::floor_toml(),
            verification::block_toml(
                "block",
                "free",
                2500.0,
                &verification::box_corners([-0.1, -0.1, 0.0], [0.1, 0.1, 0.4]),
                "",
            ),
        ],
    )
}

/// Outcome of a resting-block trial.
#[derive(Debug, Clone)]
pub struct Resting {
    pub stable: bool,
    /// ω·dt of the largest step taken.
    pub omega_dt: f64,
    /// The solver's message when it stopped, or the largest energy ratio when it did not.
    pub detail: String,
}

/// A block resting on springs of stiffness `k` for `duration` seconds, stepped either by the
/// solver's proposal × `dt_factor` (`fixed_dt` = None) or by a fixed step.
pub fn resting(
    solver: &str,
    k: f64,
    dt_factor: f64,
    fixed_dt: Option<f64>,
    duration: f64,
) -> Resting {
    let omega = (4.0 * k / RESTING_MASS).sqrt();
    let mut scene = resting_scene(k);
    scene.time.dt_max = UNCAPPED_DT;
    let mut h = match Harness::new(&scene, solver) {
        Ok(h) => h,
        Err(e) => {
            return Resting {
                stable: false,
                omega_dt: f64::NAN,
                detail: format!("could not start: {e}"),
            };
        }
    };
    let mut worst: f64 = 0.0;
    let mut dt_largest: f64 = 0.0;
    let rule = h.rule.with_factor(dt_factor);
    while h.time() < duration - 1e-12 {
        let proposal = [(h.solver.name(), h.solver.dt_proposal())];
        let dt = match fixed_dt {
            Some(dt) => dt,
            None => match grant(proposal, &rule, h.time(), duration) {
                Ok(g) => g.dt,
                Err(c) => {
                    return Resting {
                        stable: false,
                        omega_dt: omega * dt_largest,
                        detail: format!("step collapsed: {c}"),
                    };
                }
            },
        };
        dt_largest = dt_largest.max(dt);
        match h.solver.advance(dt) {
            Ok(_) => worst = worst.max(h.solver.energy.ratio),
            Err(SolverError::Unstable(msg)) => {
                return Resting {
                    stable: false,
                    omega_dt: omega * dt_largest,
                    detail: msg,
                };
            }
            Err(e) => {
                return Resting {
                    stable: false,
                    omega_dt: omega * dt_largest,
                    detail: format!("failed: {e}"),
                };
            }
        }
    }
    let z = h.block("block").position.z;
    Resting {
        stable: true,
        omega_dt: omega * dt_largest,
        detail: format!(
            "bounded: largest energy ratio {worst:.3}, block centre at z = {z:.4} m after {duration} s"
        ),
    }
}
