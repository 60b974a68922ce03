//! Mohr–Coulomb joint strength with cohesion: the shear a contact carries is bounded by
//! `c·A + N·tan φ` (Shi 1993; Doolin & Sitar 2004 for the 3D contact states).
//!
//! Contacts never carry tension (a penetration-free contact is open), and cohesion is kept
//! while a joint slides: the limit is the Mohr–Coulomb envelope itself, which is what the
//! block-on-incline reference d(t) = ½[g(sin α − cos α tan φ) − cA/m] t² assumes. A contact
//! is open, locked or sliding ([`ContactState`]) by where it stands against that envelope.

use shared::math::{Real, Vector};
use shared::scene::ContactSpec;

/// The three Mohr–Coulomb states of DDA's open–close logic (Shi 1993).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize, serde::Deserialize)]
pub enum ContactState {
    /// Not touching: no spring.
    #[default]
    Open,
    /// Touching, shear below the Mohr–Coulomb limit: normal and shear springs.
    Locked,
    /// Touching, shear at the limit: normal spring, friction force c·A + N·tan φ along the slip.
    Sliding,
}

/// Friction angle and cohesion of one pair of blocks, and for two blocks cut from one slide
/// across a joint plane, that joint's tensile strength and bond ([`crate::contact::joints`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Joint {
    pub tan_phi: Real,
    pub cohesion: Real,
    /// Tensile strength [Pa] of the intact joint (0 but for a bonded slide joint).
    pub tensile: Real,
    /// The pair is bonded across a slide's joint: its contacts found at the start are bonded,
    /// and once broken they keep residual friction only (no cohesion, no tension).
    pub bonded: bool,
}

impl Joint {
    /// The joint between two blocks: the smaller of the blocks' own `friction_angle` /
    /// `cohesion` where at least one gives one, else the scene's `[solid.contact]` values.
    pub fn of_pair(
        spec: &ContactSpec,
        phi: (Option<Real>, Option<Real>),
        cohesion: (Option<Real>, Option<Real>),
    ) -> Joint {
        let smaller = |x: (Option<Real>, Option<Real>), default: Real| match x {
            (Some(a), Some(b)) => a.min(b),
            (Some(a), None) | (None, Some(a)) => a,
            (None, None) => default,
        };
        let phi = smaller(phi, spec.friction_angle);
        Joint {
            tan_phi: phi.to_radians().tan(),
            cohesion: smaller(cohesion, spec.cohesion),
            tensile: 0.0,
            bonded: false,
        }
    }

    /// Largest shear force [N] under normal force `n` ≥ 0 over tributary area `area`.
    #[inline]
    pub fn shear_limit(tan_phi: Real, cohesion: Real, area: Real, n: Real) -> Real {
        cohesion * area + n.max(0.0) * tan_phi
    }
}

/// Returns the Mohr–Coulomb state of a closed contact whose shear spring (stiffness `ks`) is
/// stretched by `shear`, and clamps the spring to the limit when it slides (the anchor slips).
#[inline]
pub fn classify_and_clamp(shear: &mut Vector, ks: Real, limit: Real) -> ContactState {
    let f = ks * shear.norm();
    if f > limit {
        if f > 0.0 {
            *shear *= limit / f;
        }
        ContactState::Sliding
    } else {
        ContactState::Locked
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pair_uses_smaller_override_else_default() {
        let spec = ContactSpec {
            friction_angle: 30.0,
            cohesion: 100.0,
            ..Default::default()
        };
        let j = Joint::of_pair(&spec, (None, None), (None, None));
        assert!((j.tan_phi - 30f64.to_radians().tan()).abs() < 1e-15);
        assert_eq!(j.cohesion, 100.0);
        let j = Joint::of_pair(&spec, (Some(40.0), None), (Some(5.0), Some(7.0)));
        assert!((j.tan_phi - 40f64.to_radians().tan()).abs() < 1e-15);
        assert_eq!(j.cohesion, 5.0);
        let j = Joint::of_pair(&spec, (Some(40.0), Some(12.0)), (None, None));
        assert!((j.tan_phi - 12f64.to_radians().tan()).abs() < 1e-15);
    }

    #[test]
    fn sliding_clamps_to_the_envelope() {
        let limit = Joint::shear_limit(0.5, 1000.0, 0.01, 100.0);
        assert!((limit - 60.0).abs() < 1e-12);
        let mut s = Vector::new(3e-5, 4e-5, 0.0);
        assert_eq!(classify_and_clamp(&mut s, 1e6, limit), ContactState::Locked);
        assert!((s.norm() - 5e-5).abs() < 1e-18);
        let mut s = Vector::new(3e-4, 4e-4, 0.0);
        assert_eq!(
            classify_and_clamp(&mut s, 1e6, limit),
            ContactState::Sliding
        );
        assert!((1e6 * s.norm() - limit).abs() < 1e-9);
        assert!((s.normalize() - Vector::new(0.6, 0.8, 0.0)).norm() < 1e-12);
        // Tension carries nothing, not even cohesion times a negative force.
        assert_eq!(Joint::shear_limit(0.5, 0.0, 0.0, -10.0), 0.0);
    }
}
