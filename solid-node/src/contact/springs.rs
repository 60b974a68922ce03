//! Penalty springs: DDA keeps blocks apart with stiff normal springs and holds them in shear
//! with shear springs at each contact (Shi 1993), instead of exact non-penetration constraints.
//!
//! Default normal stiffness (when `[solid.contact].normal_stiffness` is unset): the spring under
//! which the lightest free block, resting on one contact, sinks `[solid.contact].allowed_penetration`
//! (ε, default 1e-4) times its own size under its own weight, `k_n = m g / (ε L)`. Its contact frequency is then
//! `sqrt(k_n/m) = sqrt(g/(ε L))`, independent of the rock density, and the explicit step
//! 2/ω_max follows from it (see [`crate::integrators::stability`]). Heavier blocks sink proportionally more
//! (still ≪ their size for piles of a few hundred blocks). With no gravity, 9.81 m/s² is used.

use crate::blocks::block::Block;
use crate::contact::Contact;
use crate::contact::friction::{self, ContactState, Joint};
use shared::math::{Real, Vector};
use shared::scene::ContactSpec;

/// Contact margin as a fraction of the smallest free block size: contacts this close are kept
/// (open) so that their history survives a momentary separation.
pub const MARGIN_FRACTION: Real = 1e-3;

/// The springs of every contact of a scene.
#[derive(Debug, Clone)]
pub struct PenaltyModel {
    /// Normal spring k_n [N/m].
    pub normal: Real,
    /// Shear spring k_s [N/m].
    pub shear: Real,
    /// Fraction of critical damping on both springs.
    pub damping_ratio: Real,
    /// Distance [m] within which a feature pair is a contact.
    pub margin: Real,
    /// Where `normal` came from, for the log.
    pub origin: String,
    /// Every contact holds elastically, with no strength limit: no slip, bonded joints in
    /// tension too (while the slides settle under gravity before t = 0, [`crate::settle`]).
    pub bonds_hold: bool,
}

impl PenaltyModel {
    /// The springs for these blocks (see the module docs for the default).
    pub fn new(spec: &ContactSpec, blocks: &[Block], gravity: &Vector) -> PenaltyModel {
        let lightest = blocks
            .iter()
            .filter(|b| b.is_free())
            .min_by(|a, b| a.mass.total_cmp(&b.mass));
        let smallest = blocks
            .iter()
            .filter(|b| b.is_free())
            .map(Block::size)
            .fold(Real::INFINITY, Real::min);
        let smallest = if smallest.is_finite() { smallest } else { 1.0 };
        let g = if gravity.norm() > 0.0 {
            gravity.norm()
        } else {
            shared::math::STANDARD_GRAVITY
        };
        let (normal, origin) = match (spec.normal_stiffness, lightest) {
            (Some(k), _) => (k, "[solid.contact].normal_stiffness".to_string()),
            (None, Some(b)) => {
                let k = b.mass * g / (spec.allowed_penetration * b.size());
                (
                    k,
                    format!(
                        "derived: lightest free block '{}' ({:.4} kg, size {:.4} m) sinks {:e} of its size under its weight",
                        b.name,
                        b.mass,
                        b.size(),
                        spec.allowed_penetration
                    ),
                )
            }
            (None, None) => (1e9, "no free block: contacts unused".to_string()),
        };
        PenaltyModel {
            normal,
            shear: normal * spec.shear_ratio,
            damping_ratio: spec.damping_ratio,
            margin: MARGIN_FRACTION * smallest,
            origin,
            bonds_hold: false,
        }
    }

    /// Reduced mass of a contact (the free side only when the other is fixed or kinematic).
    #[inline]
    pub fn reduced_mass(p: &Block, q: &Block) -> Real {
        match (p.is_free(), q.is_free()) {
            (true, true) => p.mass * q.mass / (p.mass + q.mass),
            (true, false) => p.mass,
            (false, true) => q.mass,
            (false, false) => 0.0,
        }
    }

    /// Dashpot of a spring `k` at the configured fraction of its critical damping.
    #[inline]
    pub fn dashpot(&self, k: Real, reduced_mass: Real) -> Real {
        2.0 * self.damping_ratio * (k * reduced_mass).sqrt()
    }

    /// Elastic energy stored in a contact's springs [J].
    #[inline]
    pub fn energy(&self, c: &Contact) -> Real {
        if c.gap >= 0.0 {
            return 0.0;
        }
        0.5 * self.normal * c.gap * c.gap + 0.5 * self.shear * c.shear.norm_squared()
    }

    /// Force update of one contact at the current configuration (what a scheme that evaluates
    /// the forces where the blocks have moved uses, as central differences do, paper Eqs. 5–8;
    /// Shi's implicit scheme linearises the springs instead): the shear spring is stretched by the relative
    /// material displacement of the contact point over the last step, then clamped to the
    /// Mohr–Coulomb envelope. Sets `state`, `shear`, `normal_force` and `force` (on `p`).
    ///
    /// A bonded slide joint ([`crate::contact::joints`]) also carries tension, up to `T · A`, and
    /// breaks for good when the tension or the shear passes its limit; the step it breaks,
    /// the shear is clamped to the residual envelope `N tan φ`.
    pub fn update(&self, c: &mut Contact, p: &Block, q: &Block) {
        if c.bonded {
            return self.update_bonded(c, p, q);
        }
        if c.gap >= 0.0 {
            c.state = ContactState::Open;
            c.shear = Vector::zeros();
            c.normal_force = 0.0;
            c.force = Vector::zeros();
            return;
        }
        let n = c.normal;
        let m = Self::reduced_mass(p, q);
        let v = p.point_velocity(&c.point) - q.point_velocity(&c.point);
        let vn = v.dot(&n);
        let fn_ = (self.normal * -c.gap - self.dashpot(self.normal, m) * vn).max(0.0);
        let du = p.point_step_displacement(&c.point) - q.point_step_displacement(&c.point);
        c.shear += du - n * du.dot(&n);
        let limit = if self.bonds_hold {
            Real::INFINITY
        } else {
            Joint::shear_limit(c.tan_phi, c.cohesion, c.area, fn_)
        };
        c.state = friction::classify_and_clamp(&mut c.shear, self.shear, limit);
        let mut ft = -self.shear * c.shear;
        if c.state == ContactState::Locked {
            let vt = v - n * vn;
            ft -= vt * self.dashpot(self.shear, m);
            let f = ft.norm();
            if f > limit && f > 0.0 {
                ft *= limit / f;
            }
        }
        c.normal_force = fn_;
        c.force = n * fn_ + ft;
    }

    /// [`Self::update`] for a bonded contact: Mohr–Coulomb with a tension cut-off.
    fn update_bonded(&self, c: &mut Contact, p: &Block, q: &Block) {
        let n = c.normal;
        let m = Self::reduced_mass(p, q);
        let v = p.point_velocity(&c.point) - q.point_velocity(&c.point);
        let vn = v.dot(&n);
        // Compression positive; a bonded joint pulls back when opened.
        let fn_ = self.normal * -c.gap - self.dashpot(self.normal, m) * vn;
        if self.bonds_hold {
            let du = p.point_step_displacement(&c.point) - q.point_step_displacement(&c.point);
            c.shear += du - n * du.dot(&n);
            c.state = ContactState::Locked;
            c.normal_force = fn_.max(0.0);
            c.force = n * fn_ - self.shear * c.shear - (v - n * vn) * self.dashpot(self.shear, m);
            return;
        }
        if fn_ < -c.tensile * c.area {
            // Tension cut-off: the joint opens and the bond is gone.
            c.break_bond();
            return self.update(c, p, q);
        }
        let du = p.point_step_displacement(&c.point) - q.point_step_displacement(&c.point);
        c.shear += du - n * du.dot(&n);
        let limit = Joint::shear_limit(c.tan_phi, c.cohesion, c.area, fn_);
        c.state = friction::classify_and_clamp(&mut c.shear, self.shear, limit);
        if c.state == ContactState::Sliding {
            // Sheared through: residual friction from now on (the spring slips to it).
            c.break_bond();
            let residual = Joint::shear_limit(c.tan_phi, 0.0, 0.0, fn_);
            friction::classify_and_clamp(&mut c.shear, self.shear, residual);
            c.state = ContactState::Sliding;
            if fn_ <= 0.0 {
                // Opened in the same step: nothing left to carry.
                c.state = ContactState::Open;
                c.shear = Vector::zeros();
                c.normal_force = 0.0;
                c.force = Vector::zeros();
                return;
            }
            c.normal_force = fn_;
            c.force = n * fn_ - self.shear * c.shear;
            return;
        }
        let vt = v - n * vn;
        let mut ft = -self.shear * c.shear - vt * self.dashpot(self.shear, m);
        let f = ft.norm();
        if f > limit && f > 0.0 {
            ft *= limit / f;
        }
        c.normal_force = fn_.max(0.0);
        c.force = n * fn_ + ft;
    }
}
