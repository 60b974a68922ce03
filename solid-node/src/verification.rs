//! Verification cases with closed-form references (docs/REFERENCES.md §2): free fall, a block on an
//! incline that sticks or slides (with and without cohesion), slide-or-topple, the restitution
//! of an undamped penalty bounce for both schemes, the explicit scheme pushed past its limit,
//! a stack at rest, the embedded default scene's wedge, and a spinning block that must not
//! grow; and the deformable (12-DOF) blocks' cases in [`deformable`]. `solid-validate` prints
//! them as a table; the tests run the same functions.
//!
//! Every case drives the solver through the [`SolidSolver`] interface, as the node runtime
//! does, with the run directory in a temporary folder.

use crate::dda::DdaSolver;
use crate::world::World;
use shared::math::{Real, Vector};
use shared::scene::{Scene, Scheme};
use shared::solver::{SetupContext, Solver, SolverError};
use shared::step::{StepRule, grant};
use std::f64::consts::PI;
use std::path::PathBuf;
use std::sync::atomic::{AtomicUsize, Ordering};

const G: Real = shared::math::STANDARD_GRAVITY;

pub use shared::report::{Row, Tolerance, markdown};

/// The central difference scheme's registry name: the cases whose reference is that scheme's
/// own (its limit 2/ω_max, paper Eq. 8; its restitution and period) choose by it.
pub const EXPLICIT: &str = <crate::explicit::CentralDifference as crate::integrator::Scheme>::NAME;

pub mod deformable;

// ---------------------------------------------------------------------------------------------
// Scenes built in code.

/// Corners of an axis-aligned box.
pub fn box_corners(min: [Real; 3], max: [Real; 3]) -> Vec<[Real; 3]> {
    let mut v = Vec::with_capacity(8);
    for &x in &[min[0], max[0]] {
        for &y in &[min[1], max[1]] {
            for &z in &[min[2], max[2]] {
                v.push([x, y, z]);
            }
        }
    }
    v
}

/// Rotation by `alpha` about +y: x̂ goes to (cos α, 0, −sin α), i.e. downhill for a slope of α.
pub fn rotate_y(v: &[[Real; 3]], alpha: Real) -> Vec<[Real; 3]> {
    let (s, c) = alpha.sin_cos();
    v.iter()
        .map(|p| [c * p[0] + s * p[2], p[1], -s * p[0] + c * p[2]])
        .collect()
}

/// A `[[block]]` table of convex shape.
pub fn block_toml(
    name: &str,
    kind: &str,
    density: Real,
    vertices: &[[Real; 3]],
    extra: &str,
) -> String {
    let v: Vec<String> = vertices
        .iter()
        .map(|p| format!("[{:.15e}, {:.15e}, {:.15e}]", p[0], p[1], p[2]))
        .collect();
    format!(
        "[[block]]\nname = \"{name}\"\nkind = \"{kind}\"\ndensity = {density:.6}\nshape = {{ type = \"convex\", vertices = [{}] }}\n{extra}\n",
        v.join(", ")
    )
}

/// A whole scene: header, `[solid]` lines (solver tables such as `[solid.implicit]` may follow
/// them), `[solid.contact]` lines, blocks. Checked by [`crate::check_scene`] too.
pub fn scene(
    name: &str,
    gravity: [Real; 3],
    half_extent: Real,
    solid: &str,
    contact: &str,
    blocks: &[String],
) -> Scene {
    let h = half_extent;
    let text = format!(
        "name = \"{name}\"\ngravity = [{:.15e}, {:.15e}, {:.15e}]\n[time]\nend = 10.0\ndt_max = 1e-3\ndt_min = 1e-12\n\
         [domain]\nmin = [{}, {}, {}]\nmax = [{h}, {h}, {h}]\n[output]\ninterval = 0.05\nvtk = false\n\
         [solid]\n{solid}\n[solid.contact]\n{contact}\n{}",
        gravity[0],
        gravity[1],
        gravity[2],
        -h,
        -h,
        -h,
        blocks.join("\n")
    );
    Scene::parse_checked(&text, name, &[&crate::check_scene])
        .unwrap_or_else(|e| panic!("verification scene {name} is invalid: {e}\n{text}"))
}

// ---------------------------------------------------------------------------------------------
// Driving a solver.

static RUN_COUNTER: AtomicUsize = AtomicUsize::new(0);

/// A solver with its own temporary run directory (removed on drop).
pub struct Harness {
    pub solver: DdaSolver,
    /// The scene's step limits, as the coupler applies them.
    pub rule: StepRule,
    dir: PathBuf,
}

impl Harness {
    pub fn new(scene: &Scene, solver: &str) -> Result<Harness, SolverError> {
        let n = RUN_COUNTER.fetch_add(1, Ordering::Relaxed);
        let dir = std::env::temp_dir().join(format!("rockwave-solid-{}-{n}", std::process::id()));
        std::fs::create_dir_all(&dir)?;
        let ctx = SetupContext {
            scene,
            run_dir: &dir,
            scheme: Scheme::Parallel,
            peer_present: false,
        };
        let solver = *crate::REGISTRY.build(solver, &ctx)?;
        let rule = StepRule::new(scene.time.dt_max, scene.time.dt_min);
        Ok(Harness { solver, rule, dir })
    }

    pub fn world(&self) -> &World {
        &self.solver.world
    }

    pub fn time(&self) -> Real {
        self.solver.world.time
    }

    pub fn run_dir(&self) -> &std::path::Path {
        &self.dir
    }

    /// One step towards `target`, granted by the coupler's rule ([`shared::step::grant`]: the
    /// proposal within `rule`'s limits, times its `dt_factor`, landing on `target`); returns the
    /// step taken. A collapsed proposal is an instability.
    pub fn step(&mut self, rule: &StepRule, target: Real) -> Result<Real, SolverError> {
        let proposal = [(self.solver.name(), self.solver.dt_proposal())];
        let dt = grant(proposal, rule, self.time(), target)
            .map(|g| g.dt)
            .map_err(|c| SolverError::Unstable(format!("step collapsed: {c}")))?;
        self.solver.advance(dt)?;
        Ok(dt)
    }

    /// Advances to `t_end` the way the coupler does ([`Self::step`] with the scene's limits),
    /// or with a fixed `dt`; calls `each` after every step.
    pub fn run_until(
        &mut self,
        t_end: Real,
        dt: Option<Real>,
        mut each: impl FnMut(&World),
    ) -> Result<(), SolverError> {
        let rule = self.rule;
        while self.time() < t_end - 1e-12 {
            match dt {
                Some(dt) => {
                    self.solver.advance(dt.min(t_end - self.time()))?;
                }
                None => {
                    self.step(&rule, t_end)?;
                }
            }
            each(&self.solver.world);
        }
        Ok(())
    }

    pub fn block(&self, name: &str) -> &crate::block::Block {
        let i = self.solver.block_index(name).expect("block exists");
        &self.solver.world.blocks[i]
    }
}

impl Drop for Harness {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.dir);
    }
}

// ---------------------------------------------------------------------------------------------
// Cases.

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

/// Contact damping (fraction of critical) of the incline scenes. A block set down at zero gap
/// drops onto its springs and, undamped, would bounce on them at ω for ever under the
/// explicit scheme (which has no numerical damping), its friction capacity N tan φ bouncing
/// between 0 and twice the static value with it; real joints dissipate that in a few cycles.
pub const INCLINE_DAMPING: Real = 0.2;

/// Parameters of a block on an incline.
#[derive(Debug, Clone, Copy)]
pub struct Incline {
    /// Slope angle α [deg].
    pub alpha: Real,
    /// Joint friction angle φ [deg].
    pub phi: Real,
    /// Joint cohesion c [Pa].
    pub cohesion: Real,
    /// Block length b along the slope and height h [m] (width 0.4 m).
    pub b: Real,
    pub h: Real,
}

impl Incline {
    /// The slope (a fixed slab) and the block sitting on it at zero gap, both turned by α.
    pub fn scene(&self) -> Scene {
        self.scene_with("")
    }

    /// [`Incline::scene`] with `extra` TOML lines in the block's table (e.g. `elastic = ...`).
    pub fn scene_with(&self, extra: &str) -> Scene {
        let a = self.alpha.to_radians();
        let slab = rotate_y(&box_corners([-1.0, -1.0, -0.3], [6.0, 1.0, 0.0]), a);
        let block = rotate_y(&box_corners([0.0, -0.2, 0.0], [self.b, 0.2, self.h]), a);
        scene(
            "incline",
            [0.0, 0.0, -G],
            10.0,
            "",
            &format!(
                "friction_angle = {}\ncohesion = {}\ndamping_ratio = {INCLINE_DAMPING}",
                self.phi, self.cohesion
            ),
            &[
                block_toml("slope", "fixed", 2500.0, &slab, ""),
                block_toml("rock", "free", 2500.0, &block, extra),
            ],
        )
    }

    /// Downhill unit vector.
    pub fn downhill(&self) -> Vector {
        let a = self.alpha.to_radians();
        Vector::new(a.cos(), 0.0, -a.sin())
    }

    /// d(t) = ½ [g (sin α − cos α tan φ) − c A/m] t², or 0 when the block holds.
    pub fn reference_distance(&self, t: Real) -> Real {
        let (a, phi) = (self.alpha.to_radians(), self.phi.to_radians());
        let mass = 2500.0 * self.b * 0.4 * self.h;
        let acc = G * (a.sin() - a.cos() * phi.tan()) - self.cohesion * self.b * 0.4 / mass;
        0.5 * acc.max(0.0) * t * t
    }
}

/// Runs an incline case for `duration` seconds; the downhill displacement of the centroid.
pub fn incline_distance(
    inc: &Incline,
    solver: &str,
    duration: Real,
) -> Result<(Real, Real), SolverError> {
    let mut h = Harness::new(&inc.scene(), solver)?;
    let start = h.block("rock").position;
    h.run_until(duration, None, |_| {})?;
    let b = h.block("rock");
    Ok((
        (b.position - start).dot(&inc.downhill()),
        b.rotation.angle(),
    ))
}

/// The incline rows: a block that sticks (α < φ), one that slides, and both with cohesion.
pub fn incline_rows(solver: &str) -> Vec<Row> {
    let cases = [
        (
            "incline α=20° φ=30°: sticks",
            Incline {
                alpha: 20.0,
                phi: 30.0,
                cohesion: 0.0,
                b: 0.4,
                h: 0.2,
            },
        ),
        (
            "incline α=30° φ=20°: slides",
            Incline {
                alpha: 30.0,
                phi: 20.0,
                cohesion: 0.0,
                b: 0.4,
                h: 0.2,
            },
        ),
        (
            "incline α=30° φ=20° c=250 Pa: slides",
            Incline {
                alpha: 30.0,
                phi: 20.0,
                cohesion: 250.0,
                b: 0.4,
                h: 0.2,
            },
        ),
        (
            "incline α=30° φ=20° c=1500 Pa: sticks",
            Incline {
                alpha: 30.0,
                phi: 20.0,
                cohesion: 1500.0,
                b: 0.4,
                h: 0.2,
            },
        ),
    ];
    cases
        .iter()
        .map(|(case, inc)| match incline_distance(inc, solver, 1.0) {
            Err(e) => Row::failed(case, solver, "d(1 s) [m]", &e),
            Ok((d, _)) => {
                let reference = inc.reference_distance(1.0);
                if reference > 0.0 {
                    Row::numeric(
                        case,
                        solver,
                        "d(1 s) [m]",
                        reference,
                        d,
                        Tolerance::Relative(0.005),
                    )
                } else {
                    // Holding: the elastic shear deflection of the springs (tens of µm) and the
                    // slip while the normal springs load up from the zero-gap start.
                    Row::numeric(
                        case,
                        solver,
                        "d(1 s) [m]",
                        0.0,
                        d,
                        Tolerance::Absolute(1e-3),
                    )
                }
            }
        })
        .collect()
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
            block_toml(
                "floor",
                "fixed",
                2500.0,
                &box_corners([-1.0, -1.0, -0.5], [1.0, 1.0, 0.0]),
                "",
            ),
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
/// mode, for `duration`: the largest energy ratio seen (see [`crate::energy`]), or the error.
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
            block_toml(
                "floor",
                "fixed",
                2500.0,
                &box_corners([-1.0, -1.0, -0.5], [1.0, 1.0, 0.0]),
                "",
            ),
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

/// All cases for both solvers (`quick` shortens the stack run to 3 s).
pub fn run_all(quick: bool) -> Vec<Row> {
    let mut rows = Vec::new();
    let solvers = crate::REGISTRY.names();
    for &solver in &solvers {
        rows.push(free_fall(solver));
        rows.push(spinning_block(solver));
        rows.extend(incline_rows(solver));
        rows.extend(slide_or_topple(solver));
        rows.extend(restitution_rows(solver));
        if solver == EXPLICIT {
            rows.extend(explicit_limit_rows());
        }
        rows.push(stack_row(solver, if quick { 3.0 } else { 10.0 }));
        rows.extend(default_wedge_rows(solver));
    }
    for &solver in &solvers {
        rows.extend(deformable::rows(solver));
    }
    rows
}
