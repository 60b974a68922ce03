//! Verification of the deformable (12-DOF, constant-strain) blocks against closed forms:
//!
//! - a block resting frictionless on a floor under gravity: the constant strain that minimises
//!   the potential energy is the mean stress over the block, σ̄zz = −ρ g H/2 (σ̄xx = σ̄yy = 0),
//!   so εz = −ρ g H/(2E) and εx = εy = +ν ρ g H/(2E). (The contact forces m g at z = −H/2 load
//!   εz with −m g H/2 through T_eᵀ; gravity, uniform, loads no strain; V D e balances it.)
//! - free vibration of a cube in space from an initial strain: the constant-strain modes have
//!   ω = sqrt(24 μ/ρ)/L (shear and deviatoric) and sqrt(36 K/ρ)/L (volumetric), from
//!   M_e = ρ V L²/12 (normal), ρ V L²/24 (shear) and V·D ([`crate::blocks::elastic::cube_frequencies`]).
//!   Central difference keeps the amplitude and its period is 2π Δt/θ, cos θ = 1 − Ω²/2;
//!   Shi's Newmark (β = ½, γ = 1) multiplies the amplitude by ρ = (1 + Ω²/2)^(−½) per step and
//!   turns the phase by θ, cos θ = (1 + (1 − Ω²)/(1 + Ω²/2))/(2ρ) (the same formula as the
//!   restitution rows): period 2π Δt/θ, amplitude ρ^(2π/θ) per period.
//! - the explicit limit with the elastic mode binding: stable at ω_elastic·Δt = 1.8, reported
//!   unstable, naming the elastic mode, at 2.5.
//! - rigid against stiff deformable on the sliding incline: the same distance.

use super::harness::{EXPLICIT, Harness};
use super::incline::Incline;
use super::scenes::{block_toml, box_corners, floor_toml, scene};
use crate::blocks::elastic::cube_frequencies;
use shared::geometry::strain::Strain;
use shared::math::Real;
use shared::report::{Row, Tolerance};
use shared::solver::{Solver, SolverError};
use std::f64::consts::PI;

const G: Real = shared::math::STANDARD_GRAVITY;

/// The soft block of these cases: a cube of side [`SIDE`], density [`DENSITY`], E, ν.
pub const SIDE: Real = 0.5;
pub const DENSITY: Real = 2000.0;
pub const YOUNG: Real = 5e6;
pub const POISSON: Real = 0.25;

fn elastic_toml(young: Real, poisson: Real) -> String {
    format!("elastic = {{ young_modulus = {young:e}, poisson_ratio = {poisson} }}")
}

// ---------------------------------------------------------------------------------------------
// Resting on a floor.

/// Strain of a block resting on a frictionless floor, averaged over the second half of
/// `duration` (the drop onto the springs from zero gap rings the εz–z mode; 20 % contact
/// damping and, for Newmark, the scheme's own damping take it out).
pub fn resting_strain(solver: &str, duration: Real) -> Result<Strain, SolverError> {
    let h2 = SIDE / 2.0;
    let s = scene(
        "soft_resting",
        [0.0, 0.0, -G],
        5.0,
        "",
        "friction_angle = 0.0\ndamping_ratio = 0.2",
        &[
            floor_toml(),
            block_toml(
                "soft",
                "free",
                DENSITY,
                &box_corners([-h2, -h2, 0.0], [h2, h2, SIDE]),
                &elastic_toml(YOUNG, POISSON),
            ),
        ],
    );
    let mut h = Harness::new(&s, solver)?;
    let soft = h.solver.block_index("soft").unwrap();
    h.run_until(0.5 * duration, None, |_| {})?;
    let (mut sum, mut weight) = (Strain::zeros(), 0.0);
    let mut t_last = h.time();
    h.run_until(duration, None, |w| {
        let dt = w.time - t_last;
        t_last = w.time;
        sum += w.blocks[soft].strain() * dt;
        weight += dt;
    })?;
    Ok(sum / weight)
}

pub fn resting_rows(solver: &str) -> Vec<Row> {
    let case = format!("deformable cube on frictionless floor, E = {YOUNG:.0e} Pa, ν = {POISSON}");
    let ez = -DENSITY * G * SIDE / (2.0 * YOUNG);
    match resting_strain(solver, 1.0) {
        Err(e) => vec![Row::failed(&case, solver, "mean strain", &e)],
        Ok(e) => vec![
            Row::numeric(
                &case,
                solver,
                "εz = −ρgH/(2E), mean over 0.5–1 s",
                ez,
                e[2],
                Tolerance::Relative(0.02),
            ),
            Row::numeric(
                &case,
                solver,
                "εx = +νρgH/(2E)",
                -POISSON * ez,
                e[0],
                Tolerance::Relative(0.03),
            ),
            Row::numeric(
                &case,
                solver,
                "εy = +νρgH/(2E)",
                -POISSON * ez,
                e[1],
                Tolerance::Relative(0.03),
            ),
        ],
    }
}

// ---------------------------------------------------------------------------------------------
// Free vibration.

/// Which constant-strain mode to excite.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Mode {
    /// γxy alone: ω² = 24 μ/(ρ L²).
    Shear,
    /// εx = εy = εz: ω² = 36 K/(ρ L²).
    Volumetric,
}

impl Mode {
    /// Unit strain vector of the mode.
    pub fn shape(self) -> Strain {
        match self {
            Mode::Shear => Strain::new(0.0, 0.0, 0.0, 0.0, 0.0, 1.0),
            Mode::Volumetric => Strain::new(1.0, 1.0, 1.0, 0.0, 0.0, 0.0) / 3f64.sqrt(),
        }
    }

    /// Exact ω [rad/s] of the soft cube.
    pub fn omega(self) -> Real {
        let (vol, dev) = cube_frequencies(YOUNG, POISSON, DENSITY, SIDE);
        match self {
            Mode::Shear => dev,
            Mode::Volumetric => vol,
        }
    }

    fn name(self) -> &'static str {
        match self {
            Mode::Shear => "shear γxy, ω = sqrt(24μ/ρ)/L",
            Mode::Volumetric => "volumetric, ω = sqrt(36K/ρ)/L",
        }
    }
}

/// A soft cube in space (no gravity) with the initial strain `amplitude`·mode.
fn vibrating_cube(solver: &str, mode: Mode, amplitude: Real) -> Result<Harness, SolverError> {
    let h2 = SIDE / 2.0;
    let s = scene(
        "soft_vibration",
        [0.0, 0.0, 0.0],
        5.0,
        "[solid.implicit]\ndisplacement_limit = 10.0",
        "",
        &[block_toml(
            "soft",
            "free",
            DENSITY,
            &box_corners([-h2; 3], [h2; 3]),
            &elastic_toml(YOUNG, POISSON),
        )],
    );
    let mut h = Harness::new(&s, solver)?;
    let i = h.solver.block_index("soft").unwrap();
    h.solver
        .set_initial_strain(i, mode.shape() * amplitude, Strain::zeros())?;
    Ok(h)
}

/// What a free vibration measured.
#[derive(Debug, Clone, Copy)]
pub struct Vibration {
    /// Period from the zero crossings [s].
    pub period: Real,
    /// Amplitude after the last full period over the initial one.
    pub amplitude_ratio: Real,
    /// Amplitude ratio per period (from successive peaks).
    pub decay_per_period: Real,
    /// Largest energy ratio of the monitor.
    pub energy_ratio: Real,
}

/// Free vibration of the mode at Ω = ω·Δt for `periods` periods: zero crossings (linear
/// interpolation) give the period, parabola-interpolated peaks the amplitude.
pub fn free_vibration(
    solver: &str,
    mode: Mode,
    omega_dt: Real,
    periods: Real,
) -> Result<Vibration, SolverError> {
    let amplitude = 1e-3;
    let mut h = vibrating_cube(solver, mode, amplitude)?;
    let i = h.solver.block_index("soft").unwrap();
    let dt = omega_dt / mode.omega();
    let steps = (periods * 2.0 * PI / omega_dt).ceil() as usize;
    let u = mode.shape();
    let mut q = Vec::with_capacity(steps + 1);
    q.push(h.world().blocks[i].strain().dot(&u));
    let mut energy: Real = 0.0;
    for _ in 0..steps {
        h.solver.advance(dt)?;
        q.push(h.world().blocks[i].strain().dot(&u));
        energy = energy.max(h.solver.energy.ratio);
    }
    let mut crossings = Vec::new();
    let mut peaks = Vec::new();
    for n in 1..q.len() {
        if q[n - 1] > 0.0 && q[n] <= 0.0 || q[n - 1] < 0.0 && q[n] >= 0.0 {
            crossings.push((n as Real - 1.0 + q[n - 1] / (q[n - 1] - q[n])) * dt);
        }
        if n + 1 < q.len() && q[n] > q[n - 1] && q[n] >= q[n + 1] {
            // Vertex of the parabola through the three samples.
            let (a, b, c) = (q[n - 1], q[n], q[n + 1]);
            let den = a - 2.0 * b + c;
            peaks.push(if den < 0.0 {
                b - (a - c) * (a - c) / (8.0 * den)
            } else {
                b
            });
        }
    }
    if crossings.len() < 3 || peaks.len() < 2 {
        return Err(SolverError::Failed(format!(
            "no oscillation: {} zero crossings, {} peaks",
            crossings.len(),
            peaks.len()
        )));
    }
    let period =
        2.0 * (crossings[crossings.len() - 1] - crossings[0]) / (crossings.len() - 1) as Real;
    let last = *peaks.last().unwrap();
    let decay = (last / peaks[0]).powf(1.0 / (peaks.len() - 1) as Real);
    Ok(Vibration {
        period,
        amplitude_ratio: last / amplitude,
        decay_per_period: decay,
        energy_ratio: energy,
    })
}

/// Shi's Newmark (β = ½, γ = 1) on an undamped oscillator at Ω = ω·Δt: (period / (2π/ω),
/// amplitude ratio per period). See the module docs.
pub fn newmark_vibration(omega_dt: Real) -> (Real, Real) {
    let d = 1.0 + omega_dt * omega_dt / 2.0;
    let rho = d.powf(-0.5);
    let theta = ((1.0 + (1.0 - omega_dt * omega_dt) / d) / (2.0 * rho)).acos();
    (omega_dt / theta, rho.powf(2.0 * PI / theta))
}

/// Central difference on an undamped oscillator: period / (2π/ω) = Ω/θ, cos θ = 1 − Ω²/2.
pub fn central_difference_period(omega_dt: Real) -> Real {
    omega_dt / (1.0 - omega_dt * omega_dt / 2.0).acos()
}

pub fn vibration_rows(solver: &str) -> Vec<Row> {
    let mut rows = Vec::new();
    for mode in [Mode::Shear, Mode::Volumetric] {
        let exact = 2.0 * PI / mode.omega();
        if solver == EXPLICIT {
            let omega_dt = 0.05;
            let case = format!(
                "deformable cube free vibration, {}, Ω = {omega_dt}",
                mode.name()
            );
            match free_vibration(solver, mode, omega_dt, 5.0) {
                Err(e) => rows.push(Row::failed(&case, solver, "period [s]", &e)),
                Ok(v) => {
                    rows.push(Row::numeric(
                        &case,
                        solver,
                        &format!(
                            "period [s] (central difference's own: {:.6})",
                            exact * central_difference_period(omega_dt)
                        ),
                        exact,
                        v.period,
                        Tolerance::Relative(0.002),
                    ));
                    rows.push(Row::numeric(
                        &case,
                        solver,
                        "amplitude after 5 periods / initial",
                        1.0,
                        v.amplitude_ratio,
                        Tolerance::Relative(0.01),
                    ));
                }
            }
        } else {
            let omega_dt = 0.2;
            let (stretch, decay) = newmark_vibration(omega_dt);
            let case = format!(
                "deformable cube free vibration, {}, Ω = {omega_dt}",
                mode.name()
            );
            match free_vibration(solver, mode, omega_dt, 4.0) {
                Err(e) => rows.push(Row::failed(&case, solver, "period [s]", &e)),
                Ok(v) => {
                    rows.push(Row::numeric(
                        &case,
                        solver,
                        &format!("period [s], Newmark's 2πΔt/θ (exact 2π/ω = {exact:.6})"),
                        exact * stretch,
                        v.period,
                        Tolerance::Relative(0.005),
                    ));
                    rows.push(Row::numeric(
                        &case,
                        solver,
                        "amplitude per period, Newmark's ρ^(2π/θ)",
                        decay,
                        v.decay_per_period,
                        Tolerance::Relative(0.01),
                    ));
                }
            }
        }
    }
    rows
}

// ---------------------------------------------------------------------------------------------
// The explicit limit with the elastic mode binding.

/// The soft cube vibrating in its volumetric mode (the stiffest) at Ω = ω_elastic·Δt for
/// `steps` steps: the largest energy ratio, or the error.
pub fn elastic_limit(omega_dt: Real, steps: usize) -> Result<Real, SolverError> {
    let mut h = vibrating_cube(EXPLICIT, Mode::Volumetric, 1e-3)?;
    let dt = omega_dt / Mode::Volumetric.omega();
    let mut worst: Real = 0.0;
    for _ in 0..steps {
        h.solver.advance(dt)?;
        worst = worst.max(h.solver.energy.ratio);
    }
    Ok(worst)
}

pub fn elastic_limit_rows() -> Vec<Row> {
    let mut rows = super::contact::limit_rows(
        (
            "deformable cube, volumetric mode, ω_elastic·Δt = 1.8, 400 steps",
            elastic_limit(1.8, 400),
        ),
        (
            "deformable cube, volumetric mode, ω_elastic·Δt = 2.5 (past 2/ω_max)",
            elastic_limit(2.5, 400),
        ),
        "Unstable, elastic mode named",
        &[
            "energy",
            "ω_max·dt = 2.500",
            "elastic mode of deformable block 'soft'",
        ],
    );
    // The proposal itself keeps the elastic mode below the limit.
    let case = "deformable cube in space: explicit dt proposal";
    rows.push(match vibrating_cube(EXPLICIT, Mode::Volumetric, 0.0) {
        Err(e) => Row::failed(case, EXPLICIT, "ω_elastic · dt_proposal", &e),
        Ok(h) => Row::numeric(
            case,
            EXPLICIT,
            "ω_elastic · dt_proposal",
            2.0,
            Mode::Volumetric.omega() * h.solver.dt_proposal(),
            Tolerance::AtMost(2.0),
        ),
    });
    rows
}

// ---------------------------------------------------------------------------------------------
// Rigid against stiff deformable.

/// The sliding incline block (α = 30°, φ = 20°) made deformable with E.
pub const STIFF_YOUNG: Real = 1e9;

pub fn incline_rigid_vs_deformable(solver: &str) -> Row {
    let inc = Incline {
        alpha: 30.0,
        phi: 20.0,
        cohesion: 0.0,
        b: 0.4,
        h: 0.2,
    };
    let case = format!("incline α=30° φ=20°, rigid vs deformable E = {STIFF_YOUNG:.0e} Pa");
    let run = |extra: &str| -> Result<Real, SolverError> {
        let mut h = Harness::new(&inc.scene_with(extra), solver)?;
        let start = h.block("rock").position;
        h.run_until(1.0, None, |_| {})?;
        Ok((h.block("rock").position - start).dot(&inc.downhill()))
    };
    match (run(""), run(&elastic_toml(STIFF_YOUNG, POISSON))) {
        (Err(e), _) | (_, Err(e)) => Row::failed(&case, solver, "d(1 s) [m]", &e),
        (Ok(rigid), Ok(soft)) => Row::numeric(
            &case,
            solver,
            &format!(
                "d(1 s) [m]: reference = rigid block (closed form {:.6})",
                inc.reference_distance(1.0)
            ),
            rigid,
            soft,
            Tolerance::Relative(0.001),
        ),
    }
}

/// All deformable-block rows for one solver.
pub fn rows(solver: &str) -> Vec<Row> {
    let mut rows = resting_rows(solver);
    rows.extend(vibration_rows(solver));
    if solver == EXPLICIT {
        rows.extend(elastic_limit_rows());
    }
    rows.push(incline_rigid_vs_deformable(solver));
    rows
}
