//! Jointed slopes cut from a `[[slide]]` against limit equilibrium (Hoek & Bray, *Rock Slope
//! Engineering*, 3rd ed. 1981, ch. 7 planar failure and ch. 8 wedge failure; docs/REFERENCES.md):
//! a slope whose factor of safety is above 1 stands, one below 1 fails and then slides with the
//! residual friction of its broken joints.
//!
//! Both slopes are cut by the slide's joint sets; the blocks that are not the sliding mass are
//! then fixed (they stand for the rock behind the failure surface), so the case isolates the
//! joints' strength.

use super::harness::Harness;
use super::scenes::{G, scene};
use shared::geometry::Polyhedron;
use shared::math::{Real, Vector};
use shared::report::{Row, Tolerance};
use shared::scene::{BlockKind, Scene};
use shared::solver::SolverError;

/// Contact damping of the jointed cases (fraction of critical, per contact). The joints are
/// loaded before t = 0 ([`crate::settle`]), so no transient has to be damped; and a block held
/// by 8 springs at its ends has its rocking mode damped about 5 times more than one spring
/// alone: at ζ = 0.2 that mode passes the damped central difference limit
/// ω·dt ≤ 2(√(1 + ζ²) − ζ) at the default step, which the ω_max estimate (undamped) ignores.
pub const JOINTED_DAMPING: Real = 0.05;

/// Rock density of the cases [kg/m³].
const RHO: Real = 2500.0;

/// A planar failure: a slab of thickness `t` and length `l` along a joint dipping ψ, on the
/// rock below it (Hoek & Bray's dry case without tension crack:
/// FS = (c A + W cos ψ tan φ) / (W sin ψ)).
#[derive(Debug, Clone, Copy)]
pub struct Planar {
    /// Dip ψ of the sliding joint [deg].
    pub psi: Real,
    /// Friction angle φ of the joint set [deg].
    pub phi: Real,
    /// Factor of safety the cohesion is chosen for.
    pub fs: Real,
    pub l: Real,
    pub t: Real,
}

impl Planar {
    /// Width of the slab across the slope [m].
    const WIDTH: Real = 0.5;

    /// Cohesion that gives the factor of safety `fs`: c = ρ g t (FS sin ψ − cos ψ tan φ).
    pub fn cohesion(&self) -> Real {
        let (psi, phi) = (self.psi.to_radians(), self.phi.to_radians());
        RHO * G * self.t * (self.fs * psi.sin() - psi.cos() * phi.tan())
    }

    /// Hoek & Bray's factor of safety of the slab with [`Self::cohesion`].
    pub fn factor_of_safety(&self) -> Real {
        let (psi, phi) = (self.psi.to_radians(), self.phi.to_radians());
        let a = self.l * Self::WIDTH;
        let w = RHO * G * self.t * a;
        (self.cohesion() * a + w * psi.cos() * phi.tan()) / (w * psi.sin())
    }

    /// The slope: a prism along y whose profile is the rock under the joint (a triangle) and
    /// the slab on it, cut by one joint set dipping ψ to −x through the origin. The block
    /// below the joint is fixed.
    pub fn scene(&self) -> Scene {
        let (s, c) = self.psi.to_radians().sin_cos();
        let (l, t) = (self.l, self.t);
        let profile = [
            [0.0, 0.0],
            [l * c, 0.0],
            [l * c, l * s],
            [l * c - t * s, l * s + t * c],
            [-t * s, t * c],
        ];
        let p: Vec<String> = profile
            .iter()
            .map(|q| format!("[{:.15e}, {:.15e}]", q[0], q[1]))
            .collect();
        let slide = format!(
            "[[slide]]\nname = \"slope\"\ndensity = {RHO}\n\
             region = {{ type = \"prism\", axis = \"y\", profile = [{}], extent = [0, {}] }}\n\
             [[slide.joint_set]]\ndip = {}\ndip_direction = 270\nspacing = 100\n\
             friction_angle = {}\ncohesion = {:.15e}\ntensile_strength = {:.15e}\n",
            p.join(", "),
            Self::WIDTH,
            self.psi,
            self.phi,
            self.cohesion(),
            self.cohesion()
        );
        let n = Vector::new(-s, 0.0, c);
        fix_all_but(
            scene(
                "planar",
                [0.0, 0.0, -G],
                10.0,
                "",
                &format!("damping_ratio = {JOINTED_DAMPING}"),
                &[slide],
            ),
            |centroid| n.dot(&centroid) > 0.0,
        )
    }

    /// Down-dip unit vector.
    pub fn downhill(&self) -> Vector {
        let (s, c) = self.psi.to_radians().sin_cos();
        Vector::new(-c, 0.0, -s)
    }

    /// Sliding distance at `t` once the joint has broken at once: ½ g (sin ψ − cos ψ tan φ) t²
    /// (residual friction only), or 0 when it holds (FS > 1).
    pub fn reference_distance(&self, t: Real) -> Real {
        if self.fs > 1.0 {
            return 0.0;
        }
        let (psi, phi) = (self.psi.to_radians(), self.phi.to_radians());
        0.5 * G * (psi.sin() - psi.cos() * phi.tan()) * t * t
    }
}

/// A symmetric wedge on two joint sets whose line of intersection plunges ψᵢ (towards −y),
/// each plane turned `alpha` from the vertical plane through the line: included angle
/// ξ = 180° − 2α, wedge factor K = sin β / sin(ξ/2) with β = 90°. Dry, cohesionless:
/// FS = K (tan φ_A + tan φ_B) / (2 tan ψᵢ) (Hoek & Bray ch. 8, the wedge factor with the
/// equal normal forces of a symmetric wedge).
#[derive(Debug, Clone, Copy)]
pub struct Wedge {
    pub plunge: Real,
    pub alpha: Real,
    pub phi_a: Real,
    pub phi_b: Real,
}

impl Wedge {
    /// The wedge factor K.
    pub fn wedge_factor(&self) -> Real {
        let half_xi = (90.0 - self.alpha).to_radians();
        1.0 / half_xi.sin()
    }

    pub fn factor_of_safety(&self) -> Real {
        let (ta, tb) = (self.phi_a.to_radians().tan(), self.phi_b.to_radians().tan());
        self.wedge_factor() * 0.5 * (ta + tb) / self.plunge.to_radians().tan()
    }

    /// Upward unit normals of the two planes.
    fn normals(&self) -> [Vector; 2] {
        let (sp, cp) = self.plunge.to_radians().sin_cos();
        let (sa, ca) = self.alpha.to_radians().sin_cos();
        [
            Vector::new(sa, -sp * ca, cp * ca),
            Vector::new(-sa, -sp * ca, cp * ca),
        ]
    }

    /// A box region cut by the two sets through the origin: the wedge above both is free; the
    /// two blocks each under one plane are fixed; the block under both (touching the wedge
    /// only along the line of intersection) is removed, so that the wedge rests on its two
    /// planes alone, as the limit equilibrium assumes.
    pub fn scene(&self) -> Scene {
        let normals = self.normals();
        let mut sets = String::new();
        for (n, phi) in normals.iter().zip([self.phi_a, self.phi_b]) {
            let dip = n.z.acos().to_degrees();
            let dir = n.x.atan2(n.y).to_degrees().rem_euclid(360.0);
            sets += &format!(
                "[[slide.joint_set]]\ndip = {dip:.15e}\ndip_direction = {dir:.15e}\nspacing = 100\nfriction_angle = {phi}\n"
            );
        }
        let slide = format!(
            "[[slide]]\nname = \"rock\"\ndensity = {RHO}\n\
             region = {{ type = \"box\", min = [-1, 0, -0.5], max = [1, 2, 0.8] }}\n{sets}"
        );
        let mut s = scene(
            "wedge",
            [0.0, 0.0, -G],
            10.0,
            "",
            &format!("damping_ratio = {JOINTED_DAMPING}"),
            &[slide],
        );
        let above = |c: &Vector, n: &Vector| n.dot(c) > 0.0;
        s.blocks.retain(|b| {
            let c = Polyhedron::from_shape(&b.shape).unwrap().centroid.coords;
            above(&c, &normals[0]) || above(&c, &normals[1])
        });
        fix_all_but(s, |c| above(&c, &normals[0]) && above(&c, &normals[1]))
    }

    /// Down-plunge unit vector along the line of intersection.
    pub fn downhill(&self) -> Vector {
        let (sp, cp) = self.plunge.to_radians().sin_cos();
        Vector::new(0.0, -cp, -sp)
    }

    /// ½ g (sin ψᵢ − cos ψᵢ K (tan φ_A + tan φ_B)/2) t² when FS < 1, else 0.
    pub fn reference_distance(&self, t: Real) -> Real {
        let fs = self.factor_of_safety();
        if fs >= 1.0 {
            return 0.0;
        }
        let (sp, cp) = self.plunge.to_radians().sin_cos();
        let mean = 0.5 * (self.phi_a.to_radians().tan() + self.phi_b.to_radians().tan());
        0.5 * G * (sp - cp * self.wedge_factor() * mean) * t * t
    }
}

/// A block hanging from the rock above it by one horizontal joint of tensile strength T over
/// the whole 1 m² face: it holds while T·A ≥ W, else the joint opens (tension cut-off) and the
/// block falls freely, d = ½ g t².
#[derive(Debug, Clone, Copy)]
pub struct Hanging {
    /// T·A / W.
    pub ratio: Real,
}

impl Hanging {
    /// Weight of the hanging half (1 × 1 × 0.5 m) [N].
    fn weight() -> Real {
        RHO * G * 0.5
    }

    pub fn tensile_strength(&self) -> Real {
        self.ratio * Self::weight()
    }

    /// A 1 m cube cut at z = 0.5 by one horizontal joint; the upper half fixed.
    pub fn scene(&self) -> Scene {
        let slide = format!(
            "[[slide]]\nname = \"roof\"\ndensity = {RHO}\n\
             region = {{ type = \"box\", min = [0, 0, 0], max = [1, 1, 1] }}\n\
             [[slide.joint_set]]\ndip = 0\ndip_direction = 0\nspacing = 10\noffset = [0, 0, 0.5]\n\
             friction_angle = 30\ncohesion = {:.15e}\ntensile_strength = {:.15e}\n",
            self.tensile_strength(),
            self.tensile_strength()
        );
        fix_all_but(
            scene(
                "hanging",
                [0.0, 0.0, -G],
                10.0,
                "",
                &format!("damping_ratio = {JOINTED_DAMPING}"),
                &[slide],
            ),
            |c| c.z < 0.5,
        )
    }

    pub fn reference_distance(&self, t: Real) -> Real {
        if self.ratio >= 1.0 {
            0.0
        } else {
            0.5 * G * t * t
        }
    }
}

/// Fixes every block but the one whose centroid passes `free`; names that block `mass`.
fn fix_all_but(mut s: Scene, free: impl Fn(Vector) -> bool) -> Scene {
    let mut found = 0;
    for b in &mut s.blocks {
        let c = Polyhedron::from_shape(&b.shape).unwrap().centroid.coords;
        if free(c) {
            b.name = "mass".into();
            found += 1;
        } else {
            b.kind = BlockKind::Fixed;
        }
    }
    assert_eq!(found, 1, "exactly one sliding block");
    s
}

/// Runs a jointed case for `duration`: the down-slope displacement of the sliding mass and
/// how many of its contacts are still bonded.
pub fn jointed_distance(
    scene: &Scene,
    downhill: Vector,
    solver: &str,
    duration: Real,
) -> Result<(Real, usize), SolverError> {
    let mut h = Harness::new(scene, solver)?;
    let start = h.block("mass").position;
    h.run_until(duration, None, |_| {})?;
    let d = (h.block("mass").position - start).dot(&downhill);
    let bonded = h.world().contacts.iter().filter(|c| c.bonded).count();
    Ok((d, bonded))
}

/// Time the jointed cases run [s].
pub const JOINTED_DURATION: Real = 0.6;

/// The planar, hanging and wedge rows of one solver (both model the bonds and their breaking:
/// the explicit one in [`crate::contact::springs`], the implicit one in its open–close iterations).
pub fn jointed_rows(solver: &str) -> Vec<Row> {
    let planar = |fs| Planar {
        psi: 35.0,
        phi: 22.8,
        fs,
        l: 2.0,
        t: 0.2,
    };
    let wedge = |phi_a, phi_b| Wedge {
        plunge: 30.0,
        alpha: 30.0,
        phi_a,
        phi_b,
    };
    let mut rows = Vec::new();
    let t = JOINTED_DURATION;
    let mut push = |name: String, s: Result<Scene, String>, downhill: Vector, reference: Real| {
        let quantity = format!("d({t} s) [m]");
        let scene = match s {
            Ok(s) => s,
            Err(e) => {
                rows.push(Row::categorical(&name, solver, &quantity, "valid", &e));
                return;
            }
        };
        match jointed_distance(&scene, downhill, solver, t) {
            Err(e) => rows.push(Row::failed(&name, solver, &quantity, &e)),
            // Standing: the joints' elastic deflection (µm) and no broken bond.
            Ok((d, _)) if reference == 0.0 => rows.push(Row::numeric(
                &name,
                solver,
                &quantity,
                0.0,
                d,
                Tolerance::Absolute(1e-4),
            )),
            // Failing: the bond breaks at once and the mass slides on residual friction.
            Ok((d, bonded)) => rows.push(Row::numeric(
                &format!("{name} ({bonded} bonds left)"),
                solver,
                &quantity,
                reference,
                d,
                Tolerance::Relative(0.02),
            )),
        }
    };
    for fs in [1.3, 0.8] {
        let p = planar(fs);
        push(
            format!(
                "planar ψ=35° φ=22.8° c={:.0} Pa: FS={:.2}",
                p.cohesion(),
                p.factor_of_safety()
            ),
            Ok(p.scene()),
            p.downhill(),
            p.reference_distance(t),
        );
    }
    for ratio in [1.3, 0.8] {
        let h = Hanging { ratio };
        push(
            format!(
                "hanging block, joint T={:.0} Pa: T·A/W={ratio}",
                h.tensile_strength()
            ),
            Ok(h.scene()),
            -Vector::z(),
            h.reference_distance(t),
        );
    }
    for (a, b) in [(31.0, 35.0), (19.3, 24.2)] {
        let w = wedge(a, b);
        push(
            format!(
                "wedge ψi=30° ξ=120° φA={a}° φB={b}°: K={:.3} FS={:.2}",
                w.wedge_factor(),
                w.factor_of_safety()
            ),
            Ok(w.scene()),
            w.downhill(),
            w.reference_distance(t),
        );
    }
    rows
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::verification::harness::EXPLICIT;

    #[test]
    fn the_cases_have_the_factors_of_safety_they_claim() {
        let p = Planar {
            psi: 35.0,
            phi: 22.8,
            fs: 1.3,
            l: 2.0,
            t: 0.2,
        };
        assert!((p.factor_of_safety() - 1.3).abs() < 1e-12);
        let w = Wedge {
            plunge: 30.0,
            alpha: 30.0,
            phi_a: 31.0,
            phi_b: 35.0,
        };
        assert!((w.wedge_factor() - 1.0 / 60f64.to_radians().sin()).abs() < 1e-12);
        assert!(w.factor_of_safety() > 1.25 && w.factor_of_safety() < 1.35);
        // The planes contain the line of intersection and make the included angle ξ = 120°.
        let [n1, n2] = w.normals();
        let d = -w.downhill();
        assert!(n1.dot(&d).abs() < 1e-15 && n2.dot(&d).abs() < 1e-15);
        assert!((n1.dot(&n2) - (180f64 - 120.0).to_radians().cos()).abs() < 1e-12);
    }

    #[test]
    fn a_failing_wedge_runs_the_same_to_the_bit() {
        let w = Wedge {
            plunge: 30.0,
            alpha: 30.0,
            phi_a: 19.3,
            phi_b: 24.2,
        };
        let run = || {
            let mut h = Harness::new(&w.scene(), EXPLICIT).unwrap();
            h.run_until(0.1, None, |_| {}).unwrap();
            let b = h.block("mass");
            (b.position, b.rotation, b.velocity)
        };
        let (a, b) = (run(), run());
        assert!(
            a.0 != Harness::new(&w.scene(), EXPLICIT)
                .unwrap()
                .block("mass")
                .position
        );
        assert_eq!(a, b);
    }
}
