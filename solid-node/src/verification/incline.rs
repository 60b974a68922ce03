//! A block on an incline: at rest or sliding with d(t) = ½[g(sinα − cosα tanφ) − cA/m]t²
//! (Mohr–Coulomb with cohesion; docs/REFERENCES.md).

use super::harness::Harness;
use super::scenes::{G, block_toml, box_corners, rotate_y, scene};
use shared::math::{Real, Vector};
use shared::report::{Row, Tolerance};
use shared::scene::Scene;
use shared::solver::SolverError;

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
    /// The block that slides: α = 30°, φ = 20°, no cohesion, 0.4 × 0.2 m.
    pub const SLIDING: Incline = Incline {
        alpha: 30.0,
        phi: 20.0,
        cohesion: 0.0,
        b: 0.4,
        h: 0.2,
    };

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
        ("incline α=30° φ=20°: slides", Incline::SLIDING),
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
