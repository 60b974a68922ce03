//! WCSPH's wall term on one fluid particle from one boundary particle, the force its step
//! applies (the boundary sums of [`super::pairs`] and [`super::riemann`]), as the moving blocks'
//! reaction ([`super::Wcsph`]'s `react`) and the wall-reading probes
//! ([`crate::instruments::wall_load`]) take it: m² (p_i/ρ_i² + p_w/ρ_w²) ∇W for the
//! artificial flux; m² 2P*/(ρ_i ρ_w) ∇W with P* = (p_i + p_w)/2, plus the Riemann flux's
//! dissipation along the particle's wall normal (Zhang, Hu & Adams 2017 §3.3), for the Riemann
//! flux.

use super::{Flux, Wcsph, riemann};
use crate::core::particles::Particles;
use crate::kernels::{Kernel, WendlandC2};
use shared::math::{Real, Vector};

/// The constants of the wall term.
pub struct WallTerm<'a> {
    kernel: &'a WendlandC2,
    mass: Real,
    flux: Flux,
    /// The Riemann flux's constants when the walls dissipate (`wall_limiter` > 0).
    dissipation: Option<riemann::RiemannConstants>,
}

impl<'a> WallTerm<'a> {
    pub fn new(w: &'a Wcsph, mass: Real, gravity: Vector) -> Self {
        let c = &w.constants;
        let dissipation = (c.wall_limiter > 0.0).then(|| {
            riemann::RiemannConstants::new(
                &w.kernel,
                w.rest_density,
                c.sound_speed,
                c.wall_limiter,
                gravity,
            )
        });
        Self {
            kernel: &w.kernel,
            mass,
            flux: c.flux,
            dissipation,
        }
    }

    /// Whether the term needs each particle's wall normal ([`Self::normal_part`]).
    pub fn needs_normal(&self) -> bool {
        self.dissipation.is_some()
    }

    /// One boundary particle's part of a fluid particle's wall normal n_i = Σ_b ∇W_ib /
    /// |Σ_b ∇W_ib| (pointing into the wall), r = x_i − x_b: ∇W_ib, zero past the support.
    pub fn normal_part(&self, r: &Vector) -> Vector {
        let len = r.norm();
        if len < self.kernel.support() {
            r * self.kernel.gradient_factor(len)
        } else {
            Vector::zeros()
        }
    }

    /// The force on fluid particle `i` of `p` from a boundary particle with velocity `vw`,
    /// pressure `pw` and density `rw` at r = x_i − x_w (|r| = `len`, within the support);
    /// `n`: the particle's unit normal to that part of the walls (unused without dissipation).
    #[allow(clippy::too_many_arguments)]
    pub fn force(
        &self,
        p: &Particles,
        i: usize,
        vw: &Vector,
        pw: Real,
        rw: Real,
        r: &Vector,
        len: Real,
        n: &Vector,
    ) -> Vector {
        let (ri, pi, m) = (p.density[i], p.pressure[i], self.mass);
        let f = self.kernel.gradient_factor(len);
        let pressure = match self.flux {
            Flux::Artificial => pi / (ri * ri) + pw / (rw * rw),
            Flux::Riemann => riemann::wall_pair(pi, ri, pw, rw),
        };
        // (Each form in the order of operations the blocks' loads have always had: a change
        // of the last bit would change every coupled run's output.)
        match &self.dissipation {
            Some(rc) => {
                let u = 2.0 * (p.velocity[i] - vw).dot(n);
                let d = riemann::wall_pair_dissipation(rc, ri, rw, u);
                (r * (-pressure) + n * (d * len)) * (f * m * m)
            }
            None => r * (f * (-m * m * pressure)),
        }
    }
}

/// s/|s|, or zero.
pub fn unit(s: Vector) -> Vector {
    let n = s.norm();
    if n > 0.0 { s / n } else { s }
}
