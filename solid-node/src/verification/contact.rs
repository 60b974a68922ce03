//! Contact springs against theory: bounce restitution (exact 1 for central difference,
//! exp(−πΩ/4) for Shi's Newmark), the explicit stability limit 2/ω, a stack at rest.

use super::harness::{EXPLICIT, Harness};
use super::scenes::{G, block_toml, box_corners, floor_toml, scene};
use shared::math::Real;
use shared::report::{Row, Tolerance};
use shared::solver::{Solver, SolverError};
use std::f64::consts::PI;

/// An undamped bounce: a 0.2 × 0.2 × 0.4 m block (40 kg) moving at 1 m/s onto a fixed floor
/// with no gravity, four corner springs k_n = 10⁶ N/m and no shear springs, so that the
/// vertical mode ω = sqrt(4 k_n / m) is the highest one (rocking is 2.4 k_n/m for a block
/// twice as tall as wide); the step is Ω/ω. `phase` ∈ [0, 1) shifts the start so that the
/// first touch falls at that fraction of a step. Returns the restitution (rebound speed over
/// impact speed).
pub fn bounce(solver: &str, omega_dt: Real, phase: Real) -> Result<Real, SolverError> {
    let k: Real = 1e6;
    let mass: Real = 2500.0 * 0.2 * 0.2 * 0.4;
    let omega = (4.0 * k / mass).sqrt();
    let dt = omega_dt / omega;
    // 1 m/s: a gap of (n + phase) steps of travel.
    let gap = ((2e-3 / dt).ceil() + phase) * dt;
    let s = scene(
        "bounce",
        [0.0, 0.0, 0.0],
        5.0,
        "[solid.implicit]\ndisplacement_limit = 10.0",
        &format!("normal_stiffness = {k}\nshear_ratio = 0.0"),
        &[
            floor_toml(),
            block_toml(
                "cube",
                "free",
                2500.0,
                &box_corners([-0.1, -0.1, gap], [0.1, 0.1, gap + 0.4]),
                "velocity = [0.0, 0.0, -1.0]",
            ),
        ],
    );
    let mut h = Harness::new(&s, solver)?;
    let cube = h.solver.block_index("cube").unwrap();
    let v_in = h.world().blocks[cube].velocity.z;
    let t_end = 2.0 * gap + PI / omega + 0.004;
    let mut v_out = 0.0;
    h.run_until(t_end, Some(dt), |w| v_out = w.blocks[cube].velocity.z)?;
    if h.world().blocks[cube].aabb_min.z < 0.0 {
        return Err(SolverError::Failed(format!(
            "cube still in contact at t = {t_end} s"
        )));
    }
    Ok(-v_out / v_in)
}

/// Number of touch-down phases the restitution is averaged over.
pub const BOUNCE_PHASES: usize = 8;

/// Mean and spread (max − min) of the restitution over [`BOUNCE_PHASES`] phases.
pub fn mean_restitution(solver: &str, omega_dt: Real) -> Result<(Real, Real), SolverError> {
    let mut e = Vec::with_capacity(BOUNCE_PHASES);
    for k in 0..BOUNCE_PHASES {
        e.push(bounce(
            solver,
            omega_dt,
            (k as Real + 0.5) / BOUNCE_PHASES as Real,
        )?);
    }
    let mean = e.iter().sum::<Real>() / e.len() as Real;
    let spread = e.iter().cloned().fold(Real::NEG_INFINITY, Real::max)
        - e.iter().cloned().fold(Real::INFINITY, Real::min);
    Ok((mean, spread))
}

/// Restitution of Shi's Newmark (β = ½, γ = 1) for a linear spring over one half cycle: the
/// step multiplies the amplitude by ρ = (1 + Ω²/2)^(−½) and turns the phase by θ with
/// cos θ = (1 + (1 − Ω²)/(1 + Ω²/2)) / (2ρ), so e = ρ^(π/θ). Its small-Ω limit is exp(−πΩ/4).
/// Above Ω = 4 (where cos θ reaches −1) the step's roots are real and negative: the response
/// flips sign every step, there is no half cycle, and `None` is returned.
pub fn newmark_restitution(omega_dt: Real) -> Option<Real> {
    let d = 1.0 + omega_dt * omega_dt / 2.0;
    let rho = d.powf(-0.5);
    let cos_theta = (1.0 + (1.0 - omega_dt * omega_dt) / d) / (2.0 * rho);
    (cos_theta >= -1.0).then(|| rho.powf(PI / cos_theta.acos()))
}

/// Restitution rows: central difference e ≈ 1 below Ω = 2; Shi's implicit e ≈ exp(−πΩ/4).
pub fn restitution_rows(solver: &str) -> Vec<Row> {
    // Central difference near Ω = 2 is left to the resting-block rows: a single contact
    // there lasts one or two steps and its restitution is whatever the touch-down phase makes
    // it (0.5 to 2.7 at Ω = 1.9).
    let omegas: &[Real] = if solver == EXPLICIT {
        &[0.1, 0.5, 1.0, 1.5]
    } else {
        &[0.05, 0.1, 0.2, 0.5, 1.0]
    };
    omegas
        .iter()
        .map(|&w| {
            let case = format!("undamped bounce Ω = ω·dt = {w}");
            match mean_restitution(solver, w) {
                Err(e) => Row::failed(&case, solver, "restitution e", &e),
                Ok((e, spread)) => {
                    let quantity =
                        format!("e, mean of {BOUNCE_PHASES} phases (spread {spread:.3})");
                    if solver == EXPLICIT {
                        // Contact onset and release fall between steps: an energy error that
                        // depends on the phase and grows with Ω (bounded below 2).
                        let tol = if w <= 1.0 { 0.02 } else { 0.15 };
                        Row::numeric(&case, solver, &quantity, 1.0, e, Tolerance::Absolute(tol))
                    } else {
                        let asymptote = (-PI * w / 4.0).exp();
                        let quantity = format!("{quantity}; exp(−πΩ/4) = {asymptote:.4}");
                        Row::numeric(
                            &case,
                            solver,
                            &quantity,
                            newmark_restitution(w).expect("the rows stay below Ω = 4"),
                            e,
                            Tolerance::Relative(0.03),
                        )
                    }
                }
            }
        })
        .collect()
}

/// A 0.2 × 0.2 × 0.4 m block resting on four corner springs under gravity (set down at zero
/// gap, undamped, no shear springs), stepped at Ω = ω·dt with ω = sqrt(4 k_n/m), the highest
/// mode, for `duration`: the largest energy ratio seen (see [`crate::integrators::energy`]), or the error.
pub fn resting_block(omega_dt: Real, duration: Real) -> Result<Real, SolverError> {
    let k: Real = 1e6;
    let mass: Real = 2500.0 * 0.2 * 0.2 * 0.4;
    let dt = omega_dt / (4.0 * k / mass).sqrt();
    let s = scene(
        "resting",
        [0.0, 0.0, -G],
        5.0,
        "",
        &format!("normal_stiffness = {k}\nshear_ratio = 0.0"),
        &[
            floor_toml(),
            block_toml(
                "block",
                "free",
                2500.0,
                &box_corners([-0.1, -0.1, 0.0], [0.1, 0.1, 0.4]),
                "",
            ),
        ],
    );
    let mut h = Harness::new(&s, EXPLICIT)?;
    let mut worst: Real = 0.0;
    let steps = (duration / dt).ceil() as usize;
    for _ in 0..steps {
        h.solver.advance(dt)?;
        worst = worst.max(h.solver.energy.ratio);
    }
    Ok(worst)
}

/// The explicit scheme on a sustained contact either side of Ω = 2 (paper Eq. 8): stable at
/// 1.9, and at 2.2 an `Unstable` error naming the solver, the energy growth and ω·dt.
pub fn explicit_limit_rows() -> Vec<Row> {
    limit_rows(
        (
            "block resting on springs, Ω = 1.9, 1 s",
            resting_block(1.9, 1.0),
        ),
        (
            "block resting on springs, Ω = 2.2 (past 2/ω_max)",
            resting_block(2.2, 1.0),
        ),
        "Unstable reported",
        &["explicit", "energy", "ω_max·dt"],
    )
}

/// The two rows of an explicit limit: the `stable` run's largest energy ratio (at most 1.05),
/// and the `unstable` run's outcome, which must be an `Unstable` error whose message holds
/// every one of `named`.
pub fn limit_rows(
    stable: (&str, Result<Real, SolverError>),
    unstable: (&str, Result<Real, SolverError>),
    expected: &str,
    named: &[&str],
) -> Vec<Row> {
    let (case, result) = stable;
    let first = match result {
        Ok(r) => Row::numeric(
            case,
            EXPLICIT,
            "largest energy ratio (1 = all energy supplied)",
            1.0,
            r,
            Tolerance::AtMost(1.05),
        ),
        Err(e) => Row::failed(case, EXPLICIT, "energy ratio", &e),
    };
    let (case, result) = unstable;
    let categorical =
        |measured: &str| Row::categorical(case, EXPLICIT, "outcome", expected, measured);
    let second = match result {
        Ok(r) => categorical(&format!("completed, energy ratio {r:.3}")),
        Err(SolverError::Unstable(msg)) => {
            let mut row = categorical(expected);
            row.measured = format!(
                "Unstable: {}",
                msg.split(" (central").next().unwrap_or(&msg)
            );
            row.pass = named.iter().all(|w| msg.contains(w));
            row
        }
        Err(e) => categorical(&format!("other error: {e}")),
    };
    vec![first, second]
}

/// A stack of `n` staggered boxes on a fixed floor, starting at zero gap: the largest
/// displacement of any block between t = 2 s (settled onto its springs, ~0.1 mm) and
/// `duration`.
pub fn stack_drift(solver: &str, n: usize, duration: Real) -> Result<Real, SolverError> {
    let mut blocks = vec![block_toml(
        "floor",
        "fixed",
        2500.0,
        &box_corners([-2.0, -2.0, -0.5], [2.0, 2.0, 0.0]),
        "",
    )];
    for i in 0..n {
        let s = if i % 2 == 0 { 0.03 } else { -0.03 };
        let z = 0.3 * i as Real;
        let v = box_corners([-0.2 + s, -0.2 - s, z], [0.2 + s, 0.2 - s, z + 0.3]);
        blocks.push(block_toml(&format!("box{i}"), "free", 2500.0, &v, ""));
    }
    let s = scene(
        "stack",
        [0.0, 0.0, -G],
        10.0,
        "",
        "friction_angle = 30.0\ndamping_ratio = 0.1",
        &blocks,
    );
    let mut h = Harness::new(&s, solver)?;
    h.run_until(STACK_SETTLE, None, |_| {})?;
    let settled: Vec<_> = h
        .world()
        .free
        .iter()
        .map(|&i| h.world().blocks[i].position)
        .collect();
    let mut drift: Real = 0.0;
    h.run_until(duration, None, |w| {
        for (k, &i) in w.free.iter().enumerate() {
            drift = drift.max((w.blocks[i].position - settled[k]).norm());
        }
    })?;
    Ok(drift)
}

/// Normal stiffness of [`flush_column_sink`]'s contacts [N/m]: soft enough that the lowest
/// joint is pressed several contact margins deep.
pub const FLUSH_COLUMN_STIFFNESS: Real = 2e5;

/// A column of `n` equal boxes (0.4 × 0.4 × 0.3 m, 2 500 kg/m³) on a fixed floor, as one joint
/// set cuts a rock mass: every box's bottom corners sit flush with the side faces of the box
/// below. The contacts are soft ([`FLUSH_COLUMN_STIFFNESS`]), so the joints are pressed in
/// several contact margins (n = 4: 9 at the floor, 3.4 between the lowest boxes). Returns the
/// top box's sink after [`STACK_SETTLE`] and what the springs give at rest: the floor carries
/// n weights W on the lowest box's four corners, n W/(4 k); between boxes, where the corners
/// of both coincide, each corner has a spring of either block on the other's face, eight in
/// all, and the joint j boxes from the top carries j weights: Σ_{j<n} j W/(8 k). A contact
/// that took the flush side face for its reference (depth 0, no force) let each box sink
/// through the one below (what contact/narrow_phase.rs's `over_face` prevents).
pub fn flush_column_sink(solver: &str, n: usize) -> Result<(Real, Real), SolverError> {
    let (a, hgt, density) = (0.4, 0.3, 2500.0);
    let mut blocks = vec![block_toml(
        "floor",
        "fixed",
        density,
        &box_corners([-2.0, -2.0, -0.5], [2.0, 2.0, 0.0]),
        "",
    )];
    for i in 0..n {
        let z = hgt * i as Real;
        let v = box_corners([-a / 2.0, -a / 2.0, z], [a / 2.0, a / 2.0, z + hgt]);
        blocks.push(block_toml(&format!("box{i}"), "free", density, &v, ""));
    }
    let contact = format!(
        "friction_angle = 30.0\ndamping_ratio = 0.1\nnormal_stiffness = {FLUSH_COLUMN_STIFFNESS:e}"
    );
    let s = scene("flush_column", [0.0, 0.0, -G], 10.0, "", &contact, &blocks);
    let mut h = Harness::new(&s, solver)?;
    let top = *h.world().free.last().expect("the column has boxes");
    let z0 = h.world().blocks[top].position.z;
    h.run_until(STACK_SETTLE, None, |_| {})?;
    let sink = z0 - h.world().blocks[top].position.z;
    let weight = density * a * a * hgt * G;
    let above = (n * (n - 1) / 2) as Real;
    let expected = (n as Real / 4.0 + above / 8.0) * weight / FLUSH_COLUMN_STIFFNESS;
    Ok((sink, expected))
}

pub fn flush_column_row(solver: &str) -> Row {
    let case = "column of 4 flush boxes (one joint set), soft contacts: top's sink".to_string();
    match flush_column_sink(solver, 4) {
        Err(e) => Row::failed(&case, solver, "sink [m]", &e),
        Ok((sink, expected)) => Row::numeric(
            &case,
            solver,
            "sink of the top box after 2 s [m]",
            expected,
            sink,
            Tolerance::Relative(0.03),
        ),
    }
}

/// Time the stack is given to settle onto its springs [s].
pub const STACK_SETTLE: Real = 2.0;

pub fn stack_row(solver: &str, duration: Real) -> Row {
    let case = format!("stack of 4 boxes at rest, {duration} s");
    match stack_drift(solver, 4, duration) {
        Err(e) => Row::failed(&case, solver, "drift [m]", &e),
        Ok(d) => Row::numeric(
            &case,
            solver,
            "max drift after 2 s [m]",
            0.0,
            d,
            Tolerance::Absolute(1e-4),
        ),
    }
}
