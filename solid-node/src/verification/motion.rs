//! Rigid-body motion with closed-form references: free fall, slide or topple on an incline,
//! the paper's wedge on its plane, a spinning block.

use super::harness::Harness;
use super::incline::Incline;
use super::scenes::{G, block_toml, box_corners, scene};
use shared::math::{Real, Vector};
use shared::report::{Row, Tolerance};
use shared::scene::Scene;
use shared::solver::SolverError;

/// Free fall for 1 s from rest: z(t) = −½ g t², exact for both schemes (constant acceleration).
pub fn free_fall(solver: &str) -> Row {
    let case = "free fall, 1 s";
    let s = scene(
        "free_fall",
        [0.0, 0.0, -G],
        20.0,
        "",
        "",
        &[block_toml(
            "rock",
            "free",
            2500.0,
            &box_corners([-0.2, -0.2, -0.2], [0.2, 0.2, 0.2]),
            "",
        )],
    );
    let mut h = match Harness::new(&s, solver) {
        Ok(h) => h,
        Err(e) => return Row::failed(case, solver, "drop [m]", &e),
    };
    if let Err(e) = h.run_until(1.0, None, |_| {}) {
        return Row::failed(case, solver, "drop [m]", &e);
    }
    Row::numeric(
        case,
        solver,
        "drop z(1 s) [m]",
        0.5 * G,
        -h.block("rock").position.z,
        Tolerance::Relative(1e-9),
    )
}

/// Slide-or-topple of a b × h block: slides if α > φ, topples if tan α > b/h. Measured over
/// 1 s: toppled if the block turned more than 5°, slid if its downhill bottom corner (the
/// toppling pivot) moved more than 2 cm along the slope before the block had turned 10° (a
/// block that has toppled lands on its side and may go on sliding: that is not the question).
pub fn slide_or_topple(solver: &str) -> Vec<Row> {
    let cases = [
        Incline {
            alpha: 20.0,
            phi: 30.0,
            cohesion: 0.0,
            b: 0.4,
            h: 0.4,
        },
        Incline {
            alpha: 35.0,
            phi: 25.0,
            cohesion: 0.0,
            b: 0.4,
            h: 0.4,
        },
        Incline {
            alpha: 35.0,
            phi: 45.0,
            cohesion: 0.0,
            b: 0.2,
            h: 0.4,
        },
        // Toppling while sliding needs tan φ > b/h as well: in the frame of a block sliding at
        // g (sin α − cos α tan φ), gravity leans at φ, not α. And the pivot of a block
        // released from rest slides if the friction it needs, |R_t|/R_n = 0.447 here, is above
        // tan φ. φ = 20° with b/h = 1/3 satisfies the chart and both of these.
        Incline {
            alpha: 40.0,
            phi: 20.0,
            cohesion: 0.0,
            b: 0.15,
            h: 0.45,
        },
    ];
    let label = |slide: bool, topple: bool| match (slide, topple) {
        (false, false) => "rests",
        (true, false) => "slides",
        (false, true) => "topples",
        (true, true) => "slides+topples",
    };
    cases
        .iter()
        .map(|inc| {
            let case = format!("b/h={:.3} α={}° φ={}°", inc.b / inc.h, inc.alpha, inc.phi);
            let reference = label(
                inc.alpha > inc.phi,
                inc.alpha.to_radians().tan() > inc.b / inc.h,
            );
            let run = || -> Result<(Real, Real), SolverError> {
                let mut h = Harness::new(&inc.scene(), solver)?;
                let rock = h.solver.block_index("rock").unwrap();
                // The downhill bottom corner in the block frame: local (b, ·, 0) before turning.
                let a = inc.alpha.to_radians();
                let corner_world = Vector::new(inc.b * a.cos(), 0.0, -inc.b * a.sin());
                let b0 = &h.world().blocks[rock];
                let local = b0
                    .rotation
                    .inverse_transform_vector(&(corner_world - b0.position.coords));
                let start = corner_world;
                let mut pivot_slip: Real = 0.0;
                let downhill = inc.downhill();
                h.run_until(1.0, None, |w| {
                    let b = &w.blocks[rock];
                    if b.rotation.angle() < 10f64.to_radians() {
                        let now = b.position.coords + b.rotation * local;
                        pivot_slip = pivot_slip.max((now - start).dot(&downhill).abs());
                    }
                })?;
                Ok((
                    pivot_slip,
                    h.world().blocks[rock].rotation.angle().to_degrees(),
                ))
            };
            match run() {
                Err(e) => Row::failed(&case, solver, "motion", &e),
                Ok((slip, angle)) => {
                    let measured = label(slip > 0.02, angle > 5.0);
                    let mut row =
                        Row::categorical(&case, solver, "motion in 1 s", reference, measured);
                    row.measured = format!("{measured} (pivot slip {slip:.3} m, turn {angle:.1}°)");
                    row.pass = measured == reference;
                    row
                }
            }
        })
        .collect()
}

/// The embedded default scene with no water: the wedge starts at zero gap on the 25° slope
/// (friction 5°) and must slide smoothly: d(t) = ½ g (sin 25° − cos 25° tan 5°) t² until it
/// reaches the floor (0.8 s here). Returns (distance, largest speed error, turn angle).
pub fn default_wedge(
    solver: &str,
    duration: Real,
) -> Result<(Real, Real, Real, Real), SolverError> {
    let scene = Scene::default_scene();
    let mut h = Harness::new(&scene, solver)?;
    let wedge = h.solver.block_index("wedge").unwrap();
    let a = 25f64.to_radians();
    let downhill = Vector::new(a.cos(), 0.0, -a.sin());
    let acc = G * (a.sin() - a.cos() * 5f64.to_radians().tan());
    let start = h.world().blocks[wedge].position;
    let mut speed_err: Real = 0.0;
    h.run_until(duration, None, |w| {
        let b = &w.blocks[wedge];
        speed_err = speed_err.max((b.velocity.dot(&downhill) - acc * w.time).abs());
    })?;
    let b = &h.world().blocks[wedge];
    Ok((
        (b.position - start).dot(&downhill),
        0.5 * acc * duration * duration,
        speed_err / (acc * duration),
        b.rotation.angle(),
    ))
}

pub fn default_wedge_rows(solver: &str) -> Vec<Row> {
    let case = "default scene wedge (25°, φ=5°), dry, 0.8 s";
    match default_wedge(solver, 0.8) {
        Err(e) => vec![Row::failed(case, solver, "d(0.8 s) [m]", &e)],
        Ok((d, reference, speed_err, angle)) => vec![
            Row::numeric(
                case,
                solver,
                "d(0.8 s) [m]",
                reference,
                d,
                Tolerance::Relative(0.005),
            ),
            Row::numeric(
                case,
                solver,
                "largest speed error / (a t_end)",
                0.0,
                speed_err,
                Tolerance::Absolute(0.01),
            ),
            Row::numeric(
                case,
                solver,
                "turn [rad]",
                0.0,
                angle,
                Tolerance::Absolute(1e-3),
            ),
        ],
    }
}

/// A block spinning freely at 10 rad/s about a tilted axis for 2 s: its corners keep their
/// distance to the centroid (no DDA rotation growth).
pub fn spinning_block(solver: &str) -> Row {
    let case = "free spin 10 rad/s, 2 s";
    let s = scene(
        "spin",
        [0.0, 0.0, 0.0],
        5.0,
        "[solid.implicit]\ndisplacement_limit = 10.0",
        "",
        &[block_toml(
            "rock",
            "free",
            2500.0,
            &box_corners([-0.3, -0.2, -0.1], [0.3, 0.2, 0.1]),
            "angular_velocity = [3.0, 0.0, 9.539392014169456]",
        )],
    );
    let run = || -> Result<Real, SolverError> {
        let mut h = Harness::new(&s, solver)?;
        let reference: Vec<Real> = h
            .block("rock")
            .shape
            .vertices
            .iter()
            .map(|v| v.coords.norm())
            .collect();
        let mut growth: Real = 0.0;
        let rock = h.solver.block_index("rock").unwrap();
        h.run_until(2.0, Some(1e-3), |w| {
            let b = &w.blocks[rock];
            for (v, r0) in b.world_vertices.iter().zip(&reference) {
                growth = growth.max(((v - b.position).norm() / r0 - 1.0).abs());
            }
        })?;
        Ok(growth)
    };
    match run() {
        Err(e) => Row::failed(case, solver, "size change", &e),
        Ok(g) => Row::numeric(
            case,
            solver,
            "max corner radius change (relative)",
            0.0,
            g,
            Tolerance::Absolute(1e-12),
        ),
    }
}
